"""Variationally consistent integration (Chen, Hillman & Rüter 2013, IJNME 95:387) of Galerkin stiffness matrices.

Gauss quadrature of rational shape functions (MLS) breaks the discrete divergence theorem
Σ_g w_g ∇φ_I(x_g) = Σ_b w_b φ_I(x_b) n_b, and with it the linear patch test (errors 1e-5..1e-3 with 2x2 to 6x6
points). Test gradients ∇ψ_I = ∇φ_I + Σ_p c_{I,p} q_p, q the monomials of degree < n about x_I, with c_I chosen so
that the divergence theorem holds for φ_I q_p (Chen, Hillman & Rüter 2013, §4), restore it: the Galerkin equations
Σ_g w_g ∇ψ_I·∇u = Σ_b w_b φ_I ∇u·n_b - Σ_g w_g φ_I Δu then hold exactly for every field u of degree <= n (order n
of consistency); the stiffness Σ_g w_g ∇ψ_I·k ∇φ_J (``warpfree.galerkin.assembly``) is non-symmetric
(Petrov-Galerkin).

Which order: the shape model's ``consistency_order``, for MLS one above its basis's degree p. Order p passes the
patch test and keeps the energy-norm rate, but at the nodes near the boundary the Galerkin equations of the
solution's degree-(p + 1) part stay off by O(h^(p+1)) each, O(h^p) summed along the boundary: a flux error, which a
natural (flux or traction) boundary passes to the solution, so that the L2 error falls as h^p, not h^(p+1).
Measured (relative L2 errors, regular nodes, d_max 2.5, 2 x 2 points for the linear basis, 3 x 3 for the
quadratic), rates over spacings 1/8, 1/16, 1/32, 1/64:

- the L-shaped domain with flux on its re-entrant sides (``warpfree.validation.efg_l_shape``): linear basis 3.2, 1.5,
  1.1 at order 1, 3.6, 2.4, 2.3 at order 2; quadratic basis 2.9, 2.7, 2.7 at order 2, 3.3, 3.3, 3.3 at order 3;
- the same u on the square [0, 2]² with flux on one side: linear 2.0, 1.4, 1.1 at order 1, 2.3, 2.2, 2.1 at order 2;
  with u prescribed on every side order 1 keeps 2.7, 2.3 to 1/32 (prescribed values absorb the flux error);
- plane-strain elasticity, a smooth field on a square with traction on three sides: linear 0.9, 0.9 over 1/8 ..
  1/32 of the side at order 1, 2.4, 2.0 at order 2.

float64.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpfree.errors import require_integer
from warpfree.kernels import galerkin as gk
from warpfree.space import Space

from .shapes import ShapeData, ShapeModel

__all__ = ["consistent_test_gradients", "FULL_RANK", "MONOMIALS", "ORDERS"]

#: the exponents (i, j) of the monomials r_x^i r_y^j, degree by degree: order n of consistency corrects with the
#: first n (n + 1) / 2 (the kernel's order, ``kernels/galerkin.py: corrected_gradients``) and asks the Gauss points to
#: resolve the first (n + 1) (n + 2) / 2
MONOMIALS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))
#: the consistency orders the correction supports (its monomials up to degree 2)
ORDERS = (1, 2, 3)

#: a node's Gram matrix of monomials (their products over the region's Gauss points in its support) counts as full
#: rank when its smallest eigenvalue exceeds this fraction of its largest
FULL_RANK = 1e-10


def consistent_test_gradients(model: ShapeModel, shape: ShapeData, weight, boundary: list, order: int = 2,
                              point_material=None, regions: int | None = None) -> tuple[wp.array, np.ndarray]:
    """(∇ψ per entry of ``shape``, c_{I,1} (N, regions, 2) the constant part of the correction) for consistency of
    ``order`` n (1, 2, 3; module docstring): per node I and region m, c_I solves the n (n + 1) / 2 × 2 constraints

        Σ_{g ∈ m} w_g ∇ψ_I q_p = Σ_{b ∈ ∂m} w_b φ_I q_p n_b - Σ_{g ∈ m} w_g φ_I ∇q_p,

    q = (1, r_x, r_y, r_x², r_x r_y, r_y²)[:n (n + 1) / 2], r = (x - x_I)/h_I (h_I the node's spacing; the minimum
    image in a periodic space), i.e. the divergence theorem for φ_I q_p e_k. Order 1 is the constant correction
    ξ_I = (Σ_b w_b φ_I n_b - Σ_g w_g ∇φ_I) / Σ_g w_g.

    Order k >= 2 is fitted where the node's Gauss points in the region resolve the polynomials of degree k (no
    nonzero one vanishes at all of them: their Gram matrix Σ_g w_g m m^T over the degree-k monomials m is full rank,
    :data:`FULL_RANK`), else the highest order they resolve, down to 1. On points that do not (two lines of them: the
    loaded edge of Cook's membrane at d_max 1.8, each support two columns of 2 x 2 points), the correction's
    degree-(k - 1) terms alias what the points cannot see and add error where they should remove it (Cook's
    compliance, 16 / 32 cells a side: off the exactly integrated solution's by 0.93 % / 0.33 % at order 2 on every
    node, 0.15 % / 0.02 % at order 1, 0.24 % / 0.05 % with this rule).

    ``point_material`` (n,) the Gauss points' regions 0..M-1 (None: one region); ``boundary``: (ShapeData, weights
    (m,), outward normals (m, 2), region) for every piece that closes a region (outer boundary and both sides of
    every interface), the same points the boundary integrals use: per region the theorem then holds, so
    piecewise-polynomial fields with flux continuity are integrated exactly too. Each node's sums run over the
    entries that hold it in the points' order (``np.bincount``), so a node whose support's points are all in
    ``shape`` (a distributed run's rank: its own nodes, ``regions`` given) gets the one process's correction, bit for
    bit, whatever other points ``shape`` holds. Set-up, once: the moments in NumPy (float64), one small solve per
    node, the corrected gradients by a kernel (``kernels/galerkin.py``)."""
    order = require_integer("order", order, minimum=ORDERS[0], maximum=ORDERS[-1])
    terms = order * (order + 1) // 2
    w = np.asarray(weight, dtype=np.float64)
    n_nodes = model.node_count
    region = np.zeros(shape.n, dtype=np.int64) if point_material is None else np.asarray(point_material, np.int64)
    if regions is None:
        regions = int(region.max()) + 1 if region.size else 1
    size = n_nodes * regions
    nodes = np.asarray(model.nodes_np, dtype=np.float64)
    h = np.ascontiguousarray(np.broadcast_to(np.asarray(model.spacing, dtype=np.float64), (n_nodes,)))
    space = getattr(model, "space", None) or Space.free(2)

    def relative(index, points):
        """r = (x - x_I)/h_I at every entry (minimum image)."""
        return space.displacement(points, nodes[index]) / h[index][:, None]

    def per_key(key, values):
        return np.bincount(key, weights=values, minlength=size)

    def gram(moments, count):
        """Σ w m m^T per key (size, count, count) over the first ``count`` monomials m, from the power moments."""
        out = np.empty((size, count, count))
        for a, (ia, ja) in enumerate(MONOMIALS[:count]):
            for b, (ib, jb) in enumerate(MONOMIALS[:count]):
                out[:, a, b] = moments[(ia + ib, ja + jb)]
        return out

    index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
    key = index * regions + np.repeat(region, shape.counts)
    entry_weight = np.repeat(w, shape.counts)
    rel = relative(index, np.repeat(np.asarray(shape.points, dtype=np.float64), shape.counts, axis=0))
    # Σ_g w_g r_x^i r_y^j per key for i + j <= 2·order (one entry-sized temporary at a time)
    powers = [(i, e - i) for e in range(2 * order + 1) for i in range(e + 1)]
    moments = {(i, j): per_key(key, entry_weight * rel[:, 0] ** i * rel[:, 1] ** j) for i, j in powers}
    phi = shape.phi.numpy()[: shape.n_entries]
    d = shape.dphi.numpy()[: shape.n_entries]
    inv_h = 1.0 / h[index]
    rhs = np.zeros((size, 2, terms))  # (key, gradient component k, monomial p)
    for p, (i, j) in enumerate(MONOMIALS[:terms]):
        q = rel[:, 0] ** i * rel[:, 1] ** j
        dq = (i * rel[:, 0] ** max(i - 1, 0) * rel[:, 1] ** j * inv_h,  # ∂q_p/∂x, ∂q_p/∂y
              j * rel[:, 0] ** i * rel[:, 1] ** max(j - 1, 0) * inv_h)
        for k in range(2):
            rhs[:, k, p] = -per_key(key, entry_weight * (d[:, k] * q + phi * dq[k]))
    for bshape, bw, normal, piece_region in boundary:
        b_index = bshape.rows.index.numpy()[: bshape.n_entries].astype(np.int64)
        b_key = b_index * regions + max(int(piece_region), 0)
        b_rel = relative(b_index, np.repeat(np.asarray(bshape.points, dtype=np.float64), bshape.counts, axis=0))
        flux = (np.repeat(np.asarray(bw)[:, None] * np.asarray(normal), bshape.counts, axis=0)
                * bshape.phi.numpy()[: bshape.n_entries][:, None])
        for p, (i, j) in enumerate(MONOMIALS[:terms]):
            bq = b_rel[:, 0] ** i * b_rel[:, 1] ** j
            for k in range(2):
                rhs[:, k, p] += per_key(b_key, flux[:, k] * bq)
    moment = gram(moments, terms)
    coefficient = np.zeros((size, 2, terms))
    left = moment[:, 0, 0] > 0  # the (node, region) pairs with Gauss points, not yet fitted
    for k in range(order, 0, -1):  # the highest order each pair's Gauss points resolve
        t = k * (k + 1) // 2
        fit = left.copy()
        if k > 1:
            eig = np.linalg.eigvalsh(gram(moments, (k + 1) * (k + 2) // 2))
            fit &= eig[:, 0] > FULL_RANK * eig[:, -1]
        coefficient[fit, :, :t] = np.linalg.solve(moment[fit][:, None, :t, :t], rhs[fit][:, :, :t, None])[..., 0]
        left &= ~fit
    dev = model.launcher.device
    out = wp.zeros_like(shape.dphi)
    model.launcher.launch(gk.corrected_gradients, shape.n, [
        shape.rows, shape.dphi, wp.array(np.asarray(shape.points, dtype=np.float64), dtype=wp.vec2d, device=dev),
        wp.array(region.astype(np.int32), dtype=wp.int32, device=dev), regions,
        wp.array(nodes, dtype=wp.vec2d, device=dev), wp.array(h, dtype=wp.float64, device=dev), space.box2d, terms,
        wp.array(np.ascontiguousarray(coefficient.transpose(0, 2, 1)).reshape(-1, 2), dtype=wp.vec2d, device=dev),
        out], once=True)
    return out, coefficient[:, :, 0].reshape(n_nodes, regions, 2)
