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

__all__ = ["consistent_test_gradients"]


def consistent_test_gradients(model: ShapeModel, shape: ShapeData, weight, boundary: list,
                              point_material=None) -> tuple[wp.array, np.ndarray]:
    """(∇ψ per entry of ``shape``, ξ (N, materials, 2)) (module docstring), one correction per node and material
    region: ``point_material`` (n,) the Gauss points' regions 0..M-1 (None: one region); ``boundary``: (ShapeData,
    weights (m,), outward normals (m, 2), region) for every piece that closes a region (outer boundary and both
    sides of every interface), the same points the boundary integrals use. Per region m the discrete divergence
    theorem Σ_{g ∈ m} w_g ∇ψ_I = Σ_{b ∈ ∂m} w_b φ_I n_b then holds, so piecewise-linear fields with flux
    continuity are reproduced too."""
    w = np.asarray(weight, dtype=np.float64)
    n_nodes = model.node_count
    region = np.zeros(shape.n, dtype=np.int64) if point_material is None else np.asarray(point_material, np.int64)
    regions = int(region.max()) + 1 if region.size else 1
    index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
    entry_region = np.repeat(region, shape.counts)
    key = index * regions + entry_region
    size = n_nodes * regions
    entry_weight = np.repeat(w, shape.counts)
    d = shape.dphi.numpy()[: shape.n_entries]
    volume = np.bincount(key, weights=entry_weight, minlength=size)
    integral = np.stack([np.bincount(key, weights=entry_weight * d[:, k], minlength=size) for k in range(2)], axis=1)
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
