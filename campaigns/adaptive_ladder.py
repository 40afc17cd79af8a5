"""Tolerance ladders of the adaptive time step (``time.tolerance``) against the scene's fixed δt.

Each case is `cosserat-fsi run CONFIG --set ...` into ``<runs>/<scene>-<case>`` (a scene's fixed-δt run as
shipped, and one run per tolerance, everything else as shipped); a case whose summary.json says it
completed at its t_end is not run again. The run goes through this script's ``--one`` mode, which counts
the controller's attempts (time_schemes/time_control.py: ``TimeControl.judge``) into ``attempts.csv`` beside the
run (t, δt, scaled error E, accepted): summary.json has no rejection count. The table gives, per case:
wall time, accepted and rejected steps, the δt range over the developed flow (after the inflow ramp) and
the benchmark's errors (summary.json "benchmark": amplitude, mean, frequency of the scene's observable);
the fit gives the log–log slope of |amplitude error| against the tolerance (1: tolerance proportionality)
and the Pareto figure error against wall time, fixed δt and adaptive.

    python campaigns/adaptive_ladder.py --scene cfd3 --tolerances 1e-2 1e-3 1e-4 --fixed \\
        --runs runs/adaptive --json docs/perf/adaptive-cfd3.json --md - --figure docs/figures/adaptive_cfd3.png
    python campaigns/adaptive_ladder.py --scene cfd3 --report-only ...   # analyse the finished cases only
    python campaigns/adaptive_ladder.py --scene cfd3 --tolerances 1e-3 --set time.t_end=2  # a short check
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
# scene -> (config, overrides of every case, observable, its reference's benchmark key, ramp time (s))
SCENES = {
    # CFD3 as it was measured: level 1, shedding from round-off (no tilt of the inflow during the ramp)
    "cfd3": ("configs/turek_hron_cfd3.yaml", {"geometry.level": 1, "inflow.asymmetry": 0.0}, "lift", 2.0),
    "fsi3": ("configs/turek_hron_fsi3.yaml", {}, "uy_A", 2.0),
    # the extremes: the large-deformation scene of campaigns/extremes.py, and FSI3 under a sudden load
    "soft-fast": ("configs/turek_hron_fsi3_soft_fast.yaml", {}, "uy_A", 2.0),
    "fsi3-sudden": ("configs/turek_hron_fsi3.yaml", {"inflow.ramp_time": 0.0}, "uy_A", 0.0),
}
TARGETS = {"lift": (0.02, 0.01), "uy_A": (0.03, 0.01)}  # |amplitude| / |frequency| bands (docs/performance.md)


def case_dir(runs: Path, scene: str, tolerance: float | None, sets: dict) -> Path:
    tag = "fixed" if tolerance is None else f"tol{tolerance:g}"
    extra = "".join(f"-{k.split('.')[-1]}{v}" for k, v in sorted(sets.items()))
    return runs / f"{scene}-{tag}{extra}"


def finished(out: Path, t_end: float) -> bool:
    path = out / "summary.json"
    if not path.exists():
        return False
    s = json.loads(path.read_text())
    return s.get("status") == "completed" and s["time"]["t_final"] >= t_end - 1e-9


def run_case(scene: str, tolerance: float | None, sets: dict, runs: Path) -> Path:
    """Run one case unless finished (a run stopped with exit 3 is kept and not run again either)."""
    config, base, _, _ = SCENES[scene]
    out = case_dir(runs, scene, tolerance, sets)
    overrides = {**base, "output.fields": False, "time.tolerance": tolerance, **sets}  # None: the fixed δt
    from cosserat_fsi.config import load_scene

    args = [f"{k}={'null' if v is None else v}" for k, v in overrides.items()]
    t_end = float(load_scene(ROOT / config, args).time.t_end)
    if finished(out, t_end) or (out / "exit_code").exists() and (out / "exit_code").read_text().strip() == "3":
        return out
    cmd = [sys.executable, str(Path(__file__).resolve()), "--one", str(out), str(ROOT / config)]
    cmd += [a for s in args for a in ("--set", s)]
    print(f"running {out.name}", flush=True)
    tic = time.perf_counter()
    code = subprocess.run(cmd, check=False).returncode
    print(f"finished {out.name}: exit {code} after {time.perf_counter() - tic:.0f} s", flush=True)
    (out / "exit_code").write_text(f"{code}\n")
    return out


def run_one(out: str, config: str, sets: list[str], restart: bool = False) -> int:
    """The ``--one`` mode: the CLI's run, with every attempt of the step controller logged to attempts.csv
    (``restart``: continue ``out``'s checkpoint)."""
    from cosserat_fsi.app import cli
    from cosserat_fsi.time_schemes import time_control

    path = Path(out) / "attempts.csv"
    rows: list = []
    judge = time_control.TimeControl.judge
    coordinates: dict = {}

    def located(self, stepper):
        """E, and where the velocity's part of it lives (serial only): the share of Σ ratio² in the largest
        1 % of the nodes, E of u alone, and the place of the largest ratio (the parts computed once)."""
        parts = self.parts(stepper)
        self.where = (float("nan"),) * 4
        if parts is None:
            return None
        weights = self.weights(parts)
        e = self.norm(parts, weights)
        if self.comm.size > 1:
            return e
        r2 = ((parts[0][0] / weights[0][:, None]) ** 2).sum(axis=1)
        V = stepper.state.velocity.function_space
        if id(V) not in coordinates:
            coordinates[id(V)] = V.tabulate_dof_coordinates()
        x = coordinates[id(V)][int(np.argmax(r2))]
        top = np.sort(r2)[-max(1, len(r2) // 100):].sum() / max(r2.sum(), 1e-300)
        self.where = (float(top), self.norm(parts[:1], weights[:1]), float(x[0]), float(x[1]))
        return e

    def logged(self, state, dt, error, failure=None):
        try:
            ok = judge(self, state, dt, error, failure)
        except Exception:
            rows.append((state.t, dt, error, "stop", *getattr(self, "where", (float("nan"),) * 4)))
            raise
        rows.append((state.t, dt, float("nan") if error is None else error,
                     "nonfinite" if failure is not None else int(ok), *getattr(self, "where", (float("nan"),) * 4)))
        if len(rows) % 200 == 0:
            flush()
        return ok

    def flush():
        if path.parent.exists():
            with path.open("w", newline="") as f:
                w = csv.writer(f)
                w.writerow(("t", "dt", "E", "accepted", "top1pct_share", "E_u", "x_max", "y_max"))
                w.writerows(rows)

    time_control.TimeControl.judge, time_control.TimeControl.error = logged, located
    argv = ["run", config, "--no-progress"] + (["--restart", out] if restart else ["--out", out, "--overwrite"])
    argv += [a for s in sets for a in ("--set", s)]
    try:
        return cli.main(argv)
    finally:
        flush()
        if path.parent.exists():  # CPU seconds: less dependent on the other processes than the wall time
            use = resource.getrusage(resource.RUSAGE_SELF)
            (path.parent / "cpu.json").write_text(json.dumps({"cpu": use.ru_utime + use.ru_stime}) + "\n")


def attempts(out: Path) -> dict:
    path = out / "attempts.csv"
    if not path.exists():
        return {}
    with path.open() as f:
        rows = list(csv.DictReader(f))
    judged = [r for r in rows if r["E"] != "nan"]
    return {"attempts": len(rows), "rejected": sum(r["accepted"] in ("0", "nonfinite", "stop") for r in rows),
            "E_median": float(np.median([float(r["E"]) for r in judged])) if judged else None}


def analyse(out: Path, scene: str, tolerance: float | None, fixed_summary: dict | None = None) -> dict:
    """One row of the table from a finished (or stopped) case; ``fixed_summary``: the summary.json of a
    complete fixed-δt run, when the fixed case here is a shorter timing run of the same scene."""
    from cosserat_fsi.io import read_timeseries

    _, _, name, ramp = SCENES[scene]
    row = {"case": out.name, "scene": scene, "tolerance": tolerance}
    code = out / "exit_code"
    row["exit"] = int(code.read_text()) if code.exists() else None
    if not (out / "summary.json").exists():
        return row
    s = json.loads((out / "summary.json").read_text())
    row.update(status=s["status"], message=s.get("message", ""), wall=s["wall_time"]["total"],
               steps=s["time"]["steps"], t_final=s["time"]["t_final"], dt0=s["time"]["dt"])
    series = read_timeseries(out / "timeseries.csv")
    t = series["t"]
    dt = series["dt"] if "dt" in series else np.diff(np.concatenate([[0.0], t]))
    late = (t > ramp) & (np.arange(len(t)) < len(t) - 1)  # after the ramp, without the last (shortened) step
    for key, keep in (("", np.arange(len(t)) < len(t) - 1), ("_developed", late)):
        if keep.any():
            row.update({f"dt_min{key}": float(dt[keep].min()), f"dt_max{key}": float(dt[keep].max()),
                        f"dt_median{key}": float(np.median(dt[keep]))})
    if "rejected_steps" in s["time"]:
        row["rejected"] = s["time"]["rejected_steps"]
    row.update(attempts(out))
    if (out / "cpu.json").exists():
        row["cpu"] = json.loads((out / "cpu.json").read_text())["cpu"]
    if tolerance is None and fixed_summary is not None and row["t_final"] < fixed_summary["time"]["t_final"]:
        # a short timing run of the fixed δt: its cost per step times the full run's steps, that run's errors
        full, timed = fixed_summary["time"]["steps"], row["steps"]
        row.update(timed_steps=timed, steps=full, t_final=fixed_summary["time"]["t_final"],
                   wall=s["wall_time"]["setup"] + s["wall_time"]["per_step"] * full,
                   cpu=row["cpu"] * full / timed if row.get("cpu") else None)
        s = fixed_summary
    bench = s.get("benchmark", {}).get(name, {})
    for part in ("amplitude", "mean", "frequency"):
        if part in bench:
            row[f"{part}"] = bench[part]["value"]
            row[f"{part}_error"] = bench[part]["error"]
    return row


def slope(rows: list[dict], against_finest: bool = False, part: str = "amplitude") -> float | None:
    """Least-squares slope of log |``part`` error| (amplitude, frequency) against log tolerance over the
    completed adaptive rows; ``against_finest``: the difference to the finest tolerance's value (the time error
    alone, without the mesh's)."""
    done = sorted((r for r in rows if r["tolerance"] is not None and r.get(part) is not None
                   and r.get("status") == "completed"), key=lambda r: r["tolerance"])
    if against_finest and done:
        pts = [(r["tolerance"], abs(r[part] / done[0][part] - 1.0)) for r in done[1:]]
    else:
        pts = [(r["tolerance"], abs(r[f"{part}_error"])) for r in done]
    pts = [(t, e) for t, e in pts if e > 0.0]
    if len(pts) < 2:
        return None
    x, y = np.log(np.array(pts)).T
    return float(np.polyfit(x, y, 1)[0])


def extrapolated(rows: list[dict], part: str = "amplitude") -> dict | None:
    """The time error's model over the completed adaptive rows, ``part`` = Q* + C·tol^s (least squares in Q*
    and C for each s of a fine grid, the s of the smallest residual): Q* is the value of this mesh with no
    time error, so Q*/reference − 1 is the mesh's (spatial) error floor and |Q(tol) − Q*| the time error,
    without assuming that the finest tolerance has none. None with fewer than four rows."""
    done = sorted((r for r in rows if r["tolerance"] is not None and r.get(part) is not None
                   and r.get("status") == "completed"), key=lambda r: r["tolerance"])
    if len(done) < 4:
        return None
    tol, q = np.array([r["tolerance"] for r in done]), np.array([r[part] for r in done])
    best = None
    for s in np.linspace(0.2, 3.0, 561):
        basis = np.column_stack([np.ones_like(tol), tol ** s])
        coef, *_ = np.linalg.lstsq(basis, q, rcond=None)
        residual = float(np.linalg.norm(basis @ coef - q))
        if best is None or residual < best[0]:
            best = (residual, s, coef)
    residual, s, (q_star, c) = best
    reference = done[0][part] / (1.0 + done[0][f"{part}_error"])
    return {"part": part, "slope": float(s), "value": float(q_star), "C": float(c), "residual": residual,
            "floor": float(q_star / reference - 1.0), "tolerances": tol.tolist(),
            "time_errors": (np.abs(q - q_star) / abs(q_star)).tolist()}


def _pct(x):
    return "–" if x is None else f"{100 * x:+.2f} %"


def _g(x, fmt=".3g"):
    return "–" if x is None else format(x, fmt)


def table(rows: list[dict]) -> str:
    fixed = next((r for r in rows if r["tolerance"] is None and r.get("wall")), None)
    lines = ["| case | tolerance | outcome | wall (s) | CPU (s) | × fixed (wall, CPU) | steps | rejected "
             "| δt min–max (median) after the ramp | amplitude error | mean error | frequency error |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: -(r["tolerance"] or 0.0)):
        if "status" not in r:
            lines.append(f"| {r['case']} | {_g(r['tolerance'])} | not run | | | | | | | | | |")
            continue
        outcome = r["status"] if r["status"] == "completed" else f"{r['status']} at t = {r['t_final']:.4g}"
        ratio = "–"
        if fixed:
            cpu = f"{r['cpu'] / fixed['cpu']:.2f}" if r.get("cpu") and fixed.get("cpu") else "–"
            ratio = f"{r['wall'] / fixed['wall']:.2f}, {cpu}"
        dts = (f"{r['dt_min_developed']:.3g}–{r['dt_max_developed']:.3g} ({r['dt_median_developed']:.3g})"
               if "dt_min_developed" in r else "–")
        errors = " | ".join(_pct(r.get(f"{part}_error")) if r["status"] == "completed" else "(not developed)"
                            for part in ("amplitude", "mean", "frequency"))
        lines.append(f"| {r['case']} | {_g(r['tolerance'])} | {outcome} | {r['wall']:.0f} | {_g(r.get('cpu'), '.0f')} "
                     f"| {ratio} | {r['steps']} | {r.get('rejected', '–')} | {dts} | {errors} |")
    for part in ("amplitude", "frequency"):
        p, q = slope(rows, part=part), slope(rows, against_finest=True, part=part)
        lines += ["", f"log–log slope of |{part} error| against the tolerance: {_g(p, '.2f')} (against the "
                  f"reference), {_g(q, '.2f')} (against the finest tolerance's {part})"]
        fit = extrapolated(rows, part)
        if fit is not None:
            errors = ", ".join(f"{t:g}: {100 * e:.3f} %" for t, e in zip(fit["tolerances"], fit["time_errors"]))
            lines.append(f"{part} = Q* + C·tol^s: s = {fit['slope']:.2f}, Q* = {fit['value']:.6g} (the mesh's "
                         f"floor: {_pct(fit['floor'])} against the reference); time error |Q − Q*|/Q*: {errors}")
    return "\n".join(lines)


def figure(rows: list[dict], path: Path, title: str) -> None:
    """Pareto plot: |amplitude error| and |frequency error| against wall time, the fixed δt and each tolerance,
    with the bands."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    done = [r for r in rows if r.get("status") == "completed" and r.get("amplitude_error") is not None]
    fits = [f for f in (extrapolated(rows, part) for part in ("amplitude", "frequency")) if f is not None]
    fig, axes = plt.subplots(1, 2 if fits else 1, figsize=(11.0 if fits else 6.0, 4.2), squeeze=False)
    ax = axes[0, 0]
    adaptive = sorted((r for r in done if r["tolerance"] is not None), key=lambda r: r["wall"])
    bands = TARGETS[SCENES[done[0]["scene"]][2]] if done else (None, None)
    for part, style, band, colour in (("amplitude", "o-", bands[0], "C0"), ("frequency", "^--", bands[1], "C1")):
        if adaptive:
            ax.plot([r["wall"] for r in adaptive], [100 * abs(r[f"{part}_error"]) for r in adaptive], style,
                    color=colour, label=f"adaptive, {part}")
            for r in adaptive:
                ax.annotate(f"{r['tolerance']:g}", (r["wall"], 100 * abs(r[f"{part}_error"])), fontsize=8,
                            textcoords="offset points", xytext=(4, 4))
        for r in done:
            if r["tolerance"] is None:
                ax.plot(r["wall"], 100 * abs(r[f"{part}_error"]), style[0], color="k", mfc="none",
                        label=f"fixed δt {r['dt0']:g}, {part}")
        if band is not None:
            ax.axhline(100 * band, ls=":", color=colour, label=f"{part} band")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s, from rest, serial)")
    ax.set_ylabel("|error| against the reference (%)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if fits:  # the time error |Q − Q*|/Q* against the tolerance, with the fitted power and slope 1
        right = axes[0, 1]
        for fit, style, colour in zip(fits, ("o-", "^--"), ("C0", "C1")):
            tol = np.array(fit["tolerances"])
            right.plot(tol, 100 * np.array(fit["time_errors"]), style, color=colour,
                       label=f"{fit['part']}: Q* + C·tol^s, s = {fit['slope']:.2f}")
        tol = np.array(fits[0]["tolerances"])
        right.plot(tol, 100 * max(fits[-1]["time_errors"]) * tol / tol.max(), ":", color="k", label="slope 1")
        right.set_xscale("log")
        right.set_yscale("log")
        right.set_xlabel("time.tolerance")
        right.set_ylabel("time error |Q − Q*| / Q* (%)")
        right.set_title("the time error against Q*, this mesh's value without it", fontsize=10)
        right.grid(True, which="both", alpha=0.3)
        right.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    if argv is None and len(sys.argv) > 1 and sys.argv[1] == "--one":
        p = argparse.ArgumentParser()
        p.add_argument("--one", nargs=2)
        p.add_argument("--set", dest="sets", action="append", default=[])
        p.add_argument("--restart", action="store_true")
        a = p.parse_args()
        return run_one(a.one[0], a.one[1], a.sets, a.restart)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", choices=sorted(SCENES))
    p.add_argument("--tolerances", type=float, nargs="*", default=[])
    p.add_argument("--fixed", action="store_true", help="also the scene's fixed-δt run as shipped")
    p.add_argument("--set", dest="sets", action="append", default=[], help="KEY=VALUE for every case")
    p.add_argument("--runs", type=Path, default=ROOT / "runs" / "adaptive")
    p.add_argument("--report-only", action="store_true", help="analyse the finished cases, run nothing")
    p.add_argument("--json", type=Path, help="write the rows (merged into an existing file's rows)")
    p.add_argument("--md", help="write the markdown table to this file ('-': stdout only)")
    p.add_argument("--figure", type=Path, help="the Pareto plot (error against wall time)")
    p.add_argument("--fixed-summary", type=Path, help="summary.json of a complete fixed-δt run: its errors, and "
                   "its steps at the cost per step of the (shorter) fixed case run here")
    p.add_argument("--diagnose", type=Path, metavar="DIR", help="where one step's error estimate from DIR's "
                   "checkpoint lives (with --dts: further δt to attempt)")
    p.add_argument("--dts", type=float, nargs="*", default=[0.002])
    a = p.parse_args(argv)
    if a.diagnose:
        from adaptive_diagnosis import diagnose

        print(diagnose(a.diagnose, a.dts))
        return 0
    sets = dict(s.split("=", 1) for s in a.sets)
    cases = ([None] if a.fixed else []) + list(a.tolerances)
    rows = []
    for tol in cases:
        out = case_dir(a.runs, a.scene, tol, sets)
        if not a.report_only:
            out = run_case(a.scene, tol, sets, a.runs)
        fixed = json.loads(a.fixed_summary.read_text()) if a.fixed_summary else None
        rows.append(analyse(out, a.scene, tol, fixed))
    if a.json:
        old = json.loads(a.json.read_text()) if a.json.exists() else []
        names = {r["case"] for r in rows}
        rows = [r for r in old if r["case"] not in names] + rows
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(rows, indent=1) + "\n")
    text = table(rows)
    print(text)
    if a.md and a.md != "-":
        Path(a.md).write_text(text + "\n")
    if a.figure:
        figure(rows, a.figure, f"{a.scene}: adaptive time step against the fixed δt")
    return 0


if __name__ == "__main__":
    sys.exit(main())
