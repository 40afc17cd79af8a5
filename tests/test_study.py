"""`cosserat-fsi study`: a ladder of runs, resumed not recomputed, errors taken from the runs' summaries,
the Pareto front, and one-line exit 2 for a bad study file (every run's scene checked before any runs)."""

from __future__ import annotations

import json

import pytest

from cosserat_fsi.app.study import pareto

REPO_CONFIG = "configs/schaefer_turek_2d1.yaml"


def _study(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


def test_pareto_front():
    points = [(10, 0.1), (20, 0.05), (15, 0.2), (30, 0.05), (5, 0.5)]
    assert sorted(pareto(points)) == [0, 1, 4]


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
