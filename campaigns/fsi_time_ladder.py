"""δt ladders of FSI3 uy(A) and CFD3 lift — run the cases (or read finished ones) and write a table.

Each case is `cosserat-fsi run CONFIG --set ...` into ``<runs>/<id>``; a case whose timeseries.csv reaches
its t_end is not run again. The table gives the periodic amplitude and frequency of the last full period
(cosserat_fsi.analysis.periodic_analysis, as the validation), their errors against the reference, the
same over the period ending 1 s earlier (a still-growing oscillation shows as a difference between the
two), the observed order of the amplitude against the finest run of each ladder, and s/step.

    python campaigns/fsi_time_ladder.py --ladder fsi3-seed --runs /tmp/ladder --md docs/perf/time_schemes/ladder.md
    python campaigns/fsi_time_ladder.py --read DIR [DIR ...]      # analyse finished runs only
    python campaigns/fsi_time_ladder.py --continue DIR --seconds 1.5 --set time.quadrature_degree=12 --out D
        # diagnosis: continue DIR's checkpoint with other options (a restart refuses them), also another δt
    python campaigns/fsi_time_ladder.py --continuations cfd3-dt --from DIR --runs R --md T.md  # CONTINUATIONS
    python campaigns/fsi_time_ladder.py --foot-map DIR --dts 0.0025 0.002  # the foot maps in DIR's flow
    python campaigns/fsi_time_ladder.py --averages DIR [DIR ...]  # uy(A) averaged over the last 2 s
    python campaigns/fsi_time_ladder.py --oscillator 0.5 --frequency 5.3  # generalised-α's own phase error
    python campaigns/fsi_time_ladder.py --area-defect DIR [DIR ...]  # ln J over the solid at the checkpoint
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from cosserat_fsi.analysis import periodic_analysis
from cosserat_fsi.app.cases import override
from cosserat_fsi.io import read_timeseries
from pinned_law import FSI3_VOLUME_CORRECTION, INCOMPRESSIBLE

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = {"uy_A": (0.03438, 5.3), "lift": (437.81, 4.3956)}
MR = {**INCOMPRESSIBLE, **FSI3_VOLUME_CORRECTION, "time.tolerance": None}  # the law they measured; fixed steps
FSI3_MR = ("configs/turek_hron_fsi3.yaml", MR)
FSI3_SEED = ("configs/turek_hron_fsi3.yaml", {**MR, "geometry.level": "seed", "time.scheme": "characteristics2"})
FSI3_L1 = ("configs/turek_hron_fsi3.yaml", {**MR, "time.scheme": "characteristics2"})
CFD3_L1 = ("configs/turek_hron_cfd3.yaml",  # the ladders' fixed steps, level 1, no tilt of the inflow
           {"time.tolerance": "null", "geometry.level": 1, "inflow.asymmetry": 0.0})
DTS = (0.01, 0.005, 0.0025, 0.00125)
CFD3_DTS = (0.005, 0.0025, 0.002, 0.001)
ALE = {"time.scheme": "ale_bdf2", "time.corrector_passes": "null"}  # null: the config's passes removed (0)
CHARS = {"time.scheme": "characteristics2", "time.corrector_passes": "null"}
GA = {**ALE, "time.scheme": "generalized_alpha"}  # generalised-α (ρ∞ = 0.5) on the nodal values, ALE convection


def _ladder(prefix: str, case: tuple, extra: dict, t_end: float, dts=DTS) -> list[tuple]:
    """(case id ``<prefix>-dt<δt>``, config, base overrides, ``extra`` with δt and t_end) for each δt."""
    return [(f"{prefix}-dt{dt}", *case, {**extra, "time.dt": dt, "time.t_end": t_end}) for dt in dts]


LADDERS = {
    "fsi3-seed": _ladder("fsi3-seed-c2-corr1", FSI3_SEED, {"time.corrector_passes": 1}, 7.0),
    "fsi3-L1": _ladder("fsi3-L1-c2-corr1", FSI3_L1, {"time.corrector_passes": 1}, 7.0),
    "cfd3": _ladder("cfd3-L1-c2", CFD3_L1, CHARS, 16.0, CFD3_DTS),
    # ale_bdf2: BDF2 of the nodal values + semi-implicit convection relative to the mesh
    "fsi3-seed-ale": _ladder("fsi3-seed-ale", FSI3_SEED, ALE, 8.0),
    "fsi3-L1-ale": _ladder("fsi3-L1-ale", FSI3_L1, ALE, 8.0),
    "cfd3-ale-picard": _ladder("cfd3-L1-ale-picard", CFD3_L1, {}, 10.0, (0.002,)),  # shipped: ale_bdf2 + 1 Picard
    "fsi3-seed-ga": _ladder("fsi3-seed-ga", FSI3_SEED, GA, 8.0),
    "fsi3-L1-ga": _ladder("fsi3-L1-ga", FSI3_L1, GA, 8.0),
    "cfd3-ga": _ladder("cfd3-L1-ga", CFD3_L1, GA, 16.0, CFD3_DTS),
    "cfd3-ale": _ladder("cfd3-L1-ale", CFD3_L1, ALE, 16.0, CFD3_DTS),
    # generalised-α with corrector passes (the mesh and the solid stress re-placed at the predicted
    # t^{n+α_f}, the solid's continuity pulled back from Ω^{n+1})
    **{f"fsi3-{mesh}-ga-c{passes}": _ladder(f"{mesh}-c{passes}", FSI3_MR, {**GA, "geometry.level": level,
                                                                          "time.corrector_passes": passes}, 8.0)
       for mesh, level in (("seed", "seed"), ("L1", 1)) for passes in (1, 2)},
    # the same with the volume correction undone over a fixed τ = 0.01 s (≥ every δt of the ladder)
    # instead of over max(δt, τ = 2 ms): the one-step correction's strength grows like 1/δt, which changes
    # the discrete problem with δt (docs/perf_generalized_alpha.md, "The volume correction's time and the frequency")
    **{f"fsi3-{mesh}-ga-c2-tau": _ladder(f"tau0.01-{mesh}", FSI3_MR, {**GA, "geometry.level": level,
                                         "time.corrector_passes": 2, "solid.volume_correction_time": 0.01}, 8.0)
       for mesh, level in (("seed", "seed"), ("L1", 1))},
}


def oscillator_errors(rho_infinity: float, omega_dt: float) -> tuple[float, float]:
    """Generalised-α (time_schemes/generalized_alpha.py, first-order form) on ẏ = iωy at ω δt: (relative
    frequency error, amplitude factor per period), the scheme's own phase error at 2π/(ωδt) steps a period."""
    from cosserat_fsi.time_schemes.generalized_alpha import generalized_alpha

    alpha_m, alpha_f, gamma = generalized_alpha(rho_infinity)
    lam = 1j * omega_dt  # unknowns (y^{n+1}, δt ẏ^{n+1}) from (y^n, δt ẏ^n)
    lhs = np.array([[1.0, -gamma], [-lam * alpha_f, alpha_m]])
    rhs = np.array([[1.0, 1.0 - gamma], [lam * (1.0 - alpha_f), -(1.0 - alpha_m)]])
    roots = np.linalg.eigvals(np.linalg.solve(lhs, rhs))
    root = roots[np.argmin(np.abs(roots - np.exp(lam)))]
    return float(np.angle(root) / omega_dt - 1.0), float(abs(root) ** (2.0 * np.pi / omega_dt))


# Continuations of a developed checkpoint (--continuations NAME --from DIR): (case, seconds, overrides, the
# case whose checkpoint it continues or None for DIR). DIR = a CFD3 L1 characteristics2 run at δt = 0.0025
# with a checkpoint at t = 15.
CONTINUATIONS = {
    "cfd3-dt": [(f"cfd3-euler-dt{dt}", 2.0, [f"time.dt={dt}"], None) for dt in (0.00225, 0.002, 0.00125, 0.000625)]
    + [("cfd3-euler-dt0.00125-4s", 3.5, ["time.dt=0.00125"], None),
       ("cfd3-back-to-0.0025", 2.5, ["time.dt=0.0025"], "cfd3-euler-dt0.00125-4s")],
}


def run(case_id: str, config: str, base: dict, extra: dict, runs: Path) -> Path:
    out = runs / case_id
    sets = {**base, **extra, "output.fields": "false"}
    series = out / "timeseries.csv"
    if series.exists():
        t = np.loadtxt(series, delimiter=",", skiprows=1, ndmin=2)[:, 0]
        if len(t) and t[-1] >= float(sets["time.t_end"]) - 1e-9:
            return out
    cmd = [sys.executable, "-m", "cosserat_fsi", "run", str(ROOT / config), "--out", str(out), "--no-progress",
           "--overwrite"] + [a for k, v in sets.items() for a in ("--set", override(k, v))]
    subprocess.run(cmd, check=False)
    return out


def analyse(out: Path) -> dict:
    """Amplitude/frequency of the last period and of the period ending 1 s before the end."""
    series = read_timeseries(out / "timeseries.csv")
    name = "uy_A" if "uy_A" in series else "lift"
    t, y = series["t"], series[name]
    ref_a, ref_f = REFERENCE[name]
    row = {"run": out.name, "observable": name, "t_end": float(t[-1]), "dt": float(t[-1] - t[-2])}
    for key, cut in (("", t[-1]), ("_1s_earlier", t[-1] - 1.0)):
        keep = t <= cut
        r = periodic_analysis(t[keep], y[keep]) if keep.sum() > 10 else {"amplitude": None}
        a, fr = r.get("amplitude"), r.get("frequency")
        row["amplitude" + key] = a
        row["amplitude_error" + key] = None if a is None else a / ref_a - 1
        row["frequency" + key] = fr
        row["frequency_error" + key] = None if fr is None else fr / ref_f - 1
    summary = out / "summary.json"
    if summary.exists():
        s = json.loads(summary.read_text())
        row["s_per_step"] = s["wall_time"]["per_step"]
        row["backtrack_per_step"] = s["wall_time"].get("phases_per_step", {}).get("backtrack")
        row["vertices"] = s["mesh"]["vertices"]
        row["status"] = s["status"]
    return row


def averaged(out: Path, seconds: float = 2.0) -> str:
    """uy(A) over the last ``seconds``: (mean of the maxima − mean of the minima)/2 and the frequency of the
    maxima, with the range of the maxima (a modulation the last period alone does not show)."""
    series = read_timeseries(out / "timeseries.csv")
    t, y = series["t"], series["uy_A"]
    inner = np.arange(1, len(y) - 1)
    peaks = inner[(y[1:-1] > y[:-2]) & (y[1:-1] > y[2:]) & (t[1:-1] > t[-1] - seconds)]
    troughs = inner[(y[1:-1] < y[:-2]) & (y[1:-1] < y[2:]) & (t[1:-1] > t[-1] - seconds)]
    amp = (y[peaks].mean() - y[troughs].mean()) / 2
    freq = (len(peaks) - 1) / (t[peaks[-1]] - t[peaks[0]])
    ref_a, ref_f = REFERENCE["uy_A"]
    return (f"{out.name}: amplitude {amp * 1e3:.3f} mm ({100 * (amp / ref_a - 1):+.2f} %), peaks "
            f"{y[peaks].min() * 1e3:.2f}–{y[peaks].max() * 1e3:.2f} mm, frequency {freq:.4f} Hz "
            f"({100 * (freq / ref_f - 1):+.2f} %)")


def _pct(x):
    return "–" if x is None else f"{100 * x:+.2f} %"


def _order(rows, r, finest, key):
    """Observed order of ``key`` between r and the next coarser run, against the finest run."""
    if r is finest or r[key] is None or finest[key] is None:
        return "–"
    coarser = [q for q in rows if q["dt"] > r["dt"] + 1e-12 and q[key] is not None]
    e = abs(r[key] - finest[key])
    if not coarser or e == 0:
        return "–"
    q = min(coarser, key=lambda q: q["dt"])
    e_q = abs(q[key] - finest[key])
    return f"{np.log(e_q / e) / np.log(q['dt'] / r['dt']):.2f}" if e_q > 0 else "–"


def table(rows: list[dict]) -> str:
    finest = min(rows, key=lambda r: r["dt"])
    lines = ["| run | δt | to t | amplitude | error | frequency | error | amplitude error 1 s earlier "
             "| order vs finest (amplitude, frequency) | s/step | back-tracking s/step |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: -r["dt"]):
        order = f"{_order(rows, r, finest, 'amplitude')}, {_order(rows, r, finest, 'frequency')}"
        amp = "–" if r["amplitude"] is None else f"{r['amplitude']:.5g}"
        fr = "–" if r["frequency"] is None else f"{r['frequency']:.4g}"
        lines.append(f"| {r['run']} | {r['dt']:g} | {r['t_end']:g} | {amp} | {_pct(r['amplitude_error'])} | {fr} | "
                     f"{_pct(r['frequency_error'])} | {_pct(r['amplitude_error_1s_earlier'])} | {order} | "
                     f"{r.get('s_per_step', float('nan')):.3f} | {r.get('backtrack_per_step') or float('nan'):.4f} |")
    return "\n".join(lines)


def rescale_history(sim, dt_old: float) -> None:
    """Continue a BDF2 checkpoint at another δt: each t^{n−1} level (u, ω, d, the configuration and the
    mesh displacement) is replaced by the linear interpolation f^n − (δt/δt_old)(f^n − f^{n−1}) between
    the saved levels, an O(δt²) start-up perturbation; ``step_count`` becomes t/δt."""
    state, r = sim.state, sim.scene.time.dt / dt_old
    pairs = [(state.velocity, state.velocity_prev), (state.micro_rotation, state.micro_rotation_prev),
             (state.displacement, state.displacement_prev), (state.configuration_n, state.configuration_nm1)]
    if state.motion is not None and state.mesh_displacement_prev is not None:
        pairs.append((state.motion.state_functions()["mesh_displacement"], state.mesh_displacement_prev))
    for now, before in pairs:
        if now is not None and before is not None:
            before.x.array[:] = now.x.array - r * (now.x.array - before.x.array)
    state.step_count = int(round(state.t / sim.scene.time.dt))


def _percentile(values: np.ndarray, weights: np.ndarray, q: float = 0.99) -> float:
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order]) / weights.sum()
    return float(values[order][np.searchsorted(cumulative, q)])


def checkpointed(run_dir: Path, overrides=()) -> tuple:
    """(scene, simulation, states) of ``run_dir``'s checkpoint: the simulation built from its config.yaml
    with ``overrides`` on COMM_WORLD, the states read but not yet restored into it."""
    from mpi4py import MPI

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.io.checkpoint import read_checkpoint
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD
    fingerprint = json.loads((run_dir / "checkpoint" / "meta.json").read_text())["fingerprint"]
    _, states = read_checkpoint(run_dir, comm, fingerprint)
    scene = load_scene(run_dir / "config.yaml", list(overrides))
    mesh, ct, ft, _ = load_mesh(scene, comm)
    return scene, Simulation(scene, mesh, ct, ft, comm), states


def foot_map(run_dir: Path, dts: list[float]) -> str:
    """How far the BDF2 foot maps x → x − kδt u* (k = 1, 2) are from the identity in the checkpointed
    flow of ``run_dir``, for each δt: with ∇u* at the cell centroids (u* = 2u^n − u^{n−1}, P2 on affine
    triangles), div u = 0 gives det(I − s∇u*) = 1 + s² det ∇u*, so the straight-line map over s = 2δt
    folds (det ≤ 0, feet crossing) where s √(−det ∇u*) ≥ 1 (strain-dominated), and its rotation error
    (s ω)²/2 is large where s √(det ∇u*) is (vortex cores). A markdown table of the maxima of both numbers
    over the mesh, where the maximum is, and the areas where the strain number exceeds ½ and 1."""
    _, sim, states = checkpointed(run_dir)
    sim.restore(states)
    loc = sim.locator
    u = sim.state.velocity
    dofs = loc.dofs(u.function_space)
    star = (2.0 * u.x.array - sim.state.velocity_prev.x.array).reshape(-1, 2)
    Ji = loc.Jinv.reshape(-1, 2, 2)  # rows: ∇λ1, ∇λ2
    g = [-Ji[:, 0] - Ji[:, 1], Ji[:, 0], Ji[:, 1]]  # ∇λ0, ∇λ1, ∇λ2
    third = 1.0 / 3.0  # P2 basis gradients at the centroid (λ = ⅓): vertices (4λ−1)∇λ, edges 4(λj∇λk + λk∇λj)
    grads = [third * g[0], third * g[1], third * g[2], 4 * third * (g[1] + g[2]), 4 * third * (g[0] + g[2]),
             4 * third * (g[0] + g[1])]
    grad_u = sum(star[dofs[:, k]][:, :, None] * grads[k][:, None, :] for k in range(6))  # (cells, i, j) = ∂_j u_i
    det = grad_u[:, 0, 0] * grad_u[:, 1, 1] - grad_u[:, 0, 1] * grad_u[:, 1, 0]
    area = 0.5 * np.abs(np.linalg.det(loc.J))
    centre = loc.x0 + loc.J.sum(axis=2) / 3.0
    strain, rotation = np.sqrt(np.maximum(-det, 0.0)), np.sqrt(np.maximum(det, 0.0))
    at, at_r = centre[np.argmax(strain)], centre[np.argmax(rotation)]
    lines = [f"foot maps of {run_dir.name} at t = {sim.t:g}: max √(−det ∇u*) = {strain.max():.4g} /s at "
             f"({at[0]:.3f}, {at[1]:.3f}), max √(det ∇u*) = {rotation.max():.4g} /s at ({at_r[0]:.3f}, "
             f"{at_r[1]:.3f}); 99th percentiles (by area) {_percentile(strain, area):.4g}, "
             f"{_percentile(rotation, area):.4g} /s", "",
             "| δt | 2δt·max √(−det ∇u*) (fold at 1) | area where > ½ | area where > 1 | 2δt·max √(det ∇u*) |",
             "|---|---|---|---|---|"]
    for dt in dts:
        s2 = 2.0 * dt
        lines.append(f"| {dt:g} | {s2 * strain.max():.3f} | {1e4 * area[s2 * strain > 0.5].sum():.3g} cm² | "
                     f"{1e4 * area[s2 * strain > 1.0].sum():.3g} cm² | {s2 * rotation.max():.3f} |")
    return "\n".join(lines)


def area_defect(run_dir: Path) -> str:
    """The solid's area defect at ``run_dir``'s checkpoint: mean and rms of ln J over the solid cells,
    J = 1/det(I − ∇d) (what the volume correction undoes)."""
    import dolfinx
    import ufl
    from mpi4py import MPI

    from cosserat_fsi import compat
    from cosserat_fsi.physics.solid import volume_ratio

    _, sim, states = checkpointed(run_dir)
    sim.restore(states)
    comm = sim.comm
    d, dx_solid = sim.state.displacement, sim.stepper.problem.dx_solid
    ln_j = ufl.ln(volume_ratio(d))

    def integral(e):
        return comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(e * dx_solid)), op=MPI.SUM)

    area = integral(1.0)
    return (f"{run_dir.name} at t = {sim.t:g}: ln J over the solid: mean {integral(ln_j) / area:+.3e}, "
            f"rms {np.sqrt(integral(ln_j ** 2) / area):.3e}")


def continue_with(run_dir: Path, overrides: list[str], seconds: float, out: Path) -> Path:
    """Continue the checkpoint of ``run_dir`` for ``seconds`` with ``overrides`` (another δt: the BDF2
    levels re-interpolated, ``rescale_history``); write
    ``out``/timeseries.csv (the run's series up to the checkpoint, then the new steps) and summary.json."""

    from cosserat_fsi.config import dump_resolved
    from cosserat_fsi.observables import Observables

    scene, sim, states = checkpointed(run_dir, overrides)
    comm, mesh = sim.comm, sim.mesh
    obs = Observables(sim)
    sim.state.restore(states, float(abs(sim.mesh.geometry.x).max()))
    dt_old = float(yaml.safe_load((run_dir / "config.yaml").read_text())["time"]["dt"])
    if abs(scene.time.dt - dt_old) > 1e-12 * dt_old:
        rescale_history(sim, dt_old)
    sim.stepper.restored()
    series = read_timeseries(run_dir / "timeseries.csv")
    header = list(series)
    old = np.column_stack(list(series.values()))
    old = old[old[:, 0] <= sim.t + 1e-9]
    rows, observing = [], [0.0]

    def observe(sim):
        tic = time.perf_counter()
        values = obs.evaluate()
        rows.append([sim.t] + [values[k] for k in header[1:]])
        observing[0] += time.perf_counter() - tic

    start, steps = time.perf_counter(), sim.step_count
    sim.run(sim.steps_to(sim.t + seconds), observers=[observe])
    n_steps = max(1, sim.step_count - steps)
    per_step = (time.perf_counter() - start - observing[0]) / n_steps  # without observing
    phases = {k: v / n_steps for k, v in sim.timers.totals.items()}
    out.mkdir(parents=True, exist_ok=True)
    np.savetxt(out / "timeseries.csv", np.vstack([old, np.array(rows)]), delimiter=",", header=",".join(header),
               comments="")
    from cosserat_fsi.io.checkpoint import scene_fingerprint, write_checkpoint

    (out / "config.yaml").write_text(dump_resolved(scene))  # so that ``out`` can be continued in turn
    write_checkpoint(out, sim, comm, {"fingerprint": scene_fingerprint(scene), "rows": sim.step_count,
                                      "field_steps": 0})
    wall = {"per_step": per_step, "phases_per_step": phases}
    solver = sim.stepper.solver
    if getattr(solver, "reuse", False):
        wall["factorisations_per_step"] = solver.factorisations / n_steps
        wall["krylov_iterations_per_step"] = solver.krylov_iterations / n_steps
    (out / "summary.json").write_text(json.dumps({"status": "completed", "overrides": overrides, "from": str(run_dir),
                                                  "wall_time": wall,
                                                  "mesh": {"vertices": mesh.topology.index_map(0).size_global}}))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ladder", choices=sorted(LADDERS))
    p.add_argument("--averages", nargs="+", type=Path, metavar="DIR",
                   help="uy(A) averaged over the last 2 s of each finished FSI run")
    p.add_argument("--runs", type=Path, default=ROOT / "runs" / "time_ladder")
    p.add_argument("--read", nargs="*", type=Path, default=[])
    p.add_argument("--md", type=Path)
    p.add_argument("--continue", dest="cont", type=Path)
    p.add_argument("--seconds", type=float, default=1.5)
    p.add_argument("--set", dest="sets", action="append", default=[])
    p.add_argument("--out", type=Path)
    p.add_argument("--continuations", choices=sorted(CONTINUATIONS), help="continue --from DIR's checkpoint")
    p.add_argument("--from", dest="origin", type=Path)
    p.add_argument("--foot-map", dest="foot_map", type=Path, help="checkpointed run: the foot maps' numbers")
    p.add_argument("--dts", type=float, nargs="*", default=[0.005, 0.004, 0.0025, 0.002, 0.00125, 0.000625])
    p.add_argument("--oscillator", type=float, metavar="RHO_INFINITY",
                   help="generalised-α's frequency error and amplitude factor per period on an oscillator")
    p.add_argument("--frequency", type=float, default=5.3, help="the oscillator's frequency (Hz)")
    p.add_argument("--area-defect", dest="area_defect", nargs="+", type=Path, metavar="DIR",
                   help="mean and rms of ln J over the solid at each checkpointed run's checkpoint")
    a = p.parse_args(argv)
    if a.area_defect:
        print("\n".join(area_defect(d) for d in a.area_defect))
        return 0
    if a.oscillator is not None:
        for dt in DTS:
            error, factor = oscillator_errors(a.oscillator, 2.0 * np.pi * a.frequency * dt)
            print(f"ρ∞ = {a.oscillator}, δt = {dt}: ωδt = {2 * np.pi * a.frequency * dt:.3f}, frequency "
                  f"{100 * error:+.3f} %, amplitude × {factor:.5f} per period")
        return 0
    if a.averages:
        print("\n".join(averaged(d) for d in a.averages))
        return 0
    if a.foot_map:
        print(foot_map(a.foot_map, a.dts))
        return 0
    if a.cont:
        a.read.append(continue_with(a.cont, a.sets, a.seconds, a.out))
    for case, seconds, sets, source in CONTINUATIONS.get(a.continuations, []):
        out = a.runs / case
        if not (out / "summary.json").exists():
            continue_with(a.runs / source if source else a.origin, sets, seconds, out)
        a.read.append(out)
    outs = [run(c, cfg, base, extra, a.runs) for c, cfg, base, extra in LADDERS[a.ladder]] if a.ladder else []
    rows = [analyse(o) for o in outs + a.read if (o / "timeseries.csv").exists()]
    text = table(rows)
    print(text)
    if a.md:
        a.md.write_text(text + "\n")
        a.md.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
