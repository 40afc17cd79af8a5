"""Moving-mesh XDMF time series: XDMF text + HDF5 data written by rank 0 with serial h5py.

Each step stores the current mesh geometry and the fields at the mesh vertices, in the mesh's original
(input) numbering, so the files do not depend on the number of ranks. After every step the .h5 file is
flushed and the .xdmf file atomically replaced: a run killed at any moment leaves a readable pair that
lists only flushed steps. ParaView opens the .xdmf directly (Xdmf3 reader).

HDF5 layout: ``/mesh/topology`` (int64, cells x 3; after a remesh ``/mesh/topology_<k:03d>`` too, named by
the ``topology`` attribute of the steps that use it), ``/mesh/geometry/<step:06d>``,
``/point/<name>/<step:06d>``, ``/cell/<name>/<step:06d>``.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from cosserat_fsi import compat  # before dolfinx
from cosserat_fsi.errors import InputError, OutputError
from cosserat_fsi.io.fields_check import xdmf_times
from cosserat_fsi.io.runfolder import atomic_write_text
from cosserat_fsi.files import check_free_space
from cosserat_fsi.parallel import failpoint, on_root, share
import dolfinx.fem


def _write_error(path: Path, exc: BaseException) -> BaseException:
    """An OutputError naming ``path`` for a failed write (an InputError/OutputError passes through)."""
    if isinstance(exc, InputError):
        return exc
    reason = getattr(exc, "strerror", None) or " ".join(str(exc).split())[:120] or exc.__class__.__name__
    return OutputError(f"{path}: cannot write ({reason})")


def _vec3(a: np.ndarray) -> np.ndarray:
    """2-vectors are padded to 3-vectors (z = 0) so that ParaView draws glyphs."""
    if a.ndim == 2 and a.shape[1] == 2:
        return np.hstack([a, np.zeros((a.shape[0], 1), a.dtype)])
    return a


def _data_item(h5name: str, dataset: str, shape: tuple, dtype) -> str:
    kind = "Int" if np.issubdtype(dtype, np.integer) else "Float"
    dims = " ".join(str(s) for s in shape)
    prec = np.dtype(dtype).itemsize
    return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{prec}" '
            f'Format="HDF">{h5name}:{dataset}</DataItem>')


class MovingMeshXDMF:
    """Write ``path`` (.xdmf) and ``path.with_suffix('.h5')`` for a mesh that moves between writes.

    The mesh must have affine (P1) triangle geometry. Collective: every rank calls every method.
    """

    def __init__(self, path: Path, mesh, comm, keep_steps: int | None = None):
        """``keep_steps``: continue existing files after their first ``keep_steps`` steps (a restart)."""
        self.path, self.mesh, self.comm = Path(path), mesh, comm
        self.h5path = self.path.with_suffix(".h5")
        self.num_steps = 0
        self.steps: list[tuple[float, dict]] = []  # rank 0: (t, {dataset: (shape, dtype)}) per step
        self.topology = "mesh/topology"  # the dataset of the current mesh's cells (a remesh adds one)
        self._p1: dict[tuple, tuple] = {}  # value shape -> (P1 space, P1 function)
        self.h5 = self.node_order = self.cell_order = None
        topology = self._set_mesh(mesh)

        def open_files():
            if keep_steps is None:
                try:
                    self.h5 = h5py.File(self.h5path, "w")
                    self.h5.create_dataset("mesh/topology", data=topology.astype(np.int64))
                    self.h5.flush()
                except Exception as exc:  # noqa: BLE001 (h5py wraps OS errors in its own types)
                    self.close()
                    raise _write_error(self.h5path, exc) from None
            else:
                self._reopen(topology, keep_steps)
            return len(self.steps)

        self.num_steps = on_root(comm, open_files, step="fields.open")

    def _set_mesh(self, mesh) -> np.ndarray | None:
        """Numbering of ``mesh``'s owned nodes and cells; rank 0: its topology in original numbering."""
        comm = self.comm
        geom = compat.geometry_dofmap(mesh)
        if geom.shape[1] not in (3, 4):
            raise ValueError("MovingMeshXDMF: only P1 triangle and tetrahedron meshes are supported")
        self.mesh, self._p1 = mesh, {}
        self.gdim = mesh.geometry.dim
        self.n_nodes = mesh.geometry.index_map().size_local
        self.n_cells = compat.num_owned_cells(mesh)
        node_ids = np.asarray(mesh.geometry.input_global_indices, np.int64)
        cell_ids = np.asarray(mesh.topology.original_cell_index, np.int64)[: self.n_cells]
        # rank 0: owned entities of all ranks, sorted by original index
        all_nodes = comm.gather(node_ids[: self.n_nodes], root=0)
        all_cells = comm.gather(cell_ids, root=0)
        cells = comm.gather(node_ids[geom[: self.n_cells]], root=0)
        if comm.rank != 0:
            return None
        nodes = np.concatenate(all_nodes)
        self.node_order = np.argsort(nodes, kind="stable")
        self.cell_order = np.argsort(np.concatenate(all_cells), kind="stable")
        sorted_nodes = nodes[self.node_order]
        return np.searchsorted(sorted_nodes, np.concatenate(cells)[self.cell_order])

    def new_mesh(self, mesh) -> None:
        """The run goes on on another mesh (a remesh): the next steps use its topology. Collective."""
        topology = self._set_mesh(mesh)

        def write():
            k = sum(1 for name in self.h5["mesh"] if name.startswith("topology"))
            self.topology = f"mesh/topology_{k:03d}"
            self.h5.create_dataset(self.topology, data=topology.astype(np.int64))
            self.h5.flush()

        on_root(self.comm, write, step="fields.new_mesh")

    def _reopen(self, topology: np.ndarray, keep: int):
        """Rank 0: open the existing pair, drop the steps after the first ``keep``, and continue."""
        try:
            times = [float(t) for t in xdmf_times(Path(self.path))]  # a FIFO: refused; damaged: InputError
            self.h5 = h5py.File(self.h5path, "a")
            stored = sorted(f"mesh/{n}" for n in self.h5["mesh"] if n.startswith("topology"))
            same = [n for n in stored if np.array_equal(self.h5[n][:], topology)]
            ok = len(times) >= keep and bool(same)
            self.topology = same[-1] if same else self.topology
        except Exception:  # noqa: BLE001 (h5py: OSError, KeyError, ...; a locked or damaged file)
            ok = False
        if not ok:
            raise InputError(f"--restart: {self.path} does not match the checkpoint (needs {keep} steps)")
        for group in list(self.h5.keys()):
            if group == "mesh":
                names = [f"mesh/geometry/{k}" for k in self.h5["mesh/geometry"]]
            else:
                names = [f"{group}/{field}/{k}" for field in self.h5[group] for k in self.h5[f"{group}/{field}"]]
            for name in names:
                if int(name.rsplit("/", 1)[1]) >= keep:
                    del self.h5[name]
        for step in range(keep):
            shapes = {}
            for key in ["mesh/geometry"] + [f"{g}/{f}" for g in ("point", "cell") if g in self.h5 for f in self.h5[g]]:
                name = f"{key}/{step:06d}"
                if name in self.h5:
                    shapes[key] = (self.h5[name].shape, self.h5[name].dtype)
                    if key == "mesh/geometry":
                        shapes["topology"] = str(self.h5[name].attrs.get("topology", "mesh/topology"))
            self.steps.append((times[step], shapes))
        self.h5.flush()
        self._write_xdmf()

    def _gather(self, local: np.ndarray, order: np.ndarray | None):
        """Owned values of all ranks on rank 0, in original numbering (None elsewhere)."""
        parts = self.comm.gather(np.ascontiguousarray(local), root=0)
        if self.comm.rank != 0:
            return None
        return np.concatenate(parts)[order]

    def _vertex_values(self, u: dolfinx.fem.Function) -> np.ndarray:
        """Values of ``u`` at the owned geometry nodes: (n,) or (n, bs)."""
        shape = tuple(u.ufl_shape)
        if shape not in self._p1:
            V1 = compat.function_space(self.mesh, "Lagrange", 1, shape or None)
            self._p1[shape] = (V1, dolfinx.fem.Function(V1))
        V1, u1 = self._p1[shape]
        u1.interpolate(u)
        bs = V1.dofmap.index_map_bs
        vals = u1.x.array.reshape(-1, bs)
        geom = compat.geometry_dofmap(self.mesh)
        out = np.empty((self.mesh.geometry.x.shape[0], bs))
        out[geom.ravel()] = vals[compat.cell_dofs(V1).ravel()]
        out = out[: self.n_nodes]
        return out[:, 0] if not shape else out

    def write(self, t: float, point_data: dict | None = None, cell_data: dict | None = None):
        """Write one step: the current geometry, point fields (Functions, any Lagrange degree) and
        cell fields (arrays whose first ``num_owned_cells`` rows are the owned cells)."""
        step = self.num_steps
        data = {"mesh/geometry": self._gather(self.mesh.geometry.x[: self.n_nodes, : self.gdim],
                                              self.node_order)}
        for name, u in (point_data or {}).items():
            data[f"point/{name}"] = self._gather(self._vertex_values(u), self.node_order)
        for name, a in (cell_data or {}).items():
            data[f"cell/{name}"] = self._gather(np.asarray(a)[: self.n_cells], self.cell_order)
        error = None
        try:
            failpoint("fields.write")  # every rank: a fault on any rank is shared below
        except Exception as exc:  # noqa: BLE001
            error = _write_error(self.h5path, exc)
        if self.comm.rank == 0 and error is None:
            try:
                if self.h5 is None:
                    raise OSError(5, "the file was closed after an earlier error")
                check_free_space(self.h5path, sum(a.nbytes for a in data.values()))  # HDF5 dies on a full disk
                shapes = {}
                for key, a in data.items():
                    a = a if key == "mesh/geometry" else _vec3(a)
                    dataset = self.h5.create_dataset(f"{key}/{step:06d}", data=a)
                    shapes[key] = (a.shape, a.dtype)
                    if key == "mesh/geometry" and self.topology != "mesh/topology":
                        dataset.attrs["topology"] = self.topology
                shapes["topology"] = self.topology
                self.h5.flush()
                self.steps.append((float(t), shapes))
                self._write_xdmf()
            except Exception as exc:  # noqa: BLE001 (disk full: h5py raises its own types)
                error = _write_error(self.h5path, exc)
        share(self.comm, error)  # instead of a barrier: every rank learns of a failed write
        self.num_steps += 1

    def _write_xdmf(self):
        h5name = self.h5path.name
        lines = ['<?xml version="1.0"?>', '<Xdmf Version="3.0">', "<Domain>",
                 '<Grid Name="mesh" GridType="Collection" CollectionType="Temporal">']
        for step, (t, shapes) in enumerate(self.steps):
            gshape, gdtype = shapes["mesh/geometry"]
            topo = self.h5[shapes.get("topology", "mesh/topology")]
            cell = "Triangle" if topo.shape[1] == 3 else "Tetrahedron"
            lines += [f'<Grid Name="step_{step:06d}" GridType="Uniform">',
                      f'<Time Value="{float(t)!r}"/>',
                      f'<Topology TopologyType="{cell}" NumberOfElements="{topo.shape[0]}">',
                      _data_item(h5name, "/" + topo.name.lstrip("/"), topo.shape, topo.dtype), "</Topology>",
                      f'<Geometry GeometryType="{"XY" if gshape[1] == 2 else "XYZ"}">',
                      _data_item(h5name, f"/mesh/geometry/{step:06d}", gshape, gdtype), "</Geometry>"]
            for key, item in shapes.items():
                if key in ("mesh/geometry", "topology"):
                    continue
                shape, dtype = item
                center = "Node" if key.startswith("point/") else "Cell"
                kind = "Scalar" if len(shape) == 1 else ("Vector" if shape[1] == 3 else "Matrix")
                lines += [f'<Attribute Name="{key.split("/", 1)[1]}" AttributeType="{kind}" '
                          f'Center="{center}">',
                          _data_item(h5name, f"/{key}/{step:06d}", shape, dtype), "</Attribute>"]
            lines.append("</Grid>")
        lines += ["</Grid>", "</Domain>", "</Xdmf>", ""]
        atomic_write_text(self.path, "\n".join(lines))

    def close(self):
        """Close the HDF5 file (the files are complete after every write already)."""
        if self.h5 is not None:
            try:
                self.h5.close()
            except Exception:  # noqa: BLE001 (a full disk: the steps listed in the .xdmf are flushed)
                pass
            self.h5 = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
