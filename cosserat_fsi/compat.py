"""Every difference between dolfinx 0.5.2 (Debian) and dolfinx 0.11 (PyPI wheel) lives here.

Nothing else in the package branches on the dolfinx version. Import this module before ``dolfinx``:
on the wheel stack it imports ``dolfinx_solver`` first, which orders MPI ahead of the bindings.
The measured table of differences is in shared/reference/dolfinx_stacks.md.
"""

from __future__ import annotations

import functools

import logging

try:  # the PyPI wheel must be bootstrapped before dolfinx is imported
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass
else:
    # h5py's wheel bundles its own HDF5: it must load before PETSc's (dolfinx.fem.petsc), or h5py fails
    # on import with "ValueError: Not a datatype" (h5py 3.16 / dolfinx-solver-real 0.11.0.post0)
    import h5py  # noqa: F401

import numpy as np
import ufl
import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.geometry
import dolfinx.mesh
from petsc4py import PETSc

DOLFINX_VERSION = tuple(int(v) for v in dolfinx.__version__.split(".")[:2])
NEW = DOLFINX_VERSION >= (0, 8)
"""True on the wheel stack (dolfinx 0.11); False on Debian's 0.5.2."""

# ffcx 0.5 calls logging.basicConfig() on import, which makes the JIT compiler's INFO lines appear on
# stderr: keep that root handler for warnings only.
for _handler in logging.getLogger().handlers:
    _handler.setLevel(logging.WARNING)

if NEW:
    import basix.ufl
    import dolfinx.io.gmsh as _gmshio
else:
    import dolfinx.io.gmshio as _gmshio


# --------------------------------------------------------------------------------------------- mesh
def read_msh(path, comm, gdim: int = 2):
    """Read a gmsh .msh file on rank 0 and distribute it with shared-facet ghosting.

    Returns ``(mesh, cell_tags, facet_tags)``.
    """
    if NEW:
        partitioner = dolfinx.mesh.create_cell_partitioner(dolfinx.mesh.GhostMode.shared_facet, 2)
        data = _gmshio.read_from_msh(str(path), comm, 0, gdim=gdim, partitioner=partitioner)
        return data.mesh, data.cell_tags, data.facet_tags
    # 0.5.2: read_from_msh is broken (returns an undefined name); create_mesh defaults to shared_facet
    import gmsh

    if comm.rank != 0:
        return _gmshio.model_to_mesh(None, comm, 0, gdim=gdim)
    gmsh.initialize(["-nopopup"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(path))
        return _gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
    finally:
        gmsh.finalize()


def read_xdmf(path, comm, names: tuple[str, str, str] = ("mesh", "cells", "facets")):
    """Read a mesh and its cell and facet tags from an XDMF/HDF5 pair **distributed**: every rank reads its
    share of the .h5 (no rank holds the whole mesh), with shared-facet ghosting as :func:`read_msh`.
    ``names``: the Grid names of the mesh, the cell tags and the facet tags. Returns ``(mesh, cell_tags,
    facet_tags)``. Same call on 0.5.2 and 0.11 (0.11 adds ``max_facet_to_cell_links``, default 2)."""
    import dolfinx.io

    with dolfinx.io.XDMFFile(comm, str(path), "r") as xdmf:
        mesh = xdmf.read_mesh(ghost_mode=dolfinx.mesh.GhostMode.shared_facet, name=names[0])
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)  # the facets, to place the facet tags
        mesh.topology.create_connectivity(tdim, tdim)  # 0.11 places the cell tags through it too
        cell_tags = xdmf.read_meshtags(mesh, names[1])
        facet_tags = xdmf.read_meshtags(mesh, names[2])
    return mesh, cell_tags, facet_tags


def write_xdmf(path, mesh, cell_tags, facet_tags, names: tuple[str, str] = ("cells", "facets")) -> None:
    """Write ``mesh`` and its tags into ``path`` (.xdmf) + its .h5, the tags as the Grids ``names``
    (collective on the mesh's communicator). 0.11's write_meshtags takes the mesh's geometry too."""
    import dolfinx.io

    cell_tags.name, facet_tags.name = names
    where = f"/Xdmf/Domain/Grid[@Name='{mesh.name}']/Geometry"
    with dolfinx.io.XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        for tags in (cell_tags, facet_tags):
            if NEW:
                xdmf.write_meshtags(tags, mesh.geometry, geometry_xpath=where)
            else:
                xdmf.write_meshtags(tags, geometry_xpath=where)


def geometry_dofmap(mesh) -> np.ndarray:
    """Geometry node indices per local cell, shape (num_cells, nodes_per_cell)."""
    if NEW:
        return mesh.geometry.dofmaps[0]
    dm = mesh.geometry.dofmap
    return dm.array.reshape(-1, dm.links(0).size)


def num_owned_cells(mesh) -> int:
    return mesh.topology.index_map(mesh.topology.dim).size_local


# ------------------------------------------------------------------------------- elements and spaces
def element(mesh, family: str, degree: int, shape: tuple | None = None):
    """A (possibly vector-valued) Lagrange/DG element on the mesh's cell."""
    if NEW:
        return basix.ufl.element(family, mesh.basix_cell(), degree, shape=shape)
    cell = mesh.ufl_cell()
    if shape:
        return ufl.VectorElement(family, cell, degree, dim=shape[0])
    return ufl.FiniteElement(family, cell, degree)


def mixed_element(elements):
    if NEW:
        return basix.ufl.mixed_element(list(elements))
    return ufl.MixedElement(list(elements))


def function_space(mesh, el_or_family, degree: int | None = None, shape: tuple | None = None):
    """Function space from an element, or from ``(family, degree, shape)``."""
    el = el_or_family if degree is None else element(mesh, el_or_family, degree, shape)
    if NEW:
        return dolfinx.fem.functionspace(mesh, el)
    return dolfinx.fem.FunctionSpace(mesh, el)


def collapse(subspace):
    """``V.sub(i).collapse()`` → (collapsed space, ndarray of parent dofs)."""
    V, dofs = subspace.collapse()
    return V, np.asarray(dofs, dtype=np.int32)


def cell_dofs(V) -> np.ndarray:
    """Dof indices (blocks) per local cell, shape (num_cells, dofs_per_cell)."""
    dm = V.dofmap.list
    if NEW:
        return dm
    return dm.array.reshape(-1, dm.links(0).size)


def quadrature_space(mesh, degree: int, shape: tuple = ()):
    """Space of values at the quadrature points of the default rule of ``degree`` (per cell)."""
    if NEW:
        el = basix.ufl.quadrature_element(mesh.basix_cell(), value_shape=shape, degree=degree)
        return dolfinx.fem.functionspace(mesh, el)
    cell = mesh.ufl_cell()
    if shape:
        el = ufl.VectorElement("Quadrature", cell, degree, dim=shape[0], quad_scheme="default")
    else:
        el = ufl.FiniteElement("Quadrature", cell, degree, quad_scheme="default")
    return dolfinx.fem.FunctionSpace(mesh, el)


@functools.cache
def quadrature_points(degree: int, tdim: int = 2) -> np.ndarray:
    """Reference points of the default rule of ``degree`` on the triangle (``tdim`` 2) or tetrahedron (3),
    in the order of quadrature_space."""
    import basix

    cell = basix.CellType.triangle if tdim == 2 else basix.CellType.tetrahedron
    if NEW:
        points, _ = basix.make_quadrature(cell, degree)
    else:
        points, _ = basix.make_quadrature(basix.QuadratureType.Default, cell, degree)
    return np.asarray(points)


# -------------------------------------------------------------------------------- forms and PETSc
JIT_OPTIONS = {"cffi_extra_compile_args": ["-O2", "-march=native"], "cffi_libraries": ["m"]}


def form(f):
    """Compile a UFL form (or list of forms), caching in ``cache.jit_cache_dir()``."""
    from .cache import jit_cache_dir

    options = {**JIT_OPTIONS, "cache_dir": str(jit_cache_dir())}
    if NEW:
        return dolfinx.fem.form(f, jit_options=options)
    return dolfinx.fem.form(f, jit_params=options)


def create_vector(L_form, V):
    """A PETSc vector for the compiled linear form ``L_form`` on space ``V``."""
    if NEW:
        return dolfinx.fem.petsc.create_vector(V)
    return dolfinx.fem.petsc.create_vector(L_form)


def petsc_vec(u):
    """The PETSc vector wrapping a Function's values."""
    return u.x.petsc_vec if NEW else u.vector


# ----------------------------------------------------------------------------------- point location
def bb_tree(mesh, dim: int | None = None, entities=None, padding: float = 0.0):
    dim = mesh.topology.dim if dim is None else dim
    if entities is None:
        n = mesh.topology.index_map(dim)
        entities = np.arange(n.size_local + n.num_ghosts, dtype=np.int32)
    if NEW:
        return dolfinx.geometry.bb_tree(mesh, dim, entities=entities, padding=padding)
    return dolfinx.geometry.BoundingBoxTree(mesh, dim, entities, padding=padding)


def collision_candidates(tree, points: np.ndarray):
    """Candidate cells (bounding-box collisions) for points of shape (n, 3): (offsets, cells)."""
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if NEW:
        adj = dolfinx.geometry.compute_collisions_points(tree, pts)
    else:
        adj = dolfinx.geometry.compute_collisions(tree, pts)
    return np.asarray(adj.offsets), np.asarray(adj.array)


def interpolate_nonmatching(target, source, point_values=None, cache: dict | None = None) -> None:
    """``target`` (Lagrange) ← ``source`` on another mesh of the same domain (remeshing). dolfinx 0.11: its
    non-matching interpolation (``create_interpolation_data`` + ``interpolate_nonmatching``; the point
    location it does is kept in ``cache`` for the next pair of the same spaces: 1.2 s per P2 field of the 3D
    flag); 0.5.2 has none: ``point_values(source, points (n, 3)) -> (n, value_size)`` (collective) at the
    target's dof coordinates (Lagrange dofs are point evaluations)."""
    V = target.function_space
    if NEW:
        im = V.mesh.topology.index_map(V.mesh.topology.dim)
        cells = np.arange(im.size_local + im.num_ghosts, dtype=np.int32)
        key = (id(V), id(source.function_space))
        if cache is None or key not in cache:
            data = dolfinx.fem.create_interpolation_data(V, source.function_space, cells, padding=1e-10)
            if cache is not None:  # the spaces are kept with it: their ids stay theirs
                cache[key] = (V, source.function_space, data)
        else:
            data = cache[key][2]
        target.interpolate_nonmatching(source, cells, data)
    else:
        values = point_values(source, V.tabulate_dof_coordinates())
        target.x.array[:] = np.asarray(values).ravel()
    target.x.scatter_forward()


# ---------------------------------------------------------------------------------------- versions
def versions() -> dict:
    """Versions of the stack, for `cosserat-fsi info` and summary.json."""
    import basix
    import ffcx
    import petsc4py
    from mpi4py import MPI

    return {
        "dolfinx": dolfinx.__version__,
        "basix": basix.__version__,
        "ufl": getattr(ufl, "__version__", "unknown"),
        "ffcx": ffcx.__version__,
        "petsc": ".".join(str(v) for v in PETSc.Sys.getVersion()),
        "petsc4py": petsc4py.__version__,
        "mpi": MPI.Get_library_version().splitlines()[0].strip().strip("\x00"),
        "mumps": bool(PETSc.Sys.hasExternalPackage("mumps")),
    }


def option_used(name: str) -> bool:
    """Whether PETSc's options database entry ``name`` (without the dash) has been read by an object.
    petsc4py 3.18 (Debian) has no ``Options.used``: PetscOptionsUsed from the library petsc4py links."""
    options = PETSc.Options()
    if hasattr(options, "used"):
        return bool(options.used(name))
    import ctypes
    import glob

    import petsc4py

    library = sorted(glob.glob(petsc4py.get_config()["PETSC_DIR"] + "/lib/libpetsc*.so*"))[0]
    petsc = ctypes.CDLL(library)  # the library already loaded: the same options database
    used = ctypes.c_int(0)
    if petsc.PetscOptionsUsed(None, name.encode(), ctypes.byref(used)):  # the names are stored without dash
        raise RuntimeError(f"PetscOptionsUsed failed for {name}")
    return bool(used.value)


def free_petsc_garbage(comm) -> None:
    """Destroy now the PETSc objects (matrices, factorisations, Krylov solvers) that Python has let go of, on
    every rank of ``comm`` together (collective). petsc4py 3.18 (Debian) does not destroy an object that the
    garbage collector frees: it keeps it until ``PETSc.garbage_cleanup``, so each Simulation dropped kept its
    memory (the 3D flag's: 0.45 GB each, measured); the wheel's petsc4py frees them at once (0 GB)."""
    import gc

    gc.collect()
    if hasattr(PETSc, "garbage_cleanup"):
        PETSc.garbage_cleanup(comm)
