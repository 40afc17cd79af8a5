"""The case runner of study and the campaigns (app/cases.py): what it runs, skips and resumes."""

from __future__ import annotations

import json

import pytest

from cosserat_fsi.app.cases import Case, override, status

CONFIG = "configs/schaefer_turek_2d1.yaml"


def _folder(tmp_path, summary=None, checkpoint=False):
    out = tmp_path / "case"
    out.mkdir()
    if summary is not None:
        (out / "summary.json").write_text(json.dumps(summary))
    if checkpoint:
        (out / "checkpoint").mkdir()
        (out / "checkpoint" / "meta.json").write_text("{}")
    return out


@pytest.mark.parametrize("summary, checkpoint, expected", [
    (None, False, "start"),
    (None, True, "resume"),  # killed before its summary was written
    ({"status": "completed", "time": {"t_final": 0.5}}, False, "finished"),
    ({"status": "completed", "time": {"t_final": 0.2}}, True, "resume"),  # a longer t_end since
    ({"status": "completed", "time": {"t_final": 0.2}}, False, "start"),
    ({"status": "diverged", "time": {"t_final": 0.1}}, True, "finished"),  # deterministic: not run again
    ({"status": "interrupted", "time": {"t_final": 0.1}}, True, "resume"),
])
def test_status(tmp_path, repo_root, summary, checkpoint, expected):
    out = _folder(tmp_path, summary, checkpoint)
    case = Case(repo_root / CONFIG, out, {"time.scheme": "characteristics1", "time.t_end": 0.5, "time.dt": 0.05})
    assert status(case) == expected


def test_overrides_read_back_as_written():
    assert override("time.dt", 0.001) == "time.dt=0.001" and override("output.fields", False) == "output.fields=false"
    assert override("geometry.level", "seed") == "geometry.level=seed"
    assert Case("c.yaml", "out", {"a.b": 1, "c": [0, -9.81]}).set_args() == ["--set", "a.b=1", "--set", "c=[0, -9.81]"]
