"""What a run with ``time.tolerance`` tells the user: summary.json's ``time`` block (rejected steps, the range
of δt) and the closing status line, the controller's line in run.log, a progress bar in simulated time, the
``dt`` column kept out of the signals, periodic analysis of unequally spaced samples, the δt(t) plot and the
study's two Pareto fronts (fixed δt, time.tolerance)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cosserat_fsi.analysis import periodic_analysis, second_half
from cosserat_fsi.app.verdict import classify_signals, verdict_lines
from cosserat_fsi.io import read_timeseries


def _adaptive_times(t_end: float, seed: int = 7) -> np.ndarray:
    """Steps like a controller's: fine (0.002 ± 50 %) through a transient before t = 2, coarse (0.012 ± 50 %)
    after."""
    rng = np.random.default_rng(seed)
    t = [0.0]
    while t[-1] < t_end:
        t.append(t[-1] + (0.002 if t[-1] < 2.0 else 0.012) * (1 + 0.5 * rng.uniform(-1, 1)))
    return np.array(t[1:])


def test_periodic_analysis_of_unequally_spaced_samples():
    """0.3 + 1.7 sin(2π 2.3 t + 0.4) after a decaying 7 Hz transient, on steps that vary sixfold: mean,
    amplitude and frequency to 1e-3, the FFT cross-check too."""
    t = _adaptive_times(6.0)
    assert np.ptp(np.diff(t)) > 0.01  # really unequal
    y = 0.3 + 1.7 * np.sin(2 * np.pi * 2.3 * t + 0.4) + 6 * np.exp(-t / 0.3) * np.sin(2 * np.pi * 7 * t)
    a = periodic_analysis(t, y)
    assert a["method"] == "maxima"
    assert abs(a["amplitude"] - 1.7) <= 1e-3 * 1.7 and abs(a["mean"] - 0.3) <= 1e-3 * 1.7
    assert abs(a["frequency"] - 2.3) <= 1e-3 * 2.3 and abs(a["frequency_fft"] - 2.3) <= 1e-3 * 2.3


def test_the_last_half_is_in_time():
    t = _adaptive_times(6.0)
    half = second_half(t)
    assert t[half] >= 3.0 > t[half - 1]
    for n in (2, 3, 10, 11, 1001):  # equal steps: len(t) // 2, whatever the rounding of t
        assert second_half(np.cumsum(np.full(n, 0.1))) == n // 2 == second_half(np.arange(1, n + 1) * 0.013)


def test_dt_is_not_a_signal_and_steadiness_is_judged_on_the_last_half_in_time():
    """1 + e^{-10t}, fine steps while it decays, coarse after: steady on [1, 2] (the last half in time)
    though the last half of the samples starts in the decay; the dt column is left out."""
    t = np.concatenate([np.arange(1, 501) * 1e-3, 0.5 + np.arange(1, 31) * 0.05])
    series = {"t": t, "dt": np.diff(t, prepend=0.0), "drag": 1 + np.exp(-10 * t)}
    signals, periodic = classify_signals(series)
    assert signals == {"drag": "steady"} and periodic == {}


def test_a_reference_on_dt_is_refused():
    from types import SimpleNamespace

    from cosserat_fsi.app.verdict import check_reference
    from cosserat_fsi.errors import InputError

    with pytest.raises(InputError, match=r"^reference\.dt: the time and the step size are not observables"):
        check_reference(SimpleNamespace(reference={"dt": None}), ["dt", "drag"])


def _summary(time: dict) -> dict:
    return {"status": "completed", "time": time, "wall_time": {"total": 2.0, "setup": 1.0}, "ranks": 1}


@pytest.mark.parametrize("time, expected", [
    ({"dt": 0.05, "steps": 10, "t_final": 0.5}, "10 steps of 0.05 to t = 0.5"),
    ({"dt": 0.05, "steps": 159, "t_final": 2.0, "tolerance": 1e-3, "rejected_steps": 3,
      "dt_smallest": 0.0014948, "dt_largest": 0.05}, "159 steps, δt 0.0015–0.05 (time.tolerance 0.001), 3 rejected, "
                                                      "to t = 2"),
    ({"dt": 0.05, "steps": 2, "t_final": 0.1, "tolerance": 1e-9, "rejected_steps": 1, "dt_smallest": 0.05,
      "dt_largest": 0.05}, "2 steps, δt 0.05 (time.tolerance 1e-09), 1 rejected, to t = 0.1"),
    ({"dt": 0.05, "steps": 0, "t_final": 0.0, "tolerance": 1e-3, "rejected_steps": 0, "dt_smallest": None,
      "dt_largest": None}, "0 steps, no step accepted (time.tolerance 0.001), 0 rejected, to t = 0"),
])
def test_status_line_tells_how_the_run_stepped(time, expected):
    assert verdict_lines(_summary(time))[-1] == (f"status: completed; {expected}; wall time 2.00 s (setup 1.00 s); "
                                                 "1 rank(s)")


def test_progress_bar_counts_simulated_time_with_a_tolerance(capsys):
    from types import SimpleNamespace

    from cosserat_fsi.app.progress import advance as _advance, progress_bar as _progress_bar

    sim = SimpleNamespace(t=0.0, step_count=0, state=SimpleNamespace(steps=SimpleNamespace(last=0.0)))
    bar = _progress_bar(40, True, t_end=2.0)
    for t, k, dt in ((0.05, 1, 0.05), (0.0516, 2, 0.0016), (1.3, 30, 0.05), (2.0, 45, 0.05)):
        sim.t, sim.step_count, sim.state.steps.last = t, k, dt
        _advance(bar, sim)
        assert bar.n == pytest.approx(t, abs=1e-15) and bar.total == 2.0
    bar.close()
    fixed = _progress_bar(40, True)
    sim.step_count = 7
    _advance(fixed, sim)
    assert fixed.n == 7 and fixed.total == 40
    fixed.close()
    assert _progress_bar(40, False, t_end=2.0) is None


@pytest.fixture(scope="module")
def adaptive_run(tmp_path_factory, repo_root, run_cli):
    out = tmp_path_factory.mktemp("adaptive") / "run"
    proc = run_cli("run", repo_root / "configs/micropolar_taylor_green.yaml", "--out", out, "--no-progress",
                   "--set", "geometry.level=1", "--set", "time.t_end=0.4", "--set", "time.tolerance=1e-3")
    assert proc.returncode == 0, proc.stderr
    return out


def test_summary_and_log_of_an_adaptive_run(adaptive_run):
    """The time block agrees with the dt column (steps, range, the sum of the steps is t_final); dt is no
    signal; run.log names the controller's settings once, before the first step, and ends with the range."""
    summary = json.loads((adaptive_run / "summary.json").read_text())
    series = read_timeseries(adaptive_run / "timeseries.csv")
    time = summary["time"]
    assert set(time) == {"dt", "scheme", "steps", "t_final", "tolerance", "rejected_steps", "dt_smallest",
                         "dt_largest"}
    assert time["dt"] == 0.05 and time["tolerance"] == 1e-3 and time["t_final"] == 0.4
    assert time["steps"] == len(series["t"]) and series["dt"][0] == 0.05
    assert time["dt_smallest"] == pytest.approx(series["dt"].min(), rel=1e-9)
    assert time["dt_largest"] == pytest.approx(series["dt"].max(), rel=1e-9)
    assert np.sum(series["dt"]) == pytest.approx(0.4, rel=1e-9)
    assert time["dt_smallest"] < 0.5 * time["dt_largest"]  # the controller did change the step
    assert isinstance(time["rejected_steps"], int) and time["rejected_steps"] >= 0
    assert "dt" not in summary["final"] and "dt" not in summary["signals"] and "dt" not in summary["periodic"]
    log = (adaptive_run / "run.log").read_text().splitlines()
    control = [i for i, line in enumerate(log) if "adaptive step: time.tolerance 0.001" in line]
    assert len(control) == 1 and "dt_min 5e-05, dt_max inf" in log[control[0]]
    assert control[0] < next(i for i, line in enumerate(log) if "dofs:" in line)
    status = next(line for line in log if "status: completed;" in line)
    assert (f"{time['steps']} steps, δt {time['dt_smallest']:.2g}–0.05 (time.tolerance 0.001), "
            f"{time['rejected_steps']} rejected, to t = 0.4;") in status


def test_plot_has_a_step_size_panel(adaptive_run, tmp_path):
    """steps.png: δt(t) on a log scale, from the dt column; a fixed-step series has no such figure."""
    import matplotlib.pyplot as plt

    from cosserat_fsi.app.plots import plot_timeseries, timeseries_figures

    series = read_timeseries(adaptive_run / "timeseries.csv")
    figures = timeseries_figures(series, {}, "run")
    assert sorted(figures) == ["flow", "steps"]
    (ax,) = figures["steps"].axes
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "δt (s)" and ax.get_xlabel() == "t (s)"
    line = ax.get_lines()[0]
    np.testing.assert_array_equal(line.get_ydata(), series["dt"])
    assert len(figures["flow"].axes) == 1 and figures["flow"].axes[0].get_ylabel() == "omega_max"
    for fig in figures.values():
        plt.close(fig)
    fixed = timeseries_figures({k: v for k, v in series.items() if k != "dt"}, {}, "run")
    assert sorted(fixed) == ["flow"]
    plt.close(fixed["flow"])
    made = plot_timeseries(adaptive_run, tmp_path)
    assert sorted(p.name for p in made) == ["flow.png", "steps.png"] and (tmp_path / "steps.png").stat().st_size > 1000


TG = "configs/micropolar_taylor_green.yaml"


def _tg_study(tmp_path, repo_root, extra=""):
    path = tmp_path / "s.yaml"
    path.write_text(f"name: tg\nconfig: {repo_root / TG}\nobservables: [velocity, micro_rotation]\n"
                    "base: {geometry.level: 0, time.t_end: 0.2}\n"
                    "ladder: {geometry.level: [0, 1], time.dt: [0.1, 0.05]}\ntolerances: [0.01, 0.001]\n" + extra)
    return path


def test_tolerances_are_a_ladder_beside_time_dt(tmp_path, repo_root):
    """Every ladder point without its time.dt, at each tolerance (after the fixed-step ladder, before extra)."""
    from cosserat_fsi.app.study import _combinations, load_study

    study = load_study(_tg_study(tmp_path, repo_root, "extra: {fine: {time.dt: 0.025}}\n"))
    runs = _combinations(study)
    assert [run_id for _, run_id in runs] == [
        "level0-dt0.1", "level0-dt0.05", "level1-dt0.1", "level1-dt0.05", "level0-tolerance0.01",
        "level0-tolerance0.001", "level1-tolerance0.01", "level1-tolerance0.001", "fine"]
    assert runs[5][0] == {"geometry.level": 0, "time.t_end": 0.2, "time.tolerance": 0.001}


@pytest.mark.parametrize("bad, expected", [("0", "tolerances.1: input should be greater than 0"),
                                           ("1.5", "tolerances.1: input should be less than 1")])
def test_bad_tolerance_ladder_is_one_line(tmp_path, repo_root, bad, expected):
    from cosserat_fsi.app.study import load_study
    from cosserat_fsi.errors import InputError

    path = _tg_study(tmp_path, repo_root)
    path.write_text(path.read_text().replace("tolerances: [0.01, 0.001]", f"tolerances: [0.01, {bad}]"))
    with pytest.raises(InputError) as info:
        load_study(path)
    assert "\n" not in str(info.value) and expected in str(info.value), str(info.value)


def test_tolerances_with_a_tolerance_ladder_are_refused(tmp_path, repo_root):
    from cosserat_fsi.app.study import load_study
    from cosserat_fsi.errors import InputError

    path = _tg_study(tmp_path, repo_root)
    path.write_text(path.read_text().replace("time.dt: [0.1, 0.05]", "time.tolerance: [0.1]"))
    with pytest.raises(InputError, match="tolerances: not with a ladder of time.tolerance"):
        load_study(path)


def _fake_run(folder, wall, error, tolerance=None):
    folder.mkdir(parents=True)
    time = {"dt": 0.1, "scheme": "characteristics2", "steps": 4, "t_final": 0.2}
    if tolerance is not None:
        time |= {"tolerance": tolerance, "rejected_steps": 1, "dt_smallest": 0.01, "dt_largest": 0.1}
    (folder / "summary.json").write_text(json.dumps({
        "status": "completed", "time": time, "mesh": {"vertices": 81}, "dofs": {"total": 1000},
        "wall_time": {"total": wall, "per_step": wall / 4, "phases": {}}, "memory": {"peak_rss_mib_sum": 100},
        "benchmark": {"name": "micropolar_taylor_green", "velocity": {"error": error},
                      "micro_rotation": {"error": error / 2}}}))


def test_report_has_a_front_per_group(tmp_path, repo_root):
    """Fixed-δt and tolerance runs: each group's own Pareto front, in the report and as two labelled series
    of the plot (a dominated run of one group stays on its group's front if only the other group beats it)."""
    import matplotlib.pyplot as plt

    from cosserat_fsi.app.study import _combinations, fronts, load_study, pareto_figure, write_report

    study = load_study(_tg_study(tmp_path, repo_root))
    runs = tmp_path / "out" / "runs" / "study-tg"
    made = {"level0-dt0.1": (1.0, 0.1), "level0-dt0.05": (2.0, 0.05), "level1-dt0.1": (3.0, 0.08),
            "level1-dt0.05": (4.0, 0.01), "level0-tolerance0.01": (1.5, 0.02), "level0-tolerance0.001": (2.5, 0.004),
            "level1-tolerance0.01": (3.5, 0.03)}  # level1-tolerance0.001: not run
    for run_id, (wall, error) in made.items():
        _fake_run(runs / run_id, wall, error, 0.01 if "tolerance" in run_id else None)
    todo = [(o, runs / run_id) for o, run_id in _combinations(study)]
    report = write_report(study, todo, tmp_path / "out").read_text()
    assert ("Pareto front, fixed δt (no other such run is both faster and more accurate): `level0-dt0.1` (10% in 1 s), "
            "`level0-dt0.05` (5% in 2 s), `level1-dt0.05` (1% in 4 s)") in report
    assert ("Pareto front, time.tolerance (no other such run is both faster and more accurate): "
            "`level0-tolerance0.01` (2% in 1.5 s), `level0-tolerance0.001` (0.4% in 2.5 s)") in report
    assert "| level0-tolerance0.01 | 81 | 1,000 | completed | 4 (1 rejected) |" in report
    assert "| level1-tolerance0.001 | | | not run |" in report
    assert (tmp_path / "out" / "figures" / "study_tg_pareto.png").stat().st_size > 1000
    points = [(1.0, 0.1), (2.0, 0.05), (1.5, 0.02)]
    groups = ["fixed δt", "fixed δt", "time.tolerance"]
    front = fronts(points, groups)
    assert front == {"fixed δt": [0, 1], "time.tolerance": [2]}
    fig = pareto_figure(study, points, ["a", "b", "c"], groups, front)
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert labels == ["fixed δt runs", "fixed δt: Pareto front", "time.tolerance runs", "time.tolerance: Pareto front"]
    plt.close(fig)


@pytest.mark.slow
def test_tiny_study_with_tolerances(run_cli, tmp_path, repo_root):
    """Taylor–Green to t = 0.2: two δt and two tolerances, run for real; both groups in the report."""
    path = tmp_path / "s.yaml"
    path.write_text(f"name: tg\nconfig: {repo_root / TG}\nobservables: [velocity, micro_rotation]\n"
                    "base: {geometry.level: 0, time.t_end: 0.2}\nladder: {time.dt: [0.1, 0.05]}\n"
                    "tolerances: [0.01, 0.001]\n")
    out = tmp_path / "out"
    proc = run_cli("study", path, "--out", out)
    assert proc.returncode == 0, proc.stderr
    runs = out / "runs" / "study-tg"
    summaries = {p.parent.name: json.loads(p.read_text()) for p in runs.glob("*/summary.json")}
    assert sorted(summaries) == ["dt0.05", "dt0.1", "tolerance0.001", "tolerance0.01"]
    assert all(s["status"] == "completed" and s["time"]["t_final"] == 0.2 for s in summaries.values())
    assert [s["time"].get("tolerance") for _, s in sorted(summaries.items())] == [None, None, 0.001, 0.01]
    report = (out / "study_tg.md").read_text()
    assert "Pareto front, fixed δt" in report and "Pareto front, time.tolerance" in report
    assert (out / "figures" / "study_tg_pareto.png").stat().st_size > 1000
