"""Stabilized conforming nodal integration (SCNI; Chen, Wu, Yoon & You 2001, IJNME 50:435) of Galerkin stiffness.

The domain is split into one smoothing cell Ω_L per node (a conforming partition: no gaps, no overlaps), and the
strain at node L is the cell average of the displacement gradient, by the divergence theorem a boundary integral
(Chen et al. 2001, eqs 20-21):

    ∇̃φ_I(x_L) = (1/A_L) ∫_{Ω_L} ∇φ_I dΩ = (1/A_L) ∮_{∂Ω_L} φ_I n dΓ          (1/m)

so that only φ, never ∇φ, is sampled, on Gauss points of the cell sides; the stiffness is then
K_IJ = Σ_L A_L B̃_Iᵀ(x_L) D B̃_J(x_L) (eq 24), one point per node, symmetric. Because neighbouring cells sample the
same φ on their common side with opposite normals, Σ_L A_L ∇̃φ_I(x_L) = ∮_Γ φ_I n dΓ holds exactly (the discrete
divergence theorem), and a shape function that reproduces linear fields gives their exact constant gradient in
every cell: the linear patch test passes to round-off, whatever φ's kinks inside the cells (a C⁰ natural-neighbour
interpolant, whose gradient jumps across circumcircles that no cell rule follows).

Cells of a triangulation (:func:`triangle_smoothing_cells`): node i's cell is the union over its triangles T of the
quadrilateral (x_i, the midpoint of one side at i, p_T, the midpoint of the other), p_T the circumcentre of T when it
lies in T (then the cells are the Voronoi cells of the nodes clipped to the triangulated domain: Yoo, Moran & Chen
2004, IJNME 60:861), else the midpoint of T's longest side (an obtuse triangle: a conforming cell, no longer exactly
Voronoi). The cell sides are the segments midpoint → p_T inside the triangles and the half sides on the domain's
boundary (the triangulation's sides with no neighbour).

Set-up geometry in NumPy (vectorised); the smoothed gradients, one Warp thread per cell
(``kernels/galerkin.py: smoothed_gradient_rows``), become an ordinary :class:`~.shapes.ShapeData` at the nodes:
the Galerkin assembly (``warpfree.galerkin.assembly``) uses them as it uses Gauss points, with weights A_L. float64.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels import galerkin as gk
from warpfree.neighbours import empty_rows, lay_out_rows

from .quadrature import BoundaryPoints, gauss_legendre
from .shapes import ShapeData, ShapeModel

__all__ = ["SmoothingCells", "triangle_smoothing_cells", "smoothed_shape"]

#: a cell side shorter than this × the triangle's longest side is dropped (p_T on a side: a right triangle)
SHORT_SIDE = 1e-12


class SmoothingCells(NamedTuple):
    """Smoothing cells, one per node, and the Gauss points of their sides. ``position``, ``weight`` and ``cell`` read
    as :class:`~.quadrature.QuadraturePoints` do (a solver integrates with one point per cell)."""

    position: np.ndarray      # (n, 2) float64: the cell's node (m)
    weight: np.ndarray        # (n,) float64: the cell's area A_L (m²); the areas sum to the domain's
    cell: np.ndarray          # (n,) int64: the cell's index (= its node)
    boundary: BoundaryPoints  # Gauss points of every cell's sides, cell after cell; normals outward of their cell
    owner: np.ndarray         # (b,) int64: the cell each boundary point closes (non-decreasing)


def triangle_smoothing_cells(points, triangles, adjacent, order: int = 1) -> SmoothingCells:
    """The cells of the module docstring for the triangulation ``triangles`` (m, 3) of ``points`` (n, 2), vertices
    counter-clockwise, ``adjacent[t, k]`` the triangle across the side opposite vertex k (-1: a boundary side);
    ``order`` Gauss-Legendre points per cell side (1 integrates the linear fields of the patch test exactly)."""
    x = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    adj = np.asarray(adjacent, dtype=np.int64)
    if x.ndim != 2 or x.shape[1] != 2 or tri.ndim != 2 or tri.shape[1] != 3 or adj.shape != tri.shape:
        raise ParameterError("triangles", f"points (n, 2), triangles and adjacent (m, 3) expected, got {x.shape}, "
                                          f"{tri.shape}, {adj.shape}")
    g, w = gauss_legendre(order)
    corner = x[tri]                                             # (m, 3, 2)
    mid = 0.5 * (corner + np.roll(corner, -1, axis=1))          # mid[:, k]: side k → k+1
    side = np.roll(corner, -1, axis=1) - corner
    side2 = np.einsum("mkd,mkd->mk", side, side)
    # circumcentre, and whether it lies in the triangle (no side seen from it at an obtuse angle: λ_k >= 0)
    a, b = corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    aa, bb = np.einsum("md,md->m", a, a), np.einsum("md,md->m", b, b)
    centre = corner[:, 0] + np.stack([b[:, 1] * aa - a[:, 1] * bb, a[:, 0] * bb - b[:, 0] * aa], axis=1) / (2 * det)[:, None]
    # the angle at vertex k is obtuse when the opposite side's square exceeds the sum of the other two
    opposite = np.roll(side2, -1, axis=1)                      # side opposite vertex k is side k+1
    obtuse = opposite > side2 + np.roll(side2, 1, axis=1)
    longest = np.argmax(side2, axis=1)
    meet = np.where(np.any(obtuse, axis=1)[:, None], mid[np.arange(len(tri)), longest], centre)
    # every vertex k: the cell's sides mid[k] → meet and meet → mid[k-1]; the half sides of boundary sides
    starts, ends, owners = [], [], []
    for k in range(3):
        before = (k + 2) % 3
        starts += [mid[:, k], meet]
        ends += [meet, mid[:, before]]
        owners += [tri[:, k], tri[:, k]]
        open_side = adj[:, (k + 2) % 3] < 0                    # side k → k+1 is opposite vertex k+2
        starts += [corner[open_side, k], mid[open_side, k]]
        ends += [mid[open_side, k], corner[open_side, (k + 1) % 3]]
        owners += [tri[open_side, k], tri[open_side, (k + 1) % 3]]
    start, end, owner = np.concatenate(starts), np.concatenate(ends), np.concatenate(owners)
    scale = np.sqrt(side2.max())
    d = end - start
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > SHORT_SIDE * scale
    start, d, length, owner = start[keep], d[keep], length[keep], owner[keep]
    order_by_cell = np.argsort(owner, kind="stable")
    start, d, length, owner = start[order_by_cell], d[order_by_cell], length[order_by_cell], owner[order_by_cell]
    u = 0.5 * (1.0 + g)
    position = (start[:, None, :] + u[None, :, None] * d[:, None, :]).reshape(-1, 2)
    normal = np.repeat(np.stack([d[:, 1], -d[:, 0]], axis=1) / length[:, None], g.size, axis=0)
    weight = (0.5 * w[None, :] * length[:, None]).ravel()
    segment = np.repeat(np.arange(len(start)), g.size)
    # areas: the shoelace formula of each quadrilateral (x_k, mid[k], meet, mid[k-1])
    area = np.zeros(len(x))
    for k in range(3):
        quad = np.stack([corner[:, k], mid[:, k], meet, mid[:, (k + 2) % 3]], axis=1)
        piece = 0.5 * np.sum(quad[:, :, 0] * np.roll(quad[:, :, 1], -1, axis=1)
                             - np.roll(quad[:, :, 0], -1, axis=1) * quad[:, :, 1], axis=1)
        area += np.bincount(tri[:, k], weights=piece, minlength=len(x))
    if not np.all(area > 0.0):
        j = int(np.flatnonzero(~(area > 0.0))[0])
        raise ParameterError("triangles", f"node {j} at {x[j].tolist()} has no smoothing cell (in no triangle)")
    return SmoothingCells(x.copy(), area, np.arange(len(x), dtype=np.int64),
                          BoundaryPoints(position, weight, normal, segment), np.repeat(owner, g.size))


def smoothed_shape(model: ShapeModel, cells: SmoothingCells, material=None) -> ShapeData:
    """Shape data at the cells' nodes with ∇̃φ_I (module docstring) in place of ∇φ_I and φ_I(x_L) as the values:
    the model's shape functions at the cells' side points and nodes, then one Warp thread per cell
    (``smoothed_gradient_rows``: a count pass, then a fill pass). ``material`` (n,) per cell, as ``shape_at``."""
    n, dev, L = cells.position.shape[0], model.launcher.device, model.launcher
    side = model.shape_at(cells.boundary.position, None if material is None else np.asarray(material)[cells.owner],
                          name="smoothing cell side point")
    centre = model.shape_at(cells.position, material, name="smoothing cell node")
    first = np.searchsorted(cells.owner, np.arange(n + 1)).astype(np.int32)
    flux = cells.boundary.weight[:, None] * cells.boundary.normal / cells.weight[cells.owner][:, None]
    args = [centre.kernel_rows(), side.kernel_rows(), wp.array(first, dtype=wp.int32, device=dev),
            wp.array(np.ascontiguousarray(flux), dtype=wp.vec2d, device=dev)]
    rows = empty_rows(n, dev)
    phi = wp.zeros(1, dtype=wp.float64, device=dev)
    dphi = wp.zeros(1, dtype=wp.vec2d, device=dev)
    L.launch(gk.smoothed_gradient_rows, n, args + [0, rows, phi, dphi], once=True)
    counts, total = lay_out_rows(rows, n, "cells")
    phi = wp.zeros(max(total, 1), dtype=wp.float64, device=dev)
    dphi = wp.zeros(max(total, 1), dtype=wp.vec2d, device=dev)
    L.launch(gk.smoothed_gradient_rows, n, args + [1, rows, phi, dphi], once=True)
    rcond = wp.array(np.ones(n), dtype=wp.float64, device=dev)
    return ShapeData(cells.position, rows, counts, total, phi, dphi, rcond, model.node_count)
