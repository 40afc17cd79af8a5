"""`cosserat-fsi study STUDY.yaml`: measure the speed/accuracy trade over a ladder of runs.

A study file names a scene, fixed overrides and a ladder (the product of the listed values, e.g. mesh
levels × δt × scheme × solver options):

    name: cfd3
    config: configs/turek_hron_cfd3.yaml
    observables: [drag.mean, lift.amplitude, lift.frequency]   # keys of summary.json's benchmark block
    base: {time.t_end: 8, inflow.asymmetry: 0.1}
    ladder:
      geometry.level: [0, 1]
      time.dt: [0.002, 0.001]
    variants:                                                  # optional: named override sets, each
      c2: {time.scheme: characteristics2}                      # run at every point of the ladder (ids
      c2-corrector1: {time.scheme: characteristics2,           # end in -<variant>): for options that
                      time.corrector_passes: 1}                # only make sense together
    extra:                                                     # optional: single runs beside the ladder
      ale-dt0.002-level1: {geometry.level: 1, time.dt: 0.002, time.scheme: ale_bdf2}   # (id: overrides)
    tolerances: [1.0e-3, 1.0e-4]                               # optional: adaptive runs beside the ladder
    ranks: 1                                                   # optional: runs under mpirun -n ranks

``tolerances``: a ladder of ``time.tolerance`` beside the ``time.dt`` one: every point of the ladder without
its ``time.dt`` key (× each variant) is run again at each tolerance (ids end in ``tolerance<value>``), the
steps chosen by the controller from a first step of the scene's ``time.dt`` (after ``base``).

An override ``null`` removes the key (e.g. a ``time.corrector_passes`` the scheme of the run does not take).
``config`` is relative to the study file (or absolute). Each run is a `cosserat-fsi run` into
``<out>/runs/study-<name>/<run id>/`` (``<out>``: ``--out``, default the current directory), through the
campaigns' case runner (cosserat_fsi/app/cases.py): finished runs are not run again, interrupted ones resume;
a run folder whose run was made with another scene than the study asks for now (its config.yaml, or its
summary.json's ``resolved_scene``, against the study's config file with ``base`` and the run's overrides) is
run again, and ``--report-only`` reports such a run as not the study's, without its numbers. A run whose
scene is not its benchmark's problem (summary.json ``benchmark.applicable: false``) keeps its errors in the
report, marked, and stays off the Pareto front.
The report ``<out>/study_<name>.md`` has, per run, the error of every observable against the benchmark's
reference, wall time, time per step, the per-phase times and the peak memory, and
``<out>/figures/study_<name>_pareto.png`` plots the worst error against wall time with the Pareto fronts of
the fixed-step runs and of the runs with a ``time.tolerance`` (two labelled series; a run belongs to the
second when its summary.json has a ``time.tolerance``).
"""

from __future__ import annotations

import itertools
import math
import json
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import InputError
from ..io.runfolder import atomic_write_text
from ..io.safe_yaml import read_text_file, read_yaml_file
from . import cases
from .pareto import GROUPS, fronts, pareto, quantity_fronts, pareto_figure, save_pareto_figure  # noqa: F401 (the study's API)

MAX_RUNS = 1000
PHASES = ("assemble_matrix", "backtrack", "assemble_vector", "solve", "mesh_motion", "observables", "output")


class Study(BaseModel):
    """A study file (the module docstring shows one); the string literal under a field is its description."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, use_attribute_docstrings=True)

    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    """The study's name: its runs go to ``<out>/runs/study-<name>/``, its report to ``<out>/study_<name>.md``."""
    config: str
    """The scene file of every run, relative to the study file (or absolute)."""
    observables: list[str] = Field(min_length=1)
    """Keys of summary.json's benchmark block whose error the report shows, e.g. ``drag.mean``,
    ``lift.amplitude``, ``lift.frequency``."""
    base: dict[str, Any] = {}
    """Overrides of every run, ``{dotted.key: value}`` as ``--set`` (null removes the key)."""
    ladder: dict[str, list[Any]] = Field(min_length=1)
    """``{dotted.key: [values]}``: every combination of the listed values is a run (at most 1000 runs)."""
    variants: dict[str, dict[str, Any]] = {}
    """Named override sets ``{NAME: {dotted.key: value}}``, each run at every point of the ladder (run ids end
    in ``-NAME``): for options that only make sense together."""
    extra: dict[str, dict[str, Any]] = {}
    """Single runs beside the ladder, ``{run id: {dotted.key: value}}``."""
    tolerances: list[Annotated[float, Field(gt=0, lt=1)]] = []
    """A ladder of ``time.tolerance`` beside the ``time.dt`` one: every point of the ladder without its
    ``time.dt`` key (× each variant) is run again at each tolerance, from a first step of the scene's
    ``time.dt``."""
    ranks: int = Field(default=1, ge=1, le=1024)
    """MPI ranks of each run (``mpirun -n ranks``)."""


def load_study(path: str | Path) -> Study:
    """Read and check a study file; InputError (one line, naming the key) when it is not usable."""
    path = Path(path)
    raw = read_yaml_file(path, "study file")
    if not isinstance(raw, dict):
        raise InputError(f"{path}: top level must be a mapping")
    try:
        study = Study.model_validate(raw)
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        where = ".".join(str(p) for p in err["loc"]) or "study"
        raise InputError(f"{path}: {where}: {' '.join(err['msg'].lower().split())[:200]}") from None
    if not _config_path(study, path).exists():
        raise InputError(f"{path}: config: {study.config} not found")
    for section, names in (("variants", study.variants), ("extra", study.extra)):
        for name in names:
            if not name or name in (".", "..") or not all(c.isalnum() or c in "_.-" for c in name):
                raise InputError(f"{path}: {section}.{name}: a name of letters, digits, '_', '.', '-' (a folder's "
                                 "name in the study's folder: not . or ..)")
    for where, value in [*(("base." + k, v) for k, v in study.base.items()),
                         *((f"ladder.{k}", v) for k, vs in study.ladder.items() for v in vs),
                         *((f"variants.{n}.{k}", v) for n, o in study.variants.items() for k, v in o.items()),
                         *((f"extra.{n}.{k}", v) for n, o in study.extra.items() for k, v in o.items())]:
        if isinstance(value, float) and not math.isfinite(value):
            raise InputError(f"{path}: {where}: must be a finite number (got {value!r})")
    if study.tolerances and "time.tolerance" in study.ladder:
        raise InputError(f"{path}: tolerances: not with a ladder of time.tolerance (give the values once)")
    runs = 1
    for key, values in study.ladder.items():
        if not values:
            raise InputError(f"{path}: ladder.{key}: needs at least one value")
        runs *= len(values)
    adaptive = math.prod(len(v) for k, v in study.ladder.items() if k != "time.dt") * len(study.tolerances)
    runs = (runs + adaptive) * max(len(study.variants), 1) + len(study.extra)
    if runs > MAX_RUNS:
        raise InputError(f"{path}: ladder: {runs:,} runs, more than {MAX_RUNS:,}")
    # every run's scene must validate before anything runs (a bad value costs a second, not an hour)
    from ..config import load_scene

    for overrides, _ in _combinations(study):
        try:
            scene = load_scene(_config_path(study, path), [f"{k}={_yaml(v)}" for k, v in overrides.items()])
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        _check_observables(study, scene, path)
    return study


def observable_columns(benchmark: str | None) -> list[str]:
    """The keys of summary.json's benchmark block with an error (app/verdict.py ``compare_with_reference``): a
    value by its name, a periodic one as ``NAME.mean``, ``.amplitude``, ``.frequency`` (a range has none)."""
    if benchmark is None:
        return []
    from ..references import reference_for

    out = []
    for key, reference in reference_for(benchmark).items():
        if isinstance(reference, dict) and "frequency" in reference:
            out += [f"{key}.{part}" for part in ("mean", "amplitude", "frequency") if part in reference]
        elif isinstance(reference, float):
            out.append(key)
    return out


def _check_observables(study: Study, scene, path: Path) -> None:
    """InputError naming the first observable that is not a column of the scene's benchmark block."""
    valid = observable_columns(scene.benchmark)
    for i, key in enumerate(study.observables):
        if key not in valid:
            if scene.benchmark is None:
                raise InputError(f"{path}: observables[{i}]: {key!r}: the scene has no benchmark (the report's "
                                 "errors are against a benchmark's reference)")
            raise InputError(f"{path}: observables[{i}]: {key!r} is not a column of benchmark {scene.benchmark} "
                             f"(valid: {', '.join(valid) or 'none'})")


def _config_path(study: Study, study_path: Path) -> Path:
    """The scene file: relative to the study file (an absolute path stays as it is)."""
    return study_path.parent / study.config


def _yaml(value) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def _combinations(study: Study) -> list[tuple[dict, str]]:
    """(overrides, run id) of every run: the ladder's product, each point once per variant (innermost), the
    ``tolerances`` runs, then the ``extra`` runs (an id the ladder already has is the ladder's)."""
    keys = list(study.ladder)
    variants = study.variants or {"": {}}
    runs = []
    for values in itertools.product(*study.ladder.values()):
        parts = [f"{key.rsplit('.', 1)[-1]}{_yaml(value)}" for key, value in zip(keys, values)]
        for name, extra in variants.items():
            run_id = "-".join(parts + ([name] if name else [])).replace("/", "_").replace(" ", "")
            runs.append(({**study.base, **dict(zip(keys, values)), **extra}, run_id))
    fixed = {k: v for k, v in study.ladder.items() if k != "time.dt"}  # the tolerances replace time.dt
    for values in itertools.product(*fixed.values(), study.tolerances):
        parts = [f"{key.rsplit('.', 1)[-1]}{_yaml(value)}" for key, value in zip([*fixed, "time.tolerance"], values)]
        for name, extra in variants.items():
            run_id = "-".join(parts + ([name] if name else [])).replace("/", "_").replace(" ", "")
            runs.append(({**study.base, **dict(zip(fixed, values[:-1])), "time.tolerance": values[-1], **extra},
                         run_id))
    taken = {run_id for _, run_id in runs}
    for run_id, extra in study.extra.items():  # single runs beside the ladder, after it
        if run_id not in taken:
            runs.append(({**study.base, **extra}, run_id))
    return runs


def run_all(study: Study, study_path: Path, out: Path, jobs: int = 1) -> list[tuple[dict, Path]]:
    """Run every run of the ladder not finished yet, ``jobs`` at a time; returns (overrides, folder) pairs."""
    runs = out / "runs" / f"study-{study.name}"
    config = _config_path(study, study_path)
    todo = [(o, runs / run_id) for o, run_id in _combinations(study)]
    cases.run_cases([_case(study, config, overrides, folder) for overrides, folder in todo], jobs, strict=True)
    return todo


def _case(study: Study, config: Path, overrides: dict, folder: Path) -> cases.Case:
    return cases.Case(config, folder, {"output.fields": False, **overrides}, study.ranks)


UNRECORDED = "its folder does not record its scene"


def other_scene(study: Study, config: Path, overrides: dict, folder: Path) -> str | None:
    """Why the run in ``folder`` is not this study's run (made with another scene than the study asks for
    now, or with a scene its folder does not record), or None when it is (or nothing ran there yet)."""
    if not (folder / "summary.json").exists():
        return None
    changed = cases.scene_changes(_case(study, config, overrides, folder))
    if changed is None:
        return UNRECORDED
    if changed:
        return f"made with another scene: {', '.join(changed[:3])}{' ...' if len(changed) > 3 else ''} differ"
    return None


def _measure(study: Study, folder: Path) -> dict | None:
    s = read_summary(folder)
    if s is None:
        return None
    try:
        return _measured(study, folder, s)
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError):  # OverflowError: int(inf)
        raise InputError(f"{folder / 'summary.json'}: not the summary of a cosserat-fsi run (damaged?)") from None


def _measured(study: Study, folder: Path, s: dict) -> dict:
    errors = {}
    for key in study.observables:
        name, _, part = key.partition(".")
        entry = (s.get("benchmark") or {}).get(name) or {}
        entry = entry.get(part) if part else entry
        error = entry.get("error") if isinstance(entry, dict) else None
        errors[key] = None if error is None else float(error)
    phases = s.get("wall_time", {}).get("phases", {})
    time = s.get("time", {})
    steps = max(time.get("steps", 1), 1)
    bench = s.get("benchmark") or {}
    return {"status": s.get("status"), "errors": errors, "steps": int(time.get("steps", 0)),
            "applicable": bench.get("applicable", True) is not False,
            "differs": ", ".join(bench.get("differs") or []) + " differ" if bench.get("differs") else "",
            "tolerance": time.get("tolerance"), "rejected": int(time.get("rejected_steps", 0)),
            "wall": float(s["wall_time"]["total"]),
            "per_step": float(s["wall_time"]["per_step"]),
            "phases": {p: float(phases.get(p, 0.0)) / steps for p in PHASES},
            "memory": _number((s.get("memory") or {}).get("peak_rss_mib_sum")), "vertices": int(s["mesh"]["vertices"]),
            "dofs": int(s["dofs"]["total"])}


def _number(value) -> float | None:
    """None as it is, else a float (ValueError/TypeError for anything that is not a number)."""
    return None if value is None else float(value)


def read_summary(folder: Path) -> dict | None:
    """A run's summary.json (None if there is none yet); InputError naming it if it is damaged or foreign."""
    path = Path(folder) / "summary.json"
    if not path.exists():
        return None
    try:
        data = json.loads(read_text_file(path, "summary file", 16 << 20))
    except ValueError:
        data = None
    if not isinstance(data, dict):
        raise InputError(f"{path}: not the summary of a cosserat-fsi run (damaged?)")
    return data


def write_report(study: Study, todo: list[tuple[dict, Path]], out: Path, config: Path | None = None) -> Path:
    """Write ``<out>/study_<name>.md`` (and the Pareto plot) from the runs' summaries; returns its path.
    ``config``: the study's scene file; a run made with another scene than the study asks for now is
    reported as such, without its numbers; one whose folder does not record its scene (a summary.json
    written before summaries held ``resolved_scene``) keeps its numbers, marked, off the Pareto front. A run
    whose scene is not its benchmark's problem keeps its numbers (differences from a reference that does not
    apply), marked, off the Pareto front."""
    rows, points, labels, groups, every_error = [], [], [], [], []
    head = ("| run | vertices | dofs | status | steps | " + " | ".join(f"error {k}" for k in study.observables)
            + " | wall (s) | s/step | " + " | ".join(PHASES) + " | peak memory (MiB) |")
    rows += [head, "|" + "---|" * (head.count("|") - 1)]
    for overrides, folder in todo:
        run = folder.name
        why = other_scene(study, config, overrides, folder) if config is not None else None
        if why and why != UNRECORDED:
            rows.append(f"| {run} | | | not this study's run ({why}) | |"
                        + " |" * (len(study.observables) + 3 + len(PHASES)))
            continue
        m = _measure(study, folder)
        if m is None:
            rows.append(f"| {run} | | | not run | |" + " |" * (len(study.observables) + 3 + len(PHASES)))
            continue
        errs = [m["errors"][k] for k in study.observables]
        steps = f"{m['steps']}" + (f" ({m['rejected']} rejected)" if m["tolerance"] is not None else "")
        state = m["status"] if m["applicable"] else f"{m['status']}; reference not applicable ({m['differs']})"
        state += f" ({why})" if why else ""
        rows.append(f"| {run} | {m['vertices']:,} | {m['dofs']:,} | {state} | {steps} | "
                    + " | ".join("–" if e is None else f"{100 * e:+.3g}%" for e in errs)
                    + f" | {m['wall']:.3g} | {m['per_step']:.4f} | "
                    + " | ".join(f"{m['phases'][p]:.4f}" for p in PHASES)
                    + f" | {'–' if m['memory'] is None else format(m['memory'], '.0f')} |")
        if (m["status"] == "completed" and m["applicable"] and not why and all(e is not None for e in errs)
                and all(map(math.isfinite, [m["wall"], *errs]))):  # nan/inf are shown, kept off the front
            points.append((m["wall"], max(abs(e) for e in errs)))
            every_error.append(errs)
            labels.append(run)
            groups.append(GROUPS[m["tolerance"] is not None])
    front = fronts(points, groups)
    figure = save_pareto_figure(study, points, labels, groups, front, out) if points else None
    lines = [f"# Study `{study.name}`", "",
             f"Written by `cosserat-fsi study` from `{study.config}` with base overrides "
             f"`{json.dumps(study.base)}` over the ladder `{json.dumps(study.ladder)}` "
             + (f"× the variants `{json.dumps(study.variants)}` " if study.variants else "")
             + (f"and the time.tolerance ladder `{json.dumps(study.tolerances)}` " if study.tolerances else "") +
             f"({study.ranks} rank{'s' if study.ranks > 1 else ''}). Errors are relative to the benchmark's "
             "reference; phases are seconds per step; peak memory is the sum over ranks.", "", *rows, ""]
    for group, members in front.items():
        lines += [f"Pareto front, {group} (no other such run is both faster and more accurate): "
                  + ", ".join(f"`{labels[i]}` ({100 * points[i][1]:.3g}% in {points[i][0]:.3g} s)"
                              for i in sorted(members, key=lambda i: points[i][0])), ""]
    if figure:
        lines += [f"![pareto]({figure})", ""]
    if len(study.observables) > 1 and points:
        lines += ["Each quantity on its own (every completed run that applies):", "",
                  *quantity_fronts(study.observables, [p[0] for p in points], every_error, labels), ""]
    path = out / f"study_{study.name}.md"
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


def main_study(path: str | Path, out: str | Path | None = None, jobs: int = 1, report_only: bool = False) -> Path:
    """Check the study file, run what is not finished (unless ``report_only``) and write the report."""
    study_path = Path(path)
    if not 1 <= jobs <= 64:
        raise InputError(f"--jobs: must be 1..64 (got {jobs})")
    study = load_study(study_path)
    out = Path(out) if out else Path.cwd()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out: cannot write to {out} ({exc.strerror or exc})") from None
    todo = ([(o, out / "runs" / f"study-{study.name}" / run_id) for o, run_id in _combinations(study)]
            if report_only else run_all(study, study_path, out, jobs))
    return write_report(study, todo, out, _config_path(study, study_path))
