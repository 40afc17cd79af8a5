"""Compiled (numba) kernels of the characteristics: barycentric point-in-cell tests and P2 evaluation.

Each kernel does, point by point, the same floating-point operations in the same order as the numpy
reference in location.py (``barycentric``, ``p2_basis``, ``combine``: products and sums written
out, no fast-math, no FMA contraction), so both paths give the same numbers. ``ENABLED`` is False when
numba cannot be imported or ``COSSERAT_FSI_NO_NUMBA=1``; location.py then uses numpy.

Compiled code is cached on disk (``cache=True``): in ``__pycache__`` next to this file, or, when the
package is installed read-only, in ``$NUMBA_CACHE_DIR`` (default here: ``<tmp>/cosserat_fsi-numba``).
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

_pycache = os.path.join(os.path.dirname(os.path.abspath(__file__)), "__pycache__")
if "NUMBA_CACHE_DIR" not in os.environ and not os.access(
        _pycache if os.path.isdir(_pycache) else os.path.dirname(_pycache), os.W_OK):
    # installed read-only (numba's own fallback, ~/.cache/numba, fails without a writable home)
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(tempfile.gettempdir(), "cosserat_fsi-numba")

ENABLED = os.environ.get("COSSERAT_FSI_NO_NUMBA", "0") in ("", "0")
try:
    if not ENABLED:
        raise ImportError
    import numba
except ImportError:  # the numpy path of location.py is used
    numba = None
    ENABLED = False

if numba is not None and os.environ.get("NUMBA_CACHE_DIR") and not numba.config.CACHE_DIR:
    numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]  # numba was imported before the variable was set


def jit(fn):
    return numba.njit(cache=True, nogil=True, error_model="numpy")(fn) if numba is not None else fn


@jit
def first_inside(points, offsets, candidates, x0, Jinv, tol, cell_limit):
    """Per point, the first candidate cell (offsets/candidates: a CSR list per point) below
    ``cell_limit`` whose barycentric test passes (min(λ0, λ1, λ2) ≥ −tol), else −1."""
    n = points.shape[0]
    cells = np.full(n, -1, dtype=np.int32)
    for i in range(n):
        px, py = points[i, 0], points[i, 1]
        for j in range(offsets[i], offsets[i + 1]):
            c = candidates[j]
            if c >= cell_limit:
                continue
            dx, dy = px - x0[c, 0], py - x0[c, 1]
            l1 = Jinv[c, 0] * dx + Jinv[c, 1] * dy
            l2 = Jinv[c, 2] * dx + Jinv[c, 3] * dy
            if min(min(l1, l2), 1.0 - l1 - l2) >= -tol:
                cells[i] = c
                break
    return cells


@jit
def _walk_one(px, py, c, x0, Jinv, neighbours, tol, cell_limit, max_steps):
    """``walk`` for one point (px, py) from cell c: (the cell found or −1, its λ0, λ1, λ2 there)."""
    for _ in range(max_steps):
        dx, dy = px - x0[c, 0], py - x0[c, 1]
        l1 = Jinv[c, 0] * dx + Jinv[c, 1] * dy
        l2 = Jinv[c, 2] * dx + Jinv[c, 3] * dy
        l0 = 1.0 - l1 - l2
        if min(min(l1, l2), l0) >= -tol:
            return (c if c < cell_limit else -1), l0, l1, l2
        k = 0 if l0 <= l1 and l0 <= l2 else (1 if l1 <= l2 else 2)
        c = neighbours[c, k]
        if c < 0:
            return -1, l0, l1, l2
    return -1, 0.0, 0.0, 0.0


@jit
def walk(points, start, x0, Jinv, neighbours, tol, cell_limit, max_steps):
    """Per point, a cell containing it found by walking from ``start`` (the hint cell) towards it:
    test the barycentric coordinates (min(λ0, λ1, λ2) ≥ −tol: found), else cross the edge opposite the
    most negative λ_i into ``neighbours[c, i]``. −1 when the walk reaches a boundary of the local mesh
    (domain or ghost layer), does not arrive within ``max_steps`` or ends in a cell at or above
    ``cell_limit``: the caller then asks the bounding-box tree. The first test (in the hint cell) is
    the numpy path's hint test."""
    n = points.shape[0]
    cells = np.full(n, -1, dtype=np.int32)
    for i in range(n):
        cells[i] = _walk_one(points[i, 0], points[i, 1], start[i], x0, Jinv, neighbours, tol, cell_limit,
                             max_steps)[0]
    return cells


@jit
def _basis_l(l0, l1, l2):
    """The six P2 basis functions at barycentric coordinates (λ0, λ1, λ2): ``p2_basis``."""
    return (l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l1 * l2, 4 * l0 * l2, 4 * l0 * l1)


@jit
def _basis(px, py, c, x0, Jinv):
    """The six P2 basis functions of cell c at (px, py): ``barycentric`` then ``p2_basis``."""
    dx, dy = px - x0[c, 0], py - x0[c, 1]
    l1 = Jinv[c, 0] * dx + Jinv[c, 1] * dy
    l2 = Jinv[c, 2] * dx + Jinv[c, 3] * dy
    return _basis_l(1.0 - l1 - l2, l1, l2)


@jit
def _combine(p, values, d, b):
    """Σ_k φ_k c_k summed in k order from 0.0, as numpy's row sum; ``d``: the six dofs × bs, ``b``: the
    component."""
    return (((((0.0 + p[0] * values[d[0] + b]) + p[1] * values[d[1] + b]) + p[2] * values[d[2] + b])
              + p[3] * values[d[3] + b]) + p[4] * values[d[4] + b]) + p[5] * values[d[5] + b]


@jit
def _p2_values_bs(points, cells, x0, Jinv, dofs, values, bs):
    n = points.shape[0]
    out = np.zeros((n, bs))
    for i in range(n):
        c = cells[i]
        if c < 0:
            continue
        p = _basis(points[i, 0], points[i, 1], c, x0, Jinv)
        d = (dofs[c, 0] * bs, dofs[c, 1] * bs, dofs[c, 2] * bs, dofs[c, 3] * bs, dofs[c, 4] * bs, dofs[c, 5] * bs)
        for b in range(bs):
            out[i, b] = _combine(p, values, d, b)
    return out


@jit
def _p2_values_1(points, cells, x0, Jinv, dofs, values):
    n = points.shape[0]
    out = np.zeros((n, 1))
    for i in range(n):
        c = cells[i]
        if c < 0:
            continue
        p = _basis(points[i, 0], points[i, 1], c, x0, Jinv)
        d = (dofs[c, 0], dofs[c, 1], dofs[c, 2], dofs[c, 3], dofs[c, 4], dofs[c, 5])
        out[i, 0] = _combine(p, values, d, 0)
    return out


@jit
def _p2_values_2(points, cells, x0, Jinv, dofs, values):
    n = points.shape[0]
    out = np.zeros((n, 2))
    for i in range(n):
        c = cells[i]
        if c < 0:
            continue
        p = _basis(points[i, 0], points[i, 1], c, x0, Jinv)
        d = (2 * dofs[c, 0], 2 * dofs[c, 1], 2 * dofs[c, 2], 2 * dofs[c, 3], 2 * dofs[c, 4], 2 * dofs[c, 5])
        out[i, 0] = _combine(p, values, d, 0)
        out[i, 1] = _combine(p, values, d, 1)
    return out


def p2_values(points, cells, x0, Jinv, dofs, values, bs: int) -> np.ndarray:
    """Values (n, bs) of the P2 field with local coefficients ``values`` (flat, blocked by ``bs``) at
    points in known cells: Σ_k φ_k(λ) c_k, φ as in ``location.p2_basis``, summed in k order.
    Zeros where the cell is −1. Scalar and 2-vector fields have kernels of their own (a fixed block
    size makes them ≈ 1.5–2× faster)."""
    if bs == 1:
        return _p2_values_1(points, cells, x0, Jinv, dofs, values)
    if bs == 2:
        return _p2_values_2(points, cells, x0, Jinv, dofs, values)
    return _p2_values_bs(points, cells, x0, Jinv, dofs, values, bs)


@jit
def _dofs6(dofs, c, bs):
    return (dofs[c, 0] * bs, dofs[c, 1] * bs, dofs[c, 2] * bs, dofs[c, 3] * bs, dofs[c, 4] * bs, dofs[c, 5] * bs)


@jit
def _coef(values, d, b):
    """The six coefficients of component b at the (blocked) dofs ``d``."""
    return (values[d[0] + b], values[d[1] + b], values[d[2] + b], values[d[3] + b], values[d[4] + b], values[d[5] + b])


@jit
def _combine2(a, b, e1, e2):
    """e₁a_k − e₂b_k for the six coefficients (numpy's e1 * a − e2 * b, element by element)."""
    return (e1 * a[0] - e2 * b[0], e1 * a[1] - e2 * b[1], e1 * a[2] - e2 * b[2], e1 * a[3] - e2 * b[3],
            e1 * a[4] - e2 * b[4], e1 * a[5] - e2 * b[5])


@jit
def _sum6(p, a):
    """Σ_k p_k a_k in k order from 0.0: ``_combine`` with the coefficients at hand."""
    return (((((0.0 + p[0] * a[0]) + p[1] * a[1]) + p[2] * a[2]) + p[3] * a[3]) + p[4] * a[4]) + p[5] * a[5]


@jit
def _vector_at(p, k, c, here, values, dofs):
    """Both components of a P2 2-vector at basis values p in cell k (``here``: its coefficients in c)."""
    if k == c:
        return _sum6(p, here[0]), _sum6(p, here[1])
    d = _dofs6(dofs, k, 2)
    return _sum6(p, _coef(values, d, 0)), _sum6(p, _coef(values, d, 1))


@jit
def _scalar_at(p, k, c, here, values, dofs):
    if k == c:
        return _sum6(p, here)
    return _sum6(p, _coef(values, _dofs6(dofs, k, 1), 0))


@jit
def at_reference_points(phi, dofs, values, bs, n_cells):
    """Values (n_cells·nq, bs) of a P2 field at the same reference points ``phi`` (nq, 6 basis values)
    of every cell: Σ_k φ_k c_k in k order from 0.0 (``BackTrackingNodes.at_quadrature_nodes``)."""
    nq = phi.shape[0]
    out = np.empty((n_cells * nq, bs))
    for c in range(n_cells):
        d = _dofs6(dofs, c, bs)
        for b in range(bs):
            a = _coef(values, d, b)
            for q in range(nq):
                out[c * nq + q, b] = _sum6((phi[q, 0], phi[q, 1], phi[q, 2], phi[q, 3], phi[q, 4], phi[q, 5]), a)
    return out


@jit
def bdf2_quadrature(x, nq, phi, moving, steps, tol, max_steps, loc_n, loc_nm1, neighbours,
                    dofs_u, u_n, u_nm1, dofs_w, w_n, w_nm1, with_w, qdofs_u, out_u, qdofs_w, out_w):
    """The BDF2 history α h = a₁ f^n(x − δt u*) − a₂ f^{n−1}(x − δt₂ u*), u* = e₁u^n − e₂u^{n−1}, with
    ``steps`` = (δt, δt₂, e₁, e₂, a₁, a₂) (variable_step.BdfWeights; (δt, 2δt, 2, 1, 2, ½) at constant steps), at the
    quadrature points x (cell-major: point i is point i % nq of cell i // nq), for f = u (2-vector) and,
    ``with_w``, ω (scalar), written into the quadrature functions' arrays ``out_u[2 qdofs_u[i] + b]``,
    ``out_w[qdofs_w[i]]``: the operations of histories.py's numpy path, in its order.

    u^n, u^{n−1} at x: Σ_k φ_k(ξ_q) c_k with the reference basis ``phi`` (nq, 6) on a fixed mesh; on a
    moving mesh (``moving``) at x located by a walk from its cell in the configurations ``loc_n``,
    ``loc_nm1`` ((x0, J⁻¹) of ``PointLocator``) the fields were computed on. The feet are located by a
    walk from the point's cell in ``loc_n`` (f^n) and ``loc_nm1`` (f^{n−1}), the basis taken from the
    walk's last barycentric coordinates, the coefficients of the point's own cell loaded once per cell.
    On a fixed mesh u* is Σ_k φ_k (e₁c^n_k − e₂c^{n−1}_k), as histories.py's numpy path computes it.
    Returns (status, u*): status 0 = done, 1 = a foot not reached by a walk (u* set there only), 2 = x
    not reached in an earlier configuration (moving mesh): the caller does those on the general path."""
    n = x.shape[0]
    status = np.zeros(n, dtype=np.int8)
    u_star = np.empty((n, 2))
    x0a, Ja = loc_n
    x0b, Jb = loc_nm1
    big = np.iinfo(np.int32).max
    dt, dt2, e1, e2, h1, h2 = steps
    for c in range(n // nq):
        d = _dofs6(dofs_u, c, 2)
        a = (_coef(u_n, d, 0), _coef(u_n, d, 1))  # u^n and u^{n−1} in this cell
        b = (_coef(u_nm1, d, 0), _coef(u_nm1, d, 1))
        e = _dofs6(dofs_w, c, 1)
        wa, wb = _coef(w_n, e, 0), _coef(w_nm1, e, 0)
        if not moving:  # u* = 2u^n − u^{n−1} combined coefficient by coefficient, then summed once
            sa = (_combine2(a[0], b[0], e1, e2), _combine2(a[1], b[1], e1, e2))
        for q in range(nq):
            i = c * nq + q
            px, py = x[i, 0], x[i, 1]
            if moving:
                ca, l0, l1, l2 = _walk_one(px, py, c, x0a, Ja, neighbours, tol, big, max_steps)
                cb, m0, m1, m2 = _walk_one(px, py, c, x0b, Jb, neighbours, tol, big, max_steps)
                if ca < 0 or cb < 0:
                    status[i] = 2
                    continue
                un0, un1 = _vector_at(_basis_l(l0, l1, l2), ca, c, a, u_n, dofs_u)
                um0, um1 = _vector_at(_basis_l(m0, m1, m2), cb, c, b, u_nm1, dofs_u)
            else:
                p = (phi[q, 0], phi[q, 1], phi[q, 2], phi[q, 3], phi[q, 4], phi[q, 5])
            if moving:
                s0, s1 = e1 * un0 - e2 * um0, e1 * un1 - e2 * um1
            else:
                s0, s1 = _sum6(p, sa[0]), _sum6(p, sa[1])
            f1x, f1y = px - dt * s0, py - dt * s1
            f2x, f2y = px - dt2 * s0, py - dt2 * s1
            c1, l0, l1, l2 = _walk_one(f1x, f1y, c, x0a, Ja, neighbours, tol, big, max_steps)
            c2, m0, m1, m2 = _walk_one(f2x, f2y, c, x0b, Jb, neighbours, tol, big, max_steps)
            if c1 < 0 or c2 < 0:
                status[i] = 1
                u_star[i, 0], u_star[i, 1] = s0, s1
                continue
            p1, p2 = _basis_l(l0, l1, l2), _basis_l(m0, m1, m2)
            v10, v11 = _vector_at(p1, c1, c, a, u_n, dofs_u)
            v20, v21 = _vector_at(p2, c2, c, b, u_nm1, dofs_u)
            o = 2 * qdofs_u[i]
            out_u[o] = h1 * v10 - h2 * v20
            out_u[o + 1] = h1 * v11 - h2 * v21
            if with_w:
                out_w[qdofs_w[i]] = (h1 * _scalar_at(p1, c1, c, wa, w_n, dofs_w)
                                     - h2 * _scalar_at(p2, c2, c, wb, w_nm1, dofs_w))
    return status, u_star


def warm_up() -> None:
    """Compile (or load from the cache) every kernel for the argument types location.py passes
    (writeable and read-only point and cell arrays: quadrature nodes are read-only)."""
    if not ENABLED:
        return
    x0, Jinv = np.zeros((1, 2)), np.array([[1.0, 0.0, 0.0, 1.0]])
    neighbours, dofs = np.full((1, 3), -1, dtype=np.int32), np.zeros((1, 6), dtype=np.int32)
    for readonly in (False, True):
        pts, cells = np.zeros((1, 3)), np.zeros(1, dtype=np.int32)
        pts.flags.writeable = cells.flags.writeable = not readonly
        for offsets in (np.array([0, 1], dtype=np.int32), np.array([0, 1], dtype=np.int64)):
            first_inside(pts, offsets, np.zeros(1, dtype=np.int32), x0, Jinv, 1e-10, 1)
        walk(pts, cells, x0, Jinv, neighbours, 1e-10, 1, 8)
        for bs in (1, 2, 3):
            p2_values(pts, cells, x0, Jinv, dofs, np.zeros(6 * bs), bs)
        qdofs = np.zeros(1, dtype=np.int32)
        steps = (0.1, 0.2, 2.0, 1.0, 2.0, 0.5)
        bdf2_quadrature(pts, 1, np.zeros((1, 6)), False, steps, 1e-10, 8, (x0, Jinv), (x0, Jinv), neighbours,
                        dofs, np.zeros(12), np.zeros(12), dofs, np.zeros(6), np.zeros(6), False, qdofs,
                        np.zeros(2), qdofs, np.zeros(1))
