"""The algebra of a step: the linear solver (linear_solver.py: MUMPS, the kept factorisation, or FGMRES),
the iterative solver's block preconditioner (block_preconditioner.py) with its pressure matrices
(pressure_matrices.py) and its steady Newton variant (oseen_preconditioner.py), and Newton's method
(newton.py)."""
