"""Named observables in 3D: probes (u, v, w, p, ω's three components), line profiles, flow rates through
named facet groups, where the probes landed, points outside the mesh; the force's third component ``side``.

A scene's ``observables`` section is for geometry file; these tests give a built-in 3D scene (the ``cube``,
[0, 1]³, facets ``lid`` y = 1 and ``walls``) a hand-made :class:`ObservableSet` and read the
:class:`Observables` of its Simulation. The flow is a polynomial one that the P2/P1 spaces hold exactly:

    u = (y(1 − y), z(1 − z), x(1 − x))   (div u = 0),   ω = ½ curl u = (z − ½, x − ½, y − ½),   p = x + 2y + 3z,

with the sources f, g of the steady micropolar equations (tests/test_three_d.py) computed by UFL and the
exact velocity on every face, so that the discrete solution is the exact one to round-off: a probe gives
u, v, w, ω exactly and p up to its constant (compared as differences), the flow rate through the lid is
∫ z(1 − z) dz = 1/6.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.config.sections import ObservableSet
from cosserat_fsi.errors import InputError
from cosserat_fsi.observables import Observables
from cosserat_fsi.simulation import Simulation

import ufl

PARAMS = {"rho": 1.0, "mu": 1.0, "mu_r": 0.5, "lambda1": 1.0, "lambda2": 0.7, "inertia": 1.0}
PROBES = {"P": [0.3, 0.6, 0.7], "Q": [0.55, 0.25, 0.4], "R": [0.8, 0.85, 0.15]}
LINE = {"from": [0.1, 0.2, 0.3], "to": [0.9, 0.7, 0.6], "points": 7}


class Flow3D:
    """The polynomial flow of the module docstring (``wavy``: a trigonometric one instead, u = (sin πy cos πz,
    sin πz cos πx, sin πx cos πy), ω = (sin πx cos πy, sin πy cos πz, sin πz cos πx), p = cos πx cos πy cos πz,
    that the spaces do not hold: a discrete solution whose values depend on the mesh and the solver)."""

    def __init__(self, wavy: bool = False):
        self.wavy = wavy

    def velocity(self, x, t, lib=np):
        if self.wavy:
            s, c, X = lib.sin, lib.cos, [np.pi * x[i] for i in range(3)]
            parts = (s(X[1]) * c(X[2]), s(X[2]) * c(X[0]), s(X[0]) * c(X[1]))
        else:
            parts = (x[1] * (1 - x[1]), x[2] * (1 - x[2]), x[0] * (1 - x[0]))
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def micro_rotation(self, x, t, lib=np):
        if self.wavy:
            s, c, X = lib.sin, lib.cos, [np.pi * x[i] for i in range(3)]
            parts = (s(X[0]) * c(X[1]), s(X[1]) * c(X[2]), s(X[2]) * c(X[0]))
        else:
            parts = (x[2] - 0.5, x[0] - 0.5, x[1] - 0.5)
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def pressure(self, x, t, lib=np):
        if self.wavy:
            return lib.cos(np.pi * x[0]) * lib.cos(np.pi * x[1]) * lib.cos(np.pi * x[2])
        return x[0] + 2 * x[1] + 3 * x[2]

    def sources(self, X) -> dict:
        k = PARAMS
        u, w, p = self.velocity(X, 0, ufl), self.micro_rotation(X, 0, ufl), self.pressure(X, 0, ufl)
        f = (k["rho"] * ufl.grad(u) * u + ufl.grad(p) - (k["mu"] + k["mu_r"]) * ufl.div(ufl.grad(u))
             - 2 * k["mu_r"] * ufl.curl(w))
        g = (k["rho"] * k["inertia"] * ufl.grad(w) * u - k["lambda1"] * ufl.div(ufl.grad(w))
             - k["lambda2"] * ufl.grad(ufl.div(w)) + 4 * k["mu_r"] * w - 2 * k["mu_r"] * ufl.curl(u))
        return {"body_force": f, "body_couple": g}


def _observed(observables: dict, level=1, micro=True, comm=MPI.COMM_WORLD, wavy=False, solve=True):
    """(Simulation, Observables) of the cube scene with ``observables`` set, solved (steady Newton)."""
    sections = {"geometry": {"name": "cube", "level": level}, "fluid": {"rho": PARAMS["rho"], "mu": PARAMS["mu"]},
                "time": {"scheme": "steady"}}
    if micro:
        sections["micropolar"] = {k: PARAMS[k] for k in ("mu_r", "lambda1", "lambda2", "inertia")}
    scene = validate_scene(sections)
    scene.observables = ObservableSet.model_validate(observables)
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm, exact=Flow3D(wavy))
    if solve:
        sim.run(1)
        assert sim.report.converged, sim.report.message
    return sim, Observables(sim)


@pytest.fixture(scope="module")
def cube():
    return _observed({"points": PROBES, "lines": {"diagonal": LINE}, "flow_rates": ["lid", "walls"]}, level=0)


def test_probes_give_the_three_velocity_components_pressure_and_micro_rotation(cube):
    sim, obs = cube
    columns = ("u", "v", "w", "p", "omega_x", "omega_y", "omega_z")
    assert [c for c in obs.columns if c.endswith("_P")] == [f"{c}_P" for c in columns]
    values = obs.evaluate()
    exact = Flow3D()
    for name, x in PROBES.items():
        u = exact.velocity(np.array(x)[:, None], 0)[:, 0]
        w = exact.micro_rotation(np.array(x)[:, None], 0)[:, 0]
        got = [values[f"{c}_{name}"] for c in ("u", "v", "w", "omega_x", "omega_y", "omega_z")]
        assert np.abs(np.array(got) - [*u, *w]).max() < 1e-9, (name, got)
    p = {name: exact.pressure(x, 0) for name, x in PROBES.items()}
    for a, b in (("P", "Q"), ("Q", "R")):  # p up to its constant
        assert abs((values[f"p_{a}"] - values[f"p_{b}"]) - (p[a] - p[b])) < 1e-8, (a, b)


def test_line_profile_in_3d(cube):
    sim, obs = cube
    header = ["s", "x", "y", "z", "u", "v", "w", "p", "omega_x", "omega_y", "omega_z"]
    assert obs.lines["diagonal"][0] == header
    table = obs.profiles()["diagonal"]
    assert table.shape == (7, len(header))
    frame = dict(zip(header, table.T))
    a, b = np.array(LINE["from"]), np.array(LINE["to"])
    lam = np.linspace(0, 1, 7)
    x = a + lam[:, None] * (b - a)
    assert np.allclose(frame["s"], lam * np.linalg.norm(b - a), atol=1e-14)
    assert np.allclose(np.column_stack([frame["x"], frame["y"], frame["z"]]), x, atol=1e-14)
    exact = Flow3D()
    assert np.abs(np.column_stack([frame[c] for c in "uvw"]) - exact.velocity(x.T, 0).T).max() < 1e-9
    omega = np.column_stack([frame[f"omega_{c}"] for c in "xyz"])
    assert np.abs(omega - exact.micro_rotation(x.T, 0).T).max() < 1e-9
    dp = frame["p"] - frame["p"][0]
    assert np.abs(dp - (exact.pressure(x.T, 0) - exact.pressure(x[0], 0))).max() < 1e-8


def test_flow_rates_through_named_facet_groups(cube):
    """∫ u·n over the lid (y = 1, n = e_y) is ∫∫ z(1 − z) dx dz = 1/6; over the five walls −1/6 (div u = 0)."""
    sim, obs = cube
    assert "flow_rate_lid" in obs.columns and "flow_rate_walls" in obs.columns
    values = obs.evaluate()
    assert abs(values["flow_rate_lid"] - 1 / 6) < 1e-10, values["flow_rate_lid"]
    assert abs(values["flow_rate_walls"] + 1 / 6) < 1e-10, values["flow_rate_walls"]


def test_run_log_lines_name_three_coordinates(cube):
    sim, obs = cube
    lines = obs.locations()
    assert any(line.startswith("probe P at (0.3, 0.6, 0.7): inside the mesh, fluid cell ") for line in lines), lines
    assert "line diagonal: 7 points from (0.1, 0.2, 0.3) to (0.9, 0.7, 0.6), all inside the mesh -> " \
           "line_diagonal.csv" in lines
    assert any(line.startswith("flow rate lid: ") for line in lines), lines


def test_newtonian_probe_columns_have_no_omega():
    sim, obs = _observed({"points": {"P": [0.5, 0.5, 0.5]}}, level=0, micro=False, solve=False)
    assert [c for c in obs.columns if c.endswith("_P")] == ["u_P", "v_P", "w_P", "p_P"]


@pytest.mark.parametrize("observables, message", [
    ({"points": {"P": [0.5, 0.5, 1.5]}}, "observables.points.P: point (0.5, 0.5, 1.5) is outside the mesh"),
    ({"points": {"P": [0.5, 0.5, 0.5], "far": [-0.01, 0.5, 0.5]}},
     "observables.points.far: point (-0.01, 0.5, 0.5) is outside the mesh"),
    ({"lines": {"L": {"from": [0.5, 0.5, 0.5], "to": [0.5, 0.5, 2.0], "points": 3}}},
     "observables.lines.L: point (0.5, 0.5, 1.25) is outside the mesh"),
    ({"points": {"P": [0.5, 0.5]}}, "observables.points.P: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    ({"lines": {"L": {"from": [0.5, 0.5, 0.5], "to": [0.5, 0.9], "points": 3}}},
     "observables.lines.L.to: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    ({"flow_rates": ["outlet"]}, "observables.flow_rates[0]: the mesh has no facet group 'outlet'"),
], ids=["point_outside", "second_point_outside", "line_outside", "point_2d", "line_end_2d", "flow_rate_unknown"])
def test_misplaced_3d_observables_are_refused_naming_the_key(observables, message):
    """The checks at setup (a point in no cell of any rank), and the coordinate count of a scene built in
    Python (a scene file's is checked by the validator first: tests/faults/test_scene_observables.py)."""
    with pytest.raises(InputError) as caught:
        _observed(observables, level=0, micro=False, solve=False)
    assert str(caught.value) == message


@pytest.mark.mpi
@pytest.mark.two_ranks
def test_3d_probes_serial_equals_parallel():
    """The trigonometric flow on the cube (level 1): probes, line, flow rates on COMM_WORLD (1 or 2 ranks)
    and on COMM_SELF agree to 1e-9 (p as differences: its constant is the solver's)."""
    observables = {"points": PROBES, "lines": {"diagonal": LINE}, "flow_rates": ["lid"]}
    results = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        sim, obs = _observed(observables, comm=comm, wavy=True)
        values, table = obs.evaluate(), obs.profiles()["diagonal"]
        p0 = values["p_P"]
        for name in PROBES:
            values[f"p_{name}"] -= p0
        table[:, 7] -= table[0, 7]
        results.append((values, table))
    (parallel, line_parallel), (serial, line_serial) = results
    assert parallel.keys() == serial.keys()
    for key in serial:
        assert abs(parallel[key] - serial[key]) < 1e-9 * max(1.0, abs(serial[key])), (key, parallel[key], serial[key])
    assert np.abs(line_parallel - line_serial).max() < 1e-9
    assert abs(serial["u_P"]) > 0.1 and abs(serial["omega_z_Q"]) > 0.01  # not a trivial flow


def test_3d_columns_in_the_verdict_and_the_plots():
    """The result line lists side, the 3D probe, solid point and flow rate columns; a reference on one of them
    is judged; plot groups them (forces.png with side, probes.png, solid_points.png, flow_rates.png)."""
    from cosserat_fsi.app.plots import timeseries_figures
    from cosserat_fsi.app.verdict import compare_with_scene_reference, verdict_lines
    from cosserat_fsi.config.sections import Reference

    t = np.linspace(0, 1, 5)
    series = {"t": t, "drag": 1 + t, "lift": t, "side": 0 * t, "drag_surface": 1 + t, "u_P": t, "v_P": t, "w_P": 2 * t,
              "p_P": t, "omega_x_P": t, "omega_y_P": t, "omega_z_P": t, "ux_tip": t, "uy_tip": t, "uz_tip": -t,
              "flow_rate_lid": t / 6, "omega_max": t}
    final = {k: float(v[-1]) for k, v in series.items() if k != "t"}
    summary = {"final": final, "signals": {k: "steady" for k in final}, "periodic": {}}
    summary["reference"] = compare_with_scene_reference(
        {"w_P": Reference(value=2.0, tolerance=1e-9), "side": Reference(value=0.0, abs_tolerance=1e-12),
         "uz_tip": Reference(value=1.0, tolerance=0.1)}, summary)
    lines = verdict_lines(summary)
    assert "reference: FAIL (2/3 within tolerance)" in lines
    result = next(line for line in lines if line.startswith("result: "))
    for part in ("drag = 2", "lift = 1", "side = 0", "w_P = 2", "omega_z_P = 1", "uz_tip = -1",
                 "flow_rate_lid = 0.166667", "omega_max = 1"):
        assert part in result, (part, result)
    figures = timeseries_figures(series, {}, "run")
    assert {"forces", "probes", "solid_points", "flow_rates"} <= set(figures)
    assert [ax.get_ylabel() for ax in figures["forces"].axes] == ["drag", "lift", "side"]
    assert "w_P" in [ax.get_ylabel() for ax in figures["probes"].axes]
    assert [ax.get_ylabel() for ax in figures["solid_points"].axes] == ["ux_tip", "uy_tip", "uz_tip"]


@pytest.mark.slow
def test_plot_of_a_3d_run_skips_the_snapshots_in_one_line(run_cli, tmp_path):
    """A 3D run (the cube, level 0, two steps): plot draws its time series and says in one line that it
    draws no snapshot. ≈ 8 s."""
    scene = tmp_path / "cube.yaml"
    scene.write_text("geometry: {name: cube, level: 0}\nfluid: {rho: 1.0, mu: 0.1}\ninflow: {u_mean: 1.0}\n"
                     "micropolar: {mu_r: 0.1, lambda1: 0.1}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.2}\n"
                     "output: {every: 1, progress: false}\n")
    assert run_cli("run", scene, "--out", tmp_path / "run").returncode == 0
    result = run_cli("plot", tmp_path / "run", "--out", tmp_path / "plots")
    assert result.returncode == 0, result.stderr
    skipped = [line for line in result.stdout.splitlines() if "no snapshots of a 3D run" in line]
    assert len(skipped) == 1, result.stdout
    assert sorted(p.name for p in (tmp_path / "plots").glob("*.png")) == ["flow.png"]
