"""What one scene solves, independent of the time scheme: the mixed space (spaces.py), the fields,
coefficients and residual of seed eqs. (31)–(32) (model.py), the Dirichlet data refreshed in time
(boundary.py) and the averaged normal of a slip boundary (slip_normal.py)."""
