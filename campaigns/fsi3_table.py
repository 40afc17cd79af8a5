"""The whole Turek–Hron FSI3 table of finished runs, and the cycle-by-cycle values behind it.

    python campaigns/fsi3_table.py RUN_DIR [RUN_DIR ...]              # one markdown row per run
    python campaigns/fsi3_table.py --cycles RUN_DIR [RUN_DIR ...]     # each cycle's mean and amplitude error
    python campaigns/fsi3_table.py --at 10,14 RUN_DIR [RUN_DIR ...]    # the rows as if each run ended there

Rows: the twelve quantities' errors against the benchmark authors' refined values (``ux_A``, ``uy_A``, ``drag``,
``lift``: mean, amplitude, frequency; a mean smaller than its amplitude relative to the amplitude), the worst of
them, the steps and the wall time, recomputed from each run's timeseries.csv and config.yaml with the current
analysis (campaigns/reanalyse.py); a CFD3 run's rows have its six (drag, lift). ``--at``: one row per run and
time, from the record up to that time (has the flow settled?). ``--cycles``: for each quantity (and the
surface-integral forces), the mean and amplitude errors of every cycle between two maxima from t = 6 on: a
quantity at twice the flag's frequency alternates between two cycle shapes (against the run's own benchmark:
CFD3's drag and lift too). Used by docs/fsi3_table.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "campaigns"))

from reanalyse import reanalyse  # noqa: E402

from cosserat_fsi.analysis import cycle_extrema, cycle_peaks  # noqa: E402
from cosserat_fsi.app.verdict import periodic_error  # noqa: E402
from cosserat_fsi.config import load_scene  # noqa: E402
from cosserat_fsi.io import read_timeseries  # noqa: E402
from cosserat_fsi.references import reference_for  # noqa: E402

QUANTITIES = ("ux_A", "uy_A", "drag", "lift")
PARTS = ("mean", "amplitude", "frequency")


def quantities(summary: dict) -> list[str]:
    """The periodic quantities the (reanalysed) summary judges: FSI3's four, CFD3's drag and lift."""
    return [q for q in QUANTITIES if q in summary["benchmark"]]


def row(run: Path, until: float | None = None, summary: dict | None = None) -> str:
    """``| run | steps | wall | the errors | worst |`` of one finished run (``until``: up to that time;
    ``summary``: its reanalysis, when already made)."""
    summary = reanalyse(run, until) if summary is None else summary
    bench, time = summary["benchmark"], summary["time"]
    errors = [bench[q][p]["error"] for q in quantities(summary) for p in PARTS]
    steps = f"{time['steps']:,}" + (f" (+{time['rejected_steps']})" if "rejected_steps" in time else "")
    name = run.name if until is None else f"{run.name}, t ≤ {until:g}"
    wall = "–" if until is not None else f"{summary['wall_time']['total']:.0f}"
    return (f"| {name} | {steps} | {wall} | "
            + " | ".join(f"{100 * e:+.2f}" for e in errors) + f" | {100 * max(map(abs, errors)):.2f} |")


def header(summary: dict) -> list[str]:
    cells = [f"{q} {p[:4]}" for q in quantities(summary) for p in PARTS]
    return ["| run | steps | wall (s) | " + " | ".join(cells) + " | worst (%) |", "|---" * (len(cells) + 4) + "|"]


def cycles(run: Path, since: float = 6.0) -> list[str]:
    """Each quantity's cycles from ``since`` on: (start time, mean error, amplitude error) in percent, against
    the run's own benchmark (config.yaml's ``benchmark``; FSI3 when it names none): CFD3's drag too."""
    series = read_timeseries(run / "timeseries.csv")
    benchmark = load_scene(run / "config.yaml").benchmark or "turek_hron_fsi3"
    reference = reference_for(benchmark)
    t = series["t"]
    keep = t >= since - 1.0
    lines = [f"{run.name}:"]
    for key in (*QUANTITIES, "drag_surface", "lift_surface"):
        if key not in series or key.replace("_surface", "") not in reference:
            continue
        ref = reference[key.replace("_surface", "")]
        tt, y = t[keep], series[key][keep]
        peaks = cycle_peaks(y, y[tt >= since])
        _, tops, bottoms = cycle_extrema(tt, y, peaks)
        parts = []
        for k, a in enumerate(peaks[:-1]):
            if tt[a] < since:
                continue
            top, bottom = max(tops[k], tops[k + 1]), bottoms[k]
            mean, amplitude = (top + bottom) / 2, (top - bottom) / 2
            parts.append(f"[{tt[a]:.2f}: {100 * periodic_error(mean, ref, 'mean')[0]:+.1f} / "
                         f"{100 * periodic_error(amplitude, ref, 'amplitude')[0]:+.1f}]")
        lines.append(f"  {key:13s} " + " ".join(parts[-6:]))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--cycles", action="store_true", help="each cycle's mean / amplitude error (%%)")
    parser.add_argument("--at", type=lambda text: [float(t) for t in text.split(",")],
                        help="rows as if each run had ended at these times (comma-separated)")
    args = parser.parse_args()
    if args.cycles:
        for run in args.runs:
            print("\n".join(cycles(run)))
        return
    cases = [(run, t, reanalyse(run, t)) for run in args.runs for t in (args.at or [None])]
    print("\n".join(header(cases[0][2]) + [row(run, t, summary) for run, t, summary in cases]))


if __name__ == "__main__":
    main()
