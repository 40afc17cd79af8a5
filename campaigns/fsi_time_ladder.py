"""Issue 12: δt ladders of FSI3 uy(A) and CFD3 lift — run the cases (or read finished ones) and write a table.

Each case is `cosserat-fsi run CONFIG --set ...` into ``<runs>/<id>``; a case whose timeseries.csv reaches
its t_end is not run again. The table gives the periodic amplitude and frequency of the last full period
(cosserat_fsi.analysis.periodic_analysis, as the validation), their errors against the reference, the
same over the period ending 1 s earlier (a still-growing oscillation shows as a difference between the
two), the observed order of the amplitude against the finest run of each ladder, and s/step.

    python campaigns/fsi_time_ladder.py --ladder fsi3-seed --runs /tmp/ladder --md docs/perf/issue12/ladder.md
    python campaigns/fsi_time_ladder.py --read DIR [DIR ...]      # analyse finished runs only
    python campaigns/fsi_time_ladder.py --continue DIR --seconds 1.5 --set time.quadrature_degree=12 --out D
        # diagnosis: continue DIR's checkpoint with other options at the same δt (a restart refuses them)
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

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = {"uy_A": (0.03438, 5.3), "lift": (437.81, 4.3956)}
FSI3_SEED = ("configs/turek_hron_fsi3.yaml", {"geometry.level": "seed", "time.scheme": "characteristics2"})
FSI3_L1 = ("configs/turek_hron_fsi3.yaml", {"time.scheme": "characteristics2"})
CFD3_L1 = ("configs/turek_hron_cfd3.yaml", {})
DTS = (0.01, 0.005, 0.0025, 0.00125)
LADDERS = {
    "fsi3-seed": [(f"fsi3-seed-c2-corr1-dt{dt}", *FSI3_SEED, {"time.corrector_passes": 1, "time.dt": dt,
                                                            "time.t_end": 7.0}) for dt in DTS],
    "fsi3-L1": [(f"fsi3-L1-c2-corr1-dt{dt}", *FSI3_L1, {"time.corrector_passes": 1, "time.dt": dt,
                                                        "time.t_end": 7.0}) for dt in DTS],
    "cfd3": [(f"cfd3-L1-c2-dt{dt}", *CFD3_L1, {"time.dt": dt, "time.t_end": 16.0}) for dt in (0.005, 0.0025, 0.002,
                                                                                          0.001)],
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
           "--overwrite"] + [a for k, v in sets.items() for a in ("--set", f"{k}={v}")]
    subprocess.run(cmd, check=False)
    return out


def analyse(out: Path) -> dict:
    """Amplitude/frequency of the last period and of the period ending 1 s before the end."""
    with open(out / "timeseries.csv") as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    name = "uy_A" if "uy_A" in names else "lift"
    t, y = data[:, 0], data[:, names.index(name)]
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
        row["vertices"] = s["mesh"]["vertices"]
        row["status"] = s["status"]
    return row


def _pct(x):
    return "–" if x is None else f"{100 * x:+.2f} %"


def table(rows: list[dict]) -> str:
    finest = min(rows, key=lambda r: r["dt"])
    lines = ["| run | δt | to t | amplitude | error | frequency | error | amplitude error 1 s earlier "
             "| order vs finest | s/step |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: -r["dt"]):
        order = "–"
        if r is not finest and r["amplitude"] is not None and finest["amplitude"] is not None:
            coarser = [q for q in rows if q["dt"] > r["dt"] + 1e-12 and q["amplitude"] is not None]
            e = abs(r["amplitude"] - finest["amplitude"])
            if coarser:
                q = min(coarser, key=lambda q: q["dt"])
                e_q = abs(q["amplitude"] - finest["amplitude"])
                if e > 0 and e_q > 0:
                    order = f"{np.log(e_q / e) / np.log(q['dt'] / r['dt']):.2f}"
        amp = "–" if r["amplitude"] is None else f"{r['amplitude']:.5g}"
        fr = "–" if r["frequency"] is None else f"{r['frequency']:.4g}"
        lines.append(f"| {r['run']} | {r['dt']:g} | {r['t_end']:g} | {amp} | {_pct(r['amplitude_error'])} | {fr} | "
                     f"{_pct(r['frequency_error'])} | {_pct(r['amplitude_error_1s_earlier'])} | {order} | "
                     f"{r.get('s_per_step', float('nan')):.3f} |")
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


def continue_with(run_dir: Path, overrides: list[str], seconds: float, out: Path) -> Path:
    """Continue the checkpoint of ``run_dir`` for ``seconds`` with ``overrides`` (another δt: the BDF2
    levels re-interpolated, ``rescale_history``); write
    ``out``/timeseries.csv (the run's series up to the checkpoint, then the new steps) and summary.json."""

    from mpi4py import MPI

    from cosserat_fsi.config import load_scene
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.io.checkpoint import read_checkpoint
    from cosserat_fsi.observables import Observables
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD
    fingerprint = json.loads((run_dir / "checkpoint" / "meta.json").read_text())["fingerprint"]
    meta, states = read_checkpoint(run_dir, comm, fingerprint)
    scene = load_scene(run_dir / "config.yaml", overrides)
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    obs = Observables(sim)
    sim.state.restore(states, float(abs(sim.mesh.geometry.x).max()))
    dt_old = float(yaml.safe_load((run_dir / "config.yaml").read_text())["time"]["dt"])
    if abs(scene.time.dt - dt_old) > 1e-12 * dt_old:
        rescale_history(sim, dt_old)
    sim.stepper.restored()
    with open(run_dir / "timeseries.csv") as f:
        header = f.readline().strip().split(",")
    old = np.loadtxt(run_dir / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    old = old[old[:, 0] <= sim.t + 1e-9]
    rows, observing = [], [0.0]

    def observe(sim):
        tic = time.perf_counter()
        values = obs.evaluate()
        rows.append([sim.t] + [values[k] for k in header[1:]])
        observing[0] += time.perf_counter() - tic

    start, steps = time.perf_counter(), sim.step_count
    sim.run(sim.steps_to(sim.t + seconds), observers=[observe])
    per_step = (time.perf_counter() - start - observing[0]) / max(1, sim.step_count - steps)  # without observing
    out.mkdir(parents=True, exist_ok=True)
    np.savetxt(out / "timeseries.csv", np.vstack([old, np.array(rows)]), delimiter=",", header=",".join(header),
               comments="")
    (out / "summary.json").write_text(json.dumps({"status": "completed", "overrides": overrides,
                                                  "from": str(run_dir), "wall_time": {"per_step": per_step},
                                                  "mesh": {"vertices": mesh.topology.index_map(0).size_global}}))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ladder", choices=sorted(LADDERS))
    p.add_argument("--runs", type=Path, default=ROOT / "runs" / "issue12")
    p.add_argument("--read", nargs="*", type=Path, default=[])
    p.add_argument("--md", type=Path)
    p.add_argument("--continue", dest="cont", type=Path)
    p.add_argument("--seconds", type=float, default=1.5)
    p.add_argument("--set", dest="sets", action="append", default=[])
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    if a.cont:
        a.read.append(continue_with(a.cont, a.sets, a.seconds, a.out))
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
