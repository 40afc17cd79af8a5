"""The command line: one-line errors with exit code 2, no traceback, output untouched; run/mesh/info."""

from __future__ import annotations

import logging
import sys
import types
from pathlib import Path

import pytest

from cosserat_fsi.app import cli
from cosserat_fsi.errors import DivergenceError

REPO = Path(__file__).resolve().parents[1]
CONFIG = REPO / "configs" / "turek_hron_cfd1.yaml"


@pytest.fixture
def out_dir(tmp_path):
    """An existing output directory holding a file that a failed run must not touch."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    return out


BAD_RUNS = {
    "unknown_key": (["--set", "fluid.muu=1"], "error: fluid.muu: unknown key (did you mean 'mu'?)"),
    "bad_value": (["--set", "time={scheme: characteristics1, dt: -0.1, t_end: 1}"],
                  "error: time.dt: must be > 0 (got -0.1)"),
    "dt_on_steady": (["--set", "time.dt=0.01"], "error: time.dt: not used by scheme steady (only for characteristics1, "
                     "characteristics2, ale_bdf2, generalized_alpha)"),
    "missing_scheme": (["--set", "time.scheme=null"], "error: time.scheme: missing key (one of characteristics1, "
                       "characteristics2, ale_bdf2, generalized_alpha, steady)"),
    "removed_key": (["--set", "time.convection=ale"], "error: time.convection: unknown key (removed: "),
    "steady_on_time_stepping": (["--set", "time={scheme: ale_bdf2, dt: 0.01, t_end: 1}", "--set", "time.scheme=steady"],
                                "error: time.dt: not used by scheme steady"),
    "corrector_on_first_order": (["--set", "time={scheme: characteristics1, dt: 0.01, t_end: 1, corrector_passes: 1}"],
                                 "error: time.corrector_passes: not used by scheme characteristics1"),
    "bad_set_syntax": (["--set", "time.dt"], "error: --set time.dt: expected dotted.key=value"),
    "unknown_option": (["--bogus"], "error: cosserat-fsi: unrecognized arguments: --bogus"),
    "mismatch": (["--set", "benchmark=schaefer_turek_2d1"], "error: benchmark: schaefer_turek_2d1 needs"),
}


@pytest.mark.parametrize("extra, expected", BAD_RUNS.values(), ids=BAD_RUNS)
def test_bad_run_input_exits_2_with_one_line(run_cli, out_dir, extra, expected):
    result = run_cli("run", CONFIG, "--out", out_dir, *extra)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert len(result.stderr.splitlines()) == 1, result.stderr
    assert result.stderr.startswith(expected), result.stderr
    assert result.stdout == ""
    assert sorted(p.name for p in out_dir.iterdir()) == ["keep.txt"]
    assert (out_dir / "keep.txt").read_text() == "precious"


@pytest.mark.parametrize("args, expected", [
    (["run", "missing.yaml"], "error: missing.yaml: file not found"),
    (["run"], "error: cosserat-fsi run: the following arguments are required: config"),
    (["frobnicate"], "error: cosserat-fsi: argument command: invalid choice"),
    ([], "error: cosserat-fsi: the following arguments are required: command"),
    (["mesh", "config.yaml"], "error: config.yaml: line 2: could not parse YAML"),
])
def test_usage_and_file_errors_exit_2(run_cli, tmp_path, args, expected):
    (tmp_path / "config.yaml").write_text("fluid: [\n")
    result = run_cli(*args, cwd=tmp_path)
    assert (result.returncode, len(result.stderr.splitlines())) == (2, 1), result.stderr
    assert "Traceback" not in result.stderr
    assert result.stderr.startswith(expected), result.stderr
    assert not (tmp_path / "runs").exists()


def test_unwritable_out_exits_2_naming_out(run_cli, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    result = run_cli("run", CONFIG, "--out", blocker / "sub")
    assert (result.returncode, len(result.stderr.splitlines())) == (2, 1), result.stderr
    assert result.stderr.startswith("error: --out: cannot write to")
    assert blocker.read_text() == "not a directory"


def test_info_prints_versions(run_cli):
    pytest.importorskip("cosserat_fsi.compat")
    import dolfinx

    result = run_cli("info")
    assert result.returncode == 0, result.stderr
    lines = dict(line.split(None, 1) for line in result.stdout.splitlines())
    assert lines["dolfinx"] == dolfinx.__version__
    assert lines["MUMPS"] in ("yes", "no") and lines["MPI"] != "-"


@pytest.fixture
def fake_runner(monkeypatch):
    """Replace ``cosserat_fsi.app.runner`` by a stub; ``calls`` records its arguments."""
    pytest.importorskip("mpi4py")
    module = types.ModuleType("cosserat_fsi.app.runner")
    module.calls = []
    module.error = None

    def run_scene(scene, out_dir, comm, progress, restart=False, commit=None):
        module.calls.append((scene, out_dir, progress))
        if commit is not None:
            commit()
        logging.getLogger("cosserat_fsi.app.runner").info("stub step")
        if module.error:
            raise module.error
        return {"ok": True}

    module.run_scene = run_scene
    monkeypatch.setitem(sys.modules, "cosserat_fsi.app.runner", module)
    yield module
    for handler in list(cli.log.handlers):
        cli.log.removeHandler(handler)
        handler.close()


def test_run_calls_runner_and_logs(tmp_path, fake_runner, monkeypatch):
    monkeypatch.chdir(tmp_path)
    stepping = "time={scheme: characteristics1, dt: 0.5, t_end: 1}"
    assert cli.main(["run", str(CONFIG), "--set", stepping, "--no-progress"]) == 0
    (scene, out, progress), = fake_runner.calls
    assert out == Path("runs") / "turek_hron_cfd1" and progress is False
    assert scene.time.t_end == 1.0
    log = (tmp_path / out / "run.log").read_text()
    assert "stub step" in log and "done" in log


def test_divergence_exits_3_and_keeps_output(out_dir, fake_runner, capsys):
    fake_runner.error = DivergenceError("NaN in velocity at t = 0.5")
    assert cli.main(["run", str(CONFIG), "--out", str(out_dir)]) == 3
    assert capsys.readouterr().err.splitlines()[-1] == "diverged: NaN in velocity at t = 0.5"
    assert fake_runner.calls[0][2] is True
    assert (out_dir / "keep.txt").read_text() == "precious" and (out_dir / "run.log").exists()


def test_mesh_prints_path_and_counts(tmp_path, monkeypatch, capsys):
    geometry = pytest.importorskip("cosserat_fsi.geometry")
    pytest.importorskip("gmsh")
    monkeypatch.setattr(geometry, "default_cache_dir", lambda: tmp_path)
    config = tmp_path / "cavity.yaml"
    config.write_text("geometry: {name: square, level: 0}\nfluid: {rho: 1, mu: 0.01}\n"
                      "time: {scheme: characteristics1, dt: 0.1, t_end: 1}\n")
    assert cli.main(["mesh", str(config), "--set", "geometry.length=2"]) == 0
    path, counts = capsys.readouterr().out.strip().rsplit(": ", 1)
    assert Path(path).parent == tmp_path and Path(path).exists()
    vertices, cells = int(counts.split()[0]), int(counts.split()[2])
    assert vertices > 4 and cells > 2
