"""Mesh motion (seed §5.2): solid vertices move with the material, fluid vertices by an extension.

Each step the solid vertices move by δt u^{n+1}. The fluid vertices follow an extension of the solid
displacement, zero on the outer boundary, solved on the *reference* mesh for the total displacement (the
operators are linear, so this equals the sum of incremental extensions with a fixed operator): its matrix
is assembled and factorised once, and the mesh never drifts. Extensions (``solid.mesh_motion.method``):

- ``harmonic`` (the seed's): −div(κ ∇m) = 0 with κ = 1/|K| (Jasak–Tuković), so small cells deform less;
- ``elastic``: linear elasticity −div(κ (2 ε(m) + λ div m I)) = 0, κ = |K|^−χ (Stein–Tezduyar–Benney
  Jacobian-based stiffening, χ = ``stiffness_exponent``), λ = 2ν/(1 − 2ν) (ν = ``poisson_ratio``);
- ``biharmonic``: (K_κ M_L⁻¹ K_κ) m = 0, the mixed biharmonic (w = −div κ∇m, −div κ∇w = 0, Dirichlet data on
  m only; Wick 2011, turtleFSI) with the lumped P1 mass M_L, which eliminates w: one sparse matrix, wider
  stencil, factorised once.

``cell_quality(mesh)``: the normalised shape quality 4√3·|K|/Σ|e|² of each cell (1 equilateral, 0 flat).
The gap the solid keeps from the channel's walls is checked by ``wall_gap.WallGap`` (``MeshMotion.walls``).

A mesh motion is pluggable (Simulation._motion chooses it): it offers the P1 vertex space ``M``, the
reference coordinates ``X0`` and ``node_dof``, the total ``displacement`` and ``velocity`` (P1),
``place(displacement, t)``, ``move(velocity, dt, t, alpha, base) -> mesh velocity (P1)`` and
``state_functions()`` (what a checkpoint keeps).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError
from ..tags import SOLID
from .wall_gap import WallGap

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc


class _MovingMesh:
    """Moves the mesh to reference + a P1 displacement, checks the cells, returns the mesh velocity."""

    planned = None  # a motion planned by an adaptive step's check, taken by the next move (MeshMotion)

    def __init__(self, mesh, comm):
        self.mesh, self.comm = mesh, comm
        self.dim = d = mesh.topology.dim  # 2: triangles in the plane, 3: tetrahedra
        self.M = M = compat.function_space(mesh, "Lagrange", 1, shape=(d,))
        self.X0 = mesh.geometry.x[:, :d].copy()
        self.displacement = dolfinx.fem.Function(M)  # total vertex displacement from the reference
        self.velocity = dolfinx.fem.Function(M)  # (x^{n+1} − x^n)/δt
        # geometry node <-> P1 dof (same local vertex order per cell)
        nodes, dofs = compat.geometry_dofmap(mesh), compat.cell_dofs(M)
        self.node_dof = np.empty(len(mesh.geometry.x), dtype=np.int64)
        self.node_dof[nodes.ravel()] = dofs.ravel()
        self.ref_area = self._areas()
        self.min_quality = self.lowest_quality = None  # minimum cell quality now / since the start (all ranks)
        self.fluid_cells = None  # mask of the local fluid cells (None: all); min_fluid_quality: theirs
        self.min_fluid_quality = None

    def state_functions(self) -> dict:
        """The functions a checkpoint must keep, by name (the total displacement and velocity)."""
        return {"mesh_displacement": self.displacement, "mesh_velocity_P1": self.velocity}

    def _areas(self) -> np.ndarray:
        """Signed areas (volumes in 3D) of the local cells (positive for the reference orientation)."""
        return _signed_measures(self.mesh)

    def quality(self) -> np.ndarray:
        """``cell_quality`` of the local cells, negative where a cell is inverted."""
        return cell_quality(self.mesh, np.sign(self.ref_area))

    def _apply(self, new_displacement: np.ndarray, dt: float, t: float):
        """Move to X0 + new_displacement (P1 dof array); DivergenceError (mesh untouched) if a cell would
        invert or degenerate (area below 1e-3 of its reference)."""
        self.place(new_displacement, t)
        self.velocity.x.array[:] = (new_displacement - self.displacement.x.array) / dt
        self.displacement.x.array[:] = new_displacement
        return self.velocity

    def place(self, displacement: np.ndarray, t: float):
        """Put the mesh at X0 + displacement (P1 dof array) after checking its cells (DivergenceError and
        the mesh untouched if one would invert or degenerate). ``self.displacement`` is not changed."""
        self._put(displacement, t)
        self.measure_quality()
        self.lowest_quality = min(self.min_quality, np.inf if self.lowest_quality is None else self.lowest_quality)

    def _put(self, displacement: np.ndarray, t: float):
        """:meth:`place` without measuring the cells' quality."""
        x, d = self.mesh.geometry.x, self.dim
        old = x[:, :d].copy()
        x[:, :d] = self.X0 + displacement.reshape(-1, d)[self.node_dof]
        ratio = self._areas() / self.ref_area
        worst = int(np.argmin(ratio)) if len(ratio) else -1
        bad = len(ratio) > 0 and ratio[worst] < 1e-3
        if self.comm.allreduce(bad, op=MPI.LOR):
            where = x[compat.geometry_dofmap(self.mesh)[worst, :d + 1], :d].mean(axis=0) if bad else None
            kind = "inverted" if bad and ratio[worst] <= 0 else "degenerate"
            x[:, :d] = old
            where = next(w for w in self.comm.allgather(where) if w is not None)
            kinds = self.comm.allgather(kind if bad else None)
            kind = next(k for k in kinds if k is not None)
            raise DivergenceError(f"t = {t:.6g}: the mesh motion would make a cell {kind} near "
                                  f"({', '.join(f'{c:.4g}' for c in where)}); try a smaller time.dt, "
                                  f"or the deformation is too large for a moving mesh")

    def measure_quality(self) -> None:
        """``min_quality`` (all cells) and ``min_fluid_quality`` (the cells a remesh replaces), all ranks."""
        quality = self.quality()
        fluid = quality if self.fluid_cells is None else quality[self.fluid_cells]
        self.min_quality, self.min_fluid_quality = (
            self.comm.allreduce(float(q.min()) if len(q) else np.inf, op=MPI.MIN) for q in (quality, fluid))


class MeshMotion(_MovingMesh):
    """Solid vertices follow the material (δt u^{n+1} per step), fluid vertices the harmonic extension."""

    def __init__(self, mesh, cell_tags, comm=MPI.COMM_WORLD, stiffening: bool = True, method: str = "harmonic",
                 stiffness_exponent: float = 1.0, poisson_ratio: float = 0.0, wall_facets: np.ndarray | None = None,
                 wall_gap: float | str | None = None, mesh_sizes: bool = False):
        """``wall_facets``: local facets of the channel's walls (the solid must keep ``wall_gap`` from them;
        default gap: a quarter of the shortest wall facet; ``"off"``: no check). ``mesh_sizes``: keep the
        target cell size of each vertex (P1 ``mesh_size``, in the checkpoint; a remesh meshes to it and
        carries it on), from the mean length of the vertex's edges on this mesh."""
        super().__init__(mesh, comm)
        self.method = method
        M, tdim = self.M, mesh.topology.dim
        self.solid_displacement = dolfinx.fem.Function(M)
        self._planned_solid, self.planned = dolfinx.fem.Function(M), None  # plan(): s^{n+1} and its extension
        self._u_P1 = dolfinx.fem.Function(M)
        solid_cells = cell_tags.indices[cell_tags.values == SOLID]
        self.solid_dofs = dolfinx.fem.locate_dofs_topological(M, tdim, solid_cells)
        self._solid_entries = (self.solid_dofs[:, None] * self.dim + np.arange(self.dim)).ravel()
        self.mesh_size = _vertex_sizes(mesh) if mesh_sizes else None
        self.fluid_cells = np.ones(len(self.ref_area), dtype=bool)
        self.fluid_cells[solid_cells[solid_cells < len(self.ref_area)]] = False
        self.walls = WallGap(self, wall_facets, wall_gap)
        mesh.topology.create_connectivity(tdim - 1, tdim)
        boundary = dolfinx.mesh.exterior_facet_indices(mesh.topology)
        outer = dolfinx.fem.locate_dofs_topological(M, tdim - 1, boundary)
        outer = np.setdiff1d(outer, self.solid_dofs).astype(np.int32)
        self._boundary_values = dolfinx.fem.Function(M)  # extend()'s g on the solid, apart from the state
        self.bcs = [dolfinx.fem.dirichletbc(self._boundary_values, self.solid_dofs),
                    dolfinx.fem.dirichletbc(dolfinx.fem.Function(M), outer)]
        m, v = ufl.TrialFunction(M), ufl.TestFunction(M)
        one = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))
        if method == "harmonic" and stiffness_exponent == 1.0:
            k = 1.0 / _cell_area(mesh) if stiffening else one  # the seed's, as it always was
        else:
            k = _cell_area(mesh) ** (-stiffness_exponent) if stiffening else one
        zero = dolfinx.fem.Constant(mesh, np.zeros(self.dim, dtype=PETSc.ScalarType))
        self.L = compat.form(ufl.inner(zero, v) * ufl.dx)
        if method == "elastic":
            lam = 2.0 * poisson_ratio / (1.0 - 2.0 * poisson_ratio)
            eps = ufl.sym(ufl.grad(m))
            self.a = compat.form(k * (2.0 * ufl.inner(eps, ufl.sym(ufl.grad(v)))
                                      + lam * ufl.div(m) * ufl.div(v)) * ufl.dx)
        else:
            self.a = compat.form(k * ufl.inner(ufl.grad(m), ufl.grad(v)) * ufl.dx)
        # The lifting must use the reference operator too: fem.apply_lifting would re-assemble `a` on
        # the *moved* mesh, and the mismatch with the factorised matrix grows with the deformation
        # (fluid vertices next to the flag lag behind it and cells invert at ≈ 2 cm of tip motion).
        self.A0 = fem_petsc.assemble_matrix(self.a)
        self.A0.assemble()
        if method == "biharmonic":
            self.A0 = self._biharmonic(self.A0, v)
            self.A = self.A0.duplicate(copy=True)
            self.A.zeroRowsColumns(self._global_rows([b_dofs for b_dofs in (self.solid_dofs, outer)]), diag=1.0)
        else:
            self.A = fem_petsc.assemble_matrix(self.a, bcs=self.bcs)
            self.A.assemble()
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.ksp.setOperators(self.A)
        self.b = compat.create_vector(self.L, M)
        self._new = dolfinx.fem.Function(M)

    def state_functions(self) -> dict:
        sizes = {} if self.mesh_size is None else {"mesh_size": self.mesh_size}
        return {**super().state_functions(), "solid_displacement": self.solid_displacement, **sizes}

    def node_sizes(self) -> np.ndarray:
        """``mesh_size`` at the local geometry nodes."""
        dofs = np.empty(len(self.mesh.geometry.x), dtype=np.int64)
        dofs[compat.geometry_dofmap(self.mesh).ravel()] = compat.cell_dofs(self.mesh_size.function_space).ravel()
        return self.mesh_size.x.array[dofs]

    def _biharmonic(self, K, v):
        """K M_L⁻¹ K: the mixed biharmonic operator with the auxiliary field eliminated by the lumped mass."""
        lumped = fem_petsc.assemble_vector(compat.form(
            ufl.inner(dolfinx.fem.Constant(self.mesh, np.ones(self.dim, dtype=PETSc.ScalarType)), v) * ufl.dx))
        lumped.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        lumped.reciprocal()
        scaled = K.duplicate(copy=True)
        scaled.diagonalScale(L=lumped)
        return K.matMult(scaled)

    def _global_rows(self, dof_sets) -> np.ndarray:
        """Global PETSc rows of the owned entries of the given (local, blocked) P1 dofs."""
        index_map = self.M.dofmap.index_map
        dofs = np.unique(np.concatenate(dof_sets))
        dofs = dofs[dofs < index_map.size_local]
        blocks = index_map.local_range[0] + dofs
        return (blocks[:, None] * self.dim + np.arange(self.dim)).ravel().astype(PETSc.IntType)

    def extend(self, solid_displacement: np.ndarray) -> np.ndarray:
        """The extension of a total solid displacement (P1 dof array, only the solid entries are read)
        to the whole mesh (P1 dof array); neither the mesh nor the motion's state is changed."""
        g = self._boundary_values
        g.x.array[self._solid_entries] = solid_displacement[self._solid_entries]
        g.x.scatter_forward()
        self.A0.mult(compat.petsc_vec(g), self.b)  # b = −A0 g, g = 0 off the solid
        self.b.scale(-1.0)
        fem_petsc.set_bc(self.b, self.bcs)
        self.ksp.solve(self.b, compat.petsc_vec(self._new))
        self._new.x.scatter_forward()
        return self._new.x.array.copy()

    def move(self, velocity, dt: float, t: float, alpha: float = 1.0, base: np.ndarray | None = None):
        """Solid vertices: s^{n+1} = s* + (δt/α) u^{n+1}, as the displacement d, with s* = s^n (first order)
        or the given ``base`` (BDF2: the extrapolated displacement (4D^n − D^{n−1})/3, a P1 dof array);
        fluid vertices: harmonic extension. Returns the mesh velocity (P1). The move checked by :meth:`plan`
        (same arguments) is taken as it was planned."""
        planned, self.planned = self.planned, None
        s, extended = planned if planned is not None else self._solid_and_extension(velocity, dt, t, alpha, base)
        self.solid_displacement.x.array[:] = s
        return self._apply(extended, dt, t)

    def plan(self, velocity, dt: float, t: float, alpha: float = 1.0, base: np.ndarray | None = None) -> None:
        """Check the move :meth:`move` would make with these arguments (the solid's gap to the walls, no cell
        inverted or degenerate: DivergenceError otherwise) without making it: the mesh stays where it is,
        and the next ``move`` takes the planned one. An adaptive step checks its motion this way before
        it is accepted, so that a step the mesh cannot follow is rejected, not the end of the run."""
        self.planned = None
        s, extended = self._solid_and_extension(velocity, dt, t, alpha, base)
        x = self.mesh.geometry.x
        now = x.copy()
        self._put(extended, t)
        x[:] = now
        self.planned = s, extended

    def _solid_and_extension(self, velocity, dt, t, alpha, base):
        """s^{n+1} (:meth:`move`), checked against the walls, and its extension (P1 dof arrays)."""
        self._u_P1.interpolate(velocity)
        entries = self._solid_entries
        new = self._planned_solid
        new.x.array[:] = self.solid_displacement.x.array
        s_star = new.x.array[entries] if base is None else base[entries]
        new.x.array[entries] = s_star + (dt / alpha) * self._u_P1.x.array[entries]
        new.x.scatter_forward()
        s = new.x.array.copy()
        self.walls.check(s, t)
        return s, self.extend(s)

    def velocity_of(self, velocity) -> np.ndarray:
        """The mesh velocity (P1 dof array) that the velocity field ``velocity`` gives the mesh: its values
        at the solid's vertices, extended (the extension is linear, so this is the rate of the mesh
        displacement when the solid's vertices move with ``velocity``). The mesh is not moved."""
        self._u_P1.interpolate(velocity)
        return self.extend(self._u_P1.x.array)


class PrescribedMotion(_MovingMesh):
    """The mesh follows a given displacement ``motion(X, t)`` of the reference coordinates X (n, d) → (n, d).

    For verification (ALE consistency): the flow must not notice a mesh motion that is not the material's.
    """

    def __init__(self, mesh, motion, comm=MPI.COMM_WORLD):
        super().__init__(mesh, comm)
        n, d = len(self.X0), self.dim
        self._X0_dof = np.zeros((len(self.displacement.x.array) // d, d))
        self._X0_dof[self.node_dof[:n]] = self.X0
        self.motion = motion

    def move(self, velocity, dt: float, t: float, alpha: float = 1.0, base=None):
        return self._apply(np.asarray(self.motion(self._X0_dof, t), dtype=float).ravel(), dt, t)

    def velocity_of(self, velocity, t: float | None = None) -> np.ndarray:
        """The mesh velocity (P1 dof array) at time ``t``: the prescribed motion's time derivative
        (central difference); ``velocity`` (the flow) does not move this mesh."""
        eps = 1e-6
        ahead, behind = (np.asarray(self.motion(self._X0_dof, t + s), dtype=float).ravel() for s in (eps, -eps))
        return (ahead - behind) / (2.0 * eps)


def cell_quality(mesh, orientation: np.ndarray | None = None) -> np.ndarray:
    """Normalised shape quality 4√3·|K|/Σ|e|² of the local cells (1: equilateral, 0: flat, < 0: inverted
    relative to ``orientation``, the signs of the reference cells' areas; without it the sign is gmsh's).
    Tetrahedra: 6√2·|K|/(Σ|e|²/6)^(3/2) (1 for the regular tetrahedron)."""
    if mesh.topology.dim == 3:
        x, n = mesh.geometry.x, compat.geometry_dofmap(mesh)[:, :4]
        edges = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
        squares = sum(((x[n[:, b]] - x[n[:, a]]) ** 2).sum(1) for a, b in edges)
        quality = 6.0 * np.sqrt(2.0) * _signed_measures(mesh) / (squares / 6.0) ** 1.5
        return quality if orientation is None else quality * orientation
    x = mesh.geometry.x[:, :2]
    n = compat.geometry_dofmap(mesh)[:, :3]
    e1, e2, e3 = x[n[:, 1]] - x[n[:, 0]], x[n[:, 2]] - x[n[:, 0]], x[n[:, 2]] - x[n[:, 1]]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    quality = 4.0 * np.sqrt(3.0) * area / ((e1 ** 2).sum(1) + (e2 ** 2).sum(1) + (e3 ** 2).sum(1))
    return quality if orientation is None else quality * orientation


def _vertex_sizes(mesh):
    """P1 function: the mean length of each vertex's edges over all its cells (triangles or tetrahedra; an
    edge counts once per cell it belongs to), on the current mesh.

    Summed over the owned cells of each rank and then added across ranks (ghost update), so a vertex on a
    partition boundary gets the same size as in a serial run (the remeshed mesh must not depend on the
    partition)."""
    V = compat.function_space(mesh, "Lagrange", 1)
    size = dolfinx.fem.Function(V, name="mesh_size")
    total, count = dolfinx.fem.Function(V), dolfinx.fem.Function(V)
    d = mesh.topology.dim
    owned = mesh.topology.index_map(d).size_local
    x = mesh.geometry.x[:, :d]
    nodes, dofs = compat.geometry_dofmap(mesh)[:owned, :d + 1], compat.cell_dofs(V)[:owned, :d + 1]
    edges = ((0, 1), (1, 2), (2, 0)) if d == 2 else ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
    for a, b in edges:
        length = np.linalg.norm(x[nodes[:, a]] - x[nodes[:, b]], axis=1)
        for end in (a, b):
            np.add.at(total.x.array, dofs[:, end], length)
            np.add.at(count.x.array, dofs[:, end], 1.0)
    for f in (total, count):
        vec = compat.petsc_vec(f)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    size.x.array[:] = total.x.array / np.maximum(count.x.array, 1.0)
    return size


def _signed_measures(mesh) -> np.ndarray:
    """Signed areas (triangles) or volumes (tetrahedra) of the local cells, on the current mesh."""
    n = compat.geometry_dofmap(mesh)
    if mesh.topology.dim == 3:
        x = mesh.geometry.x
        e1, e2, e3 = (x[n[:, k]] - x[n[:, 0]] for k in (1, 2, 3))
        return np.einsum("ij,ij->i", np.cross(e1, e2), e3) / 6.0
    x = mesh.geometry.x[:, :2]
    e1, e2 = x[n[:, 1]] - x[n[:, 0]], x[n[:, 2]] - x[n[:, 0]]
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def _cell_area(mesh):
    """|cell| (area or volume) as a DG0 function on the current (reference) mesh."""
    Q = compat.function_space(mesh, "DG", 0)
    area = dolfinx.fem.Function(Q)
    a = np.abs(_signed_measures(mesh))
    dofs = compat.cell_dofs(Q)[:, 0]
    area.x.array[dofs] = a[: len(dofs)]
    return area
