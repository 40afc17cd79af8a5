"""`cosserat-fsi plot` and what ParaView reads: the moving mesh in fields.h5 follows the flag tip exactly as
timeseries.csv says, the PNGs are drawn (not blank), bad RUN_DIR is a one-line exit 2."""

from __future__ import annotations


import numpy as np
import pytest

from cosserat_fsi.io import read_timeseries


@pytest.fixture(scope="module")
def fsi_run(tmp_path_factory, repo_root, run_cli):
    out = tmp_path_factory.mktemp("plot") / "run"
    proc = run_cli("run", repo_root / "configs/turek_hron_fsi3.yaml", "--out", out, "--no-progress",
                   "--set", "geometry.level=0", "--set", "time.dt=0.01", "--set", "time.t_end=0.06",
                   "--set", "output.every=1", "--set", "solid.mu_s=2.0e4", "--set", "inflow.ramp_time=0.01",
                   "--set", "time.tolerance=null",
                   # a very soft flag that moves visibly within a few steps: the incompressible law (a
                   # compressible one this soft is squeezed flat by the sudden inflow's pressure)
                   "--set", "solid.law=mooney_rivlin_incompressible", "--set", "solid.lambda_s=null")
    assert proc.returncode == 0, proc.stderr
    return out


def test_moving_mesh_in_fields_follows_point_A(fsi_run):
    """The vertex at A in fields.h5 moves by (ux_A, uy_A) of timeseries.csv, step by step (to 1e-12)."""
    from cosserat_fsi.app.plots import Fields

    fields = Fields(fsi_run)
    ts = read_timeseries(fsi_run / "timeseries.csv")
    x0 = fields.geometry(0)
    a = int(np.argmin(np.linalg.norm(x0 - [0.6, 0.2], axis=1)))
    assert np.linalg.norm(x0[a] - [0.6, 0.2]) < 1e-12
    np.testing.assert_allclose(fields.times, np.round(np.arange(7) * 0.01, 12), atol=1e-12)
    moved = np.array([fields.geometry(i)[a] - x0[a] for i in range(1, len(fields.times))])
    np.testing.assert_allclose(moved, np.column_stack([ts["ux_A"], ts["uy_A"]]), atol=1e-12, rtol=0)
    assert np.abs(ts["uy_A"]).max() > 1e-7  # it did move


@pytest.mark.slow
def test_plot_writes_time_series_and_snapshots(run_cli, fsi_run, tmp_path):
    import matplotlib.image as mpimg

    proc = run_cli("plot", fsi_run, "--out", tmp_path, "--time", "0.02", "--time", "0.06", timeout=300)
    assert proc.returncode == 0, proc.stderr
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    assert names == ["energies.png", "flow.png", "forces.png", "snapshot_t0.0200.png", "snapshot_t0.0600.png",
                     "tip.png"], names
    for name in names:
        image = mpimg.imread(tmp_path / name)
        assert image.ndim == 3 and image[..., :3].std() > 0.05, name  # drawn, not blank


def test_plot_of_a_folder_that_is_not_a_run_exits_2(run_cli, tmp_path):
    proc = run_cli("plot", tmp_path / "nope", timeout=120)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "RUN_DIR" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
