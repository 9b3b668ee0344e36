"""Fang's fourth-order staggered difference (the (2,4) scheme) on a uniform lattice, closed at conductor walls by
images: a derivative pair that is exactly skew-adjoint, with no boundary rows to fit (set-up, NumPy).

In the interior a derivative along axis a reads the four particles of the other set on the lattice line through the
particle, at ±Δ/2 and ±3Δ/2 (Fang 1989; Taflove & Hagness, §4.6):

    ∂u/∂x_a ≈ [9/8 (u(+Δ/2) - u(-Δ/2)) - 1/24 (u(+3Δ/2) - u(-3Δ/2))] / Δ,      error Δ⁴ u⁽⁵⁾ 3/640,

against Yee's Δ²u'''/24: the phase error of a wave falls from (kΔ)²/24 to 3(kΔ)⁴/640, 1/8 of it at 20 particles per
wavelength and 1/35 at 40... so that the material interfaces (second order with the averaged permittivity) are what is
left. Next to a wall held at Ez = 0 (a perfect conductor on a lattice line) a stencil that reaches past it reads the
fields' images: Ez odd about the wall (Ez(-s) = -Ez(s)), the tangential H even (H(-s) = H(s)), as the exact fields
are. With equal volumes the pair is then exactly skew-adjoint, V_E D_E = -(V_H D_H)ᵀ (checked at set-up): the
leapfrog conserves the discrete energy and is stable below the step limit the model computes (6/7 of Yee's in the
interior). Its rows are consistent for fields of the walls' parity, which the exact fields have; they are not
exact for arbitrary linear fields next to a wall, so the energy-conserving projection of :mod:`.conservative` is not
applied.

Needs: a uniform lattice (``staggered_box`` with Yee's staggering or ``staggered_line``, no jitter or grading), its
walls held (``pec=True``); conductor objects (a surface row off the lattice) are refused. Units: 1/m.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError

from .layouts import HX, HY, StaggeredLayout

__all__ = ["fourth_order_pair", "lattice_cell", "NEAR", "FAR"]

#: the (2,4) difference's weights for the nearest and the next particles on the line (times 1/Δ)
NEAR, FAR = 9.0 / 8.0, -1.0 / 24.0

#: how far (in spacings) a particle may sit from its lattice point and still count as on it
ON_LATTICE = 1e-6


def _lattice(layout: StaggeredLayout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lower corner, spacing per axis, cells per axis) of the layout's uniform lattice, or ParameterError."""
    dim = layout.dim
    if layout.lower is None or layout.upper is None:
        raise ParameterError("order", "the fourth-order difference needs a box or line layout")
    lo, hi = np.asarray(layout.lower, float)[:dim], np.asarray(layout.upper, float)[:dim]
    cells = np.round((hi - lo) / layout.spacing).astype(int)
    cells = np.maximum(cells, 1)
    step = (hi - lo) / cells
    e = (layout.e_position[:, :dim] - lo) / step
    if (layout.n_e != int(np.prod(cells + 1)) or np.any(np.abs(e - np.round(e)) > ON_LATTICE)
            or (dim == 2 and layout.h_carries is None)):
        raise ParameterError("order", "the fourth-order difference needs a uniform lattice with Yee's staggering "
                                      "(staggered_box or staggered_line, no jitter, grading or conductor objects)")
    return lo, step, cells


def lattice_cell(layout: StaggeredLayout) -> float:
    """The volume of the lattice's cell (m^dim), the product of its spacings (ParameterError if not a lattice)."""
    return float(np.prod(_lattice(layout)[1]))


def fourth_order_pair(layout: StaggeredLayout, held: np.ndarray, e_volume: np.ndarray,
                      h_volume: np.ndarray) -> tuple[list, list, float]:
    """Per axis a, (D_E^a (n_e × n_h), D_H^a (n_h × n_e)) as CSR (1/m), and the pair's skew-adjointness residual
    max |V_E D_E + (V_H D_H)ᵀ| Δ / V over the free E rows (rounding: 1e-12)."""
    lo, step, cells = _lattice(layout)
    dim = layout.dim
    wall = layout.on_wall
    if not np.array_equal(held, wall):
        raise ParameterError("pec", "the fourth-order difference closes the lattice's walls as perfect conductors: "
                                    "leave pec on and drive no particle on a wall")
    e_index = np.round((layout.e_position[:, :dim] - lo) / step).astype(np.int64)
    h_half = (layout.h_position[:, :dim] - lo) / step  # along its axis m + 1/2, across it an integer
    e_map = np.full(tuple(cells + 1), -1, np.int64)
    e_map[tuple(e_index.T)] = np.arange(layout.n_e)
    weights = np.array([-FAR, -NEAR, NEAR, FAR])  # at offsets -3/2, -1/2, +1/2, +3/2
    e_ops, h_ops = [], []
    residual = 0.0
    for axis in range(dim):
        if dim == 1:
            on = np.arange(layout.n_h)
        else:
            on = np.flatnonzero(layout.h_carries == (HY if axis == 0 else HX))
        n_along = cells[axis]
        h_index = np.round(h_half[on] - 0.5 * np.eye(dim)[axis]).astype(np.int64)  # m along the axis
        h_map = np.full(tuple(cells + 1), -1, np.int64)
        h_map[tuple(h_index.T)] = on
        # E rows: the H of the line at m = i - 2, i - 1, i, i + 1; beyond a wall the even image 2N - m - 1 or -m - 1
        free = np.flatnonzero(~held)
        rows, cols, vals = [], [], []
        for k, w in zip((-2, -1, 0, 1), weights):
            m = e_index[free, axis] + k
            m = np.where(m < 0, -m - 1, np.where(m >= n_along, 2 * n_along - m - 1, m))
            at = e_index[free].copy()
            at[:, axis] = m
            j = h_map[tuple(at.T)]
            if np.any(j < 0):
                raise ParameterError("order", "a lattice line lacks an H particle the fourth-order difference reads")
            rows.append(free), cols.append(j), vals.append(np.full(free.size, w / step[axis]))
        d_e = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(layout.n_e, layout.n_h))
        # H rows: the E of the line at i = m - 1, m, m + 1, m + 2; beyond a wall the odd image (-i or 2N - i, negated)
        rows, cols, vals = [], [], []
        for k, w in zip((-1, 0, 1, 2), weights):
            i = h_index[:, axis] + k
            sign = np.where((i < 0) | (i > n_along), -1.0, 1.0)
            i = np.where(i < 0, -i, np.where(i > n_along, 2 * n_along - i, i))
            at = h_index.copy()
            at[:, axis] = i
            j = e_map[tuple(at.T)]
            rows.append(on), cols.append(j), vals.append(sign * w / step[axis])
        d_h = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(layout.n_h, layout.n_e))
        d_e.sum_duplicates()
        d_h.sum_duplicates()
        d_e.eliminate_zeros()
        d_h.eliminate_zeros()
        balance = (sp.diags(e_volume) @ d_e + (sp.diags(h_volume) @ d_h).T).tocsr()[free]
        if balance.nnz:
            residual = max(residual, float(np.abs(balance.data).max() * step[axis] / np.max(e_volume)))
        e_ops.append(d_e)
        h_ops.append(d_h)
    return e_ops, h_ops, residual
