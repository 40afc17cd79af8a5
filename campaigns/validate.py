"""`make validate`: run the benchmark ladder and write docs/validation.md (+ PNG plots).

Each case is a config of configs/ plus `--set` overrides, run as its own `cosserat-fsi run` process
(several at once with ``--jobs``). A finished case (its summary.json matches the resolved config) is not
run again, so an interrupted validation resumes. Tolerances are each benchmark's acceptance criteria.
The cases are in validate_cases.py, the figures in validate_plots.py; this script measures and writes the report.

    python campaigns/validate.py [--jobs 2] [--only PATTERN] [--out docs]
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import sys
from pathlib import Path

import numpy as np

from cosserat_fsi.app import cases as app_cases
from cosserat_fsi.app.verdict import periodic_error
from cosserat_fsi.io import read_timeseries
from cosserat_fsi.references import load_references, parse_periodic

from validate_cases import ALL_CASES, FSI_CASES, LADDERS, ROOT, STEADY_NOTES, Case
from validate_cases import CFD3 as CFD3  # re-exported: tests/test_validate.py builds cases with it
from validate_plots import plot_c1_sweep, plot_cfd3, plot_expansion, plot_flap, plot_tip


def run_case(case: Case, runs: Path, python: str | None = None, fields: bool = False) -> Path:
    """Run one case (unless it already finished; see cosserat_fsi.app.cases) and return its output folder."""
    return app_cases.run_case(case.run(runs, fields), python)


def measured(summary: dict, key: str):
    """The value of ``key`` ("c_D", "drag", "lift.amplitude", …) in a run's benchmark comparison."""
    bench = summary.get("benchmark", {})
    name, _, part = key.partition(".")
    entry = bench.get(name)
    if entry is None:
        return None
    return entry.get(part) if part else entry


def not_applicable(case: Case, summary: dict | None = None) -> list[str]:
    """The defining keys in which the case's scene differs from the benchmark it names (config/benchmarks.py;
    a summary.json's ``benchmark.differs`` when it says): such a case's rows get no verdict ("n/a")."""
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.config.benchmarks import differences
    from cosserat_fsi.errors import InputError

    bench = (summary or {}).get("benchmark") or {}
    if "applicable" in bench:
        return list(bench.get("differs") or [])
    if case.measure is not None:  # an example: its own measurements, no benchmark
        return []
    try:
        scene = load_scene(ROOT / case.config, [app_cases.override(k, v) for k, v in case.overrides.items()])
    except InputError:  # no such scene file here: nothing to tell
        return []
    return list(differences(scene))


def _without_verdict(rows: list[str]) -> list[str]:
    """Earlier rows of a case that is not its benchmark's problem, their ``ok`` cell "n/a"."""
    out = []
    for row in rows:
        cells = row.strip().strip("|").split("|")
        if len(cells) == 12:
            cells[9] = " n/a "
            row = "|" + "|".join(cells) + "|"
        out.append(row)
    return out


def previous_rows(report: Path) -> dict[str, list[str]]:
    """Rows of an earlier docs/validation.md, by case id: a case whose run folder is gone (a fresh
    checkout keeps only docs/runs/*/summary.json, and only for runs made since that was committed)
    keeps its measured rows instead of turning into "not run"."""
    rows: dict[str, list[str]] = {}
    if not report.exists():
        return rows
    for line in report.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 12 and cells[4] != "not run" and cells[0] not in ("case", "---"):
            rows.setdefault(cells[0].split(" (")[0], []).append(line)
    return rows


def _percent(x: float, sign: str, digits: int, fine: bool) -> str:
    """x as a percentage with ``digits`` decimals; ``fine``: 2 significant digits below 0.1 % (the examples'
    small tolerances and errors)."""
    return f"{100 * x:{sign}.2g}%" if fine and 0 < abs(x) < 1e-3 else format(x, f"{sign}.{digits}%")


def observed(case: Case, runs: Path, summary: dict) -> dict:
    """{key: {value, reference, error}} of a finished case: its ``measure`` of the run folder (None when the
    folder has only its summary.json), else the benchmark comparison in its summary.json."""
    if case.measure is None:
        return {key: measured(summary, key) for key in case.tolerances}
    try:
        return case.measure(runs / case.id)
    except (OSError, KeyError, ValueError, IndexError):  # its timeseries.csv is gone (a fresh checkout)
        return None


def judged_error(summary: dict, key: str, m: dict) -> tuple[float | None, str]:
    """(signed error, " of amplitude" or "") of a measured ``key`` as app/verdict.py judges it: a mean about zero
    (a lift, uy(A)) relative to the amplitude, also for a summary written before the verdict said so."""
    name, _, part = key.partition(".")
    entry = (summary.get("benchmark") or {}).get(name)
    if part in ("mean", "amplitude", "frequency") and isinstance(entry, dict):
        references = {p: e.get("reference") for p, e in entry.items() if isinstance(e, dict)}
        err, relative_to = periodic_error(m["value"], references, part)
        return err, " of amplitude" if relative_to == "amplitude" and part == "mean" else ""
    return ((m["value"] - m["reference"]) / abs(m["reference"]) if m["reference"] else None), ""


SCHEME_NAMES = {"characteristics1": "1st order", "characteristics2": "BDF2", "ale_bdf2": "BDF2, ale",
                "generalized_alpha": "generalised-α", "steady": "steady"}


def table(cases, runs: Path, previous: dict | None = None) -> list[str]:
    previous = previous or {}
    rows = ["| case | mesh (vertices) | scheme | δt | observable | value | reference | error | tolerance | ok "
            "| wall (s) | s/step |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for case in cases:
        path = runs / case.id / "summary.json"
        if not path.exists():
            earlier = previous.get(case.id, [f"| {case.id} | – | – | – | not run | | | | | | | |"])
            rows += _without_verdict(earlier) if case.id in previous and not_applicable(case) else earlier
            continue
        s = json.loads(path.read_text())
        mesh = f"L{s['mesh']['level']} ({s['mesh']['vertices']:,})"
        scheme = SCHEME_NAMES.get(s["time"]["scheme"], s["time"]["scheme"])
        if s["time"].get("convection") == "ale" and scheme == "BDF2":  # a summary from before ale_bdf2
            scheme += ", ale"
        dt = "–" if s["time"]["scheme"] == "steady" else s["time"]["dt"]
        if s["time"].get("tolerance") is not None:  # the step chosen by time.tolerance: its range
            dt = f"tol {s['time']['tolerance']:g} ({s['time']['dt_smallest']:.2g}–{s['time']['dt_largest']:.2g})"
        status = "" if s["status"] == "completed" else f" ({s['status']})"
        found = observed(case, runs, s)
        if found is None:  # only summary.json is kept: the rows written when the run was there
            earlier = previous.get(case.id, [f"| {case.id} | – | – | – | not measured | | | | | | | |"])
            rows += _without_verdict(earlier) if case.id in previous and not_applicable(case, s) else earlier
            continue
        wall = f"{s['wall_time']['total']:.0f} | {s['wall_time']['per_step']:.3f} |"
        judged = not not_applicable(case, s)  # another problem than the benchmark's: no verdict
        for key, tol in case.tolerances.items():
            m = found.get(key)
            fine = case.measure is not None
            shown = "–" if tol is None else _percent(tol, "", 1, fine)
            if not m or m.get("value") is None:
                rows.append(f"| {case.id}{status} | {mesh} | {scheme} | {dt} | {key} | – | | | "
                            f"{shown} | {'–' if tol is None else 'no'} | {wall}")
                continue
            if tol is None or m.get("reference") is None:  # reported, not checked
                rows.append(f"| {case.id}{status} | {mesh} | {scheme} | {dt} | {key} | {m['value']:.6g} | – | – | "
                            f"– | – | {wall}")
                continue
            err, of = judged_error(s, key, m)
            ok = err is not None and abs(err) <= tol
            rows.append(f"| {case.id}{status} | {mesh} | {scheme} | {dt} | {key} | {m['value']:.6g} | "
                        f"{m['reference']:.6g} | {'–' if err is None else _percent(err, '+', 2, fine) + of} | "
                        f"{shown} | "
                        f"{('yes' if ok else 'no') if judged else 'n/a'} | {wall}")
    return rows


def steady_ladder(runs: Path, pattern: str, keys: tuple) -> list[str]:
    """Errors of the steady runs ``pattern.format(level=...)`` per level and the observed order
    log2(e_l / e_{l+1}) (the mesh size halves per level); Newton iterations and wall time."""
    found = []
    for level in range(8):
        path = runs / pattern.format(level=level) / "summary.json"
        if path.exists():
            found.append((level, json.loads(path.read_text())))
    if not found:
        return []
    rows = ["| level (vertices) | " + " | ".join(f"{k} error | order" for k in keys) + " | Newton it. | wall (s) |",
            "|---|" + "---|---|" * len(keys) + "---|---|"]
    previous = None
    for level, s in found:
        errors = [(measured(s, k) or {}).get("error") for k in keys]
        cells = []
        for i, e in enumerate(errors):
            order = "–"
            if previous is not None and e and previous[i]:
                order = f"{np.log2(abs(previous[i]) / abs(e)):.2f}"
            cells += ["–" if e is None else f"{e:+.4%}", order]
        rows.append(f"| L{level} ({s['mesh']['vertices']:,}) | " + " | ".join(cells)
                    + f" | {s.get('newton', {}).get('iterations', '–')} | {s['wall_time']['total']:.1f} |")
        previous = errors
    return rows


def energy_drift(run: Path, frequency: float) -> float | None:
    """The change of the total energy over the run per period of ``frequency``, relative to the largest
    kinetic energy (an undamped solid: 0; numerical damping: negative), or None without a time series."""
    path = run / "timeseries.csv"
    if not path.exists():
        return None
    series = read_timeseries(path)
    t, total, kinetic = series["t"], series["energy_total"], series["energy_kinetic"]
    return float((total[-1] - total[0]) / kinetic.max() / ((t[-1] - t[0]) * frequency))


def energy_lines(runs: Path) -> list[str]:
    """The CSM3 runs' energy drift per period (the flag undamped, gravity on from t = 0)."""
    frequency = parse_periodic(load_references()["turek_hron"]["cases"]["CSM3"]["uy_A"])["frequency"]
    rows = []
    for case in (c for c in FSI_CASES if c.id.startswith("csm3-")):
        drift = energy_drift(runs / case.id, frequency)
        if drift is not None:
            rows.append(f"`{case.id}` {100 * drift:+.3f} %")
    return (["CSM3, total energy (kinetic + stored + the weight's potential) per period, relative to the largest "
             "kinetic energy: " + ", ".join(rows) + " (target: within ±0.5 %)."] if rows else [])


def cheapest(cases, runs: Path, previous: dict | None = None) -> list[str]:
    """Per benchmark, the cheapest case (wall time) that meets every tolerance."""
    previous = previous or {}
    best = {}
    for case in cases:
        path = runs / case.id / "summary.json"
        s = json.loads(path.read_text()) if path.exists() else None
        found = observed(case, runs, s) if s is not None else None
        if found is not None:
            wall = s["wall_time"]["total"]
            ok = s["status"] == "completed" and not not_applicable(case, s) and all(
                (m := found.get(key)) and m.get("error") is not None and abs(m["error"]) <= tol
                for key, tol in case.tolerances.items() if tol is not None)
        elif case.id in previous:
            cells = [[c.strip() for c in r.strip().strip("|").split("|")] for r in previous[case.id]]
            ok = (bool(cells) and all(c[9] in ("yes", "–") and "(" not in c[0] for c in cells)
                  and not not_applicable(case))
            wall = float(cells[0][10]) if ok else 0.0
        else:
            continue
        group = case.id.split("-")[0]
        best.setdefault(group, None)
        if ok and (best[group] is None or wall < best[group][1]):
            best[group] = (case.id, wall)
    return [f"- {group}: " + (f"`{b[0]}` ({b[1]:.0f} s)" if b else "no case meets every tolerance yet")
            for group, b in best.items()]


EXAMPLES_TITLE = "## Examples: user scenes, written by `make validate`"


def handwritten_sections(report: Path) -> list[str]:
    """The ``## `` sections of an earlier report that this script does not write (notes added by hand:
    the 3D results, the flap's discussion), to be kept after the generated part."""
    if not report.exists():
        return []
    kept, keep = [], False
    for line in report.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            keep = line != EXAMPLES_TITLE
        if keep:
            kept.append(line)
    while kept and not kept[-1].strip():
        kept.pop()
    return kept


def write_report(cases, runs: Path, out: Path) -> Path:
    previous = previous_rows(out / "validation.md")
    handwritten = handwritten_sections(out / "validation.md")
    examples = [c for c in cases if c.measure is not None]
    cases = [c for c in cases if c.measure is None]
    figure = plot_cfd3(cases, runs, out)
    extra = [f for f in (plot_tip(cases, runs, out, "fsi3", "fsi3_uy_A.png", "FSI3: tip displacement uy(A)"),
                         plot_c1_sweep(runs, out)) if f]
    lines = [
        "# Validation",
        "",
        "Written by `make validate` (`python campaigns/validate.py`): every number below is measured, on",
        "the Debian stack (dolfinx 0.5.2), serial, on a 2-core machine (two cases run at a time).",
        "References: shared/reference/benchmarks.yaml (Schäfer & Turek 1996; Turek & Hron 2006; FSI3: the",
        "benchmark authors' refined values, 34.99 mm at 5.46 Hz, except the incompressible law's rows, measured",
        "against the 2006 paper's 34.38 mm at 5.3 Hz: the reference column says which).",
        "Errors are relative; for periodic observables, mean / amplitude are (max ± min)/2 over the last two",
        "periods (one period of the flag for ux(A) and the drag, which oscillate at twice its frequency: the",
        "benchmark's window) and the frequency comes from the same periods (cosserat_fsi/analysis.py); a mean",
        "about zero (uy(A), lift) is judged relative to the amplitude. Summaries of runs made before the two-period",
        "window keep their last-cycle values.",
        "drag and lift are the variational (residual) forces; `drag_surface` in timeseries.csv is ∫ T n.",
        "An `ok` of `n/a`: the case solves another problem than its benchmark's (the incompressible law, another",
        "clamp or μ_s: see \"Which scenes are a benchmark's problem\" below), so its numbers are shown beside the",
        "reference without a verdict.",
        "",
        *table(cases, runs, previous),
        "",
        "Cheapest case meeting every tolerance of its benchmark:",
        "",
        *cheapest(cases, runs, previous),
        "",
    ]
    for case in cases:
        if case.note:
            lines.append(f"- `{case.id}`: {case.note}")
    for group, (pattern, keys) in LADDERS.items():
        ladder = steady_ladder(runs, pattern, keys)
        if ladder:
            lines += ["", f"Steady {group} by Newton, level ladder (relative errors; order = log2 of the error "
                      "ratio of consecutive levels, h halves per level):", "", *ladder]
    energy = energy_lines(runs)
    if energy:
        lines += ["", *energy]
    lines += ["", STEADY_NOTES]
    lines += ["", "Cosserat FSI (seed figures 3–10) and the physics sanity check (Navier–Stokes with μ and with "
              "μ + μ_r bracket the micropolar fluid): [seed_reproduction.md](seed_reproduction.md) (`make figures`). "
              "Stability at the extremes: [extremes.md](extremes.md) (`make extremes`)."]
    if figure:
        lines += ["", f"![CFD3 lift]({figure})", ""]
    for f in extra:
        lines += ["", f"![{Path(f).stem}]({f})", ""]
    if handwritten:
        lines += ["", *handwritten, ""]
    lines += ["", EXAMPLES_TITLE, "",
              "The two examples of examples/ run in full (their README.md says what they are); a tolerance `–`: "
              "reported, not checked. CI runs the flap for 3 steps and the expansion's steady solve on level 0 "
              "(tests/test_user_scene.py).", "",
              *table(examples, runs, previous), ""]
    lines += [f"- `{c.id}`: {c.note}" for c in examples if c.note]
    for f in (plot_flap(examples, runs, out), plot_expansion(examples, runs, out)):
        if f:
            lines += ["", f"![{Path(f).stem}]({f})"]
    path = out / "validation.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python campaigns/validate.py", description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", default="*", help="glob over case ids")
    parser.add_argument("--out", default=str(ROOT / "docs"))
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args(argv)
    out = Path(args.out)
    runs = out / "runs"
    chosen = [c for c in ALL_CASES if fnmatch.fnmatch(c.id, args.only)]
    if not args.report_only:
        app_cases.run_cases([c.run(runs) for c in chosen], args.jobs,
                            report=lambda done: print(f"finished {done.name}", flush=True))
    print(write_report(ALL_CASES, runs, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
