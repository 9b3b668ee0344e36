"""Background cells and nodes graded toward points: a quadtree refinement of a box's regular cells (host NumPy).

Near a re-entrant corner the field of a Poisson or elasticity problem is singular (|∇u| ~ r^(λ-1), r the distance
to the corner), and a uniform layout spends its nodes where the field is smooth. :func:`graded_box` starts from the
box's ``cells`` = (nx, ny) equal rectangles and, ``levels`` times, splits into four every cell whose distance to one
of the ``toward`` points is less than ``reach`` × its longer side. The result is a graded quadtree: cell size
≈ r / reach down to the base size / 2^levels, so the cells (and the nodes on their corners) ring each point with a
fixed number per level, and the node count grows by O(levels) per point, not by O(4^levels).

Nodes are the cells' corners (a fine cell's corner on a coarse neighbour's side is a node too: meshfree shape
functions need no conforming mesh); the cells carry tensor Gauss points (:meth:`GradedBox.gauss_points`) and a
side's nodes give its boundary pieces (:func:`side_vertices`). Cells are held as integer corners on the finest
lattice (spacing (upper - lower) / (n · 2^levels) along each axis), so shared corners are exactly equal.
``levels = 0`` is the regular grid of ``warpfree.galerkin.node_layouts.grid_nodes`` and
``warpfree.galerkin.quadrature.rectangle_cells`` (the same nodes and cells, Gauss points to round-off).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from warpfree.errors import ParameterError, require_integer, require_memory, require_positive
from warpfree.galerkin.quadrature import (BYTES_PER_GAUSS_POINT, QuadraturePoints, _box, _cell_counts, _cells_of,
                                             _tensor_gauss)

__all__ = ["GradedBox", "graded_box", "merged_nodes", "side_vertices"]

#: cells of a graded box, bytes each before its Gauss points: three int64 numbers (corner and size) and the splitting
BYTES_PER_CELL = 64.0


class GradedBox(NamedTuple):
    """Cells of a box as integer squares of the finest lattice: corner (i, j) and side ``size`` (lattice units)."""

    lower: np.ndarray  # (2,) float64: the box's lower corner (m)
    upper: np.ndarray  # (2,) float64: the box's upper corner (m)
    lattice: np.ndarray  # (2,) int64: lattice intervals across the box along x and y (n · 2^levels)
    corner: np.ndarray  # (c, 2) int64: each cell's lower corner on the lattice
    size: np.ndarray  # (c,) int64: each cell's side in lattice units

    def _to_metres(self, i, axis: int) -> np.ndarray:
        return self.lower[axis] + (self.upper[axis] - self.lower[axis]) * (np.asarray(i, np.float64) / self.lattice[axis])

    def cell_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(c, 2) lower and upper corners of the cells (m)."""
        lo = np.stack([self._to_metres(self.corner[:, k], k) for k in (0, 1)], axis=1)
        hi = np.stack([self._to_metres(self.corner[:, k] + self.size, k) for k in (0, 1)], axis=1)
        return lo, hi

    def nodes(self) -> np.ndarray:
        """(n, 2) the cells' distinct corners (m), ordered by lattice row, then column (the regular grid's i + (nx+1)·j
        order when ``levels`` = 0)."""
        corners = np.concatenate([self.corner + np.stack([dx * self.size, dy * self.size], axis=1)
                                  for dx in (0, 1) for dy in (0, 1)])
        key = np.unique(corners[:, 1] * (self.lattice[0] + 1) + corners[:, 0])
        j, i = np.divmod(key, self.lattice[0] + 1)
        return np.stack([self._to_metres(i, 0), self._to_metres(j, 1)], axis=1)

    def gauss_points(self, order: int) -> QuadraturePoints:
        """order × order Gauss points on every cell; weight = w_i w_j · (cell area) / 4 (m²); cell index = row."""
        xi, eta, w = _tensor_gauss(order, len(self.size))
        lo, hi = self.cell_bounds()
        half = 0.5 * (hi - lo)
        centre = lo + half
        x = centre[:, 0:1] + half[:, 0:1] * xi[None, :]
        y = centre[:, 1:2] + half[:, 1:2] * eta[None, :]
        weight = (w[None, :] * (half[:, 0] * half[:, 1])[:, None]).ravel()
        return QuadraturePoints(np.stack([x.ravel(), y.ravel()], axis=1), weight, _cells_of(len(self.size), xi.size))


def _distance_to_cells(box: GradedBox, point: np.ndarray) -> np.ndarray:
    """Euclidean distance from ``point`` (m) to each cell (0 inside it)."""
    lo, hi = box.cell_bounds()
    gap = np.maximum(np.maximum(lo - point, point - hi), 0.0)
    return np.hypot(gap[:, 0], gap[:, 1])


def graded_box(lower, upper, cells, toward, levels: int, reach: float = 2.0) -> GradedBox:
    """The box [lower, upper] in ``cells`` = (nx, ny) equal cells, each split ``levels`` times toward the points
    ``toward`` ((p, 2), m): a cell is split while its distance to a point is below ``reach`` × its longer side."""
    lo, hi = _box(lower, upper)
    nx, ny = _cell_counts("cells", cells)
    levels = require_integer("levels", levels, minimum=0)
    require_positive("reach", reach)
    points = np.atleast_2d(np.asarray(toward, dtype=np.float64))
    if points.size and points.shape[1] != 2:
        raise ParameterError("toward", f"must be points (p, 2), got shape {points.shape}")
    if levels > 30:
        raise ParameterError("levels", f"must be at most 30 (the lattice is int64), got {levels}")
    scale = 1 << levels
    # a level splits at most the cells within reach of a point: about π (reach + 1)² · 4 new cells per point and level
    require_memory("cells, levels", float(nx * ny) + 4.0 * np.pi * (reach + 1.0) ** 2 * len(points) * 4 * levels,
                   BYTES_PER_CELL, "graded cells")
    j, i = np.divmod(np.arange(nx * ny, dtype=np.int64), nx)
    box = GradedBox(lo, hi, np.array([nx * scale, ny * scale], dtype=np.int64),
                    np.stack([i * scale, j * scale], axis=1), np.full(nx * ny, scale, dtype=np.int64))
    cell_side = (hi - lo) / (nx * scale, ny * scale)          # one lattice interval along x and y (m)
    for _ in range(levels):
        longer = box.size * float(np.max(cell_side))
        near = np.zeros(len(box.size), dtype=bool)
        for p in points:
            near |= _distance_to_cells(box, p) < reach * longer
        split = near & (box.size > 1)
        if not split.any():
            break
        box = _split(box, split)
    require_memory("cells, levels", float(len(box.size)), BYTES_PER_GAUSS_POINT, "graded cells' Gauss points")
    return box


def _split(box: GradedBox, split: np.ndarray) -> GradedBox:
    """``box`` with the cells ``split`` (bool per cell) replaced by their four quarters (appended)."""
    half = box.size[split] // 2
    corner = box.corner[split]
    children = np.concatenate([corner + np.stack([dx * half, dy * half], axis=1) for dy in (0, 1) for dx in (0, 1)])
    return box._replace(corner=np.concatenate([box.corner[~split], children]),
                        size=np.concatenate([box.size[~split], np.tile(half, 4)]))


def merged_nodes(parts: list[np.ndarray], resolution: float) -> np.ndarray:
    """The distinct points of ``parts`` (each (n, 2), m) in their order of first appearance: points closer than
    ``resolution`` / 2 along both axes (shared corners of boxes that meet) count once."""
    allp = np.vstack(parts)
    key = np.round(allp / resolution).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return allp[np.sort(first)]


def side_vertices(nodes: np.ndarray, start, end, tol: float) -> np.ndarray:
    """The nodes on the segment start → end (within ``tol``, m), ordered from start to end (the segment's ends
    included when they are nodes): the vertices of its boundary pieces."""
    a, b = np.asarray(start, np.float64), np.asarray(end, np.float64)
    d = b - a
    length = float(np.hypot(*d))
    s = (nodes - a) @ d / length
    off = np.abs((nodes - a) @ np.array([-d[1], d[0]]) / length)
    on = (off <= tol) & (s >= -tol) & (s <= length + tol)
    return nodes[on][np.argsort(s[on])]
