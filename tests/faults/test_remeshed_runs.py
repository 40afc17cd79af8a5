"""A run that remeshed (its fields hold several meshes, its checkpoint names the mesh of OUT/meshes it is
on): ``plot`` reads it, and a restart whose checkpoint mesh is missing, cut short or another mesh is a
one-line exit 2 naming the file, the folder kept byte for byte."""

from __future__ import annotations

import json
import shutil

import pytest

from faultlib import check, cli, snapshot

SCENE = """\
geometry: {name: turek_hron, level: 0, flag: solid}
fluid: {rho: 1000.0, mu: 1.0}
solid: {rho: 1000.0, mu_s: 5.0e4, mesh_motion: {remesh: {quality: 0.95, max_count: 2}}}
inflow: {u_mean: 1.0, ramp_time: 0.05}
time: {dt: 0.01, t_end: 0.02, scheme: characteristics2}
output: {every: 1, checkpoint_every: 2, progress: false}
"""
"""tests/test_remesh.py's RUN, 2 steps: a remesh at each, the checkpoint of step 2 on meshes/remesh_002.msh."""


@pytest.fixture(scope="module")
def remeshed(tmp_path_factory):
    """(scene file, run folder) of the completed run above."""
    root = tmp_path_factory.mktemp("remeshed")
    config = root / "remesh.yaml"
    config.write_text(SCENE)
    result = cli("run", config, "--out", root / "run")
    assert result.returncode == 0, result
    assert sorted(p.name for p in (root / "run" / "meshes").iterdir()) == ["remesh_001.msh", "remesh_002.msh"]
    return config, root / "run"


@pytest.mark.slow
def test_plot_of_a_remeshed_run_draws_every_mesh(remeshed, tmp_path):
    _, run = remeshed
    result = cli("plot", run, "--out", tmp_path, "--time", 0, "--time", 0.01, "--time", 0.02)
    assert result.returncode == 0, result
    names = {p.name for p in tmp_path.iterdir()}
    assert {"forces.png", "snapshot_t0.0000.png", "snapshot_t0.0100.png", "snapshot_t0.0200.png"} <= names
    assert all(p.stat().st_size > 1000 for p in tmp_path.iterdir())


def _cut_short(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _forget_digests(folder):
    path = folder / "checkpoint" / "meta.json"
    meta = json.loads(path.read_text())
    for record in meta["remeshes"]:
        record.pop("sha256")
    path.write_text(json.dumps(meta))


MESH_FAULTS = {  # what is done to the copy's meshes -> what the message must contain
    "missing": (lambda f: (f / "meshes/remesh_002.msh").unlink(), "the checkpoint's mesh is missing"),
    "cut_short": (lambda f: _cut_short(f / "meshes/remesh_002.msh"), "is not the mesh the checkpoint was written on"),
    "replaced": (lambda f: shutil.copy(f / "meshes/remesh_001.msh", f / "meshes/remesh_002.msh"),
                 "is not the mesh the checkpoint was written on"),
    "replaced_no_digest": (lambda f: (_forget_digests(f), shutil.copy(f / "meshes/remesh_001.msh",
                                                                      f / "meshes/remesh_002.msh")), "cells"),
    "cut_short_no_digest": (lambda f: (_forget_digests(f), _cut_short(f / "meshes/remesh_002.msh")),
                            "cannot be read as a mesh"),
}


@pytest.mark.slow
@pytest.mark.parametrize("fault", sorted(MESH_FAULTS))
def test_restart_on_a_damaged_checkpoint_mesh_is_refused(remeshed, tmp_path, fault):
    config, run = remeshed
    assert "sha256" in json.loads((run / "checkpoint" / "meta.json").read_text())["remeshes"][-1]
    folder = tmp_path / "run"
    shutil.copytree(run, folder)
    damage, message = MESH_FAULTS[fault]
    damage(folder)
    before = snapshot(folder)
    line = check(cli("run", config, "--restart", folder), 2, f"error: {folder / 'meshes' / 'remesh_002.msh'}: ",
                 message)
    assert snapshot(folder) == before, line
