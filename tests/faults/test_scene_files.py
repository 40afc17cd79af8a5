"""A scene's own files and the run folder's names: a .geo that would reach outside its model (programs,
files written or read out of its folder) is refused naming the file and line unless ``geometry.trusted``;
comments and strings are not commands; no output is written through a link; no reader blocks on a FIFO;
mixed cell types and paths too long are one line (docs/reliability.md, "Scene files")."""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import pytest

from faultlib import check, cli, snapshot

SQUARE = """Point(1) = {0,0,0,0.5}; Point(2) = {1,0,0,0.5}; Point(3) = {1,1,0,0.5}; Point(4) = {0,1,0,0.5};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("walls") = {1,2,3,4};
"""
BODY = ("fluid: {rho: 1.0, mu: 0.01}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
        "output: {progress: false}\n")
NO_CYLINDER = "observables.forces[0]: m.geo has no boundary 'cylinder'"  # checked only after meshing


def _scene(folder: Path, geo: str, trusted: bool = False, name: str = "m.geo", after_mesh: bool = False) -> Path:
    (folder / name).write_text(geo)
    scene = folder / "scene.yaml"
    extra = ", trusted: true" if trusted else ""
    bad = "observables: {forces: [cylinder]}\n" if after_mesh else ""
    scene.write_text(f"geometry: {{name: file, path: {name}{extra}}}\n{BODY}{bad}")
    return scene


def _run(scene: Path, out: Path, tmp_path: Path, *extra, **environ):
    return cli("run", scene, "--out", out, "--no-progress", *extra, cwd=tmp_path,
               COSSERAT_FSI_MESH_CACHE=tmp_path / "cache", **environ)


# ------------------------------------------------------------------ 1. the .geo contract
def _refused_cases(mark: str) -> dict:
    """name -> (the .geo line, the command named in the message). ``mark`` is a file that must not appear."""
    return {
        "System": (f'System "touch {mark}";', "System"),
        "SystemCall": (f'SystemCall "touch {mark}";', "SystemCall"),
        "NonBlockingSystemCall": (f'NonBlockingSystemCall "touch {mark}";', "NonBlockingSystemCall"),
        "OnelabRun": (f'OnelabRun("x", "touch {mark}");', "OnelabRun"),
        "Printf_to_file": (f'Printf("x") > "{mark}";', "Printf to a file"),
        "Printf_append": (f'Printf("x %g", 1) >> "{mark}";', "Printf to a file"),
        "Save": (f'Save "{mark}.msh";', "Save"),
        "Print": (f'Print "{mark}.png";', "Print"),
        "CreateDir": (f'CreateDir "{mark}";', "CreateDir"),
        "DeleteFile": (f'DeleteFile "{mark}";', "DeleteFile"),
        "RenameFile": (f'RenameFile "m.geo", "{mark}";', "RenameFile"),
        "Exit": ("Exit;", "Exit"),
        "Abort": ("Abort;", "Abort"),
        "Sleep": ("Sleep 1000;", "Sleep"),
        "Plugin": ('Plugin(Crack).Run;', "Plugin"),
        "Solver_option": (f'Solver.Executable0 = "{mark}";', "Solver.*"),
        "System_after_a_backslash": (f's = "a \\"; System "touch {mark}"; t = "\\";', "System"),
        "Include_absolute": ('Include "/etc/hostname";', "Include of a file outside"),
        "Include_parent": ('Include "../other.geo";', "Include of a file outside"),
        "Include_computed": ('Include StrCat("a", ".geo");', "Include of a computed file name"),
        "Merge_outside": ('Merge "/etc/hostname";', "Merge of a file outside"),
        "ShapeFromFile_outside": ('v() = ShapeFromFile("/etc/x.step");', "ShapeFromFile of a file outside"),
    }


REFUSED = list(_refused_cases("MARK"))


@pytest.mark.parametrize("case", REFUSED)
def test_gmsh_command_is_refused(tmp_path, case):
    mark = tmp_path / "ran"
    line, command = _refused_cases(str(mark))[case]
    scene = _scene(tmp_path, SQUARE + "// a comment\n" + line + "\n")
    before = snapshot(tmp_path)
    result = _run(scene, tmp_path / "out", tmp_path)
    check(result, 2, f"error: {tmp_path / 'm.geo'}:6: gmsh command {command}",
          "is not allowed in a scene (geometry.trusted: true allows it)")
    assert snapshot(tmp_path) == before and not mark.exists() and not (tmp_path / "out").exists()
    assert not list(tmp_path.glob("ran*"))


def test_command_in_an_included_file_names_that_file(tmp_path):
    mark = tmp_path / "ran"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "part.geo").write_text(f'\n\nSystem "touch {mark}";\n')
    scene = _scene(tmp_path, SQUARE + 'Include "sub/part.geo";\n')
    check(_run(scene, tmp_path / "out", tmp_path), 2, f"error: {tmp_path / 'sub' / 'part.geo'}:3: gmsh command "
          "System is not allowed")
    assert not mark.exists()


NOT_COMMANDS = {  # words of the refused commands where they are no command: meshed, then the scene's own error
    "line_comment": '// System "touch X"; Printf("x") > "X";\n',
    "block_comment": '/* System "touch X";\n Exit; */\n',
    "string": 's = "System Exit Save"; t = StrCat("Printf", "Sleep");\n',
    "print_option": "Print.Width = 640;\n",
    "printf_to_terminal": 'Printf("size %g", 1 > 0);\n',
    "include_inside": 'Include "part.geo";\n',
}


@pytest.mark.parametrize("case", list(NOT_COMMANDS))
def test_words_that_are_not_commands(tmp_path, case):
    (tmp_path / "part.geo").write_text("a = 1;\n")
    scene = _scene(tmp_path, SQUARE + NOT_COMMANDS[case], after_mesh=True)
    check(_run(scene, tmp_path / "out", tmp_path), 2, "error: " + NO_CYLINDER)
    assert not (tmp_path / "X").exists() and not (tmp_path / "out").exists()


def test_trusted_allows_a_command(tmp_path):
    """``geometry.trusted: true``: the .geo runs as in gmsh (here a harmless Printf to a file of its folder)."""
    scene = _scene(tmp_path, SQUARE + 'Printf("made") > "made.txt";\n', trusted=True, after_mesh=True)
    check(_run(scene, tmp_path / "out", tmp_path), 2, "error: " + NO_CYLINDER)
    assert (tmp_path / "made.txt").read_text().strip() == "made"


# ------------------------------------------------------------------ 2. nothing written through a link
OUTPUT_NAMES = [".lock", "config.yaml", "timeseries.csv", "fields.h5", "summary.json", "run.log"]
OUTPUT_DIRS = ["checkpoint", "checkpoint.tmp", "meshes", "plots"]


@pytest.mark.parametrize("name", OUTPUT_NAMES + OUTPUT_DIRS)
@pytest.mark.parametrize("dangling", [False, True], ids=["to_a_file", "dangling"])
def test_link_at_an_output_name(tiny_config, tmp_path, name, dangling):
    out, outside = tmp_path / "out", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    target = outside / "victim"
    if not dangling:
        target.mkdir() if name in OUTPUT_DIRS else target.write_text("keep me\n")
    (out / name).symlink_to(target)
    before, before_out = snapshot(outside), snapshot(out)
    for mode in ([], ["--overwrite"]):
        check(cli("run", tiny_config, "--out", out, "--no-progress", *mode), 2, "error: --out:",
              f"{out / name} is a link")
    assert snapshot(outside) == before and snapshot(out) == before_out
    assert os.path.lexists(out / name) and (target.exists() != dangling)


def test_link_inside_the_checkpoint(run_copy, tmp_path):
    victim = tmp_path / "victim.json"
    victim.write_text("{}\n")
    meta = run_copy / "checkpoint" / "meta.json"
    meta.unlink()
    meta.symlink_to(victim)
    before = snapshot(run_copy)
    check(cli("run", run_copy / "config.yaml", "--restart", run_copy, "--no-progress"), 2, "error: --out:",
          "is a link")
    assert snapshot(run_copy) == before and victim.read_text() == "{}\n"


def test_plot_refuses_a_plots_link(run_copy, tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (run_copy / "plots").symlink_to(outside)
    before = snapshot(run_copy)
    check(cli("plot", run_copy), 2, "error: --out:", "is a link")
    assert snapshot(run_copy) == before and not list(outside.iterdir())


# ------------------------------------------------------------------ 4. readers never block on a FIFO
def test_fifo_geo(tmp_path):
    os.mkfifo(tmp_path / "m.geo")
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: m.geo}}\n{BODY}")
    check(_run(scene, tmp_path / "out", tmp_path), 2, "error: geometry.path:", "not a regular file")


def test_fifo_msh(tmp_path):
    os.mkfifo(tmp_path / "m.msh")
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: m.msh}}\n{BODY}")
    check(_run(scene, tmp_path / "out", tmp_path), 2, "error: geometry.path:", "not a regular file")


def test_fifo_include(tmp_path):
    os.mkfifo(tmp_path / "part.geo")
    scene = _scene(tmp_path, SQUARE + 'Include "part.geo";\n')
    check(_run(scene, tmp_path / "out", tmp_path), 2, f"error: {tmp_path / 'part.geo'}: not a regular file")


@pytest.mark.parametrize("name", ["checkpoint/meta.json", "checkpoint/rank0000.npz", "timeseries.csv"])
def test_fifo_in_a_restart(run_copy, name):
    (run_copy / name).unlink()
    os.mkfifo(run_copy / name)
    before = snapshot(run_copy)
    result = cli("run", run_copy / "config.yaml", "--restart", run_copy, "--no-progress")
    check(result, 2, "error:", "not a regular file")
    assert snapshot(run_copy) == before


# ------------------------------------------------------------------ 4. mixed cells, long paths
def test_mixed_cell_types(tmp_path):
    geo = SQUARE.replace('Physical Surface("fluid") = {1};', "") + """Point(5) = {2,0,0,0.5}; Point(6) = {2,1,0,0.5};
Line(5) = {2,5}; Line(6) = {5,6}; Line(7) = {6,3}; Curve Loop(2) = {5,6,7,-2}; Plane Surface(2) = {2};
Recombine Surface{2}; Physical Surface("fluid") = {1, 2};
"""
    scene = _scene(tmp_path, geo)
    check(_run(scene, tmp_path / "out", tmp_path), 2,
          f"error: {tmp_path / 'm.geo'}: mixed cell types (triangle and quadrilateral) are not supported")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("where", ["out", "scene"])
def test_path_too_long(tiny_config, tmp_path, where):
    long = tmp_path / ("a" * 300)
    args = (tiny_config, "--out", long) if where == "out" else (str(long) + ".yaml", "--out", tmp_path / "o")
    before = snapshot(tmp_path)
    check(cli("run", *args, "--no-progress"), 2, "error:", "file name too long")
    assert snapshot(tmp_path) == before


# ------------------------------------------------------------------ 3. a checkpoint on a signal after a remesh
REMESH = """geometry: {name: turek_hron, level: 0, flag: solid}
fluid: {rho: 1000.0, mu: 1.0}
solid: {rho: 1000.0, mu_s: 5e5, mesh_motion: {remesh: {quality: 0.99, max_count: 1}}}
inflow: {u_mean: 0.2}
time: {dt: 0.01, t_end: 0.05, scheme: characteristics2}
output: {every: 1, checkpoint_every: 100, progress: false}
"""  # remeshed at step 1 (the quality is below 0.99 at once); no checkpoint of its own before the end


@pytest.mark.slow
@pytest.mark.parametrize("failpoint, code", [("remesh@0:sigterm", 143), ("timeseries.write@0:sigterm:3", 143),
                                             ("timeseries.write@0:sigint:3", 130)],
                         ids=["sigterm_right_after_gmsh", "sigterm_steps_later", "sigint_steps_later"])
def test_signal_after_a_remesh_writes_a_checkpoint(tmp_path, failpoint, code):
    """gmsh (in the run's process for a remesh) takes the signal handlers; the time loop's are put back."""
    scene = tmp_path / "remesh.yaml"
    scene.write_text(REMESH)
    out = tmp_path / "out"
    result = _run(scene, out, tmp_path, COSSERAT_FSI_FAILPOINT=failpoint)
    check(result, code, "interrupted: signal", "checkpoint written")
    meta = json.loads((out / "checkpoint" / "meta.json").read_text())
    assert meta["mesh"] == "meshes/remesh_001.msh" and (out / "checkpoint" / "rank0000.npz").is_file()
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


# ------------------------------------------------------------------ 4. Ctrl-C at start-up, a full disk
HOOK = """import sys


class _CtrlC:  # Ctrl-C while {name} is imported
    def find_spec(self, name, path=None, target=None):
        if name == "{name}":
            raise KeyboardInterrupt


sys.meta_path.insert(0, _CtrlC())
"""


@pytest.mark.parametrize("module", ["pydantic", "dolfinx", "ffcx"])
def test_ctrl_c_while_importing(tiny_config, tmp_path, module):
    """Ctrl-C while the libraries load (an import hook raises KeyboardInterrupt as SIGINT would)."""
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(HOOK.format(name=module))
    out = tmp_path / "out"
    result = cli("run", tiny_config, "--out", out, "--no-progress",
                 PYTHONPATH=os.pathsep.join([str(hook), str(Path(__file__).resolve().parents[2])]))
    check(result, 130, "interrupted: Ctrl-C (SIGINT)")
    assert not out.exists()


def test_free_space_is_checked_before_hdf5(tmp_path):
    from cosserat_fsi.files import check_free_space

    check_free_space(tmp_path / "fields.h5", 1000)
    with pytest.raises(OSError) as caught:
        check_free_space(tmp_path / "fields.h5", 1 << 62)
    assert caught.value.errno == 28 and caught.value.filename == str(tmp_path / "fields.h5")


@pytest.mark.slow
def test_a_disk_that_really_fills(tiny_config, tmp_path):
    """A 2 MB tmpfs (root only; skipped elsewhere): fields.h5 fills it: exit 2 naming it, no crash, the
    steps written before listed in fields.xdmf, summary.json ``failed``."""
    import subprocess

    disk = tmp_path / "disk"
    disk.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2M", "tmpfs", str(disk)],
                                           capture_output=True).returncode != 0:
        pytest.skip("cannot mount a small tmpfs here")
    try:
        out = disk / "run"
        result = cli("run", tiny_config, "--out", out, "--no-progress", "--set", "time.t_end=4.0",
                     "--set", "output.checkpoint_every=1000")
        check(result, 2, f"error: {out / 'fields.h5'}: cannot write (No space left on device)")
        assert json.loads((out / "summary.json").read_text())["status"] == "failed"
        steps = (out / "fields.xdmf").read_text().count("<Time ")
        with h5py.File(out / "fields.h5", "r") as f:  # every listed step is readable
            assert steps >= 2 and len(f["point/velocity"]) >= steps
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


@pytest.mark.parametrize("hit", [1, 3])
def test_overwrite_failing_half_way_keeps_the_old_run(tiny_config, run_copy, hit):
    """The earlier run's files are moved aside one by one at the commit; a move that fails puts back those
    already moved: the old run is whole."""
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--out", run_copy, "--overwrite", "--no-progress",
                 COSSERAT_FSI_FAILPOINT=f"overwrite@0:enospc:{hit}")
    check(result, 2, "error:", "No space left on device")
    assert snapshot(run_copy) == before
