"""The validation report keeps measured rows whose run folders are gone (fresh checkout) and judges each
quantity as the run's verdict does."""

from __future__ import annotations

from validate import CFD3, Case, cheapest, judged_error, previous_rows, table

ROW = ("| cfd3-L1-c2-dt0.001 | L1 (2,723) | BDF2 | 0.001 | {key} | 1 | 1 | +0.10% | 1.0% | {ok} | 1186 | 0.148 |")


def _report(tmp_path, ok="yes"):
    lines = ["| case | mesh (vertices) | scheme | δt | observable | value | reference | error | tolerance | ok | "
             "wall (s) | s/step |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [ROW.format(key=k, ok=ok if k == "lift.amplitude" else "yes") for k in CFD3]
    lines += ["| cfd3-other | – | – | – | not run | | | | | | | |"]
    path = tmp_path / "validation.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_rows_of_missing_runs_are_carried_over(tmp_path):
    previous = previous_rows(_report(tmp_path))
    assert list(previous) == ["cfd3-L1-c2-dt0.001"] and len(previous["cfd3-L1-c2-dt0.001"]) == len(CFD3)
    cases = [Case("cfd3-L1-c2-dt0.001", "c.yaml", {}, CFD3), Case("cfd3-other", "c.yaml", {}, CFD3)]
    rows = table(cases, tmp_path / "runs", previous)
    assert rows[2:2 + len(CFD3)] == previous["cfd3-L1-c2-dt0.001"] and "not run" in rows[2 + len(CFD3)]
    assert cheapest(cases, tmp_path / "runs", previous) == ["- cfd3: `cfd3-L1-c2-dt0.001` (1186 s)"]


def test_a_failed_carried_over_row_is_not_the_cheapest(tmp_path):
    previous = previous_rows(_report(tmp_path, ok="no"))
    cases = [Case("cfd3-L1-c2-dt0.001", "c.yaml", {}, CFD3)]
    assert cheapest(cases, tmp_path / "runs", previous) == ["- cfd3: no case meets every tolerance yet"]


def test_an_example_case_is_measured_from_its_run_folder(tmp_path):
    """An example's rows come from its ``measure`` of the run folder: checked keys against their tolerance,
    reported keys (tolerance None) without a verdict; a folder with only summary.json keeps the earlier rows."""
    import json

    def measure(run):
        (run / "timeseries.csv").read_text()  # what a fresh checkout lacks
        return {"u": {"value": 1.0005, "reference": 1.0, "error": 5e-4},
                "x_r": {"value": 2.2, "reference": None, "error": None}}

    run = tmp_path / "runs" / "ex-L0"
    run.mkdir(parents=True)
    (run / "summary.json").write_text(json.dumps({
        "status": "completed", "mesh": {"level": 0, "vertices": 10}, "time": {"scheme": "steady", "dt": 1.0},
        "wall_time": {"total": 4.0, "per_step": 4.0}}))
    case = Case("ex-L0", "c.yaml", {}, {"u": 1e-3, "x_r": None}, measure=measure)
    assert "not measured" in table([case], tmp_path / "runs")[2]  # no timeseries.csv, no earlier rows
    (run / "timeseries.csv").write_text("t\n1\n")
    rows = table([case], tmp_path / "runs")
    assert rows[2] == "| ex-L0 | L0 (10) | steady | – | u | 1.0005 | 1 | +0.05% | 0.1% | yes | 4 | 4.000 |"
    assert rows[3] == "| ex-L0 | L0 (10) | steady | – | x_r | 2.2 | – | – | – | – | 4 | 4.000 |"
    assert cheapest([case], tmp_path / "runs") == ["- ex: `ex-L0` (4 s)"]
    case.tolerances["u"] = 1e-4
    assert "| no |" in table([case], tmp_path / "runs")[2]


def test_a_mean_about_zero_is_judged_relative_to_the_amplitude_in_any_summary():
    """FSI3's lift 2.50 ± 153.91: a mean of 1.70 is 0.52 % of the amplitude off (the run's verdict), not 32 % of
    itself — also in a summary written before its entries carried the error; a drag mean stays relative to
    itself, a non-periodic key to its reference."""
    lift = {"mean": {"value": 1.70, "reference": 2.5}, "amplitude": {"value": 153.2, "reference": 153.91},
            "frequency": {"value": 5.457, "reference": 5.46}}
    drag = {"mean": {"value": 463.7, "reference": 460.5}, "amplitude": {"value": 28.7, "reference": 27.74}}
    summary = {"benchmark": {"lift": lift, "drag": drag}}
    err, of = judged_error(summary, "lift.mean", lift["mean"])
    assert err == (1.70 - 2.5) / 153.91 and of == " of amplitude"
    assert judged_error(summary, "lift.amplitude", lift["amplitude"]) == ((153.2 - 153.91) / 153.91, "")
    assert judged_error(summary, "drag.mean", drag["mean"]) == ((463.7 - 460.5) / 460.5, "")
    assert judged_error({}, "c_D", {"value": 5.58, "reference": 5.57954}) == ((5.58 - 5.57954) / 5.57954, "")
