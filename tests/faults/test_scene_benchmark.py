"""A scene that names a benchmark but solves another problem (config/benchmarks.py): the run's last lines show
its numbers beside the reference without a verdict, and summary.json says ``applicable: false``."""

from __future__ import annotations

import json

from faultlib import REPO, cli


def test_schaefer_turek_with_another_viscosity_prints_no_verdict(tmp_path):
    """The steady 2D-1 scene on level 0 with μ doubled: exit 0, "reference not applicable", no PASS/FAIL."""
    out = tmp_path / "run"
    result = cli("run", REPO / "configs" / "schaefer_turek_2d1.yaml", "--out", out, "--no-progress",
                 "--set", "geometry.level=0", "--set", "fluid.mu=0.002", "--set", "output.fields=false")
    assert result.returncode == 0, result
    lines = result.stdout.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("benchmark schaefer_turek_2d1:"))
    assert lines[head] == ("benchmark schaefer_turek_2d1: reference not applicable: fluid.mu differs (0.002; the "
                           "benchmark: 0.001)"), lines[head]
    table = lines[head + 1:head + 6]
    assert [row.split()[0] for row in table[2:]] == ["c_D", "c_L", "dp"], table
    assert all(row.split()[-1] == "n/a" for row in table[2:]), table
    assert "PASS" not in result.stdout and "FAIL" not in result.stdout and " pass\n" not in result.stdout
    bench = json.loads((out / "summary.json").read_text())["benchmark"]
    assert bench["applicable"] is False and bench["differs"] == ["fluid.mu"]
    assert bench["c_D"]["reference"] > 5.5  # the numbers are kept beside the reference


def test_the_shipped_scene_keeps_its_verdict(tmp_path):
    """The same run with the benchmark's viscosity: a PASS/FAIL line, no "not applicable"."""
    out = tmp_path / "run"
    result = cli("run", REPO / "configs" / "schaefer_turek_2d1.yaml", "--out", out, "--no-progress",
                 "--set", "geometry.level=0", "--set", "output.fields=false")
    assert result.returncode == 0, result
    assert any(line.startswith(("benchmark schaefer_turek_2d1: PASS", "benchmark schaefer_turek_2d1: FAIL"))
               for line in result.stdout.splitlines()), result
    assert "not applicable" not in result.stdout
    assert json.loads((out / "summary.json").read_text())["benchmark"]["applicable"] is True
