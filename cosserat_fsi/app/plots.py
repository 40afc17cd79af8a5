"""`cosserat-fsi plot RUN_DIR`: PNGs of a finished (or stopped) run.

Time series from timeseries.csv (tip displacement, forces, energies, other observables; a file scene's
named probes, solid points and flow rates: :func:`own_groups`; the step size δt(t) of a run with
``time.tolerance``, steps.png), with the reference band of the scene's benchmark when there is one, and
pyvista off-screen snapshots of |u|, p and ω on the deformed mesh (the solid outlined) at chosen times, from
fields.h5 (2D runs; a 3D run's fields are for ParaView). Works on any rank count's output (the files are
global) and needs no display.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..config import GEOMETRY_OF_BENCHMARK
from ..errors import InputError
from ..files import read_json


def _save(write, path: Path) -> None:
    """Write a picture through a temporary name, renamed when complete."""
    import os

    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.png")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise InputError(f"--out: cannot write {path} ({exc.strerror or exc})") from None
    finally:
        if tmp.exists():
            tmp.unlink()

GROUPS = {  # file stem -> (columns, y label)
    "tip": (("ux_A", "uy_A", "uz_A"), "displacement of A (m)"),
    "forces": (("drag", "lift", "side"), "force (N per m; N in 3D)"),
    "energies": (("energy_kinetic", "energy_elastic", "energy_total"), "energy (J per m)"),
    "flow": (("dp", "flow_rate", "omega_max"), "value"),
}


def own_groups(series: dict) -> dict:
    """A file scene's named observables (config ``observables``): probes.png (u_, v_, w_, p_, omega_ NAME;
    omega_x_, omega_y_, omega_z_ NAME in 3D), solid_points.png (ux_, uy_, uz_ NAME), flow_rates.png
    (flow_rate_NAME); its forces are in forces.png with the built-in scenes'."""
    builtin = {c for columns, _ in GROUPS.values() for c in columns}
    probes = tuple(c for c in series if c.startswith(("u_", "v_", "w_", "p_", "omega_")) and c not in builtin)
    solid = tuple(c for c in series if c.startswith(("ux_", "uy_", "uz_")) and c not in builtin)
    rates = tuple(c for c in series if c.startswith("flow_rate_"))
    out = {"probes": (probes, "probe values"), "solid_points": (solid, "displacement (m)"),
           "flow_rates": (rates, "flow rate (m³/s)")}
    return {stem: group for stem, group in out.items() if group[0]}


class Fields:
    """Read-only view of a run's fields.h5: output times, deformed mesh and vertex values of a step. A run
    that remeshed has several meshes: each step's cells are those of its own mesh (:meth:`cells`)."""

    def __init__(self, run_dir: Path):
        """Open and check the pair (InputError naming the file if it is damaged, foreign or missing); a
        run still writing is read up to the last step its .xdmf lists (flushed, see io/xdmf.py)."""
        from ..io.fields_check import open_h5, step_names, xdmf_times

        self.path = Path(run_dir) / "fields.h5"
        self.times = xdmf_times(Path(run_dir) / "fields.xdmf")
        self.h5 = open_h5(self.path)
        self.steps = step_names(self.h5, len(self.times), self.path)
        self._cells: dict[str, np.ndarray] = {}
        try:
            self.corners = self.h5["mesh/topology"].shape[1]  # 3: triangles; 4: tetrahedra (a 3D run)
        except Exception:  # noqa: BLE001 (h5py: OSError, KeyError, ValueError)
            raise InputError(f"{self.path}: the mesh is damaged (mesh/topology cannot be read)") from None
        self.triangles = self.cells(0) if self.steps else self.h5["mesh/topology"][:, :3]  # the first mesh

    def cells(self, i: int) -> np.ndarray:
        """The triangles of step ``i``'s mesh (``mesh/topology``, or after a remesh the dataset named by the
        step's ``topology`` attribute), checked against its geometry."""
        try:
            name = str(self.h5[f"mesh/geometry/{self.steps[i]}"].attrs.get("topology", "mesh/topology"))
            if name not in self._cells:
                topology = self.h5[name]
                if not name.startswith("mesh/topology") or topology.ndim != 2 or topology.shape[1] != self.corners:
                    raise ValueError
                self._cells[name] = np.asarray(topology[()])[:, :3]
            cells, n = self._cells[name], self.h5[f"mesh/geometry/{self.steps[i]}"].shape[0]
            ok = cells.dtype.kind in "iu" and len(cells) > 0 and cells.min() >= 0 and cells.max() < n
        except Exception:  # noqa: BLE001 (h5py: OSError, KeyError, ValueError)
            ok = False
        if not ok:
            raise InputError(f"{self.path}: the mesh is damaged (the cells of step {self.steps[i]} name vertices "
                             "that do not exist)")
        return cells

    def nearest(self, t: float) -> int:
        return int(np.argmin(np.abs(self.times - t)))

    def _read(self, key: str, rows: int | None = None) -> np.ndarray | None:
        """Dataset ``key`` (None if absent); InputError naming the file if it cannot be read or has not
        ``rows`` finite rows."""
        try:
            if key not in self.h5:
                return None
            data = np.asarray(self.h5[key][()], dtype=float)
        except Exception:  # noqa: BLE001 (h5py: OSError, KeyError, TypeError on a damaged file)
            raise InputError(f"{self.path}: {key} cannot be read (damaged, or being written?)") from None
        if data.ndim == 0 or (rows is not None and data.shape[0] != rows):
            raise InputError(f"{self.path}: {key} has the wrong shape {data.shape} (damaged file)")
        return data

    def geometry(self, i: int) -> np.ndarray:
        data = self._read(f"mesh/geometry/{self.steps[i]}")
        if data.ndim != 2 or not np.isfinite(data).all():
            raise InputError(f"{self.path}: mesh/geometry/{self.steps[i]} is damaged")
        return data[:, :2]

    def point(self, name: str, i: int) -> np.ndarray | None:
        return self._read(f"point/{name}/{self.steps[i]}", len(self.geometry(i)))

    def solid_triangles(self, i: int) -> np.ndarray:
        data = self._read(f"cell/subdomain/{self.steps[i]}", len(self.cells(i)))
        if data is None:
            return np.zeros(0, dtype=int)
        return np.where(data.ravel() == 2)[0]


def _reference(run_dir: Path) -> dict:
    try:  # no reference band when summary.json is missing, in progress or damaged
        summary = read_json(run_dir / "summary.json", "summary file")
        name = summary.get("benchmark", {}).get("name")
        if summary["benchmark"].get("applicable") is False:  # another problem: no reference band
            return {}
    except (InputError, AttributeError, KeyError, TypeError):
        return {}
    if name not in GEOMETRY_OF_BENCHMARK:
        return {}
    if not name:
        return {}
    from ..references import reference_for

    return reference_for(name) or {}


def plot_timeseries(run_dir: Path, out: Path) -> list[Path]:
    """One PNG per group of observables present in timeseries.csv (and steps.png with a ``dt`` column)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io import read_timeseries

    series = read_timeseries(run_dir / "timeseries.csv")
    if "t" not in series or len(series["t"]) == 0:
        raise InputError(f"{run_dir / 'timeseries.csv'}: no time steps to plot")
    made = []
    for stem, fig in timeseries_figures(series, _reference(run_dir), run_dir.name).items():
        path = out / f"{stem}.png"
        _save(lambda tmp, fig=fig: fig.savefig(tmp, dpi=110, format="png"), path)
        plt.close(fig)
        made.append(path)
    return made


def timeseries_figures(series: dict, ref: dict, title: str) -> dict:
    """{file stem: matplotlib figure} of the time series: the groups present, and ``steps`` (δt(t) on a log
    scale) when the run chose its steps (time.tolerance: a ``dt`` column)."""
    import matplotlib.pyplot as plt

    figures = {}
    for stem, (columns, ylabel) in {**GROUPS, **own_groups(series)}.items():
        present = [c for c in columns if c in series]
        if not present:
            continue
        fig, axes = plt.subplots(len(present), 1, figsize=(9, 2.6 * len(present)), sharex=True, squeeze=False)
        for ax, column in zip(axes[:, 0], present):
            ax.plot(series["t"], series[column], lw=0.8, label=column)
            r = ref.get(column)
            if isinstance(r, dict) and "mean" in r and "amplitude" in r:
                ax.axhspan(r["mean"] - r["amplitude"], r["mean"] + r["amplitude"], color="0.85", zorder=0,
                           label="reference range")
            elif isinstance(r, (int, float)):
                ax.axhline(r, color="k", ls="--", lw=0.8, label="reference")
            ax.set_ylabel(column)
            ax.legend(fontsize=7, loc="upper left")
        axes[-1, 0].set_xlabel("t (s)")
        fig.suptitle(f"{title}: {ylabel}")
        fig.tight_layout()
        figures[stem] = fig
    if "dt" in series and len(series["dt"]):
        fig, ax = plt.subplots(figsize=(9, 2.6))
        ax.semilogy(series["t"], series["dt"], ".-", lw=0.8, ms=3, label="δt (the step ending at t)")
        ax.set_ylabel("δt (s)")
        ax.set_xlabel("t (s)")
        ax.legend(fontsize=7, loc="upper left")
        fig.suptitle(f"{title}: step size (time.tolerance)")
        fig.tight_layout()
        figures["steps"] = fig
    return figures


def plot_snapshots(run_dir: Path, out: Path, times: Sequence[float] | None = None) -> list[Path]:
    """pyvista off-screen pictures of |u|, p (and ω) at the output steps nearest to ``times``."""
    if not (run_dir / "fields.h5").exists():
        return []
    fields = Fields(run_dir)
    import pyvista as pv

    pv.OFF_SCREEN = True
    if len(fields.times) == 0:
        return []
    if fields.corners != 3:
        from .failure import say

        say(f"{run_dir}: no snapshots of a 3D run (its fields: fields.xdmf in ParaView)")
        return []
    steps = sorted({fields.nearest(t) for t in times}) if times else [len(fields.times) - 1]
    made = []
    for i in steps:
        x = np.zeros((len(fields.geometry(i)), 3))
        x[:, :2] = fields.geometry(i)
        triangles = fields.cells(i)  # a remeshed run: the mesh of this step
        cells = np.hstack([np.full((len(triangles), 1), 3), triangles]).ravel()
        grid = pv.UnstructuredGrid(cells, np.full(len(triangles), pv.CellType.TRIANGLE), x)
        velocity = fields.point("velocity", i)
        if velocity is None or velocity.ndim != 2:
            raise InputError(f"{fields.path}: point/velocity/{fields.steps[i]} is missing (damaged file)")
        panels = [("speed (m/s)", np.linalg.norm(velocity[:, :2], axis=1), "viridis")]
        p = fields.point("pressure", i)
        if p is not None:
            panels.append(("p (Pa)", p.ravel(), "coolwarm"))
        w = fields.point("micro_rotation", i)
        if w is not None:
            panels.append(("ω (1/s)", w.ravel(), "PuOr_r"))
        solid = fields.solid_triangles(i)
        plotter = pv.Plotter(off_screen=True, shape=(len(panels), 1), window_size=(1600, 330 * len(panels)))
        fluid = np.setdiff1d(np.arange(len(x)), np.unique(triangles[solid])) if len(solid) else slice(None)
        for k, (label, values, cmap) in enumerate(panels):
            plotter.subplot(k, 0)
            mesh = grid.copy()
            mesh.point_data[label] = values
            # colour range from the fluid (1–99 %): the solid's pressure is a Lagrange multiplier of
            # another scale and would wash the fluid out
            clim = np.percentile(values[fluid], [1, 99]) if label.startswith(("p", "ω")) else None
            plotter.add_mesh(mesh, scalars=label, cmap=cmap, clim=clim, show_scalar_bar=True,
                             scalar_bar_args={"title": label, "vertical": True})
            if len(solid):
                plotter.add_mesh(grid.extract_cells(solid).extract_feature_edges(), color="white", line_width=2)
            plotter.add_text(f"{label}, t = {fields.times[i]:.4g} s", font_size=9)
            plotter.view_xy()
            plotter.camera.zoom(2.3)
        path = out / f"snapshot_t{fields.times[i]:.4f}.png"
        _save(lambda tmp, plotter=plotter: plotter.screenshot(str(tmp)), path)
        plotter.close()
        made.append(path)
    return made


def plot_run(run_dir: str | Path, out: str | Path | None = None, times: Sequence[float] | None = None) -> list[Path]:
    """Write every picture of ``run_dir`` into ``out`` (default RUN_DIR/plots); returns their paths."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise InputError(f"RUN_DIR: {run_dir} is not a folder")
    if not (run_dir / "timeseries.csv").exists():
        raise InputError(f"RUN_DIR: {run_dir} has no timeseries.csv (not a cosserat-fsi run folder?)")
    from ..io.runfolder import folder_in_use

    running = folder_in_use(run_dir) is not None
    fields = (run_dir / "fields.h5").exists() and (run_dir / "fields.xdmf").exists()
    if (run_dir / "fields.h5").exists() != (run_dir / "fields.xdmf").exists() and not running:
        missing = "fields.xdmf" if (run_dir / "fields.h5").exists() else "fields.h5"
        raise InputError(f"{run_dir / missing} is missing (fields.h5 and fields.xdmf go together)")
    out = Path(out) if out else run_dir / "plots"
    from ..files import refuse_link

    refuse_link(out, "--out: ", folder=True)  # never written through a link (PNGs replace their names: tmp + rename)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out: cannot write to {out} ({exc.strerror or exc})") from None
    # a run that has just started has fields.h5 but no fields.xdmf yet: its time series only
    return plot_timeseries(run_dir, out) + (plot_snapshots(run_dir, out, times) if fields else [])
