"""An energy-conserving and consistent derivative pair on irregular particles (set-up, once, in SciPy).

The leapfrog of SPEM, ε dEz/dt = D_E^x Hy - D_E^y Hx and μ dH/dt = (-D_H^y Ez, D_H^x Ez), conserves the
discrete energy W = ½ Σ_E ε V Ez² + ½ Σ_H μ V |H|² when, for each axis a,

    V_E D_E^a = -(V_H D_H^a)^T           on the E particles that are updated (summation by parts)      (1)

(D_E: rows of E over H, D_H: rows of H over E; V: the particles' volumes; held E particles, the perfect
conductor, are zero and drop out). Then the semi-discrete system is skew-adjoint, its spectrum imaginary,
and the leapfrog is stable below its step limit on any layout. FPM (Mendes 2010, eqs 2.30-2.35) on both sides is
exact for linear fields but satisfies (1) only on a uniform layout away from walls: on 30 %-jittered
particles its energy grows ~100x a period. The reverse choice, D_H := -V_H^-1 D_E^T V_E, conserves energy
but is not a derivative on jittered particles (the thesis's failure on non-uniform layouts, §5).

Here both hold. The unknowns are the entries of D_E on a pattern one shell wider than the FPM support
(``pattern_reach``) and the entries of D_H on the held columns (they multiply Ez = 0, so they only make the
H rows next to a wall consistent); D_H on the free columns is defined by (1). The constraints are linear
exactness of every row,

    Σ_j g_ij = 0,   Σ_j g_ij (x_j - x_i)_b = δ_ab           (E rows i, and H rows k through (1))     (2)

and among all pairs that satisfy them the one nearest the FPM pair (least squares in the entries) is
taken, d = d0 + δ with min |δ|² subject to C δ = r - C d0: the saddle-point system [[I, Cᵀ], [C, 0]] by
sparse LU (both axes share C). On a uniform interior FPM already satisfies (2) and (1) (it is Yee's
difference): only entries within ``BAND`` spacings of a violated constraint change (next to walls on a
uniform layout, everywhere on a jittered one), which keeps the solve small and the uniform interior's rows
at their 4 terms.

The order-2 pair (``order=2``) adds the quadratic moments Σ_j g_ij (x_j - x_i)_b (x_j - x_i)_c = 0 to (2),
on a pattern ``QUADRATIC_SHELL`` spacings beyond the support, in least squares (they and (1) cannot all hold on a
jittered layout); it lowers the jittered cavity's error from 0.63 % to 0.35 % (uniform 0.22 %), at a set-up cost
that grows fast with the layout (``bench/results/scene_studies.md``).

Units: coefficients in 1/m, volumes in m^dim; solved in float64 in units of the nominal spacing.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from warpfree.errors import ParameterError

__all__ = ["ConservativePair", "energy_conserving_pair", "pattern_reach"]

#: the pattern's radius beyond the FPM support (spacings): the next shell of the other set (at 1.58 Δ in
#: 2D, 1.5 Δ in 1D, against the nearest at 0.71 Δ and 0.5 Δ)
NEXT_SHELL = 0.6

#: the pattern's radius beyond the FPM support for the order-2 pair (spacings): its rows fit 6 moments in 2D
QUADRATIC_SHELL = 1.5

#: the weight w of the order-2 pair's quadratic moments, min |δ|² + w² Σ (quadratic moment)²: they cannot all hold
#: exactly with (1) (summation by parts would need the volumes to integrate cubic terms exactly, which a jittered
#: layout's do not), so they are met in least squares; the jittered cavity's error at w = 3, 10, 30, 100:
#: 0.38, 0.35, 0.37, 0.43 % (``bench/results/scene_studies.md``)
QUADRATIC_WEIGHT = 10.0

#: half-width (spacings) of the band around the violated constraints in which entries may change
BAND = 4.0

#: largest admitted constraint residual (the constraints are O(1)). The kernels see float32 positions and
#: coefficients: x/Δ carries a rounding of 6e-8·|x|/Δ (1.2e-5 at 200 spacings from the origin), so a residual
#: below this is rounding, not a violation (FPM next to a wall violates (1) by 0.1-1)
RESIDUAL_LIMIT = 1e-4


def pattern_reach(support: np.ndarray, spacing: np.ndarray, order: int = 1) -> np.ndarray:
    """Pattern radius per particle (m): its FPM support plus ``NEXT_SHELL`` spacings (``QUADRATIC_SHELL`` for the
    order-2 pair)."""
    return support + (NEXT_SHELL if order == 1 else QUADRATIC_SHELL) * spacing


class ConservativePair(NamedTuple):
    """The energy-conserving E/H operator pair: its per-axis matrices, the largest change from the FPM operators and the
    constraints' residual."""
    e_operator: list  # per axis, CSR (n_e, n_h), 1/m
    h_operator: list  # per axis, CSR (n_h, n_e), 1/m
    largest_change: float  # largest |entry change| from FPM, in 1/spacing
    residual: float  # largest constraint residual after the solve


def _pairs(query: np.ndarray, points: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(query index, point index) of all points within radius[q] of query q."""
    if query.shape[0] == 0 or points.shape[0] == 0:
        return np.zeros(0, int), np.zeros(0, int)
    hits = cKDTree(points).query_ball_point(query, radius)
    q = np.repeat(np.arange(query.shape[0]), [len(h) for h in hits])
    p = np.concatenate([np.asarray(h, dtype=int) for h in hits]) if q.size else np.zeros(0, int)
    return q, p


class _Constraints(NamedTuple):
    matrix: sp.csr_matrix  # C: rows = (2) for free E rows, then H rows; columns = the unknown entries
    start: list  # per axis, the FPM entries d0 (units of 1/spacing)
    rhs: list  # per axis, r
    e_row: np.ndarray  # entry -> E particle (the first m1 entries), H particle (the last m2)
    e_col: np.ndarray
    h_row: np.ndarray
    h_col: np.ndarray


def _moments(dx: np.ndarray, dim: int, order: int = 1) -> list:
    """The monomials a row must reproduce (lengths in spacings): 1 and dx_b; for ``order`` 2 also dx_b dx_c
    (b <= c), whose derivative at the row's own particle is zero."""
    out = [np.ones(dx.shape[0])] + [dx[:, b] for b in range(dim)]
    if order == 2:
        out += [dx[:, b] * dx[:, c] for b in range(dim) for c in range(b, dim)]
    return out


def _constraints(e_position, h_position, dim, held, e_volume, h_volume, e_operator, h_operator, e_reach, h_reach,
                 spacing, axes, order: int = 1) -> _Constraints:
    """The linear system C d = r of (1)-(2) in the unknown entries d (module docstring), lengths in spacings."""
    xe, xh = e_position[:, :dim] / spacing, h_position[:, :dim] / spacing
    free = np.flatnonzero(~held)
    held_idx = np.flatnonzero(held)
    n_e, n_h = xe.shape[0], xh.shape[0]
    # pattern: free E rows over H (m1 entries), H rows over held E (m2 entries)
    q, ej_h = _pairs(xe[free], xh, e_reach[free] / spacing)
    ei = free[q]
    hk, q2 = _pairs(xh, xe[held_idx], h_reach / spacing)
    el = held_idx[q2]
    m1, m2 = ei.size, hk.size
    e_moments = _moments(xh[ej_h] - xe[ei], dim, order)
    h_moments = _moments(xe[ei] - xh[ej_h], dim, order)
    held_moments = _moments(xe[el] - xh[hk], dim, order)
    nc = len(e_moments)
    row_of_free = np.full(n_e, -1)
    row_of_free[free] = np.arange(free.size)
    off = free.size * nc
    rows, cols, vals = [], [], []
    for b in range(nc):  # E rows: Σ g = 0, Σ g (x_j - x_i)_b 
        rows.append(row_of_free[ei] * nc + b)
        cols.append(np.arange(m1))
        vals.append(e_moments[b])
    ratio = e_volume[ei] / h_volume[ej_h]
    for b in range(nc):  # H rows through (1): D_H[k, l] = -(V_l/V_k) D_E[l, k] on free l, h_kl on held l
        rows.append(off + ej_h * nc + b)
        cols.append(np.arange(m1))
        vals.append(-ratio * h_moments[b])
        rows.append(off + hk * nc + b)
        cols.append(m1 + np.arange(m2))
        vals.append(held_moments[b])
    matrix = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(off + n_h * nc, m1 + m2))
    start, rhs = [], []
    for a in axes:
        start.append(np.concatenate([np.asarray(e_operator[a][ei, ej_h]).ravel(),
                                     np.asarray(h_operator[a][hk, el]).ravel()]) * spacing)
        r = np.zeros(off + n_h * nc)
        r[1 + a:off:nc] = 1.0
        r[off + 1 + a::nc] = 1.0
        rhs.append(r)
    return _Constraints(matrix, start, rhs, ei, ej_h, hk, el)


def energy_conserving_pair(e_position: np.ndarray, h_position: np.ndarray, dim: int, held: np.ndarray,
                           e_volume: np.ndarray, h_volume: np.ndarray, e_operator: list, h_operator: list,
                           e_reach: np.ndarray, h_reach: np.ndarray, spacing: float,
                           axes: tuple[int, ...] | None = None, order: int = 1) -> ConservativePair:
    """The pair nearest the FPM pair (``e_operator``, ``h_operator``: per axis CSR) that satisfies (1) and (2)
    of the module docstring, for the ``axes`` given (default: all; the operators returned are those axes', in
    order): under Yee's staggering each axis has its own H particles (``StaggeredLayout.h_subsets``) and is
    solved on its own. ``order`` 2: also the quadratic moments of (2), in least squares (:data:`QUADRATIC_WEIGHT`;
    ``e_reach``/``h_reach`` from :func:`pattern_reach` with the same order). Raises ParameterError('conservative')
    when the constraints cannot be met (e.g. walls without held E particles: then (1) needs a boundary term this
    pair does not have)."""
    axes = tuple(range(dim)) if axes is None else tuple(axes)
    if order not in (1, 2):
        raise ParameterError("pair_order", f"must be 1 or 2, got {order!r}")
    con = _constraints(e_position, h_position, dim, held, e_volume, h_volume, e_operator, h_operator, e_reach,
                       h_reach, spacing, axes, order)
    C, m1 = con.matrix, con.e_row.size
    n_e, n_h = e_position.shape[0], h_position.shape[0]
    # only the entries near a violated constraint change (a uniform interior is already Yee's exact pair)
    violated = np.zeros(C.shape[0], bool)
    for k in range(len(axes)):
        violated |= np.abs(con.rhs[k] - C @ con.start[k]) > RESIDUAL_LIMIT
    free = np.flatnonzero(~held)
    nc = C.shape[0] // (free.size + n_h)
    exact_rows = np.arange(C.shape[0]) % nc < 1 + dim          # 1 and the linear moments; the rest (order 2) soft
    where = np.vstack([e_position[free], h_position])[np.flatnonzero(violated.reshape(-1, nc).any(axis=1))]
    entry_at = np.vstack([e_position[con.e_row], h_position[con.h_row]])
    unknown = np.zeros(C.shape[1], bool)
    if where.shape[0]:
        near, _ = cKDTree(where[:, :dim]).query(entry_at[:, :dim], distance_upper_bound=BAND * spacing)
        unknown = np.isfinite(near)
    cu = C[:, np.flatnonzero(unknown)]
    touched = np.diff(cu.tocsr().indptr) > 0
    cu = cu[touched]
    lu = None
    if cu.shape[1]:
        # the soft rows' multipliers carry -1/w² on the diagonal (min |δ|² + w² |C_soft (d0 + δ)|²)
        diagonal = np.where(exact_rows[touched], 1e-13, 1.0 / QUADRATIC_WEIGHT ** 2)
        kkt = sp.bmat([[sp.identity(cu.shape[1]), cu.T], [cu, -sp.diags(diagonal)]]).tocsc()
        lu = spla.splu(kkt, permc_spec="MMD_AT_PLUS_A", options=dict(SymmetricMode=True), diag_pivot_thresh=0.0)
    e_out, h_out, change, residual = [], [], 0.0, 0.0
    for k in range(len(axes)):
        d0, rhs = con.start[k], con.rhs[k]
        d = d0.copy()
        if lu is not None:      # the solve, refined twice on the KKT system itself (soft rows need not vanish)
            b = np.concatenate([np.zeros(cu.shape[1]), (rhs - C @ d)[touched]])
            x = lu.solve(b)
            for _ in range(2):
                x = x + lu.solve(b - kkt @ x)
            d[unknown] += x[:cu.shape[1]]
        res = float(np.abs(rhs - C @ d)[exact_rows].max())
        residual = max(residual, res)
        change = max(change, float(np.abs(d - d0).max()))
        de = sp.csr_matrix((d[:m1] / spacing, (con.e_row, con.e_col)), shape=(n_e, n_h))
        dh_free = -(sp.diags(1.0 / h_volume) @ de.T @ sp.diags(e_volume))
        dh_held = sp.csr_matrix((d[m1:] / spacing, (con.h_row, con.h_col)), shape=(n_h, n_e))
        e_out.append(de.tocsr())
        h_out.append((dh_free + dh_held).tocsr())
    if not residual <= RESIDUAL_LIMIT:
        raise ParameterError("conservative", f"no energy-conserving pair that is exact for linear fields on this "
                                             f"layout (constraint residual {residual:.3g}): a boundary without held "
                                             f"(PEC) E particles needs a boundary term; use conservative=False there")
    return ConservativePair(e_out, h_out, change, residual)
