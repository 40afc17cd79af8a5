"""The validation report keeps measured rows whose run folders are gone (fresh checkout)."""

from __future__ import annotations

from validate import CFD3, Case, cheapest, previous_rows, table

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
    assert list(previous) == ["cfd3-L1-c2-dt0.001"] and len(previous["cfd3-L1-c2-dt0.001"]) == 3
    cases = [Case("cfd3-L1-c2-dt0.001", "c.yaml", {}, CFD3), Case("cfd3-other", "c.yaml", {}, CFD3)]
    rows = table(cases, tmp_path / "runs", previous)
    assert rows[2:5] == previous["cfd3-L1-c2-dt0.001"] and "not run" in rows[5]
    assert cheapest(cases, tmp_path / "runs", previous) == ["- cfd3: `cfd3-L1-c2-dt0.001` (1186 s)"]


def test_a_failed_carried_over_row_is_not_the_cheapest(tmp_path):
    previous = previous_rows(_report(tmp_path, ok="no"))
    cases = [Case("cfd3-L1-c2-dt0.001", "c.yaml", {}, CFD3)]
    assert cheapest(cases, tmp_path / "runs", previous) == ["- cfd3: no case meets every tolerance yet"]
