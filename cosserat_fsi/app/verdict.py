"""How a run did, in words and numbers: the last lines a run prints, and the signal classification of summary.json.

:func:`classify_signals` tells for each observable (not ``t``, nor the step size ``dt`` of a run with
``time.tolerance``) whether it is ``"steady"``, ``"periodic"`` (then with the
periodic analysis: mean ± amplitude [frequency]) or ``"not periodic yet"``; only periodic signals get an
analysis, so noise on a steady signal is not reported as an oscillation.

:func:`verdict_lines` turns a summary into the lines printed at the end of ``cosserat-fsi run``: for a
benchmark scene a table (quantity, value, reference, error, tolerance, pass/fail), then the headline
observables (final value, or mean ± amplitude [frequency]; a file scene's named probes, solid points and flow
rates too) and the wall time. A scene that differs from its benchmark in a defining key (config/benchmarks.py)
solves another problem: its table has "n/a" for every verdict under ``benchmark NAME: reference not
applicable: KEY differs (VALUE; the benchmark: VALUE)``. A scene's own ``reference`` section
(config/sections.py ``Reference``) gets the same table under ``reference: PASS|FAIL``.

``TOLERANCES``: the relative tolerance of each benchmark quantity (the bands of campaigns/validate.py;
periodic parts as ``"lift.amplitude"``). Quantities without one are shown but not judged.
"""

from __future__ import annotations

import numpy as np

from ..analysis import periodic_analysis, relative_error, second_half

TOLERANCES = {
    "schaefer_turek_2d1": {"c_D": 0.005, "c_L": 0.05, "dp": 0.01},
    "schaefer_turek_3d1z": {"c_D": 0.01, "c_L": 0.2, "dp": 0.02},
    "turek_hron_cfd1": {"drag": 0.01, "lift": 0.05},
    "turek_hron_cfd2": {"drag": 0.01, "lift": 0.05},
    "turek_hron_cfd3": {"drag.mean": 0.02, "drag.amplitude": 0.02, "drag.frequency": 0.02,
                        "lift.mean": 0.01, "lift.amplitude": 0.02, "lift.frequency": 0.02},
    "turek_hron_csm1": {"ux_A": 0.01, "uy_A": 0.01},
    "turek_hron_csm2": {"ux_A": 0.01, "uy_A": 0.01},
    "turek_hron_csm3": {f"{q}.{part}": 0.01 for q in ("ux_A", "uy_A") for part in ("mean", "amplitude", "frequency")},
    "turek_hron_fsi1": {"ux_A": 0.01, "uy_A": 0.01, "drag": 0.01, "lift": 0.01},
    "turek_hron_fsi3": {f"{q}.{part}": 0.02 for q in ("ux_A", "uy_A", "drag", "lift")
                        for part in ("mean", "amplitude", "frequency")},
    # exact solutions: absolute relative L² errors of the fields
    "micropolar_poiseuille": {"velocity": 1e-3, "micro_rotation": 1e-3},
    "micropolar_taylor_green": {"velocity": 1e-2, "micro_rotation": 1e-2},
}
"""Every quantity a benchmark publishes has its tolerance (tests/test_verdict_tolerances.py): Turek–Hron's
FSI3 and CFD3 within 2 % (CFD3's lift mean within 1 % of the lift amplitude), FSI1 and CSM1–3 within 1 %. A
periodic mean smaller than its amplitude (the lift, uy(A) of FSI3 and CSM3) is judged relative to the
amplitude (:func:`periodic_error`)."""

NOT_SIGNALS = ("t", "dt")  # the time and, with time.tolerance, the step size: not observables
STEADY_RTOL = 1e-4  # a signal whose last half varies by less than this fraction of its size is steady
HEADLINE = ("drag", "lift", "side", "dp", "ux_A", "uy_A", "uz_A", "flow_rate", "omega_max", "energy_total",
            "velocity_error", "micro_rotation_error")
OWN = ("u_", "v_", "w_", "p_", "omega_", "ux_", "uy_", "uz_", "flow_rate_")  # a file scene's named columns


def classify_signals(series: dict) -> tuple[dict, dict]:
    """({observable: "steady" | "periodic" | "not periodic yet"}, {observable: periodic analysis})."""
    signals, periodic = {}, {}
    t = series.get("t")
    half = second_half(t) if t is not None and len(t) else None  # the last half in time
    for key, values in series.items():
        if key in NOT_SIGNALS or not len(values):
            continue
        y = np.asarray(values, dtype=float)
        tail = y[half:] if half is not None and len(y) == len(t) else y[len(y) // 2:]
        scale = max(float(np.abs(y).max()), np.finfo(float).tiny)
        if len(y) == 1 or (len(y) >= 3 and np.ptp(tail) <= STEADY_RTOL * scale):
            signals[key] = "steady"  # one row: a steady solve
            continue
        analysis = periodic_analysis(t, y) if len(y) > 10 else {"method": None}
        if analysis.get("method") in ("maxima", "fft"):
            signals[key] = "periodic"
            periodic[key] = analysis
        else:
            signals[key] = "not periodic yet"
    return signals, periodic


def time_summary(scene, sim) -> dict:
    """summary.json's ``time``: the scheme, the first step ``dt``, the steps taken and the final t; with
    ``time.tolerance`` also the rejected steps and the range of the accepted steps."""
    out = {"dt": scene.time.dt, "scheme": scene.time.scheme, "steps": sim.step_count, "t_final": sim.t}
    if sim.time_control is not None:
        steps = sim.state.steps
        out.update(tolerance=scene.time.tolerance, rejected_steps=int(steps.rejected),
                   dt_smallest=steps.smallest or None, dt_largest=steps.largest or None)
    return out


def _num(value) -> str:
    return "–" if value is None else f"{value:.6g}"


BENCHMARK_KEYS = ("name", "applicable", "differs", "differences")
"""The keys of summary.json's ``benchmark`` block that are not compared quantities."""


def applicable(summary: dict) -> bool:
    """The run solved its benchmark's problem (summary.json ``benchmark.applicable``; a summary without the
    key counts as applicable)."""
    return (summary.get("benchmark") or {}).get("applicable", True) is not False


def completed(summary: dict) -> bool:
    """The run reached its t_end (or its steady solution): a run that diverged, was interrupted or failed has
    solved part of the problem, and its values are shown without a verdict."""
    return summary.get("status", "completed") == "completed"


def not_judged_text(summary: dict) -> str:
    """``not judged: the run diverged at t = 0.0262 (a verdict is given for a completed run)``."""
    t_final = (summary.get("time") or {}).get("t_final")
    at = f" at t = {t_final:.6g}" if isinstance(t_final, (int, float)) else ""
    return f"not judged: the run {summary.get('status')}{at} (a verdict is given for a completed run)"


def not_applicable_text(bench: dict) -> str:
    """``reference not applicable: solid.law differs (neo_hookean; the benchmark: saint_venant_kirchhoff)``,
    with the number of defining keys that differ when more than one does."""
    differs = list(bench.get("differs") or [])
    if not differs:
        return "reference not applicable"
    first = differs[0]
    values = (bench.get("differences") or {}).get(first) or {}
    text = f"reference not applicable: {first} differs"
    if values:
        text += f" ({_value(values.get('scene'))}; the benchmark: {_value(values.get('benchmark'))})"
    if len(differs) > 1:
        text += f"; {len(differs)} defining keys differ: {', '.join(differs)}"
    return text


def _value(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def benchmark_rows(summary: dict) -> list[tuple]:
    """(quantity, value, reference, error, tolerance, verdict) for each compared quantity; verdict "n/a" for
    every row of a run whose scene is not its benchmark's problem or that did not complete."""
    bench = summary.get("benchmark") or {}
    name = bench.get("name")
    tolerances = TOLERANCES.get(name, {})
    exact = name in ("micropolar_poiseuille", "micropolar_taylor_green")
    judged = applicable(summary) and completed(summary)
    rows = []
    for key, entry in bench.items():
        if key in BENCHMARK_KEYS or not isinstance(entry, dict):
            continue
        parts = entry.items() if "value" not in entry else [(None, entry)]
        for part, e in parts:
            label = key if part is None else f"{key}.{part}"
            tol = tolerances.get(label)
            err = e.get("error")
            if exact:
                error_text = f"{err:.2e}" if err is not None else "–"
            else:
                error_text = f"{100 * err:+.3f} %" if err is not None else "–"
                error_text += f" of {e['scale']}" if e.get("scale") and err is not None else ""
            if not judged:
                verdict = "n/a"
            elif tol is None or err is None:
                verdict = "–"
            else:
                verdict = "pass" if abs(err) <= tol else "FAIL"
            tol_text = "–" if tol is None else (f"{tol:.0e}" if exact else f"{100 * tol:g} %")
            rows.append((label, _num(e.get("value")), _num(e.get("reference")), error_text, tol_text, verdict))
    seen = {r[0] for r in rows}
    signals = summary.get("signals", {})
    for label, tol in tolerances.items():  # a judged quantity without a value (e.g. not periodic yet): FAIL
        if label not in seen:
            state = signals.get(label.partition(".")[0], "no value")
            rows.append((f"{label} ({state})", "–", "–", "–", f"{100 * tol:g} %" if not exact else f"{tol:.0e}",
                         "FAIL" if judged else "n/a"))
    return rows


def check_reference(scene, columns: list[str]) -> None:
    """InputError naming ``reference.NAME`` for a reference to a column the scene's time series lacks."""
    from ..errors import InputError

    for name in scene.reference or {}:
        if name in NOT_SIGNALS:
            raise InputError(f"reference.{name}: the time and the step size are not observables")
        if name not in columns:
            raise InputError(f"reference.{name}: not a column of this scene's timeseries.csv (it has: "
                             f"{', '.join(columns)[:200]})")


def compare_with_scene_reference(reference: dict, summary: dict) -> dict:
    """summary.json's ``reference``: {label: {value, reference, error, tolerance, absolute, verdict}} for a
    scene's own ``reference`` section; a periodic part of a column that is not periodic by the end FAILs; a run
    that did not complete gets "n/a"."""
    final, periodic, signals = summary.get("final", {}), summary.get("periodic", {}), summary.get("signals", {})
    out = {}
    for name, ref in reference.items():
        for part, expected in ref.parts().items():
            value = final.get(name) if part == "value" else (periodic.get(name) or {}).get(part)
            label = name if part == "value" else f"{name}.{part}"
            if part != "value" and name not in periodic:
                label += f" ({signals.get(name, 'no value')})"
            absolute = ref.abs_tolerance is not None
            error = None if value is None else (value - expected if absolute else (value - expected) / abs(expected))
            tol = ref.abs_tolerance if absolute else ref.tolerance
            ok = error is not None and abs(error) <= tol
            out[label] = {"value": value, "reference": expected, "error": error, "tolerance": tol,
                          "absolute": absolute,
                          "verdict": ("pass" if ok else "FAIL") if completed(summary) else "n/a"}
    return out


def reference_rows(summary: dict) -> list[tuple]:
    """Rows (quantity, value, reference, error, tolerance, verdict) of summary.json's ``reference``."""
    rows = []
    for label, e in (summary.get("reference") or {}).items():
        err, tol = e.get("error"), e["tolerance"]
        if e.get("absolute"):
            error_text, tol_text = ("–" if err is None else f"{err:+.3g}"), f"{tol:g}"
        else:
            error_text, tol_text = ("–" if err is None else f"{100 * err:+.3f} %"), f"{100 * tol:g} %"
        rows.append((label, _num(e.get("value")), _num(e.get("reference")), error_text, tol_text, e["verdict"]))
    return rows


def _headline(final: dict) -> list[str]:
    """The headline columns present: the built-in ones, then a file scene's named probes, solid points and flow
    rates."""
    own = [k for k in final if k not in HEADLINE and k.startswith(OWN)]
    return [k for k in HEADLINE if k in final] + own


def _table(header: tuple, rows: list[tuple]) -> list[str]:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    return [fmt.format(*header), fmt.format(*("-" * w for w in widths))] + [fmt.format(*r) for r in rows]


def verdict_lines(summary: dict) -> list[str]:
    """The closing lines of a run: benchmark table, headline observables, wall time."""
    lines = []
    rows = benchmark_rows(summary)
    if summary.get("benchmark") and not applicable(summary):  # another problem: values, no verdict
        lines.append(f"benchmark {summary['benchmark']['name']}: {not_applicable_text(summary['benchmark'])}")
        lines += _table(("quantity", "value", "reference", "error", "tolerance", "verdict"), rows) if rows else []
    elif summary.get("benchmark") and not completed(summary):  # part of the problem: values, no verdict
        lines.append(f"benchmark {summary['benchmark']['name']}: {not_judged_text(summary)}")
        lines += _table(("quantity", "value", "reference", "error", "tolerance", "verdict"), rows) if rows else []
    elif rows:
        bench = summary["benchmark"]["name"]
        judged = [r for r in rows if r[5] != "–"]
        ok = all(r[5] == "pass" for r in judged)
        lines.append(f"benchmark {bench}: " + (("PASS" if ok else "FAIL") + f" ({sum(r[5] == 'pass' for r in judged)}"
                                                 f"/{len(judged)} within tolerance)" if judged else "no tolerances"))
        lines += _table(("quantity", "value", "reference", "error", "tolerance", "verdict"), rows)
    own = reference_rows(summary)
    if own:
        ok = sum(r[5] == "pass" for r in own)
        lines.append(f"reference: {not_judged_text(summary)}" if not completed(summary) else
                     f"reference: {'PASS' if ok == len(own) else 'FAIL'} ({ok}/{len(own)} within tolerance)")
        lines += _table(("quantity", "value", "reference", "error", "tolerance", "verdict"), own)
    final, periodic, signals = summary.get("final", {}), summary.get("periodic", {}), summary.get("signals", {})
    parts = []
    for key in _headline(final):
        a = periodic.get(key) if isinstance(periodic, dict) else None
        if a and a.get("frequency"):
            parts.append(f"{key} = {a['mean']:.6g} ± {a['amplitude']:.4g} [{a['frequency']:.4g} Hz]")
        else:
            state = signals.get(key, "")
            parts.append(f"{key} = {final[key]:.6g}" + (f" ({state})" if state and state != "steady" else ""))
    if parts:
        lines.append("result: " + ", ".join(parts))
    wall = summary.get("wall_time", {})
    time = summary.get("time", {})
    how = (f"steady (Newton, {summary['newton']['iterations']} iterations)" if "newton" in summary
           else _steps_text(time))
    lines.append(f"status: {summary.get('status')}; {how}; wall time {wall.get('total', 0):.2f} s "
                 f"(setup {wall.get('setup', 0):.2f} s); {summary.get('ranks', 1)} rank(s)")
    return lines


def _steps_text(time: dict) -> str:
    """How the run stepped: "N steps of DT to t = T", or with time.tolerance "N steps, δt A–B (time.tolerance
    TOL), R rejected, to t = T"."""
    end = f"to t = {time.get('t_final', 0):.6g}"
    if time.get("tolerance") is None:
        return f"{time.get('steps')} steps of {time.get('dt')} {end}"
    low, high = time.get("dt_smallest"), time.get("dt_largest")
    if low is None or high is None:
        sizes = "no step accepted"
    else:
        sizes = f"δt {low:.2g}" if f"{low:.2g}" == f"{high:.2g}" else f"δt {low:.2g}–{high:.2g}"
    return (f"{time.get('steps')} steps, {sizes} (time.tolerance {time['tolerance']:g}), "
            f"{time.get('rejected_steps', 0)} rejected, {end}")


def compare_with_reference(scene, summary: dict) -> dict:
    """{observable: {value, reference, error}} for the scene's benchmark (relative errors), with ``applicable``
    (and the defining keys that differ: config/benchmarks.py)."""
    from ..config.benchmarks import applicability
    from ..exact import EXACT_BENCHMARKS
    from ..observables import schaefer_turek_coefficients
    from ..references import reference_for

    final = summary["final"]
    if scene.benchmark in EXACT_BENCHMARKS:  # errors against an exact solution: the reference is 0
        out = {"name": scene.benchmark, **applicability(scene)}
        for key in ("velocity", "micro_rotation"):
            if key + "_error" in final:
                out[key] = {"value": final[key + "_error"], "reference": 0.0, "error": final[key + "_error"]}
        return out
    ref = reference_for(scene.benchmark)
    computed = dict(final)
    if scene.benchmark in ("schaefer_turek_2d1", "schaefer_turek_3d1z") and "drag" in final:
        span = 0.41 if scene.benchmark == "schaefer_turek_3d1z" else 1.0  # 3D: the projected area D H
        computed["c_D"], computed["c_L"] = schaefer_turek_coefficients(
            final["drag"], final["lift"], scene.fluid.rho, scene.inflow.u_mean, span=span)
    out = {"name": scene.benchmark, **applicability(scene)}
    for key, reference in ref.items():
        if isinstance(reference, dict) and "frequency" in reference:
            analysis = summary["periodic"].get(key)
            if not analysis:
                continue
            out[key] = {}
            for part in ("mean", "amplitude", "frequency"):
                if part in reference:
                    error, scale = periodic_error(analysis.get(part), reference, part)
                    out[key][part] = {"value": analysis.get(part), "reference": reference[part], "error": error,
                                      **({"scale": scale} if scale != part else {})}
        elif isinstance(reference, float) and key in computed:
            out[key] = {"value": computed[key], "reference": reference,
                        "error": _error(computed[key], reference)}
    return out


def _error(value, reference):
    """Signed relative error (value − reference)/|reference|."""
    if value is None or reference in (None, 0):
        return None
    return relative_error(value, reference) * (1.0 if value >= reference else -1.0)


def periodic_error(value, reference: dict, part: str) -> tuple[float | None, str]:
    """(signed error, the part it is relative to) of one part of a periodic quantity: relative to the reference's
    own value, except a mean smaller than the amplitude (a lift about zero), relative to the amplitude: a lift
    mean of 2.5 ± 153.91 off by 1.3 is 0.8 % of the amplitude, not 52 % of itself."""
    mean, amplitude = reference.get("mean"), reference.get("amplitude")
    if part == "mean" and mean is not None and amplitude and abs(mean) < amplitude:
        return (None if value is None else (value - mean) / amplitude), "amplitude"
    return _error(value, reference[part]), part
