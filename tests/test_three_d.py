"""Three dimensions: the vector micro-rotation, λ₂ ∇(∇·ω), the vector coupling 2μ_r curl u − 4μ_r ω.

Steady equations (seed eqs. 31–32 with d = 3, ∂/∂t = 0), solved by the steady Newton solver on the
``cube`` geometry (structured tetrahedra, 2 / 4 / 8 divisions per side at levels 0 / 1 / 2):

    ρ (u·∇)u = −∇p + (μ + μ_r) Δu + 2 μ_r curl ω + f,                         div u = 0,
    ρ I (u·∇)ω = λ₁ Δω + λ₂ ∇(div ω) − 4 μ_r ω + 2 μ_r curl u + g.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.app.verdict import compare_with_reference
from cosserat_fsi.config import validate_scene
from cosserat_fsi.exact import NP, UFL, MicropolarPoiseuille
from cosserat_fsi.observables import Observables
from cosserat_fsi.physics.kinematics import spin
from cosserat_fsi.points.location import probe
from cosserat_fsi.simulation import Simulation

import dolfinx
import ufl

PARAMS = {"rho": 1.0, "mu": 1.0, "mu_r": 0.5, "lambda1": 1.0, "lambda2": 0.7, "inertia": 1.0}


class Manufactured3D:
    """On [0, 1]³: u = a (sin πy cos πz, sin πz cos πx, sin πx cos πy) (each component independent of its
    own coordinate: div u = 0), ω = (sin πx cos πy, sin πy cos πz, sin πz cos πx) (div ω ≠ 0, so λ₂ acts),
    p = cos πx cos πy cos πz (zero mean). The sources f, g are the strong equations applied to them,
    differentiated by UFL (exact at the quadrature points)."""

    def __init__(self, a=1.0, **params):
        self.a, self.params = a, params

    def velocity(self, x, t, lib=np):
        s, c, a = lib.sin, lib.cos, self.a
        X, Y, Z = np.pi * x[0], np.pi * x[1], np.pi * x[2]
        parts = (a * s(Y) * c(Z), a * s(Z) * c(X), a * s(X) * c(Y))
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def micro_rotation(self, x, t, lib=np):
        s, c = lib.sin, lib.cos
        X, Y, Z = np.pi * x[0], np.pi * x[1], np.pi * x[2]
        parts = (s(X) * c(Y), s(Y) * c(Z), s(Z) * c(X))
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def pressure(self, x, t, lib=np):
        return lib.cos(np.pi * x[0]) * lib.cos(np.pi * x[1]) * lib.cos(np.pi * x[2])

    def sources(self, X) -> dict:
        k = self.params
        u, w, p = self.velocity(X, 0, ufl), self.micro_rotation(X, 0, ufl), self.pressure(X, 0, ufl)
        f = (k["rho"] * ufl.grad(u) * u + ufl.grad(p) - (k["mu"] + k["mu_r"]) * ufl.div(ufl.grad(u))
             - 2 * k["mu_r"] * ufl.curl(w))
        g = (k["rho"] * k["inertia"] * ufl.grad(w) * u - k["lambda1"] * ufl.div(ufl.grad(w))
             - k["lambda2"] * ufl.grad(ufl.div(w)) + 4 * k["mu_r"] * w - 2 * k["mu_r"] * ufl.curl(u))
        return {"body_force": f, "body_couple": g}


def _scene(level, **overrides):
    sections = {"geometry": {"name": "cube", "level": level},
                "fluid": {"rho": PARAMS["rho"], "mu": PARAMS["mu"]},
                "micropolar": {k: PARAMS[k] for k in ("mu_r", "lambda1", "lambda2", "inertia")},
                "time": {"scheme": "steady"}}
    sections.update(overrides)
    return validate_scene(sections)


def _l2(comm, mesh, expr):
    value = dolfinx.fem.assemble_scalar(compat.form(ufl.inner(expr, expr) * ufl.dx(domain=mesh)))
    return np.sqrt(comm.allreduce(value, op=MPI.SUM))


def _errors(level, exact, comm=MPI.COMM_WORLD):
    scene = _scene(level)
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm, exact=exact)
    sim.run(1)
    assert sim.report.converged, sim.report.message
    X = ufl.SpatialCoordinate(mesh)
    p_mean = comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(sim.pressure * ufl.dx(domain=mesh))),
                            op=MPI.SUM)
    return (_l2(comm, mesh, sim.velocity - exact.velocity(X, 0, ufl)),
            _l2(comm, mesh, sim.micro_rotation - exact.micro_rotation(X, 0, ufl)),
            _l2(comm, mesh, sim.pressure - p_mean - exact.pressure(X, 0, ufl)))


def test_spin_is_the_curl_tensor():
    """div W(ω) = curl ω for the 3D spin tensor (so T = … + 2μ_r W gives the 2μ_r curl ω of eq. 31)."""
    mesh = dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 1, 1, 1)
    X = ufl.SpatialCoordinate(mesh)
    w = Manufactured3D().micro_rotation(X, 0, ufl)
    diff = ufl.div(spin(w)) - ufl.curl(w)  # ufl.div of a matrix contracts its last index: ∂_j W_ij
    assert _l2(MPI.COMM_WORLD, mesh, diff) < 1e-12


@pytest.mark.slow
def test_manufactured_3d_rates():
    """All micropolar terms active (λ₂ included), convection by the steady Newton solver, levels 0/1/2
    (2, 4, 8 divisions per side). Measured (both stacks, docs/validation_3d.md): ‖u − u_ex‖ 2.72e-2, 7.72e-3,
    1.03e-3 (rates 1.82, 2.91), ‖ω − ω_ex‖ 2.75e-2, 7.94e-3, 1.05e-3 (1.80, 2.92), ‖p − p_ex‖ 0.224, 8.13e-2,
    1.40e-2 (1.46, 2.53); level 0 (2 divisions) is pre-asymptotic. Asserted: rates > 2.7 (u, ω) and > 1.7
    (p) over the last pair, errors decreasing at every level."""
    exact = Manufactured3D(**PARAMS)
    errors = np.array([_errors(level, exact) for level in (0, 1, 2)])
    rates = np.log2(errors[:-1] / errors[1:])
    print("errors", errors.tolist(), "rates", rates.tolist())
    assert np.all(rates > 0.5), (errors, rates)
    assert rates[-1, 0] > 2.7 and rates[-1, 1] > 2.7 and rates[-1, 2] > 1.7, (errors, rates)


def _has_pc(kind: str) -> bool:
    from petsc4py import PETSc

    pc = PETSc.PC().create(MPI.COMM_SELF)
    try:
        pc.setType(kind)
        return True
    except PETSc.Error:
        return False
    finally:
        pc.destroy()


@pytest.mark.parametrize("case, amg", [("steady-3d", "gamg"), ("characteristics-2d", "gamg"), ("steady-3d", "hypre")])
def test_iterative_solver_agrees_with_mumps(case, amg):
    """``solver.type: iterative`` (FGMRES, Schur fieldsplit, AMG on the velocity and micro-rotation block,
    scaled pressure mass matrix on the Schur complement) gives MUMPS's solution to the Krylov tolerance
    (1e-10): the 3D manufactured problem (level 1, steady Newton; measured differences 3e-14 in u and ω,
    3e-12 in p, ≈ 300 FGMRES iterations over the two Newton steps) and two BDF2 steps of a 2D micropolar
    cavity (1–2e-9 in u, ω, 5–7e-9 in p, 76 iterations). hypre exists in the Debian PETSc only."""
    if amg == "hypre" and not _has_pc("hypre"):
        pytest.skip("this PETSc has no hypre")
    comm = MPI.COMM_WORLD
    if case == "steady-3d":
        exact = Manufactured3D(**PARAMS)
        krylov = {"krylov_rtol": 1e-10, "amg": amg}  # refused with MUMPS
        scenes = [_scene(1, solver={"type": kind, **(krylov if kind == "iterative" else {})})
                  for kind in ("direct", "iterative")]
    else:
        exact = None
        scenes = [validate_scene({"geometry": {"name": "square", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.1},
                                  "micropolar": {"mu_r": 0.1, "lambda1": 0.1}, "inflow": {"u_mean": 1.0},
                                  "time": {"dt": 0.1, "t_end": 0.2, "scheme": "characteristics2"},
                                  "solver": {"type": kind, "krylov_rtol": 1e-10}})
                  for kind in ("direct", "iterative")]
    mesh, ct, ft, _ = load_mesh(scenes[0], comm)
    fields = []
    for scene in scenes:
        sim = Simulation(scene, mesh, ct, ft, comm, exact=exact)
        sim.run(sim.steps_to(scene.time.t_end) if scene.time.scheme != "steady" else 1)
        fields.append((sim.velocity.copy(), sim.micro_rotation.copy(), sim.pressure.copy()))
        iterations = getattr(getattr(sim.stepper, "solver", None) or getattr(sim.stepper.newton, "linear_solver", None),
                             "krylov_iterations", None)
        print(case, scene.solver.type, "krylov iterations", iterations)
    differences = []
    for name, direct, iterative in zip(("u", "omega", "p"), *fields):
        diff = direct - iterative
        if name == "p":  # the pure-Dirichlet pressure's constant is fixed by the penalty only: compare modulo it
            volume = comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)
            diff = diff - comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(diff * ufl.dx)), op=MPI.SUM) / volume
        differences.append(_l2(comm, mesh, diff) / _l2(comm, mesh, direct))
    print(case, "relative differences u, omega, p", differences)
    assert max(differences) < 1e-7, differences


class Poiseuille3D:
    """The 2D micropolar Poiseuille solution (exact.MicropolarPoiseuille) in the slab of a duct:
    u = (u(y), 0, 0), ω = (0, 0, ω(y)), p = G (L − x); div ω = 0, so λ₂ does not act."""

    def __init__(self, **kw):
        self.plane = MicropolarPoiseuille(**kw)

    def velocity(self, x, t, lib=np):
        u = self.plane.profiles(x, UFL if lib is ufl else NP)[0]
        return ufl.as_vector((u, 0, 0)) if lib is ufl else np.vstack([u, 0 * u, 0 * u])

    def micro_rotation(self, x, t, lib=np):
        w = self.plane.profiles(x, UFL if lib is ufl else NP)[1]
        return ufl.as_vector((0, 0, w)) if lib is ufl else np.vstack([0 * w, 0 * w, w])


@pytest.mark.slow
def test_micropolar_poiseuille_in_a_3d_slab():
    """The 2D micropolar Poiseuille flow (G = h = μ = μ_r = λ₁ = 1, λ₂ = 0.5) in a duct 2 × 2 × 1 with the
    exact data on the inlet, the walls y = 0, 2 and the side faces z = 0, 1, do-nothing outlet, steady Newton,
    levels 1/2 (4 × 4 × 2 and 8 × 8 × 4 hexahedra of 6 tetrahedra). Measured: relative L² errors of u 1.6e-3,
    2.1e-4 (rate 2.95), of ω 1.8e-2, 2.3e-3 (3.01); outlet flow rate per unit width 0.37076360, 0.37072354
    against the 2D exact 0.37072084 (tests/test_micropolar.py)."""
    comm = MPI.COMM_WORLD
    exact = Poiseuille3D(G=1.0, h=1.0, mu=1.0, mu_r=1.0, lambda1=1.0, L=2.0)
    errors, flow = [], []
    for level in (1, 2):
        geometry = {"name": "duct", "level": level, "length": 2.0, "height": 2.0, "width": 1.0}
        scene = validate_scene({"geometry": geometry,
                                "fluid": {"rho": 1.0, "mu": 1.0},
                                "micropolar": {"mu_r": 1.0, "lambda1": 1.0, "lambda2": 0.5, "inertia": 1.0},
                                "time": {"scheme": "steady"}})
        mesh, ct, ft, _ = load_mesh(scene, comm)
        sim = Simulation(scene, mesh, ct, ft, comm, exact=exact)
        sim.run(1)
        assert sim.report.converged, sim.report.message
        X = ufl.SpatialCoordinate(mesh)
        norm_u = _l2(comm, mesh, exact.velocity(X, 0, ufl))
        norm_w = _l2(comm, mesh, exact.micro_rotation(X, 0, ufl))
        errors.append((_l2(comm, mesh, sim.velocity - exact.velocity(X, 0, ufl)) / norm_u,
                       _l2(comm, mesh, sim.micro_rotation - exact.micro_rotation(X, 0, ufl)) / norm_w))
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft)
        flow.append(comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(sim.velocity[0] * ds(2))), op=MPI.SUM))
    errors = np.array(errors)
    rates = np.log2(errors[0] / errors[1])
    print("relative errors", errors.tolist(), "rates", rates.tolist(), "flow rate per unit width", flow)
    assert np.all(rates > 2.5), (errors, rates)
    assert errors[-1, 0] < 3e-4 and errors[-1, 1] < 3e-3, errors
    assert abs(flow[-1] - 0.37072084) < 1e-5, flow


# recorded forces of schaefer_turek_3d level 0 (steady, Re 20; the z component changes none of them), per stack
# (each meshes with its own gmsh): drag, lift, drag_surface, lift_surface
ST3D_FORCES = {"0.5.2": (0.005005343358931408, 8.943793776510143e-06, 0.004778879984239796, -1.5854896766916636e-05),
               "0.11.0.post0": (0.005030156453757787, 4.292164989744879e-05, 0.004797445598509633,
                                7.648432211057119e-05)}


@pytest.mark.slow
def test_schaefer_turek_3d1z_coarse():
    """Schäfer–Turek 3D-1Z (cylinder in a square duct, Re 20), steady Newton + MUMPS on level 0 against Braack
    & Richter 2006 / FEAT3 (cosserat_fsi/data/three_d_references.yaml). Each stack meshes with its own gmsh:
    gmsh 4.8 (Debian; 38,873 dofs) gives c_D −1.31 %, c_L +16 %, Δp 0.16729; gmsh 4.15 (the wheel; 38,553
    dofs) c_D −0.82 %, c_L +457 %, Δp 0.16513. So c_D within 2 %; Δp within the benchmark's published interval
    [0.165, 0.175] (Schäfer & Turek 1996); the level-0 lift only bounded, 0 < c_L < 0.1 (it is ≈ 1e-3 of the
    drag and set by the coarse mesh's asymmetry: level 1 +9.8 %, level 2 +0.93 %, docs/validation_3d.md). ≈ 25 s.

    The force's three components: the columns drag, lift, side and their surface forms; drag and lift as
    recorded (to 1e-9 relative); the duct and the cylinder are symmetric in z about 0.205, so side ≈ 0:
    measured side / drag −2.2e-4 (Debian), +2.6e-4 (latest), side_surface / drag −2.7e-4, +1.5e-5 (the coarse
    mesh's asymmetry); asserted |side| < 1e-3 drag, both forms. The surface form within 6 % of the residual
    one (measured −4.5 %, −4.6 %)."""
    scene = validate_scene({"benchmark": "schaefer_turek_3d1z",
                            "geometry": {"name": "schaefer_turek_3d", "level": 0},
                            "fluid": {"rho": 1.0, "mu": 1e-3, "body_force": [0.0, 0.0, 0.0]},
                            "inflow": {"u_mean": 0.2, "ramp_time": 0.0}, "time": {"scheme": "steady"}})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, MPI.COMM_WORLD)
    obs = Observables(sim)
    forces = ["drag", "lift", "side", "drag_surface", "lift_surface", "side_surface"]
    assert [c for c in obs.columns if c in forces] == forces
    sim.run(sim.steps_to(scene.time.t_end))
    final = obs.evaluate()
    result = compare_with_reference(scene, {"final": final, "periodic": {}})
    assert abs(result["c_D"]["error"]) < 0.02, result["c_D"]
    assert 0.0 < result["c_L"]["value"] < 0.1, result["c_L"]
    assert 0.165 <= result["dp"]["value"] <= 0.175, result["dp"]
    recorded = ST3D_FORCES.get(dolfinx.__version__)
    if recorded is not None:
        got = [final[k] for k in ("drag", "lift", "drag_surface", "lift_surface")]
        assert np.allclose(got, recorded, rtol=1e-9, atol=1e-15), (got, recorded)
    drag = final["drag"]
    assert drag > 0 and abs(final["side"]) < 1e-3 * drag and abs(final["side_surface"]) < 1e-3 * drag, final
    assert abs(final["drag_surface"] / drag - 1) < 0.06, final  # the surface form, coarser


# ---------------------------------------------------------------------------------- time stepping in 3D
UNSTEADY = {"rho": 1.0, "mu": 0.1, "mu_r": 0.1, "lambda1": 0.1, "lambda2": 0.05, "inertia": 1.0}


class Unsteady3D:
    """On [0, π]³: u = cos t · U, U = (sin x (cos y − cos z), sin y (cos z − cos x), sin z (cos x − cos y))
    (div U = 0 and U·n = 0 on every face: no foot leaves the cube, so the boundary treatment of the feet
    does not enter), ω = (1 + ½ sin t) (sin y sin z, sin z sin x, sin x sin y), p = 0. The sources f, g are
    the unsteady equations (31)–(32) applied to them (UFL, with the problem's time constant t)."""

    time_dependent = True

    def __init__(self, **params):
        self.params = params

    @staticmethod
    def _U(x, lib):
        s, c = lib.sin, lib.cos
        return (s(x[0]) * (c(x[1]) - c(x[2])), s(x[1]) * (c(x[2]) - c(x[0])), s(x[2]) * (c(x[0]) - c(x[1])))

    @staticmethod
    def _W(x, lib):
        s = lib.sin
        return (s(x[1]) * s(x[2]), s(x[2]) * s(x[0]), s(x[0]) * s(x[1]))

    @staticmethod
    def _amplitudes(t, lib):
        """(F, F', G, G'): u = F U, ω = G W."""
        return lib.cos(t), -lib.sin(t), 1.0 + 0.5 * lib.sin(t), 0.5 * lib.cos(t)

    def velocity(self, x, t, lib=np):
        F = self._amplitudes(t, lib)[0]
        parts = [F * a for a in self._U(x, lib)]
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def micro_rotation(self, x, t, lib=np):
        G = self._amplitudes(t, lib)[2]
        parts = [G * a for a in self._W(x, lib)]
        return ufl.as_vector(parts) if lib is ufl else np.vstack(parts)

    def sources(self, X, t) -> dict:
        k = self.params
        F, dF, G, dG = self._amplitudes(t, ufl)
        U, W = ufl.as_vector(self._U(X, ufl)), ufl.as_vector(self._W(X, ufl))
        u, w = F * U, G * W
        f = (k["rho"] * (dF * U + ufl.grad(u) * u) - (k["mu"] + k["mu_r"]) * ufl.div(ufl.grad(u))
             - 2 * k["mu_r"] * ufl.curl(w))
        g = (k["rho"] * k["inertia"] * (dG * W + ufl.grad(w) * u) - k["lambda1"] * ufl.div(ufl.grad(w))
             - k["lambda2"] * ufl.grad(ufl.div(w)) + 4 * k["mu_r"] * w - 2 * k["mu_r"] * ufl.curl(u))
        return {"body_force": f, "body_couple": g}


def _unsteady(scheme, dt, t_end, comm=MPI.COMM_WORLD, level=1, mesh=None):
    """The unsteady 3D problem run to ``t_end``; ``mesh``: (mesh, cell tags, facet tags) to run on (the
    scene's, loaded, by default)."""
    scene = validate_scene({"geometry": {"name": "cube", "level": level, "length": float(np.pi)},
                            "fluid": {"rho": UNSTEADY["rho"], "mu": UNSTEADY["mu"]},
                            "micropolar": {k: UNSTEADY[k] for k in ("mu_r", "lambda1", "lambda2", "inertia")},
                            "time": {"dt": dt, "t_end": t_end, "scheme": scheme}})
    mesh, ct, ft = mesh or load_mesh(scene, comm)[:3]
    sim = Simulation(scene, mesh, ct, ft, comm, exact=Unsteady3D(**UNSTEADY))
    sim.run(sim.steps_to(t_end))
    return sim


@pytest.mark.slow
def test_time_order_3d_characteristics1():
    """Seed's first-order characteristics on tetrahedra (cube level 1, 384 cells, 4,499 dofs), T = 1,
    δt = 0.2, 0.1, 0.05. Measured (both stacks): ‖u − u_ex‖ 0.435, 0.229, 0.123 (rates 0.93, 0.90),
    ‖ω − ω_ex‖ 0.415, 0.226, 0.127 (0.88, 0.83). Asserted: rates within 0.25 of 1."""
    exact, T = Unsteady3D(**UNSTEADY), 1.0
    errors = []
    for dt in (0.2, 0.1, 0.05):
        sim = _unsteady("characteristics1", dt, T)
        X = ufl.SpatialCoordinate(sim.mesh)
        errors.append((_l2(sim.comm, sim.mesh, sim.velocity - exact.velocity(X, T, ufl)),
                       _l2(sim.comm, sim.mesh, sim.micro_rotation - exact.micro_rotation(X, T, ufl))))
    errors = np.array(errors)
    rates = np.log2(errors[:-1] / errors[1:])
    print("errors", errors.tolist(), "rates", rates.tolist())
    assert np.all(np.abs(rates - 1) < 0.25), (errors, rates)


@pytest.mark.slow
def test_time_order_3d_characteristics2():
    """BDF2 characteristics on tetrahedra (cube level 1), T = 1, δt = 0.2, 0.1, 0.05, 0.025. On this mesh
    the spatial error (‖u − u_ex‖ → 0.034) hides the time error from δt = 0.05 on, so the order is read
    from the differences of successive solutions on the same mesh (the spatial error cancels): measured
    ‖u_δt − u_δt/2‖ 6.85e-2, 1.46e-2, 3.54e-3 (rates 2.24, 2.04), ω 0.116, 3.32e-2, 1.00e-2 (1.80, 1.73:
    ω's start is pre-asymptotic). Against the exact solution: ‖u − u_ex‖ 0.098, 0.041, 0.035, 0.034.
    Asserted: u rates within 0.3 of 2, ω's mean rate > 1.6, the exact errors decreasing and < 0.04 (u)."""
    exact, T = Unsteady3D(**UNSTEADY), 1.0
    sims, errors, differences = [], [], []
    mesh = load_mesh(validate_scene({"geometry": {"name": "cube", "level": 1, "length": float(np.pi)},
                                     "fluid": {"rho": 1.0, "mu": 1.0}, "time": {"scheme": "steady"}}),
                     MPI.COMM_WORLD)[:3]
    for dt in (0.2, 0.1, 0.05, 0.025):  # on one mesh: the solutions are compared dof by dof
        sim = _unsteady("characteristics2", dt, T, mesh=mesh)
        X = ufl.SpatialCoordinate(sim.mesh)
        errors.append(_l2(sim.comm, sim.mesh, sim.velocity - exact.velocity(X, T, ufl)))
        if sims:
            previous = sims[-1]
            differences.append((_l2(sim.comm, sim.mesh, sim.velocity - previous.velocity),
                                _l2(sim.comm, sim.mesh, sim.micro_rotation - previous.micro_rotation)))
        sims = [sim]
    differences = np.array(differences)
    rates = np.log2(differences[:-1] / differences[1:])
    mean_w = np.log2(differences[0, 1] / differences[-1, 1]) / 2
    print("errors", errors, "differences", differences.tolist(), "rates", rates.tolist())
    assert np.all(np.abs(rates[:, 0] - 2) < 0.3) and mean_w > 1.6, (differences, rates)
    assert np.all(np.diff(errors) < 0) and errors[-1] < 0.04, errors


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", ["characteristics1", "characteristics2"])
@pytest.mark.two_ranks
def test_time_stepping_3d_serial_equals_parallel(scheme):
    """Three steps (δt = 0.1) of the unsteady 3D problem on COMM_WORLD (1 or 2 ranks) and on COMM_SELF:
    u, ω and p (modulo its constant: the cube has Dirichlet data all round) at probe points agree to 1e-8."""
    points = [[0.5, 1.0, 2.0], [1.5, 1.5, 1.5], [2.9, 0.3, 1.1], [0.05, 3.0, 0.2]]
    values = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        sim = _unsteady(scheme, 0.1, 0.3, comm)
        u, w, p = probe(sim.locator, [sim.velocity, sim.micro_rotation, sim.pressure], points, comm)
        values.append((u, w, p - p[1]))
    for name, parallel, serial in zip(("u", "omega", "p"), *values):
        assert np.abs(parallel - serial).max() < 1e-8 * max(1.0, np.abs(serial).max()), (name, parallel, serial)
