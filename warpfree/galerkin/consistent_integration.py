"""Variationally consistent integration (Chen, Hillman & Rüter 2013, IJNME 95:387) of Galerkin stiffness matrices.

Gauss quadrature of rational shape functions (MLS) breaks the discrete divergence theorem
Σ_g w_g ∇φ_I(x_g) = Σ_b w_b φ_I(x_b) n_b, and with it the linear patch test (errors 1e-5..1e-3 with 2x2 to 6x6 points).
Test gradients ∇ψ_I = ∇φ_I + ξ_I with ξ_I = (Σ_b w_b φ_I n_b - Σ_g w_g ∇φ_I) / Σ_{g ∈ supp I} w_g restore it exactly;
the stiffness Σ_g w_g ∇ψ_I·k ∇φ_J (``warpfree.galerkin.assembly``) is then non-symmetric (Petrov-Galerkin) and linear
fields are reproduced to round-off. float64.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpfree.kernels import galerkin as gk

from .shapes import ShapeData, ShapeModel

__all__ = ["consistent_test_gradients", "quadratic_consistent_test_gradients"]


def _one_process(values: np.ndarray) -> np.ndarray:
    return values


def consistent_test_gradients(model: ShapeModel, shape: ShapeData, weight, boundary: list,
                              point_material=None, regions: int | None = None,
                              total=_one_process) -> tuple[wp.array, np.ndarray]:
    """(∇ψ per entry of ``shape``, ξ (N, materials, 2)) (module docstring), one correction per node and material
    region: ``point_material`` (n,) the Gauss points' regions 0..M-1 (None: one region); ``boundary``: (ShapeData,
    weights (m,), outward normals (m, 2), region) for every piece that closes a region (outer boundary and both
    sides of every interface), the same points the boundary integrals use. Per region m the discrete divergence
    theorem Σ_{g ∈ m} w_g ∇ψ_I = Σ_{b ∈ ∂m} w_b φ_I n_b then holds, so piecewise-linear fields with flux
    continuity are reproduced too. A distributed run's rank passes its own Gauss points, the number of ``regions``
    and ``total``, the sum over the ranks of the Gauss points' per-node sums (the boundary's are every rank's
    alike: added once, after)."""
    w = np.asarray(weight, dtype=np.float64)
    n_nodes = model.node_count
    region = np.zeros(shape.n, dtype=np.int64) if point_material is None else np.asarray(point_material, np.int64)
    if regions is None:
        regions = int(region.max()) + 1 if region.size else 1
    index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
    entry_region = np.repeat(region, shape.counts)
    key = index * regions + entry_region
    size = n_nodes * regions
    entry_weight = np.repeat(w, shape.counts)
    d = shape.dphi.numpy()[: shape.n_entries]
    volume = total(np.bincount(key, weights=entry_weight, minlength=size))
    integral = total(np.stack([np.bincount(key, weights=entry_weight * d[:, k], minlength=size) for k in range(2)],
                              axis=1))
    target = np.zeros((size, 2))
    for bshape, bw, normal, piece_region in boundary:
        phi = bshape.phi.numpy()[: bshape.n_entries]
        b_index = bshape.rows.index.numpy()[: bshape.n_entries].astype(np.int64)
        flux = (np.asarray(bw)[:, None] * np.asarray(normal))
        b_flux = np.repeat(flux, bshape.counts, axis=0) * phi[:, None]
        b_key = b_index * regions + max(int(piece_region), 0)
        for k in range(2):
            target[:, k] += np.bincount(b_key, weights=b_flux[:, k], minlength=size)
    covered = volume > 0
    xi = np.zeros((size, 2))
    xi[covered] = (target[covered] - integral[covered]) / volume[covered, None]
    dev = model.launcher.device
    out = wp.zeros_like(shape.dphi)
    model.launcher.launch(gk.corrected_gradients, shape.n, [shape.rows, shape.dphi,
                                                            wp.array(region.astype(np.int32), dtype=wp.int32,
                                                                     device=dev), regions,
                                                            wp.array(xi, dtype=wp.vec2d, device=dev), out], once=True)
    return out, xi.reshape(n_nodes, regions, 2)


#: a node's 3 x 3 moment matrix (its q_p q_q over the region's Gauss points in its support) counts as full rank when
#: its smallest eigenvalue exceeds this fraction of its largest
FULL_RANK = 1e-10


def quadratic_consistent_test_gradients(model: ShapeModel, shape: ShapeData, weight, boundary: list,
                                        point_material=None, regions: int | None = None,
                                        total=_one_process) -> tuple[wp.array, np.ndarray]:
    """The quadratic variationally consistent correction (Chen, Hillman & Rüter 2013, §4): ∇ψ_I(x) = ∇φ_I(x) +
    Σ_p c_{I,p} q_p(x) with q = (1, (x - x_I)/h_I, (y - y_I)/h_I), c_I solved per node and region from the three
    integration constraints

        Σ_g w_g ∇ψ_I q_p = Σ_b w_b φ_I q_p n_b - Σ_g w_g φ_I ∇q_p,      p = 1, x, y,

    (the divergence theorem for φ_I q_p), which a quadratic field's Galerkin equations need to hold exactly; the
    linear correction (:func:`consistent_test_gradients`) is its p = 1 part. h_I: the node's spacing. Returns (∇ψ per
    entry, c_{I,1} (N, regions, 2), the constant part). A node whose support meets a region only at Gauss points on a
    line (rank-deficient moments, :data:`FULL_RANK`) gets the constant part alone there, which keeps p = 1. Set-up,
    once, float64 in NumPy (3 x 3 solves per node). ``regions`` and ``total``: as for
    :func:`consistent_test_gradients`."""
    w = np.asarray(weight, dtype=np.float64)
    n_nodes = model.node_count
    region = np.zeros(shape.n, dtype=np.int64) if point_material is None else np.asarray(point_material, np.int64)
    if regions is None:
        regions = int(region.max()) + 1 if region.size else 1
    size = n_nodes * regions
    nodes = np.asarray(model.nodes_np, dtype=np.float64)
    h = np.broadcast_to(np.asarray(model.spacing, dtype=np.float64), (n_nodes,))

    def monomials(index, points):
        scale = h[index][:, None]
        rel = (points - nodes[index]) / scale
        return np.stack([np.ones(index.size), rel[:, 0], rel[:, 1]], axis=1), 1.0 / scale[:, 0]

    index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
    key = index * regions + np.repeat(region, shape.counts)
    entry_weight = np.repeat(w, shape.counts)
    q, inv_h = monomials(index, np.repeat(np.asarray(shape.points, dtype=np.float64), shape.counts, axis=0))
    phi = shape.phi.numpy()[: shape.n_entries]
    d = shape.dphi.numpy()[: shape.n_entries]
    moment = np.zeros((size, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            moment[:, a, b] = moment[:, b, a] = np.bincount(key, weights=entry_weight * q[:, a] * q[:, b],
                                                            minlength=size)
    rhs = np.zeros((size, 2, 3))  # (key, gradient component k, monomial p)
    for k in range(2):
        for p in range(3):
            rhs[:, k, p] -= np.bincount(key, weights=entry_weight * d[:, k] * q[:, p], minlength=size)
        # - Σ_g w_g φ_I ∂_k q_p: only q_{1+k} = (x_k - x_I,k)/h has a derivative, 1/h
        rhs[:, k, 1 + k] -= np.bincount(key, weights=entry_weight * phi * inv_h, minlength=size)
    moment, rhs = total(moment), total(rhs)
    for bshape, bw, normal, piece_region in boundary:
        b_index = bshape.rows.index.numpy()[: bshape.n_entries].astype(np.int64)
        b_key = b_index * regions + max(int(piece_region), 0)
        b_phi = bshape.phi.numpy()[: bshape.n_entries]
        bq, _ = monomials(b_index, np.repeat(np.asarray(bshape.points, dtype=np.float64), bshape.counts, axis=0))
        flux = np.repeat(np.asarray(bw)[:, None] * np.asarray(normal), bshape.counts, axis=0) * b_phi[:, None]
        for k in range(2):
            for p in range(3):
                rhs[:, k, p] += np.bincount(b_key, weights=flux[:, k] * bq[:, p], minlength=size)
    coefficient = np.zeros((size, 2, 3))
    covered = moment[:, 0, 0] > 0
    eig = np.linalg.eigvalsh(moment)
    full = covered & (eig[:, 0] > FULL_RANK * eig[:, 2])
    coefficient[full] = np.linalg.solve(moment[full][:, None], rhs[full][..., None])[..., 0]
    # a node whose support meets the region at Gauss points on a line (a sliver of a cell) cannot carry the linear
    # part: the constant one alone, the linear correction's (p = 1 holds exactly, x and y as they are)
    thin = covered & ~full
    coefficient[thin, :, 0] = rhs[thin, :, 0] / moment[thin, 0, 0][:, None]
    corrected = d + np.einsum("ekp,ep->ek", coefficient[key], q)
    out = wp.array(corrected, dtype=wp.vec2d, device=model.launcher.device)
    return out, coefficient[:, :, 0].reshape(n_nodes, regions, 2)
