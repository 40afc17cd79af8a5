"""The time loop: characteristics → assemble → MUMPS solve → update (seed §5).

One stepper owns the loop. On a fixed mesh the matrix of the characteristics-Galerkin scheme does not change
from step to step (the convection is in the right-hand side), so it is assembled and factorised once per
value of the BDF coefficient α: once for the seed's first-order scheme, twice for BDF2 (its first step
is first order).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError, InputError
from .characteristics import Characteristics, PointLocator, evaluate
from .mesh_motion import MeshMotion, PrescribedMotion
from .problem import Model, Problem, ramp
from .spaces import mixed_space

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc

SCHEMES = {"characteristics1": 1, "characteristics2": 2, "steady": 1}  # steady: scheme/steady.py

MUMPS_ORDERING = {"amd": 0, "pord": 4, "metis": 5, "auto": 7}

TAGS = {"inlet": 1, "outlet": 2, "walls": 3, "cylinder": 4, "interface": 5, "lid": 6, "clamp": 7}
FLUID, SOLID = 1, 2  # cell tags


@dataclass
class Timers:
    """Accumulated wall time per phase of the step."""

    totals: dict = field(default_factory=dict)

    def add(self, name: str, seconds: float):
        self.totals[name] = self.totals.get(name, 0.0) + seconds

    class _Ctx:
        def __init__(self, timers, name):
            self.timers, self.name = timers, name

        def __enter__(self):
            self.t0 = time.perf_counter()

        def __exit__(self, *exc):
            self.timers.add(self.name, time.perf_counter() - self.t0)

    def __call__(self, name: str):
        return Timers._Ctx(self, name)


class Stepper:
    """Monolithic velocity (× micro-rotation) × pressure system of one scene, advanced step by step."""

    def __init__(self, scene, mesh, cell_tags, facet_tags, comm=MPI.COMM_WORLD, exact=None,
                 prescribed_motion=None):
        """``exact``: optional exact solution (attributes ``velocity(x, t)`` and, with micro-rotation,
        ``micro_rotation(x, t)``) giving the initial state and the Dirichlet data on every boundary but
        the outlet; used by the verification tests. ``prescribed_motion(X, t)``: a displacement of the
        reference coordinates that the mesh follows instead of the material (ALE verification)."""
        self.scene, self.mesh, self.comm, self.exact = scene, mesh, comm, exact
        self.model = Model.from_scene(scene)
        self.cell_tags, self.facet_tags = cell_tags, facet_tags
        self.timers = Timers()
        self.dt = float(scene.time.dt)
        self.order = SCHEMES[scene.time.scheme]
        self.t = 0.0
        self.step_count = 0

        self.space = sp = mixed_space(mesh, self.model.micro_rotation)
        self.w = dolfinx.fem.Function(sp.W, name="state")
        V = sp.space("velocity")
        self.u_n = dolfinx.fem.Function(V, name="velocity")
        self.u_nm1 = dolfinx.fem.Function(V)
        # histories α·h live at quadrature points (FreeFEM's convect) or, optionally, at the P2 nodes
        self.quadrature_degree = scene.time.quadrature_degree if scene.time.characteristics == "quadrature" else None
        if self.quadrature_degree:
            self.u_hist = dolfinx.fem.Function(compat.quadrature_space(mesh, self.quadrature_degree, (2,)))
            self.dx_inertia = ufl.dx(domain=mesh, metadata={"quadrature_degree": self.quadrature_degree})
        else:
            self.u_hist = dolfinx.fem.Function(V)
            self.dx_inertia = ufl.dx(domain=mesh)
        self.p_n = dolfinx.fem.Function(sp.space("pressure"), name="pressure")
        if self.model.micro_rotation:
            S = sp.space("micro_rotation")
            self.omega_n = dolfinx.fem.Function(S, name="micro_rotation")
            self.omega_nm1 = dolfinx.fem.Function(S)
            at_quadrature = self.quadrature_degree and not scene.micropolar.nodal_characteristics
            self.omega_hist = dolfinx.fem.Function(
                compat.quadrature_space(mesh, self.quadrature_degree) if at_quadrature else S)
        self.chars = Characteristics(V, sp.space("micro_rotation") if self.model.micro_rotation else None, comm)
        self.mesh_velocity = dolfinx.fem.Function(V, name="mesh_velocity")  # (x^n − x^{n−1})/δt
        self.motion = None
        if self.model.solid:
            self.d_n = dolfinx.fem.Function(V, name="displacement")
            self.d_nm1 = dolfinx.fem.Function(V)
            # the solid terms are linearised around d* = d^n (first order) or (4d^n − d^{n−1})/3 (BDF2),
            # with d^{n+1} = d* + (δt/α) u^{n+1}
            self.d_star = dolfinx.fem.Function(V)
            solid_cells = cell_tags.indices[cell_tags.values == SOLID]
            self.solid_dofs = dolfinx.fem.locate_dofs_topological(V, mesh.topology.dim, solid_cells)
            self.motion = MeshMotion(mesh, cell_tags, comm)
        if prescribed_motion is not None:
            self.motion = PrescribedMotion(mesh, prescribed_motion, comm)
        if self.motion is not None and self.order == 2:
            # displacement of the configurations u^n and u^{n−1} were computed on (Ω^{n−1}, Ω^{n−2})
            # BDF2 solves on the extrapolated configuration Ω* = X + (4D^n − D^{n−1})/3 (second order in
            # the geometry: solving on Ω^n would be first order); D^{n−1} is kept for it
            self.mesh_displacement_prev = dolfinx.fem.Function(self.motion.M)  # D^{n−1}
            self.solve_displacement = dolfinx.fem.Function(self.motion.M)  # Ω* − X
            self.mesh_displacement_n = dolfinx.fem.Function(self.motion.M)
            self.mesh_displacement_nm1 = dolfinx.fem.Function(self.motion.M)
            self._history_locators = (self.chars.locator, self.chars.locator)
            self._shift, self._shift_current = dolfinx.fem.Function(V), dolfinx.fem.Function(V)

        self.problem = Problem(scene, mesh, cell_tags, facet_tags, self.space, exact)
        self._constants()
        self._forms()
        self._boundary_conditions()
        self.set_initial()
        self.A = None
        self._alpha_of_A = None
        self.ksp = self._make_solver()
        self.b = compat.create_vector(self.L_form, sp.W)
        self._ref_coords = None
        self._reference_coordinates()

    # ------------------------------------------------------------------------------------- set-up
    def _const(self, value):
        return dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(value))

    def cellwise(self, fluid_value, solid_value, shape=()):
        return self.problem.cellwise(fluid_value, solid_value, shape)

    def _constants(self):
        pr = self.problem
        self.alpha = self._const(1.0)
        self.inv_dt = self._const(1.0 / self.dt)
        self.rho, self.mu, self.f = pr.rho, pr.mu, pr.body_force
        if self.model.solid:
            self.mu_s = pr.mu_s
            self.solid_dt = self._const(self.dt)  # δt/α
        if self.model.micro_rotation:
            self.mu_r = pr.mu_r

    def acceleration(self, u):
        """(α u − α h)/δt: the characteristics scheme's material acceleration of u (α h = ``u_hist``)."""
        return (self.alpha * u - self.u_hist) * self.inv_dt

    def _forms(self):
        pr = self.problem
        trial, test = ufl.TrialFunctions(pr.space.W), ufl.TestFunctions(pr.space.W)
        u, _, omega = pr.split(trial)
        micro = (self.alpha * omega - self.omega_hist) * self.inv_dt if omega is not None else None
        F = pr.residual(trial, test, acceleration=self.acceleration(u), micro_acceleration=micro,
                        dx_inertia=self.dx_inertia)
        if self.model.solid:
            F = F + pr.solid_residual(trial, test, self.d_star, self.solid_dt)
        self.a_form, self.L_form = compat.form(ufl.lhs(F)), compat.form(ufl.rhs(F))

    def facets(self, *names):
        ft = self.facet_tags
        tags = [TAGS[n] for n in names]
        return np.unique(ft.indices[np.isin(ft.values, tags)]).astype(np.int32)

    def _boundary_conditions(self):
        """Dirichlet data: no-slip (and ω = 0) on walls, cylinder, flag; inflow profile × ramp at the inlet;
        the lid of the square moves with ``inflow.u_mean``. With an exact solution, its values on every
        tagged boundary but the outlet."""
        sp, mesh = self.space, self.mesh
        fdim = mesh.topology.dim - 1
        V = sp.space("velocity")
        self._updates = []  # callables t -> None that refresh time-dependent boundary values
        self.bcs = []

        def add(space_name, facet_names, values=None, scale=None, exact=None, kick=None):
            """``kick = (values2, scale2)``: a second, transient part added to ``values``·scale(t)."""
            Vs = sp.space(space_name)
            g = dolfinx.fem.Function(Vs)
            if values is not None:
                g.interpolate(values)
                if scale is not None:
                    g0 = g.x.array.copy()
                    g1, scale1 = np.zeros_like(g0), (lambda t: 0.0)
                    if kick is not None:
                        g.interpolate(kick[0])
                        g1, scale1 = g.x.array.copy(), kick[1]
                    self._updates.append(lambda t: g.x.array.__setitem__(slice(None), scale(t) * g0 + scale1(t) * g1))
            if exact is not None:
                self._updates.append(lambda t: g.interpolate(lambda x: exact(x, t)))
            dofs = dolfinx.fem.locate_dofs_topological((sp.sub(space_name), Vs), fdim, self.facets(*facet_names))
            self.bcs.append(dolfinx.fem.dirichletbc(g, dofs, sp.sub(space_name)))

        weak = self._half_curl_walls() if self.model.micro_rotation else ()
        if self.exact is not None:
            boundary = [name for name in TAGS if name != "outlet"]
            add("velocity", boundary, exact=self.exact.velocity)
            if self.model.micro_rotation:
                add("micro_rotation", [b for b in boundary if b not in weak], exact=self.exact.micro_rotation)
            return
        inflow = self.scene.inflow
        moving_lid = inflow is not None and self.scene.geometry.name == "square"
        no_slip = self.no_slip_boundaries()
        add("velocity", no_slip + (() if moving_lid else ("lid",)))
        if inflow is not None:
            ramp_time = inflow.ramp_time
            y0 = self.comm.allreduce(mesh.geometry.x[:, 1].min(), op=MPI.MIN)
            H = self.comm.allreduce(mesh.geometry.x[:, 1].max(), op=MPI.MAX) - y0

            def profile(x):
                y = x[1] - y0
                ux = (6.0 * inflow.u_mean * y * (H - y) / H**2 if inflow.profile == "parabolic"
                      else np.full_like(y, inflow.u_mean))
                return np.vstack([ux, np.zeros_like(ux)])

            def lid(x):
                return np.vstack([np.full_like(x[0], inflow.u_mean), np.zeros_like(x[0])])

            def tilt(x):  # antisymmetric about mid-height: breaks the symmetry of the start-up
                return profile(x) * (2.0 * (x[1] - y0) / H - 1.0)

            def bump(t):  # ε sin(π t / T) during the ramp, then 0
                return inflow.asymmetry * np.sin(np.pi * t / ramp_time) if 0 < t < ramp_time else 0.0

            kick = (tilt, bump) if inflow.asymmetry and not moving_lid else None
            add("velocity", ("lid",) if moving_lid else ("inlet",), values=lid if moving_lid else profile,
                scale=lambda t: ramp(t, ramp_time), kick=kick)
        if self.model.micro_rotation and not weak:
            add("micro_rotation", no_slip + ("lid",))

    def _half_curl_walls(self) -> tuple:
        """Boundaries where ω = ½ curl u is imposed weakly (micropolar.wall_condition: half_curl)."""
        if self.scene.micropolar.wall_condition != "half_curl":
            return ()
        return self.no_slip_boundaries() + ("lid",)

    def no_slip_boundaries(self) -> tuple:
        """Walls, cylinder, the clamp, and the flag when it is rigid (a solid flag's boundary is free)."""
        return ("walls", "cylinder", "clamp") + (() if self.model.solid else ("interface",))

    def set_initial(self):
        """Initial state: rest (the solid with its initial velocity), or the exact solution at t = 0."""
        if self.model.solid and any(self.scene.solid.initial_velocity):
            values = self.u_n.x.array.reshape(-1, 2)
            values[self.solid_dofs] = self.scene.solid.initial_velocity
            fixed = dolfinx.fem.locate_dofs_topological(self.u_n.function_space, self.mesh.topology.dim - 1,
                                                        self.facets(*self.no_slip_boundaries()))
            values[fixed] = 0.0  # the clamp stays at rest
        if self.exact is None:
            return
        self.u_n.interpolate(lambda x: self.exact.velocity(x, 0.0))
        if self.model.micro_rotation:
            self.omega_n.interpolate(lambda x: self.exact.micro_rotation(x, 0.0))

    def _make_solver(self):
        ksp = PETSc.KSP().create(self.comm)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self.factorisations = 0
        self.krylov_iterations = 0
        self._reuse = self.motion is not None and self.scene.solver.reuse_factorization
        if self._reuse:  # the last LU preconditions GMRES until GMRES needs too many iterations
            solver = self.scene.solver
            ksp.setType("gmres")
            ksp.setTolerances(rtol=solver.krylov_rtol, atol=1e-50, max_it=solver.max_krylov_iterations)
            ksp.setInitialGuessNonzero(True)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            ksp.getPC().setReusePreconditioner(True)
        return ksp

    def _mumps_options(self):
        """MUMPS controls, set on the factor matrix (no options database, nothing left unused)."""
        pc = self.ksp.getPC()
        pc.setFactorSetUpSolverType()
        F = pc.getFactorMatrix()
        F.setMumpsIcntl(7, MUMPS_ORDERING[self.scene.solver.mumps_ordering])  # fill-reducing ordering
        F.setMumpsIcntl(14, 100)  # workspace relaxation (%)
        F.setMumpsIcntl(24, 1)  # null-pivot detection (pure-Dirichlet pressure)

    def _solve(self, b, x):
        """Direct solve (factorisation reused while the matrix is constant); on a moving mesh, GMRES
        preconditioned by the last factorisation, refactorising when it does not converge in time."""
        ksp = self.ksp
        ksp.solve(b, x)
        if not self._reuse:
            return
        self.krylov_iterations += ksp.getIterationNumber()
        if self.factorisations == 0 or ksp.getConvergedReason() <= 0:
            if self.factorisations > 0:  # the old factorisation no longer does: refactorise
                ksp.getPC().setReusePreconditioner(False)
                ksp.setOperators(self.A)
                x.set(0.0)  # a failed GMRES may have left NaN in the initial guess
                ksp.solve(b, x)
                ksp.getPC().setReusePreconditioner(True)
            self.factorisations += 1

    # --------------------------------------------------------------------------------- one step
    def _matrix(self, alpha: float):
        """Assemble (and have MUMPS factorise) the matrix when α changed or the mesh moved."""
        if self.A is not None and self._alpha_of_A == alpha and self.motion is None:
            return
        with self.timers("assemble_matrix"):
            self.alpha.value = alpha
            if self.model.solid:
                self.solid_dt.value = self.dt / alpha
            if self.A is None:
                self.A = fem_petsc.assemble_matrix(self.a_form, bcs=self.bcs)
            else:
                self.A.zeroEntries()
                fem_petsc.assemble_matrix(self.A, self.a_form, bcs=self.bcs)
            self.A.assemble()
            self.ksp.setOperators(self.A)
            if self._alpha_of_A is None:
                self._mumps_options()
            self._alpha_of_A = alpha

    def _histories(self, alpha: float):
        """Set α·h for u (and ω) from the characteristics (first order, or BDF2 feet): at the quadrature
        points of the inertia term, or at the P2 nodes (``time.characteristics: nodes``; for ω alone with
        ``micropolar.nodal_characteristics``)."""
        chars, micro = self.chars, self.model.micro_rotation
        degree = self.quadrature_degree
        omega_apart = micro and degree and self.scene.micropolar.nodal_characteristics
        with_omega = micro and not omega_apart
        hist = self._history_values(alpha, degree, [self.u_n] + ([self.omega_n] if with_omega else []),
                                    [self.u_nm1] + ([self.omega_nm1] if with_omega else []))
        if degree:
            self._set_quadrature(self.u_hist, hist[0])
            if with_omega:
                self._set_quadrature(self.omega_hist, hist[1])
        else:
            n = chars.n_nodes
            self.u_hist.x.array[: n * 2] = hist[0].ravel()
            self.u_hist.x.scatter_forward()
        if omega_apart or (micro and not degree):
            values = (self._history_values(alpha, None, [self.omega_n], [self.omega_nm1])[0] if omega_apart
                      else hist[1])
            self.omega_hist.x.array[:] = chars.to_S(values[:, 0])
            self.omega_hist.x.scatter_forward()

    def _history_values(self, alpha: float, degree, fns_n, fns_nm1) -> list:
        """α·h of ``fns_n`` (and ``fns_nm1`` for BDF2) at the quadrature points of ``degree`` in every
        cell, or at the local P2 nodes (``degree`` None)."""
        chars = self.chars
        if degree:
            x, cells = chars.quadrature_nodes(degree)

            def at_x(f):
                return chars.at_quadrature_nodes(f, degree)
        else:
            x, cells = chars.nodes(), None

            def at_x(f):
                return chars.nodal(f)
        u_x = at_x(self.u_n)
        if alpha == 1.0:
            w_x = at_x(self.mesh_velocity) if self.motion is not None else 0.0
            hist = self._at_feet(x, x - self.dt * _pad(u_x - w_x), fns_n, cells)
        else:  # BDF2: feet x − δt u*, x − 2δt u*, u* = 2u^n − u^{n−1}
            if self.motion is None:
                u_star = _pad(2.0 * u_x - at_x(self.u_nm1))
                vals1 = self._at_feet(x, x - self.dt * u_star, fns_n, cells)
                vals2 = self._at_feet(x, x - 2.0 * self.dt * u_star, fns_nm1, cells)
            else:
                # moving mesh: u^n (and ω^n) live on Ω^{n−1}, u^{n−1} on Ω^{n−2}, where they were computed;
                # the feet (physical points) are located in those configurations of the mesh. A mesh-
                # velocity shift of the feet (as in the first-order scheme) is only O(δt²) accurate
                # per step, which would make the scheme first order.
                # Points outside such an earlier configuration (its boundary moved: a solid-only scene)
                # are pulled back to the image of x in it (same cell, same barycentric coordinates).
                loc_n, loc_nm1 = self._history_locators
                x_n, x_nm1 = (self._earlier_position(x, loc, disp, degree)
                              for loc, disp in ((loc_n, self.mesh_displacement_n),
                                                (loc_nm1, self.mesh_displacement_nm1)))
                (un_x,) = evaluate(loc_n, [self.u_n], x, x_n, self.comm, hint=cells)
                (unm1_x,) = evaluate(loc_nm1, [self.u_nm1], x, x_nm1, self.comm, hint=cells)
                u_star = _pad(2.0 * un_x - unm1_x)
                vals1 = evaluate(loc_n, fns_n, x - self.dt * u_star, x_n, self.comm, hint=cells)
                vals2 = evaluate(loc_nm1, fns_nm1, x - 2.0 * self.dt * u_star, x_nm1, self.comm, hint=cells)
            hist = [2.0 * v1 - 0.5 * v2 for v1, v2 in zip(vals1, vals2)]
        return hist

    def _to_solve_configuration(self, alpha: float):
        """BDF2 on a moving mesh: put the mesh at Ω* = X + (4D^n − D^{n−1})/3 (Ω^n for the first-order
        start step), where d* = (4d^n − d^{n−1})/3 lives, and locate in it."""
        m = self.motion
        D = m.displacement.x.array
        E = self.solve_displacement.x.array
        E[:] = D if alpha == 1.0 else (4.0 * D - self.mesh_displacement_prev.x.array) / 3.0
        m.place(E, self.t)
        self.chars.locator = PointLocator(self.mesh)

    def _earlier_position(self, x, locator, displacement, degree):
        """Where the points x of the current mesh were in an earlier configuration of it (``locator``,
        reached with the P1 vertex ``displacement``): the same cell and barycentric coordinates."""
        if degree:
            return self.chars.quadrature_nodes(degree, locator)[0]
        shift = self._shift
        shift.interpolate(displacement)
        current = self._shift_current
        current.interpolate(self.solve_displacement)
        return x - _pad(self.chars.nodal(current) - self.chars.nodal(shift))

    def _at_feet(self, anchors, feet, functions, cells=None):
        return evaluate(self.chars.locator, functions, feet, anchors, self.comm, hint=cells)

    @staticmethod
    def _set_quadrature(f, values):
        """Write values at the quadrature points (cell-major, as quadrature_nodes) into ``f``."""
        dofs = compat.cell_dofs(f.function_space)
        bs = f.function_space.dofmap.index_map_bs
        arr = f.x.array.reshape(-1, bs)
        arr[dofs[: len(values) // dofs.shape[1]].ravel()] = values.reshape(-1, bs)

    def advance(self, before_move=None):
        """One time step t^n → t^{n+1}: solve on Ω^n, update d, then move the mesh to Ω^{n+1}.

        ``before_move`` is called after the solve, while the mesh is still Ω^n (observables).
        """
        alpha = 1.0 if (self.order == 1 or self.step_count == 0) else 1.5
        if self.motion is not None and self.order == 2:
            with self.timers("mesh_motion"):
                self._to_solve_configuration(alpha)
        if self.model.solid:
            d_star = self.d_star.x.array
            d_star[:] = self.d_n.x.array if alpha == 1.0 else (4.0 * self.d_n.x.array - self.d_nm1.x.array) / 3.0
        self._matrix(alpha)
        t_new = (self.step_count + 1) * self.dt
        for update in self._updates:
            update(t_new)
        self.problem.update_sources(t_new)
        with self.timers("backtrack"):
            self._histories(alpha)
        with self.timers("assemble_vector"):
            b = self.b
            with b.localForm() as loc:
                loc.set(0.0)
            fem_petsc.assemble_vector(b, self.L_form)
            fem_petsc.apply_lifting(b, [self.a_form], bcs=[self.bcs])
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            fem_petsc.set_bc(b, self.bcs)
        with self.timers("solve"):
            self._solve(b, compat.petsc_vec(self.w))
            self.w.x.scatter_forward()
        self._check_finite(t_new)
        sp = self.space
        self.u_nm1.x.array[:] = self.u_n.x.array
        self.u_n.x.array[:] = self.w.x.array[sp.dofs("velocity")]
        self.p_n.x.array[:] = self.w.x.array[sp.dofs("pressure")]
        if self.model.micro_rotation:
            self.omega_nm1.x.array[:] = self.omega_n.x.array
            self.omega_n.x.array[:] = self.w.x.array[sp.dofs("micro_rotation")]
        if self.model.solid:
            # seed §5.1: d^{n+1} = d^n∘X^n + δt u^{n+1}. The solid nodes move with the material, so in
            # their frame X^n is the identity: d^{n+1}_i = d^n_i + δt u^{n+1}_i (BDF2: d*_i + (2δt/3) u^{n+1}_i,
            # d* = (4d^n − d^{n−1})/3) (exact at the vertices;
            # at the P2 mid-edge nodes up to O(δt h² ∇²u) per step). Back-tracking d with the ALE
            # velocity u − w instead (w the P1 mesh velocity) gives the same vertices but lets the
            # mid-edge values drift from them; on the seed's FSI3 run that drift triggers a local
            # pressure blow-up at the flag tip (t = 6.09 at δt = 0.005, earlier at smaller δt).
            self.d_nm1.x.array[:] = self.d_n.x.array
            d, d_star = self.d_n.x.array.reshape(-1, 2), self.d_star.x.array.reshape(-1, 2)
            u = self.u_n.x.array.reshape(-1, 2)
            nodes = self.solid_dofs
            d[nodes] = d_star[nodes] + (self.dt / alpha) * u[nodes]
            self.d_n.x.scatter_forward()
        self.t = t_new
        self.step_count += 1
        if before_move is not None:
            before_move()
        if self.motion is not None:
            with self.timers("mesh_motion"):
                if self.order == 2:  # the configuration u^n was computed on, for the next BDF2 feet
                    self.mesh_displacement_nm1.x.array[:] = self.mesh_displacement_n.x.array
                    self.mesh_displacement_n.x.array[:] = self.solve_displacement.x.array
                    self.mesh_displacement_prev.x.array[:] = self.motion.displacement.x.array
                    self._history_locators = (self.chars.locator, self._history_locators[0])
                base = self.solve_displacement.x.array if self.order == 2 else None
                w_P1 = self.motion.move(self.u_n, self.dt, self.t, alpha, base)
                self.mesh_velocity.interpolate(w_P1)
                if self.order == 2:
                    self.chars.locator = PointLocator(self.mesh)
                else:
                    self.chars.locator.update()

    def _check_finite(self, t):
        bad = not np.isfinite(self.w.x.array).all()
        reason = self.ksp.getConvergedReason()
        if self.comm.allreduce(bad or reason < 0, op=MPI.LOR):
            raise DivergenceError(f"step {self.step_count + 1} (t = {t:.6g}): non-finite solution "
                                  f"(linear solver reason {reason}); try a smaller time.dt or a finer mesh")

    # ------------------------------------------------------------------------------ checkpoints
    def _state_functions(self) -> dict:
        fns = {"u_n": self.u_n, "u_nm1": self.u_nm1, "p_n": self.p_n, "mesh_velocity": self.mesh_velocity}
        if self.model.micro_rotation:
            fns.update(omega_n=self.omega_n, omega_nm1=self.omega_nm1)
        if self.model.solid:
            fns["d_n"] = self.d_n
            if self.order == 2:
                fns["d_nm1"] = self.d_nm1
        if self.motion is not None and self.order == 2:
            fns["mesh_displacement_prev"] = self.mesh_displacement_prev
            fns["mesh_displacement_n"] = self.mesh_displacement_n
            fns["mesh_displacement_nm1"] = self.mesh_displacement_nm1
        if self.motion is not None:
            fns["mesh_displacement"] = self.motion.displacement
            fns["mesh_velocity_P1"] = self.motion.velocity
            if hasattr(self.motion, "solid_displacement"):
                fns["solid_displacement"] = self.motion.solid_displacement
        return fns

    def _reference_coordinates(self) -> dict:
        """Dof coordinates of every state function on the reference mesh (computed before it moves)."""
        if getattr(self, "_ref_coords", None) is None:
            self._ref_coords = {name: f.function_space.tabulate_dof_coordinates()[:, :2].copy()
                                for name, f in self._state_functions().items()}
        return self._ref_coords

    def state(self) -> dict:
        """The state the next steps depend on, as this rank's owned dofs keyed by their reference
        coordinates: a checkpoint independent of the partition (which is not deterministic)."""
        out = {"t": np.array(self.t), "step_count": np.array(self.step_count)}
        for name, f in self._state_functions().items():
            n = f.function_space.dofmap.index_map.size_local
            bs = f.function_space.dofmap.index_map_bs
            out[name + ".x"] = self._reference_coordinates()[name][:n]
            out[name + ".v"] = f.x.array.reshape(-1, bs)[:n]
        return out

    def restore(self, states: list[dict]):
        """Inverse of :meth:`state`, from the states of all ranks of the run that wrote them."""
        scale = 1e9 / max(1.0, float(np.abs(self.mesh.geometry.x).max()))
        ref = self._reference_coordinates()

        def keys(x):
            return [tuple(k) for k in np.rint(x * scale).astype(np.int64)]

        for name, f in self._state_functions().items():
            if any(name + ".v" not in s for s in states):
                raise InputError(f"--restart: the checkpoint has no {name!r} (another scene)")
            bs = f.function_space.dofmap.index_map_bs
            saved = dict(zip(keys(np.concatenate([s[name + ".x"] for s in states])),
                             np.concatenate([s[name + ".v"] for s in states]).reshape(-1, bs)))
            try:
                values = np.array([saved[k] for k in keys(ref[name])])
            except KeyError:
                raise InputError(f"--restart: checkpoint field {name!r} does not fit this mesh") from None
            f.x.array[:] = values.ravel()
        self.t, self.step_count = float(states[0]["t"]), int(states[0]["step_count"])
        sp = self.space  # the mixed solution (the Krylov solver's initial guess)
        self.w.x.array[sp.dofs("velocity")] = self.u_n.x.array
        self.w.x.array[sp.dofs("pressure")] = self.p_n.x.array
        if self.model.micro_rotation:
            self.w.x.array[sp.dofs("micro_rotation")] = self.omega_n.x.array
        if self.motion is not None:  # the mesh: reference + displacement
            m = self.motion
            self.mesh.geometry.x[:, :2] = m.X0 + m.displacement.x.array.reshape(-1, 2)[m.node_dof]
            self.chars.locator.update()
            if self.order == 2:
                self._history_locators = tuple(
                    PointLocator(self.mesh, m.X0 + f.x.array.reshape(-1, 2)[m.node_dof])
                    for f in (self.mesh_displacement_n, self.mesh_displacement_nm1))
        self.A, self._alpha_of_A = None, None

    # ----------------------------------------------------------------------------------- sizes
    def num_dofs(self) -> dict:
        out = {}
        for name in self.space.names:
            V = self.space.space(name)
            out[name] = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        out["total"] = sum(out.values())
        return out


def _pad(v):
    """(n, 2) → (n, 3) with z = 0 (points and displacements in dolfinx are 3D)."""
    return np.hstack([v, np.zeros((len(v), 1))]) if np.ndim(v) == 2 and v.shape[1] == 2 else v
