"""The ``solver`` section: the linear solver of every step."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from .base import _Section


class Solver(_Section):
    """Linear solver: pressure penalty, MUMPS fill-reducing ordering, and LU reuse on moving meshes; or
    ``type: iterative``: FGMRES to ``krylov_rtol`` with a Schur fieldsplit preconditioner, ``amg`` on the
    velocity block (scheme/block_preconditioner.py): ``auto`` takes hypre BoomerAMG where this PETSc has it
    (Debian's), else GAMG (the wheel's), and the run log names it; the two give the same solution to the
    Krylov tolerance, BoomerAMG in fewer iterations on FSI (docs/performance.md). ``type: auto`` (the
    default) takes MUMPS for steady Newton and below the measured crossover, the iterative solver for the time
    steps of 3D scenes from ``linear_solver.AUTO_ITERATIVE_FROM`` unknowns; the run log says which and why.

    ``reuse_factorization``: when the matrix changes every step, keep the last MUMPS factorisation as the
    preconditioner of a GMRES solve (relative tolerance ``krylov_rtol``) and refactorise only when GMRES
    needs more than ``max_krylov_iterations`` iterations. Default (unset): on for the characteristics
    schemes on a moving mesh (the geometry changes a little per step), off for ale_bdf2 and
    generalized_alpha, whose convection changes the matrix more: measured on FSI3 L1 at δt = 0.005 in the
    developed flow, GMRES needed 10.7 iterations per step and refactorised on 46 % of the steps anyway, a
    solve phase of 0.129 s per step against 0.062 s for a numeric refactorisation every step
    (docs/performance.md).

    ``penalty``: the dimensionless ζ of the pressure penalty −ζ/(μ + μ_r) (p, p̃) over the fluid cells (seed
    eq. 31; p/μ ~ div u), used only when the velocity is prescribed on the whole boundary (no_slip, velocity,
    slip everywhere), where it fixes the pressure's constant (mean zero). A scene with a do_nothing, traction
    or outflow boundary has no penalty: its pressure is determined and its mass conserved for any μ. 0: no
    penalty anywhere (a closed box then has a singular pressure).

    ``petsc_options``: PETSc options without the leading dash, read after the defaults
    (``fieldsplit_primal_pc_gamg_threshold: 0.05``, ``ksp_monitor: ""``, ``mat_mumps_icntl_14: 200``); one PETSc
    did not use by the end of the first solve is an error (scheme/linear_solver.py).
    """

    penalty: float = Field(default=1e-10, ge=0)
    mumps_ordering: Literal["metis", "pord", "amd", "auto"] = "auto"
    reuse_factorization: bool | None = None
    krylov_rtol: float = Field(default=1e-10, gt=0, lt=1)
    max_krylov_iterations: int = Field(default=12, ge=1, le=10_000)
    type: Literal["auto", "direct", "iterative"] = "auto"
    amg: Literal["auto", "gamg", "hypre"] = "auto"  # the velocity block's multigrid (iterative; auto: hypre if any)
    max_iterations: int = Field(default=1000, ge=1, le=100_000)  # FGMRES iterations (iterative)
    petsc_options: dict[Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=200)],
                        str | int | float | bool] = Field(default_factory=dict)

    def reuses_factorization(self, moving_mesh: bool, nodal_convection: bool) -> bool:
        """Whether the kept LU preconditions GMRES (``reuse_factorization``, or its default for the scheme;
        ``nodal_convection``: the scheme is in config.NODAL_CONVECTION)."""
        if self.reuse_factorization is not None:
            return self.reuse_factorization and (moving_mesh or nodal_convection)
        return moving_mesh and not nodal_convection
