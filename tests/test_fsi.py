"""Moving mesh and solid (seed eqs. 27–29): ALE consistency, beam frequency, energy, inverted cells."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.config import validate_scene
from cosserat_fsi.io import read_timeseries
from cosserat_fsi.observables import Observables
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.simulation import Simulation


def _run(scene, comm=MPI.COMM_WORLD, **kwargs):
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm, **kwargs)
    obs = Observables(sim)
    rows = []
    sim.run(sim.steps_to(scene.time.t_end), observers=[lambda sim: rows.append({"t": sim.t, **obs.evaluate()})])
    series = {k: np.array([r[k] for r in rows]) for k in rows[0]} if rows else {}
    return sim, series


class Uniform:
    """u = U everywhere: a solution of the Navier–Stokes equations with constant pressure."""

    U = np.array([1.0, 0.5])

    def velocity(self, x, t):
        return np.outer(self.U, np.ones(x.shape[1]))


def _wobble(X, t):
    """An interior mesh motion of the unit square, zero on its boundary, back and forth in time."""
    bump = np.sin(np.pi * X[:, 0]) * np.sin(np.pi * X[:, 1])
    return 0.08 * np.sin(2 * np.pi * t / 0.2)[None] * np.column_stack([bump, -bump * X[:, 0]])


@pytest.mark.parametrize("scheme", ["characteristics1", "ale_bdf2", "generalized_alpha"])
def test_free_stream_is_preserved_under_mesh_motion(scheme):
    """A uniform flow stays uniform to round-off on a mesh that moves independently of the flow."""
    scene = validate_scene({"geometry": {"name": "square", "level": 1}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "time": {"dt": 0.01, "t_end": 0.2, "scheme": scheme}})
    sim, _ = _run(scene, exact=Uniform(), prescribed_motion=_wobble)
    u = sim.velocity.x.array.reshape(-1, 2)
    assert sim.motion.displacement.x.array.std() > 0  # the mesh did move
    assert np.abs(u - Uniform.U).max() < 1e-10


def _taylor_green_error(scheme, dt, motion, after_move=False):
    """L² velocity error of the Taylor–Green vortex at T = 1, measured on the mesh the last step was
    solved on, before it moves on, or (``after_move``) on Ω(T) after it moved (generalised-α solves on
    the configuration of t^{n+α_f}, not of t^{n+1})."""
    from test_navier_stokes import TaylorGreen, _l2

    import dolfinx

    T, exact = 1.0, TaylorGreen(0.1)
    scene = validate_scene({"geometry": {"name": "square", "level": 2, "length": float(np.pi)},
                            "fluid": {"rho": 1.0, "mu": 0.1},
                            "time": {"dt": dt, "t_end": T, "scheme": scheme}})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, exact=exact, prescribed_motion=motion)
    n, error = sim.steps_to(T), []

    def measure(sim):
        if sim.step_count < n:
            return
        u_exact = dolfinx.fem.Function(sim.velocity.function_space)
        u_exact.interpolate(lambda x: exact.velocity(x, T))
        error.append(_l2(sim, sim.velocity - u_exact))

    sim.run(n, after_step=[measure]) if after_move else sim.run(n, observers=[measure])
    return error[0]


def _tg_wobble(X, t):
    """Interior motion of [0, π]², up to 0.25 (mesh velocity up to 1.6, above the flow's 1)."""
    bump = np.sin(X[:, 0]) * np.sin(X[:, 1])
    return 0.25 * np.sin(2 * np.pi * t)[None] * np.column_stack([bump, -bump * X[:, 0] / np.pi])


@pytest.mark.slow
def test_generalized_alpha_on_a_moving_mesh_is_second_order():
    """Generalised-α (ρ∞ = 0.5) on the wobbling mesh of the test below, δt = 0.05, 0.025, 0.0125: second
    order with the continuity equation on u^{n+α_f} in Ω^{n+α_f}, where the step is solved (measured
    2.1162e-3, 5.2881e-4, 1.3393e-4; rates 2.00, 1.98). With div u^{n+1} = 0 imposed there instead (the
    first form of the scheme) it was first order: 2.379e-2, 1.189e-2, 5.946e-3 (rates 1.00, 1.00), which
    made FSI3 first order in δt (docs/perf_generalized_alpha.md,
    "Second order on a moving mesh; FSI3 from δt = 0.01")."""
    errors = np.array([_taylor_green_error("generalized_alpha", dt, _tg_wobble, after_move=True)
                       for dt in (0.05, 0.025, 0.0125)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all((rates > 1.8) & (rates < 2.3)), (errors, rates)
    assert np.allclose(errors, [2.1162e-3, 5.2881e-4, 1.3393e-4], rtol=0.01), errors


@pytest.mark.slow
@pytest.mark.parametrize("scheme", ["characteristics2", "ale_bdf2"])
def test_bdf2_on_a_moving_mesh_is_second_order(scheme):
    """BDF2 characteristics on a mesh that moves independently of the flow: the Taylor–Green errors equal
    the fixed-mesh ones (measured: 1.1478e-2, 2.553e-3, 5.99e-4 for δt = 0.2, 0.1, 0.05 on both; rates
    2.17, 2.09). The feet are located in the configurations the histories were computed on; shifting them
    by the mesh velocity instead (the first-order scheme's ALE correction) is O(δt²) per step.
    ``time.scheme: ale_bdf2`` (BDF2 of the nodal values + convection relative to the mesh) is second order
    too (measured 2.4188e-1, 4.4579e-2, 7.4346e-3: rates 2.44, 2.58) but its error follows the mesh's own
    motion, fast here, not the flow's: 100× the fixed-mesh ALE errors (1.3057e-3, 3.1204e-4, 7.6533e-5,
    rates 2.07, 2.03; 9× below the characteristics' on the fixed mesh)."""
    dts = (0.2, 0.1, 0.05)
    moving = np.array([_taylor_green_error(scheme, dt, _tg_wobble) for dt in dts])
    fixed = np.array([_taylor_green_error(scheme, dt, None) for dt in dts])
    rates = np.log2(moving[:-1] / moving[1:])
    if scheme == "ale_bdf2":  # second order, but the nodes' BDF2 follows the mesh's fast motion (w up to 1.6)
        assert np.all((rates > 1.8) & (rates < 2.9)), (moving, rates)
        assert np.all(moving > 10 * fixed), (moving, fixed)
        return
    assert np.all(np.abs(rates - 2) < 0.25), (moving, rates)
    assert np.allclose(moving, fixed, rtol=0.01), (moving, fixed)


@pytest.mark.slow
@pytest.mark.parametrize("options", [{}, {"corrector_passes": 1},
                                     {"scheme": "generalized_alpha", "corrector_passes": 1}],
                         ids=["seed", "corrector", "generalized_alpha_corrector"])
def test_solid_time_order(options):
    """Flag under gravity ramped in smoothly over 0.2 s (no fluid): uy(A) at t = 0.3 for δt = 4e-3, 2e-3,
    1e-3, the observed order from the differences of successive values (log2 of their ratio; no reference
    run). BDF2 (d^{n+1} = (4d^n − d^{n−1})/3 + (2δt/3) u^{n+1} on the solid nodes and vertices, the stress
    linearised around d* = (4d^n − d^{n−1})/3 on the configuration X + d*): measured 2.10 (against BDF2 at
    δt = 5e-4 the errors are 3.0e-5, 6.6e-6, 1.2e-6, rates 2.17, 2.46); with a corrector pass 1.85, ale_bdf2
    1.89, generalised-α 1.81 with 0, 1 or 2 passes (its errors against its own δt = 5e-4 run: rates 1.87,
    2.03: the coarsest step is not yet asymptotic). First order at δt = 4e-3 is 33× further from the finest
    BDF2 value than BDF2 at the same step (a first-order scheme's observed order would be ≈ 1). ale_bdf2 and
    generalised-α without corrector passes: on constant and on random steps in
    test_variable_step.test_solid_order_on_a_random_step_sequence; a second corrector pass repeats the first's
    code."""
    def uy_A(scheme, dt):
        scene = validate_scene({"geometry": {"name": "flag", "level": 0},
                                "solid": {"rho": 1000.0, "mu_s": 2e6, "gravity": 2.0, "gravity_ramp_time": 0.2},
                                "time": {"dt": dt, "t_end": 0.3, "scheme": scheme, **options}})
        return _run(scene)[1]["uy_A"][-1]

    values = np.array([uy_A("characteristics2", dt) for dt in (0.004, 0.002, 0.001)])
    differences = np.abs(np.diff(values))  # (1 − 2^−p) e(δt): their ratio is 2^p
    rate = np.log2(differences[0] / differences[1])
    assert 1.7 < rate < 3.2, (values, rate)
    if options:
        return
    first_order = abs(uy_A("characteristics1", 0.004) - values[-1])
    assert first_order > 10 * abs(values[0] - values[-1]), (first_order, values)


def _cfd1_drag(prescribed_motion=None, drop_mesh_velocity=False):
    scene = validate_scene({"benchmark": "turek_hron_cfd1", "geometry": {"name": "turek_hron", "flag": "rigid"},
                            "fluid": {"rho": 1000.0, "mu": 1.0}, "inflow": {"u_mean": 0.2},
                            "time": {"scheme": "characteristics1", "dt": 0.02, "t_end": 1.0}})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, prescribed_motion=prescribed_motion)
    obs = Observables(sim)
    drag = []
    def drop(sim):
        if drop_mesh_velocity:
            sim.state.mesh_velocity.x.array[:] = 0.0

    drop(sim)
    sim.run(50, observers=[lambda sim: drag.append(obs.evaluate()["drag"])], after_step=[drop])
    return np.array(drag)


def _downstream_wobble(X, t):
    """Vertices behind the flag (x > 1) move vertically by up to 1.5 cm and back; the rest stays."""
    s = np.where(X[:, 0] > 1.0, np.sin(np.pi * (X[:, 0] - 1.0) / 1.5) * np.sin(np.pi * X[:, 1] / 0.41), 0.0)
    return np.column_stack([0 * s, 0.015 * np.sin(2 * np.pi * t / 0.25) * s])


@pytest.mark.slow
def test_moving_mesh_cfd1_matches_fixed_mesh():
    """CFD1 (Re = 20) on a mesh moved back and forth gives the fixed-mesh drag to discretisation
    accuracy; without the ALE mesh-velocity correction in the feet it does not."""
    fixed = _cfd1_drag()
    moving = _cfd1_drag(_downstream_wobble)
    no_ale = _cfd1_drag(_downstream_wobble, drop_mesh_velocity=True)
    err_ale = np.abs(moving / fixed - 1)[10:].max()
    err_no_ale = np.abs(no_ale / fixed - 1)[10:].max()
    assert err_ale < 2e-3, err_ale
    assert err_no_ale > 3 * err_ale, (err_ale, err_no_ale)


@pytest.mark.slow
def test_flag_free_vibration_matches_euler_bernoulli():
    """First bending frequency of the clamped flag (small amplitude) vs Euler–Bernoulli with bending
    stiffness 4 μ_s h³/12 (incompressible plane strain, E/(1 − ν²) = 4 μ_s): within 3 %. This pins the
    factor of the solid stress (seed eq. 14: the coefficient of Dd − ∇d∇dᵀ is μ_s = 2c₁)."""
    mu_s, rho_s, L, h = 2.0e6, 1000.0, 0.35, 0.02
    scene = validate_scene({"geometry": {"name": "flag", "level": 0},
                            "solid": {"rho": rho_s, "mu_s": mu_s, "initial_velocity": [0.0, 0.01]},
                            "time": {"scheme": "characteristics1", "dt": 0.002, "t_end": 1.0}})
    _, series = _run(scene)
    f_beam = 1.875**2 / (2 * np.pi * L**2) * np.sqrt(4 * mu_s * h**3 / 12 / (rho_s * h))
    t, y = series["t"], series["uy_A"]
    crossings = t[1:][np.sign(y[1:]) != np.sign(y[:-1])]  # half periods
    f = 0.5 / np.diff(crossings).mean()
    assert abs(series["uy_A"]).max() < 0.01 * L  # small amplitude: linear regime
    assert f == pytest.approx(f_beam, rel=0.03), (f, f_beam)


def test_closed_box_energy_never_increases():
    """Fluid + solid disk in a closed box, the disk thrown sideways: kinetic + elastic energy does not
    increase from one step to the next (no inflow, no forcing: only dissipation)."""
    scene = validate_scene({"geometry": {"name": "box", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "solid": {"rho": 2.0, "mu_s": 50.0, "initial_velocity": [0.05, 0.02]},
                            "time": {"scheme": "characteristics1", "dt": 0.01, "t_end": 1.0}})
    _, series = _run(scene)
    energy = series["energy_total"]
    assert energy[0] > 0 and energy[-1] < 0.9 * energy[0]
    assert np.all(np.diff(energy) <= 1e-12 * energy[0]), np.diff(energy).max()


def _diverged_box_run(run_cli, tmp_path, solid: str, time: str):
    """A disk in the box (``solid``, ``time``: YAML flow mappings) that must stop with exit 3: the one
    "diverged:" line (no traceback), the summary and the time series."""
    cfg = tmp_path / "box.yaml"
    cfg.write_text(f"geometry: {{name: box}}\nfluid: {{rho: 1.0, mu: 0.01}}\nsolid: {solid}\ntime: {time}\n")
    out = tmp_path / "out"
    proc = run_cli("run", cfg, "--out", out, "--no-progress", timeout=300)
    assert proc.returncode == 3, proc.stderr
    line = [x for x in proc.stderr.splitlines() if x.startswith("diverged:")]
    assert len(line) == 1 and "Traceback" not in proc.stderr, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "diverged"
    return line[0], summary, read_timeseries(out / "timeseries.csv")


@pytest.mark.slow
def test_inverted_cell_stops_with_exit_3(run_cli, tmp_path):
    """A disk thrown across the box in one step would invert cells: exit 3, the time and place named,
    and the output written so far kept."""
    line, _, series = _diverged_box_run(run_cli, tmp_path, "{rho: 1.0, mu_s: 100.0, gravity: 400.0}",
                                        "{scheme: characteristics1, dt: 0.05, t_end: 1.0}")
    assert "near (" in line and "t = " in line
    assert len(series["t"]) >= 1  # the steps before it are kept


@pytest.mark.slow
def test_an_adaptive_step_the_mesh_cannot_follow_is_rejected(run_cli, tmp_path):
    """The same disk with time.tolerance: the first step of 0.05, which would invert cells, is rejected and
    taken in four, and the run goes on with steps the mesh can follow; once the disk meets the floor even
    time.dt_min fails: exit 3 naming the time, dt_min and the cell, the steps so far kept."""
    line, summary, series = _diverged_box_run(
        run_cli, tmp_path, "{rho: 1.0, mu_s: 100.0, gravity: 400.0}",
        "{scheme: characteristics1, dt: 0.05, t_end: 1.0, tolerance: 0.1, dt_min: 0.001}")
    assert re.search(r"a step of time\.dt_min = 0\.001 failed too: t = [\d.]+: the mesh motion would make a "
                     r"cell inverted near \(", line), line
    assert series["dt"][0] == pytest.approx(0.0125, rel=1e-12)  # 0.05 rejected, then a quarter of it
    assert summary["time"]["steps"] >= 10 and summary["time"]["rejected_steps"] >= 2
    assert series["t"][-1] > 0.05  # past the fixed step's first (inverting) step


@pytest.mark.slow
def test_solid_reaching_a_wall_stops_with_exit_3(run_cli, tmp_path):
    """A disk sinking onto the box's floor: within ``wall_gap`` of the wall the run stops with
    exit 3 and a message naming the wall, the place and the time; the output so far is kept."""
    line, _, series = _diverged_box_run(run_cli, tmp_path,
                                        "{rho: 10.0, mu_s: 100.0, gravity: 2.0, mesh_motion: {wall_gap: 0.1}}",
                                        "{scheme: characteristics1, dt: 0.01, t_end: 2.0}")
    match = re.search(r"the solid is within 0\.1 of the wall near \(([-\d.e]+), ([-\d.e]+)\) at t = ([\d.]+)", line)
    assert match, line
    x, y, t = map(float, match.groups())
    assert abs(x - 0.5) < 0.05 and 0.09 < y < 0.1 and 0.3 < t < 1.0  # the bottom of the disk, on its way down
    assert len(series["t"]) >= 9


@pytest.mark.mpi
@pytest.mark.parametrize("scheme, passes", [("characteristics1", 0), ("characteristics2", 0), ("ale_bdf2", 0),
                                            ("generalized_alpha", 0), ("generalized_alpha", 1),
                                            ("generalized_alpha", 2)])
@pytest.mark.slow
@pytest.mark.two_ranks
def test_fsi_serial_equals_parallel(scheme, passes):
    """Tip displacement, forces and energies of a short FSI run: COMM_WORLD (1 or 2 ranks) = COMM_SELF."""
    scene = validate_scene({"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"},
                            "fluid": {"rho": 1000.0, "mu": 1.0}, "solid": {"rho": 1000.0, "mu_s": 0.5e5},
                            "inflow": {"u_mean": 1.0, "ramp_time": 0.1},
                            "time": {"dt": 0.01, "t_end": 0.2, "scheme": scheme,
                                     **({"corrector_passes": passes} if passes else {})}})
    _, parallel = _run(scene, MPI.COMM_WORLD)
    _, serial = _run(scene, MPI.COMM_SELF)
    for key in ("uy_A", "ux_A", "drag", "lift", "energy_total"):
        scale = np.abs(serial[key]).max()
        assert np.abs(parallel[key] - serial[key]).max() <= 1e-8 * scale, key
    assert np.abs(serial["uy_A"]).max() > 1e-5  # the flag did move


@pytest.mark.parametrize("correction, relax", [(True, 0.0), (False, 0.0), (True, 0.05)])
def test_solid_area_is_kept_by_the_volume_correction(correction, relax):
    """A flag swinging fast (≈ 0.1 rad per step): the seed's node update x += δt u inflates it; with the
    volume correction (default) its area stays within 0.1 % of 0.35 × 0.02 (measured 1.6e-4; without it
    3.8e-2). Undone over ``volume_correction_time`` = 0.05 s (5 steps) instead of one step, the drift
    settles near its rate × 0.05 s: measured 2.4e-3 (0.02 s: 5.5e-4)."""
    import dolfinx
    import ufl

    from cosserat_fsi import compat

    scene = validate_scene({"geometry": {"name": "flag", "level": 0},
                            "solid": {"rho": 1000.0, "mu_s": 2.0e6, "initial_velocity": [0.0, 1.0],
                                      "volume_correction": correction, "volume_correction_time": relax},
                            "time": {"scheme": "characteristics1", "dt": 0.01, "t_end": 0.5}})
    sim, _ = _run(scene)
    area = sim.comm.allreduce(dolfinx.fem.assemble_scalar(
        compat.form(dolfinx.fem.Constant(sim.mesh, 1.0) * ufl.dx)), op=MPI.SUM)
    drift = abs(area / (0.35 * 0.02) - 1)
    if relax:
        assert 1e-3 < drift < 5e-3, drift
        return
    assert (drift < 1e-3) if correction else (drift > 3e-3), drift


def test_reused_factorisation_matches_refactorising_every_step():
    """GMRES preconditioned by an old LU (default on a moving mesh) = a fresh LU every step, to 1e-6."""
    results = {}
    for reuse in (True, False):
        scene = validate_scene({"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"},
                                "fluid": {"rho": 1000.0, "mu": 1.0}, "solid": {"rho": 1000.0, "mu_s": 0.5e5},
                                "inflow": {"u_mean": 1.0, "ramp_time": 0.1},
                                "time": {"scheme": "characteristics1", "dt": 0.01, "t_end": 0.2},
                                "solver": {"reuse_factorization": reuse}})
        sim, results[reuse] = _run(scene)
        if reuse:
            assert sim.stepper.solver.factorisations < 5  # the point of it
    for key in ("uy_A", "drag", "lift"):
        scale = np.abs(results[False][key]).max()
        assert np.abs(results[True][key] - results[False][key]).max() <= 1e-6 * scale, key


@pytest.mark.mpi
def test_mesh_motion_is_the_harmonic_extension_of_the_total_displacement():
    """Ten steps of a flag bending (tip +2 cm) move the fluid vertices exactly as one step of the same
    total displacement: the extension is solved on the reference mesh, lifting included. (Lifting
    re-assembled on the moved mesh lagged the fluid vertices next to the flag and inverted cells.)"""
    import dolfinx

    from cosserat_fsi import compat
    from cosserat_fsi.mesh.motion import MeshMotion

    scene = validate_scene({"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"},
                            "fluid": {"rho": 1.0, "mu": 1.0}, "solid": {"rho": 1.0, "mu_s": 1.0},
                            "inflow": {"u_mean": 1.0}, "time": {"scheme": "characteristics1", "dt": 0.1, "t_end": 1.0}})

    mesh, ct, _, _ = load_mesh(scene, MPI.COMM_WORLD)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    velocity = dolfinx.fem.Function(V)
    velocity.interpolate(lambda x: np.vstack([-0.01 * (x[1] - 0.2) * (x[0] > 0.24),
                                              0.02 * np.clip((x[0] - 0.2485) / 0.3515, 0, 1) ** 2]))

    def moved(steps):
        motion = MeshMotion(mesh, ct, MPI.COMM_WORLD)
        for _ in range(steps):
            motion.move(velocity, 1.0 / steps, 0.0)
        out = motion.displacement.x.array.copy(), mesh.geometry.x[:, :2] - motion.X0
        mesh.geometry.x[:, :2] = motion.X0  # back to the reference mesh
        return out

    d10, x10 = moved(10)
    d1, x1 = moved(1)
    assert MPI.COMM_WORLD.allreduce(np.abs(d10).max(), op=MPI.MAX) > 0.019
    assert np.abs(d10 - d1).max() < 1e-12 and np.abs(x10 - x1).max() < 1e-12
