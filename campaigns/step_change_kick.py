"""What a change of the time step does to the forces: the drag's step-to-step roughness of finished runs, and
the response of a fixed-step run's checkpoint to one prescribed change.

    python campaigns/step_change_kick.py roughness T0 T1 RUN_DIR [RUN_DIR ...]   # per run, over T0 <= t <= T1
    python campaigns/step_change_kick.py kick RUN_DIR [--ratio 1.2] [--steps 10,20]
    python campaigns/step_change_kick.py fitted 0.1 RUN_DIR [RUN_DIR ...]       # FSI3 runs

``roughness``: per run, the median step, how many steps change the step size, and for the drag, the lift and
uy(A) the RMS and the largest deviation of each row from the straight line through its two neighbours (in
time: a smooth signal's deviation is its curvature, A (2πf δt)²/2 at most: about 0.1 N for FSI3's drag at
δt = 0.00125), the deviation after a change and after none. ``kick``: from RUN_DIR's checkpoint (a
fixed-step run), ``--steps`` n₁ steps of the run's own δt then n₂ of ``ratio`` × δt, prescribed with
``Simulation.step(dt=...)``, and the same n₁ + n₂ steps at the run's δt: the drag's deviation row by row.
``fitted``: each FSI3 quantity's mean and amplitude errors with the verdict's extrema and with least-squares
parabolas over ± FIT × the period (cosserat_fsi.analysis, ``fit``): how much of an amplitude error is the
step-scale roughness at an extremum. Used by docs/fsi3_table.md ("A finer flag at level 1's fluid").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "campaigns"))


def deviation(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """|y_k − the line through (t_{k−1}, y_{k−1}) and (t_{k+1}, y_{k+1})| for the inner rows."""
    line = (y[:-2] * (t[2:] - t[1:-1]) + y[2:] * (t[1:-1] - t[:-2])) / (t[2:] - t[:-2])
    return np.abs(y[1:-1] - line)


def roughness(run: Path, t0: float, t1: float) -> str:
    """One markdown row: the run's steps, step changes and the forces' roughness over t0 ≤ t ≤ t1."""
    from cosserat_fsi.io import read_timeseries

    series = read_timeseries(run / "timeseries.csv")
    t = series["t"]
    keep = (t >= t0) & (t <= t1)
    steps = series["dt"][keep] if "dt" in series else np.diff(t[keep])
    changed = np.abs(np.diff(steps)) > 1e-12 * steps[1:]
    cells = [run.name, f"{keep.sum()}", f"{np.median(steps):.3g}", f"{changed.sum()}"]
    rows = {key: deviation(t[keep], series[key][keep]) for key in ("drag", "lift", "uy_A")}
    cells += [f"{np.sqrt(np.mean(r ** 2)):.3g} / {r.max():.3g}" for r in rows.values()]
    r = rows["drag"]
    after = changed[:len(r)]  # row k + 1 is the first of a changed step
    cells.append(f"{r[after].mean():.3g} / {r[~after].mean():.3g}" if after.any() else f"– / {r.mean():.3g}")
    return "| " + " | ".join(cells) + " |"


def kick(run: Path, ratio: float, steps: tuple[int, int]) -> list[str]:
    """The drag's deviation row by row after one prescribed change of the step (module docstring)."""
    from fsi_time_ladder import checkpointed

    from cosserat_fsi.observables import Observables

    lines = []
    for label, factor in (("constant", 1.0), (f"x {ratio:g} after {steps[0]}", ratio)):
        scene, sim, states = checkpointed(run)
        observables = Observables(sim)  # on the reference mesh, before the restore
        sim.restore(states)
        dt = float(scene.time.dt)
        rows = []
        for k in range(sum(steps)):
            sim.step(dt=dt if k < steps[0] else factor * dt)
            rows.append((sim.t, observables.evaluate()["drag"]))
        t, drag = np.array(rows).T
        lines.append(f"{label:>16}: " + " ".join(f"{d:.2f}" for d in deviation(t, drag)))
    return lines


def fitted(run: Path, fit: float) -> str:
    """One markdown row: each FSI3 quantity's mean and amplitude errors (%) with the extrema of the verdict
    (three-sample vertices) → with least-squares parabolas over ± ``fit`` × the period."""
    from cosserat_fsi.analysis import periodic_analysis
    from cosserat_fsi.app.verdict import periodic_error
    from cosserat_fsi.io import read_timeseries
    from cosserat_fsi.references import reference_for

    from fsi3_table import QUANTITIES

    series, reference = read_timeseries(run / "timeseries.csv"), reference_for("turek_hron_fsi3")
    cells = [run.name]
    for key in QUANTITIES:
        results = [periodic_analysis(series["t"], series[key], fit=f) for f in (None, fit)]
        for part in ("mean", "amplitude"):
            a, b = (100 * periodic_error(r[part], reference[key], part)[0] for r in results)
            cells.append(f"{a:+.2f} → {b:+.2f}")
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    rough = sub.add_parser("roughness")
    rough.add_argument("t0", type=float)
    rough.add_argument("t1", type=float)
    rough.add_argument("runs", nargs="+", type=Path)
    one = sub.add_parser("kick")
    one.add_argument("run", type=Path)
    one.add_argument("--ratio", type=float, default=1.2)
    one.add_argument("--steps", type=lambda s: tuple(int(n) for n in s.split(",")), default=(10, 20))
    fit = sub.add_parser("fitted")
    fit.add_argument("fit", type=float)
    fit.add_argument("runs", nargs="+", type=Path)
    args = parser.parse_args()
    if args.what == "fitted":
        from fsi3_table import QUANTITIES

        cells = [f"{q} {p}" for q in QUANTITIES for p in ("mean", "ampl")]
        print("| run | " + " | ".join(cells) + " |")
        print("|---" * (len(cells) + 1) + "|")
        for run in args.runs:
            print(fitted(run, args.fit))
    elif args.what == "roughness":
        print("| run | rows | median δt | step changes | drag RMS / max (N) | lift RMS / max (N) | uy(A) RMS / max (m) "
              "| drag after a change / after none (N) |")
        print("|---" * 8 + "|")
        for run in args.runs:
            print(roughness(run, args.t0, args.t1))
    else:
        print("\n".join(kick(args.run, args.ratio, args.steps)))


if __name__ == "__main__":
    main()
