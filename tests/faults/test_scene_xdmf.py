"""An .xdmf scene (``geometry: {name: file, path: block.xdmf}``, converted by ``cosserat-fsi mesh --format xdmf``)
whose files do not hold what a run needs: its names table missing, damaged or not this mesh's; the .xdmf without
its tags, with other tag names, not XML; the .h5 missing or truncated; the options that do not apply to it; the
conversion under mpirun; a restart after the files changed. One line ``error: ...``, exit 2, no traceback, the
--out folder as it was (in-process: the CLI's ``main``); under 2 ranks the same line once. What works:
tests/test_xdmf_mesh.py."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from faultlib import MPI_TIMEOUT, check, cli, in_process_main

DATA = Path(__file__).resolve().parents[1] / "data" / "user_scene"
SCENE = """geometry: {name: file, path: block.xdmf}
fluid: {rho: 1.0, mu: 1.0}
solid: {rho: 1.0, mu_s: 100.0}
boundaries: {inlet: {type: velocity, value: [1, 0, 0]}, outlet: {type: do_nothing}, walls: {type: no_slip}}
time: {scheme: characteristics1, dt: 0.01, t_end: 0.01}
output: {progress: false, fields: false, checkpoint_every: 1}
"""


@pytest.fixture(scope="module")
def converted(tmp_path_factory) -> Path:
    """block_box.geo (a solid cube in a channel) converted once: block.xdmf, block.h5, block.names.json."""
    folder = tmp_path_factory.mktemp("xdmf")
    (folder / "block.geo").write_text((DATA / "block_box.geo").read_text())
    (folder / "geo.yaml").write_text(SCENE.replace("block.xdmf", "block.geo"))
    result = cli("mesh", folder / "geo.yaml", "--format", "xdmf", COSSERAT_FSI_MESH_CACHE=folder / "cache")
    assert result.returncode == 0, result
    (folder / "block.geo").unlink()
    return folder


@pytest.fixture
def case(converted, tmp_path) -> Path:
    """A private copy of the converted files and the scene (scene.yaml)."""
    for name in ("block.xdmf", "block.h5", "block.names.json"):
        shutil.copy(converted / name, tmp_path / name)
    (tmp_path / "scene.yaml").write_text(SCENE)
    return tmp_path


@pytest.fixture
def main(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    yield from in_process_main(capsys, tmp_path)


def _names(folder: Path, change) -> None:
    path = folder / "block.names.json"
    names = json.loads(path.read_text())
    change(names)
    path.write_text(json.dumps(names))


def _xdmf(folder: Path, old: str, new: str) -> None:
    path = folder / "block.xdmf"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def _truncate(folder: Path) -> None:
    path = folder / "block.h5"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _cells(names: dict) -> None:
    names["cells"]["fluid"] -= 1  # as many cells in all, one fewer fluid: only the tags tell
    names["cells"]["solid"] += 1


CASES = {  # damage -> (the message's start after "error: ", a part of it)
    "no_names_table": (lambda f: (f / "block.names.json").unlink(),
                       "geometry.path: block.xdmf has no names table block.names.json beside it", "--format xdmf"),
    "names_table_not_json": (lambda f: (f / "block.names.json").write_text("{"), "geometry.path: block.names.json "
                             "cannot be read", None),
    "names_table_other_form": (lambda f: (f / "block.names.json").write_text("[1, 2]"),
                               "geometry.path: block.names.json is not a names table", None),
    "names_table_cell_count": (lambda f: _names(f, lambda n: n["cells"].update(fluid=n["cells"]["fluid"] + 7)),
                               "geometry.path: block.names.json does not match block.xdmf (", "cells in the table"),
    "names_table_cell_tags": (lambda f: _names(f, _cells), "geometry.path: block.names.json does not match "
                              "block.xdmf (cells tagged fluid", None),
    "names_table_facet_ids": (lambda f: _names(f, lambda n: n["facets"].update(outlet=40)),
                              "geometry.path: block.xdmf's facet tags hold ids [", "that block.names.json does not"),
    "names_table_dimension": (lambda f: _names(f, lambda n: n.update(dim=2)),
                              "geometry.path: block.xdmf holds Tetrahedron cells but block.names.json says 2D", None),
    "no_cell_tags": (lambda f: _xdmf(f, '<Grid Name="cells"', '<Grid Name="zones"'),
                     "geometry.path: block.xdmf has no cell tags (a Grid named 'cells'", "'zones'"),
    "facet_tags_named_otherwise": (lambda f: _xdmf(f, '<Grid Name="facets"', '<Grid Name="boundaries"'),
                                   "geometry.path: block.xdmf has no facet tags (a Grid named 'facets'",
                                   "'boundaries'"),
    "no_tags_at_all": (lambda f: _xdmf(f, '<Grid Name="cells"', '<Grid Name="cells2"') or _xdmf(
        f, '<Grid Name="facets"', '<Grid Name="facets2"'), "geometry.path: block.xdmf has no cell tags", None),
    "not_xml": (lambda f: (f / "block.xdmf").write_text("mesh\n"), "geometry.path: not an XDMF file", None),
    "broken_xml": (lambda f: _xdmf(f, "</Xdmf>", ""), "geometry.path: block.xdmf is not an XDMF file", None),
    "missing_h5": (lambda f: (f / "block.h5").unlink(), "geometry.path: block.h5, the data of block.xdmf, is missing",
                   None),
    "truncated_h5": (_truncate, "geometry.path: block.h5 ", "truncated"),
    "h5_without_a_dataset": (lambda f: _xdmf(f, "block.h5:/MeshTags/facets/Values", "block.h5:/MeshTags/none"),
                             "geometry.path: block.h5 has no dataset /MeshTags/none", None),
}


@pytest.mark.parametrize("damage, start, part", CASES.values(), ids=CASES)
def test_xdmf_refused(main, case, damage, start, part):
    damage(case)
    code, err = main("run", case / "scene.yaml", "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + start), err
    assert part is None or part in lines[0], err


@pytest.mark.parametrize("option, start", [("geometry.level=1", "geometry.level: not for an .xdmf mesh"),
                                           ("geometry.cells.fluid=[water]", "geometry.cells: not for an .xdmf")])
def test_xdmf_options_refused(main, case, option, start):
    code, err = main("run", case / "scene.yaml", "--out", main.out, "--set", option)
    assert code == 2 and err.startswith("error: " + start) and len(err.splitlines()) == 1, err


def test_convert_an_xdmf_refused(main, case):
    code, err = main("mesh", case / "scene.yaml", "--format", "xdmf", "--out", case)
    assert code == 2 and err == "error: geometry.path: block.xdmf is an XDMF mesh already\n", err


@pytest.mark.slow
def test_two_ranks_say_it_once(mpi_launcher, case):
    """Under 2 ranks: the conversion refused (one process), a missing .h5 (rank 0's check) and tags that do not
    match the table (found by both ranks after the distributed read): each one line, once."""
    result = cli("mesh", case / "scene.yaml", "--format", "xdmf", launcher=mpi_launcher, timeout=MPI_TIMEOUT)
    check(result, 2, "error: --format xdmf: converts on one process")
    assert len(result.stderr.splitlines()) == 1, result
    _names(case, _cells)
    result = cli("run", case / "scene.yaml", "--out", case / "out", launcher=mpi_launcher, timeout=MPI_TIMEOUT)
    check(result, 2, "error: geometry.path: block.names.json does not match block.xdmf (cells tagged fluid")
    assert len(result.stderr.splitlines()) == 1 and not (case / "out").exists(), result
    (case / "block.h5").unlink()
    result = cli("run", case / "scene.yaml", "--out", case / "out", launcher=mpi_launcher, timeout=MPI_TIMEOUT)
    check(result, 2, "error: geometry.path: block.h5, the data of block.xdmf, is missing")
    assert len(result.stderr.splitlines()) == 1, result


@pytest.mark.slow
def test_restart_after_the_mesh_changed(case):
    """A run from the .xdmf, then its .h5 rewritten (same mesh, other bytes): the restart is refused, one line,
    the run's folder as it was; with the files as they were, it restarts."""
    out = case / "out"
    assert cli("run", case / "scene.yaml", "--out", out).returncode == 0
    saved = (case / "block.h5").read_bytes()
    (case / "block.h5").write_bytes(saved + b"\0" * 64)  # HDF5 reads it as before: only the hash differs
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    result = cli("run", case / "scene.yaml", "--restart", out, "--set", "time.t_end=0.02")
    check(result, 2, "error: --restart: the checkpoint is from another scene")
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    (case / "block.h5").write_bytes(saved)
    assert cli("run", case / "scene.yaml", "--restart", out, "--set", "time.t_end=0.02").returncode == 0
