"""The ``solver`` section: the linear solver of every step."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from .base import _Section


class Solver(_Section):
    """Linear solver of every step: MUMPS (direct) or FGMRES with a Schur fieldsplit preconditioner
    (iterative, solvers/block_preconditioner.py); the run log says which was taken and why."""

    penalty: float = Field(default=1e-10, ge=0)
    """ζ of the pressure penalty −ζ/(μ + μ_r) (p, p̃) over the fluid cells (seed eq. 31; dimensionless, p/μ ~
    div u), used only when the velocity is prescribed on the whole boundary (no_slip, velocity, slip
    everywhere), where it fixes the pressure's constant (mean zero). A scene with a do_nothing, traction or
    pressure boundary has no penalty: its pressure is determined and its mass conserved for any μ. 0: no
    penalty anywhere (a closed box then has a singular pressure)."""
    mumps_ordering: Literal["metis", "pord", "amd", "auto"] = "auto"
    """MUMPS's fill-reducing ordering (``auto``: MUMPS chooses)."""
    reuse_factorization: bool | None = None
    """When the matrix changes every step, keep the last MUMPS factorisation as the preconditioner of a GMRES
    solve (to ``krylov_rtol``) and refactorise only when GMRES needs more than ``max_krylov_iterations``.
    null: on for the characteristics schemes on a moving mesh (the geometry changes a little per step), off
    for ale_bdf2 and generalized_alpha, whose matrix changes more (FSI3 L1 at δt = 0.005: 10.7 GMRES
    iterations per step and a refactorisation on 46 % of the steps anyway, 0.129 s per step against 0.062 s
    for a refactorisation every step; docs/perf_time_schemes.md,
    "BDF2 with the convection relative to the moving mesh (ale_bdf2): the FSI3 and CFD3 targets met")."""
    krylov_rtol: float = Field(default=1e-10, gt=0, lt=1)
    """Relative tolerance of the Krylov solves: GMRES with a kept factorisation, FGMRES of ``type:
    iterative``."""
    max_krylov_iterations: int = Field(default=12, ge=1, le=10_000)
    """With a kept factorisation: refactorise when GMRES needs more iterations than this."""
    type: Literal["auto", "direct", "iterative"] = "auto"
    """``direct``: MUMPS. ``iterative``: FGMRES to ``krylov_rtol`` with a Schur fieldsplit preconditioner, an
    AMG cycle on the velocity block. ``auto``: MUMPS for steady Newton and below the measured crossover, the
    iterative solver for the time steps of 3D scenes from ``linear_solver.AUTO_ITERATIVE_FROM`` unknowns."""
    amg: Literal["auto", "gamg", "hypre"] = "auto"  # the velocity block's multigrid (iterative; auto: hypre if any)
    """The velocity block's multigrid (iterative): ``hypre`` (BoomerAMG), ``gamg``, or ``auto``: BoomerAMG
    where this PETSc has it (Debian's), else GAMG (the wheel's; the run log names it). Both give the same
    solution to the Krylov tolerance, BoomerAMG in fewer iterations on FSI (docs/perf_linear_solvers.md,
    "Iterations under refinement and ranks")."""
    max_iterations: int = Field(default=1000, ge=1, le=100_000)  # FGMRES iterations (iterative)
    """Most FGMRES iterations of one solve (iterative)."""
    petsc_options: dict[Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=200)],
                        str | int | float | bool] = Field(default_factory=dict)
    """PETSc options without the leading dash, read after the defaults (``fieldsplit_primal_pc_gamg_threshold:
    0.05``, ``ksp_monitor: ""``, ``mat_mumps_icntl_14: 200``); one PETSc did not use by the end of the first
    solve is an error (solvers/linear_solver.py)."""

    def reuses_factorization(self, moving_mesh: bool, nodal_convection: bool) -> bool:
        """Whether the kept LU preconditions GMRES (``reuse_factorization``, or its default for the scheme;
        ``nodal_convection``: the scheme is in config.NODAL_CONVECTION)."""
        if self.reuse_factorization is not None:
            return self.reuse_factorization and (moving_mesh or nodal_convection)
        return moving_mesh and not nodal_convection
