"""``time.tolerance`` and its keys: a bad combination is one line ``error: time.KEY: ...``, exit 2, nothing
written; a restart that adds a tolerance is another scene; a tolerance that cannot be met at ``time.dt_min``
stops the run with exit 3, naming the time and ``time.dt_min``, its output kept."""

from __future__ import annotations

import json

import pytest

from faultlib import REPO, check, cli, in_process_main, snapshot


@pytest.fixture
def main(capsys, tmp_path):
    yield from in_process_main(capsys, tmp_path)


KEYS = {  # --set overrides of the tiny scene (characteristics1, dt 0.05) -> the error line's start
    "dt_min_without_tolerance": (["time.dt_min=0.01"], "error: time.dt_min: needs time.tolerance"),
    "dt_max_without_tolerance": (["time.dt_max=0.1"], "error: time.dt_max: needs time.tolerance"),
    "error_floor_without_tolerance": (["time.error_floor=0.1"], "error: time.error_floor: needs time.tolerance"),
    "dt_max_below_dt": (["time.tolerance=1e-3", "time.dt_max=0.01"],
                        "error: time.dt_max: must be >= time.dt, the first step (got 0.01 < 0.05)"),
    "dt_min_above_dt": (["time.tolerance=1e-3", "time.dt_min=0.1"],
                        "error: time.dt_min: must be <= time.dt, the first step (got 0.1 > 0.05)"),
    "tolerance_zero": (["time.tolerance=0"], "error: time.tolerance: must be > 0"),
    "tolerance_above_one": (["time.tolerance=1.5"], "error: time.tolerance: must be < 1"),
    "tolerance_one": (["time.tolerance=1"], "error: time.tolerance: must be < 1"),
    "tolerance_nan": (["time.tolerance=.nan"], "error: time.tolerance: must be a finite number"),
    "tolerance_text": (["time.tolerance=abc"], "error: time.tolerance: must be a number"),
    "dt_min_zero": (["time.tolerance=1e-3", "time.dt_min=0"], "error: time.dt_min: must be > 0"),
    "dt_max_negative": (["time.tolerance=1e-3", "time.dt_max=-1"], "error: time.dt_max: must be > 0"),
    "error_floor_zero": (["time.tolerance=1e-3", "time.error_floor=0"], "error: time.error_floor: must be > 0"),
    "error_floor_above_one": (["time.tolerance=1e-3", "time.error_floor=2"],
                              "error: time.error_floor: must be <= 1"),
}


@pytest.mark.parametrize("overrides, start", KEYS.values(), ids=KEYS)
def test_bad_step_control_is_one_line_before_anything(main, tiny_config, overrides, start):
    argv = ["run", tiny_config, "--out", main.out]
    for item in overrides:
        argv += ["--set", item]
    code, err = main(*argv)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith(start), err


def test_tolerance_of_a_steady_scene(main):
    code, err = main("run", REPO / "configs/micropolar_poiseuille.yaml", "--out", main.out,
                     "--set", "time.tolerance=1e-3")
    assert code == 2 and err.splitlines() == [
        "error: time.tolerance: not used by scheme steady (only for characteristics1, characteristics2, "
        "ale_bdf2, generalized_alpha)"], err


def test_restart_that_adds_a_tolerance_is_another_scene(tiny_config, run_copy):
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--restart", run_copy, "--set", "time.tolerance=1e-3")
    check(result, 2, "error: --restart: the checkpoint is from another scene")
    assert snapshot(run_copy) == before


def test_a_step_rejected_at_dt_min_stops_the_run_with_exit_3(tmp_path):
    """Taylor–Green with an unreachable tolerance: steps 1 and 2 take time.dt (no estimate yet), step 3 is
    rejected at dt_min = dt: exit 3 at t = 0.1, the two rows and a summary saying "diverged" kept."""
    out = tmp_path / "run"
    result = cli("run", REPO / "configs/micropolar_taylor_green.yaml", "--out", out, "--no-progress",
                 "--set", "geometry.level=0", "--set", "time.tolerance=1e-9", "--set", "time.dt_min=0.05")
    line = check(result, 3, "diverged: t = 0.1: a step of time.dt_min = 0.05 is rejected", "time.dt_min")
    assert "time.tolerance" in line
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "diverged" and summary["message"] in line
    assert summary["time"] == {
        "dt": 0.05, "scheme": "characteristics2", "steps": 2, "t_final": 0.1, "tolerance": 1e-9,
        "rejected_steps": 1, "dt_smallest": 0.05, "dt_largest": 0.05}
    rows = (out / "timeseries.csv").read_text().splitlines()
    assert rows[0].startswith("t,dt,") and len(rows) == 3
    assert "2 steps, δt 0.05 (time.tolerance 1e-09), 1 rejected, to t = 0.1" in (out / "run.log").read_text()
