"""Finished runs of the large-deformation scenes side by side: one markdown row each.

    python campaigns/large_runs.py [--from T] RUN [RUN ...]

Per run folder (its summary.json and timeseries.csv): ranks, status, steps (rejected attempts), remeshes,
uy(A) min / max and the frequency of uy(A) over t >= T (default 11, the saturated swing of the heavy, soft
flag), ux(A) min, the lowest cell quality, the wall time and its ratio to the first run's (run the first and
the others side by side for a fair ratio). docs/perf_adaptive_step.md, "Large deformation with a
compressible flag".
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cosserat_fsi.analysis import periodic_analysis
from cosserat_fsi.io import read_timeseries

HEADER = ("| run | ranks | status | steps (rejected) | remeshes | uy(A) min / max (cm) | uy(A) frequency (Hz) "
          "| ux(A) min (cm) | lowest q | wall time (s) | × the first |\n|---|---|---|---|---|---|---|---|---|---|---|")


def row(run: Path, t_from: float, first_wall: float | None) -> tuple[str, float]:
    """The run's markdown row and its wall time."""
    summary = json.loads((run / "summary.json").read_text())
    series = read_timeseries(run / "timeseries.csv")
    t, uy, ux = series["t"], series["uy_A"], series["ux_A"]
    tail = t >= t_from
    if tail.sum() >= 3:
        swing = f"{100 * uy[tail].min():.2f} / {100 * uy[tail].max():+.2f}"
        frequency = periodic_analysis(t[tail], uy[tail])["frequency"]
        frequency = f"{frequency:.3f}" if frequency is not None else "–"
        ux_min = f"{100 * ux[tail].min():.2f}"
    else:
        swing, frequency, ux_min = f"(ends at t = {t[-1]:.3f})", "–", "–"
    time, wall = summary["time"], summary["wall_time"]["total"]
    ratio = "1" if first_wall is None else f"{wall / first_wall:.2f}"
    text = (f"| {run.name} | {summary['ranks']} | {summary['status']} | {time['steps']:,} "
            f"({time.get('rejected_steps', 0)}) | {summary['remeshes']['count']} | {swing} | {frequency} | {ux_min} "
            f"| {summary['mesh_quality']['lowest']:.3f} | {wall:,.0f} | {ratio} |")
    return text, wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--from", dest="t_from", type=float, default=11.0)
    args = parser.parse_args(argv)
    print(HEADER)
    first = None
    for run in args.runs:
        text, wall = row(run, args.t_from, first)
        first = wall if first is None else first
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
