"""`cosserat-fsi study`: a ladder of runs, resumed not recomputed, errors taken from the runs' summaries,
the Pareto front, and one-line exit 2 for a bad study file (every run's scene checked before any runs)."""

from __future__ import annotations

import json

import pytest

from cosserat_fsi.app.study import pareto, quantity_fronts

REPO_CONFIG = "configs/schaefer_turek_2d1.yaml"


def _study(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


def test_pareto_front():
    points = [(10, 0.1), (20, 0.05), (15, 0.2), (30, 0.05), (5, 0.5)]
    assert sorted(pareto(points)) == [0, 1, 4]


def test_each_quantity_has_its_own_front():
    """A run can be on one quantity's front and off another's: the cheap run is the best for `a` only."""
    rows = quantity_fronts(["a", "b"], [10.0, 40.0, 20.0], [[0.01, -0.5], [0.02, 0.01], [0.03, 0.2]],
                           ["cheap", "fine", "middle"])
    assert rows[2] == "| a | `cheap` (+1 %, 10 s) |"
    assert rows[3] == "| b | `cheap` (-50 %, 10 s), `middle` (+20 %, 20 s), `fine` (+1 %, 40 s) |"


@pytest.mark.slow
def test_study_runs_resumes_and_reports(run_cli, tmp_path, repo_root):
    study = _study(tmp_path, f"name: tiny\nconfig: {repo_root / REPO_CONFIG}\nobservables: [c_D, dp]\n"
                             "base: {geometry.level: 0, time.t_end: 0.3, time.scheme: characteristics2}\n"
                             "ladder: {time.dt: [0.1, 0.05]}\n")
    out = tmp_path / "docs"
    first = run_cli("study", study, "--out", out)
    assert first.returncode == 0, first.stderr
    runs = out / "runs" / "study-tiny"
    summaries = {p.parent.name: json.loads(p.read_text()) for p in runs.glob("*/summary.json")}
    assert sorted(summaries) == ["dt0.05", "dt0.1"] and all(s["status"] == "completed" for s in summaries.values())
    assert all(s["memory"]["peak_rss_mib_max_rank"] > 10 for s in summaries.values())
    report = (out / "study_tiny.md").read_text()
    for run, s in summaries.items():
        row = next(line for line in report.splitlines() if line.startswith(f"| {run} |"))
        assert f"{s['benchmark']['c_D']['error']:+.2%}" in row and f"{s['wall_time']['per_step']:.4f}" in row
    assert "Pareto front" in report and (out / "figures" / "study_tiny_pareto.png").stat().st_size > 1000
    assert next(line for line in report.splitlines() if line.startswith("| dp | `"))  # a front per quantity
    stamps = {p: p.stat().st_mtime_ns for p in runs.glob("*/summary.json")}
    again = run_cli("study", study, "--out", out)  # resumes: nothing is run again
    assert again.returncode == 0 and {p: p.stat().st_mtime_ns for p in stamps} == stamps


@pytest.mark.parametrize("text, expected", [
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nbase: {{time.scheme: characteristics1, time.t_end: 1}}\n"
     "ladder: {{time.dt: [0.1, -1]}}\n", "time.dt: must be > 0"),
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nladder: {{time.dt: [0.1]}}\n", "time.dt: not used by scheme steady"),
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nladder: {{time.dtt: [0.1]}}\n", "time.dtt: unknown key"),
    ("name: x\nconfig: nope.yaml\nobservables: [c_D]\nladder: {{time.dt: [0.1]}}\n", "config: nope.yaml not found"),
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nladder: {{}}\n", "ladder: "),
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nladder: {{time.dt: [0.1]}}\nextra: 1\n", "extra: "),
    ("name: x\nconfig: {cfg}\nladder: {{time.dt: [0.1]}}\n", "observables: "),
    ("name: x\nconfig: {cfg}\nobservables: [c_D]\nladder: [\n", "could not parse YAML"),
])
def test_bad_study_exits_2_before_running(run_cli, tmp_path, repo_root, text, expected):
    study = _study(tmp_path, text.format(cfg=repo_root / REPO_CONFIG))
    result = run_cli("study", study, "--out", tmp_path / "docs")
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1, result.stderr
    assert "Traceback" not in result.stderr and expected in result.stderr, result.stderr
    assert not (tmp_path / "docs" / "runs").exists()


def test_variants_multiply_the_ladder(tmp_path, repo_root):
    from cosserat_fsi.app.study import _combinations, load_study

    study = load_study(_study(tmp_path, f"name: v\nconfig: {repo_root / REPO_CONFIG}\nobservables: [c_D]\n"
                                        "base: {time.t_end: 0.3}\nladder: {time.dt: [0.1, 0.05]}\n"
                                        "variants: {c1: {time.scheme: characteristics1},\n"
                                        "           c2: {time.scheme: characteristics2, time.quadrature_degree: 6}}\n"))
    runs = _combinations(study)
    assert [run_id for _, run_id in runs] == ["dt0.1-c1", "dt0.1-c2", "dt0.05-c1", "dt0.05-c2"]
    assert runs[3][0] == {"time.t_end": 0.3, "time.dt": 0.05, "time.scheme": "characteristics2",
                          "time.quadrature_degree": 6}


def test_extra_runs_follow_the_ladder(tmp_path, repo_root):
    """``extra``: single runs beside the ladder (base + their own overrides), after it."""
    from cosserat_fsi.app.study import _combinations, load_study

    study = load_study(_study(tmp_path, f"name: v\nconfig: {repo_root / REPO_CONFIG}\nobservables: [c_D]\n"
                                        "base: {time.t_end: 0.3, time.scheme: characteristics1}\n"
                                        "ladder: {time.dt: [0.1, 0.05]}\n"
                                        "extra: {c2-fine: {time.dt: 0.01, time.scheme: characteristics2}}\n"))
    runs = _combinations(study)
    assert [run_id for _, run_id in runs] == ["dt0.1", "dt0.05", "c2-fine"]
    assert runs[2][0] == {"time.t_end": 0.3, "time.scheme": "characteristics2", "time.dt": 0.01}


def test_bad_variant_exits_2(run_cli, tmp_path, repo_root):
    study = _study(tmp_path, f"name: v\nconfig: {repo_root / REPO_CONFIG}\nobservables: [c_D]\n"
                             "ladder: {time.dt: [0.1]}\nvariants: {a: {time.scheme: nope}}\n")
    result = run_cli("study", study, "--out", tmp_path / "docs")
    assert result.returncode == 2 and "time.scheme" in result.stderr and "Traceback" not in result.stderr


@pytest.mark.parametrize("section", ["variants", "extra"])
def test_bad_run_name_is_one_line_naming_it(tmp_path, repo_root, section):
    """A variant's or an extra run's name becomes a folder name: only letters, digits, '_', '.', '-'."""
    from cosserat_fsi.app.study import load_study
    from cosserat_fsi.errors import InputError

    path = _study(tmp_path, f"name: v\nconfig: {repo_root / REPO_CONFIG}\nobservables: [c_D]\n"
                            f"ladder: {{time.dt: [0.1]}}\n{section}: {{'../x': {{time.dt: 0.05}}}}\n")
    with pytest.raises(InputError) as info:
        load_study(path)
    message = str(info.value)
    assert "\n" not in message and f"{section}.../x: a name of letters, digits" in message, message


def _fake_run(folder, scene, error):
    """A finished run of ``scene`` in ``folder`` as the case runner leaves it (config.yaml, summary.json),
    made without solving anything: c_D's error is ``error``."""
    folder.mkdir(parents=True)
    (folder / "config.yaml").write_text(scene.to_yaml())
    summary = {"scene": scene.name, "status": "completed", "mesh": {"vertices": 100, "level": 0},
               "dofs": {"total": 1000}, "time": {"steps": 3, "t_final": scene.time.t_end, "dt": scene.time.dt},
               "wall_time": {"total": 1.0, "per_step": 0.1, "phases": {}},
               "benchmark": {"name": scene.benchmark, "applicable": True,
                             "c_D": {"value": 5.0, "reference": 5.5795, "error": error}}}
    (folder / "summary.json").write_text(json.dumps(summary))


STALE = "name: s\nconfig: {cfg}\nobservables: [c_D]\nbase: {{time.scheme: characteristics1, time.t_end: 0.3, " \
        "fluid.mu: {mu}}}\nladder: {{time.dt: [0.1]}}\n"


def _stale_study(tmp_path, repo_root, mu_then, mu_now):
    """A study whose run folder holds a finished run made with fluid.mu = mu_then, the study now asking for
    mu_now: (study file, run folder, the case the study would run)."""
    from cosserat_fsi.app import cases
    from cosserat_fsi.app.study import _case, _combinations, load_study

    path = _study(tmp_path, STALE.format(cfg=repo_root / REPO_CONFIG, mu=mu_then))
    study = load_study(path)
    (overrides, run_id), = _combinations(study)
    folder = tmp_path / "out" / "runs" / "study-s" / run_id
    _fake_run(folder, cases.case_scene(_case(study, repo_root / REPO_CONFIG, overrides, folder)), -0.0123)
    path.write_text(STALE.format(cfg=repo_root / REPO_CONFIG, mu=mu_now))
    study = load_study(path)
    (overrides, _), = _combinations(study)
    return path, folder, _case(study, repo_root / REPO_CONFIG, overrides, folder)


def test_a_run_of_the_same_scene_is_finished(tmp_path, repo_root):
    from cosserat_fsi.app import cases
    from cosserat_fsi.app.study import main_study

    path, folder, case = _stale_study(tmp_path, repo_root, 0.001, 0.001)
    assert cases.scene_changes(case) == [] and cases.status(case, strict=True) == "finished"
    report = main_study(path, tmp_path / "out", report_only=True).read_text()
    assert "-1.23%" in report and "not this study's run" not in report


def test_a_study_rerun_after_its_base_changed_runs_again(tmp_path, repo_root, monkeypatch):
    """μ 1e-3 -> 2e-3 in ``base``: the folder's run is another scene's. The study runs it again (never reports the
    old numbers under the new header); ``--report-only`` says per run that it is not this study's run."""
    from cosserat_fsi.app import cases
    from cosserat_fsi.app.study import main_study

    path, folder, case = _stale_study(tmp_path, repo_root, 0.001, 0.002)
    assert cases.scene_changes(case) == ["fluid.mu"] and cases.status(case, strict=True) == "start"
    report = main_study(path, tmp_path / "out", report_only=True).read_text()
    row = next(line for line in report.splitlines() if line.startswith("| dt0.1 |"))
    assert "not this study's run (made with another scene: fluid.mu differ" in row and "-1.23%" not in report
    started = []

    def run_case(case, python=None, cwd=None, strict=False):  # what the case runner would run (no solve here)
        started.append((case.out, cases.status(case, strict)))
        return case.out

    monkeypatch.setattr(cases, "run_case", run_case)
    main_study(path, tmp_path / "out")
    assert started == [(folder, "start")]


def test_a_later_t_end_is_another_run_and_a_shorter_one_is_continued(tmp_path, repo_root):
    from cosserat_fsi.app import cases

    _, folder, case = _stale_study(tmp_path, repo_root, 0.001, 0.001)
    longer = cases.Case(case.config, folder, {**case.overrides, "time.t_end": 0.6})
    assert cases.scene_changes(longer) == []  # continued from its checkpoint (status resume/start)
    assert cases.status(longer) in ("resume", "start")
    shorter = cases.Case(case.config, folder, {**case.overrides, "time.t_end": 0.2})
    assert cases.scene_changes(shorter) == ["time.t_end"] and cases.status(shorter) == "start"


def test_a_folder_that_does_not_record_its_scene(tmp_path, repo_root):
    """An older run folder with only its summary.json: run again by a study, reported marked (off the Pareto
    front); one whose config.yaml is not a scene is not replaced: exit 2 naming it."""
    from cosserat_fsi.app import cases
    from cosserat_fsi.app.study import main_study
    from cosserat_fsi.errors import InputError

    path, folder, case = _stale_study(tmp_path, repo_root, 0.001, 0.001)
    (folder / "config.yaml").unlink()
    assert cases.scene_changes(case) is None
    assert cases.status(case, strict=True) == "start" and cases.status(case) == "finished"
    report = main_study(path, tmp_path / "out", report_only=True).read_text()
    row = next(line for line in report.splitlines() if line.startswith("| dt0.1 |"))
    assert "its folder does not record its scene" in row and "Pareto front" not in report
    (folder / "config.yaml").write_text("geometry: {name: nowhere}\n")
    with pytest.raises(InputError, match=str(folder)):
        main_study(path, tmp_path / "out")


def test_summary_resolved_scene_counts_like_config_yaml(tmp_path, repo_root):
    """A folder with only summary.json, which records the resolved scene: compared like config.yaml."""
    from cosserat_fsi.app import cases

    _, folder, case = _stale_study(tmp_path, repo_root, 0.001, 0.002)
    from cosserat_fsi.config import load_scene

    summary = json.loads((folder / "summary.json").read_text())
    summary["resolved_scene"] = cases.resolved_scene(load_scene(folder / "config.yaml"))
    (folder / "summary.json").write_text(json.dumps(summary))
    (folder / "config.yaml").unlink()
    assert cases.scene_changes(case) == ["fluid.mu"] and cases.status(case, strict=True) == "start"


def test_a_run_whose_scene_is_not_its_benchmarks_problem_stays_off_the_pareto_front(tmp_path, repo_root):
    from cosserat_fsi.app.study import main_study

    path, folder, _ = _stale_study(tmp_path, repo_root, 0.002, 0.002)
    summary = json.loads((folder / "summary.json").read_text())
    summary["benchmark"].update(applicable=False, differs=["fluid.mu"])
    (folder / "summary.json").write_text(json.dumps(summary))
    report = main_study(path, tmp_path / "out", report_only=True).read_text()
    row = next(line for line in report.splitlines() if line.startswith("| dt0.1 |"))
    assert "reference not applicable (fluid.mu differ)" in row and "Pareto front" not in report
