"""Re-derive the periodic analysis and the benchmark comparison of finished runs from their own files.

    python campaigns/reanalyse.py RUN_DIR [RUN_DIR ...]            # rewrite each summary.json in place
    python campaigns/reanalyse.py --print RUN_DIR [RUN_DIR ...]    # only print the benchmark errors

For runs made before a change of cosserat_fsi/analysis.py or app/verdict.py: the ``signals``, ``periodic``
and ``benchmark`` blocks of each run's summary.json are recomputed from its timeseries.csv and its resolved
config.yaml, as the runner computes them at the end of a run; nothing else in the summary changes.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosserat_fsi.app.verdict import classify_signals, compare_with_reference  # noqa: E402
from cosserat_fsi.config import load_scene  # noqa: E402
from cosserat_fsi.io import read_timeseries  # noqa: E402


def reanalyse(run: Path, until: float | None = None) -> dict:
    """The run's summary with ``signals``, ``periodic`` and ``benchmark`` recomputed (``until``: from the
    record up to that time, as if the run had ended there)."""
    summary = json.loads((run / "summary.json").read_text())
    scene = load_scene(run / "config.yaml")
    series = read_timeseries(run / "timeseries.csv")
    if until is not None:
        keep = series["t"] <= until + 1e-9
        series = {key: values[keep] for key, values in series.items()}
        summary["time"] = {k: v for k, v in summary["time"].items() if k != "rejected_steps"}  # (of the whole run)
        summary["time"].update(steps=int(keep.sum()), t_final=float(series["t"][-1]))
    summary["signals"], summary["periodic"] = classify_signals(series)
    if scene.benchmark:
        summary["benchmark"] = compare_with_reference(scene, summary)
    return summary


def errors_line(summary: dict) -> str:
    """``quantity part error`` for every compared quantity, in percent."""
    parts = []
    for key, value in (summary.get("benchmark") or {}).items():
        if isinstance(value, dict) and "error" in value:
            parts.append(f"{key} {100 * value['error']:+.2f} %")
        elif isinstance(value, dict):
            parts += [f"{key}.{p} {100 * v['error']:+.2f} %" for p, v in value.items()
                      if isinstance(v, dict) and v.get("error") is not None]
    return ", ".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--print", action="store_true", help="print only, leave summary.json alone")
    args = parser.parse_args()
    for run in args.runs:
        summary = reanalyse(run)
        print(f"{run}: {errors_line(summary)}")
        if not args.print:
            (run / "summary.json").write_text(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
