"""Neighbour grid: a wrapper over ``wp.HashGrid`` with a rebuild policy, and static CSR neighbour lists.

- :class:`NeighbourGrid` holds a HashGrid over one particle set (the *source*). Kernels query it with
  ``grid.id`` and ``grid.query_radius`` and test the true distance against the cut-off ``grid.radius``.
  The same grid serves same-set queries (fluid-fluid) and cross-set queries (fluid -> boundary,
  Gauss point -> node, particle -> node) because a query point need not belong to the source set.
- Rebuild policy: ``"static"`` builds once (SPEM particles, EFG nodes, fixed walls); ``"always"``
  rebuilds every step; a ``skin`` > 0 keeps the grid until a particle has moved more than skin/2 since
  the last build (queries then use radius + skin).
- :func:`neighbour_list` builds CSR lists (offsets, indices) once for static structures, in two passes
  (count, then fill) so each query writes only its own row.

Cell width equals the query radius. 2D sets (z = 0) use one cell layer in z.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .device import Launcher
from .errors import ParameterError, require_positive
from warpfree.kernels import neighbours as nk


def _grid_dims(dim: int, n_points: int) -> tuple[int, int, int]:
    """Hash table size: about one cell per point, at most 128 per axis (the hash wraps beyond)."""
    if dim == 2:
        side = int(min(256, max(8, math.ceil(math.sqrt(max(n_points, 1))))))
        return side, side, 1
    side = int(min(128, max(8, math.ceil(max(n_points, 1) ** (1.0 / 3.0)))))
    return side, side, side


class NeighbourGrid:
    """HashGrid over a source particle set.

    Parameters
    ----------
    positions: ``wp.array(dtype=wp.vec3)`` of the source set (float32; z = 0 in 2D).
    radius: cut-off (support) radius, > 0.
    dim: 2 or 3.
    policy: ``"always"``, ``"static"`` or ``"skin"``.
    skin: extra query margin for ``policy="skin"``.
    """

    POLICIES = ("always", "static", "skin")

    def __init__(self, positions: wp.array, radius: float, dim: int, policy: str = "always",
                 skin: float = 0.0, device: str | None = None):
        self.radius = require_positive("radius", radius)
        if dim not in (1, 2, 3):
            raise ParameterError("dim", f"must be 1, 2 or 3, got {dim!r}")
        if policy not in self.POLICIES:
            raise ParameterError("policy", f"must be one of {self.POLICIES}, got {policy!r}")
        self.skin = require_positive("skin", skin, allow_zero=True)
        if policy == "skin" and self.skin == 0.0:
            raise ParameterError("skin", "must be > 0 with policy='skin'")
        self.dim = dim
        self.policy = policy
        self.positions = positions
        self.device = device or str(positions.device)
        dx, dy, dz = _grid_dims(2 if dim < 3 else 3, positions.shape[0])
        self.grid = wp.HashGrid(dx, dy, dz, device=self.device)
        self.builds = 0
        self._built_at: np.ndarray | None = None
        self.build()

    @property
    def id(self):
        return self.grid.id

    @property
    def query_radius(self) -> float:
        """Radius to pass to ``wp.hash_grid_query`` (cut-off plus skin)."""
        return self.radius + (self.skin if self.policy == "skin" else 0.0)

    def build(self, positions: wp.array | None = None) -> None:
        """(Re)build the hash grid over the current source positions."""
        if positions is not None:
            self.positions = positions
        self.grid.build(self.positions, self.query_radius)
        self.builds += 1
        if self.policy == "skin":
            self._built_at = self.positions.numpy().copy()

    def update(self, positions: wp.array | None = None) -> bool:
        """Apply the rebuild policy after the source set moved; returns True if it rebuilt."""
        if positions is not None:
            self.positions = positions
        if self.policy == "static":
            return False
        if self.policy == "skin":
            moved = np.max(np.linalg.norm(self.positions.numpy() - self._built_at, axis=1), initial=0.0)
            if moved <= 0.5 * self.skin:
                return False
        self.build()
        return True


def neighbour_counts(launcher: Launcher, grid: NeighbourGrid, query_points: wp.array,
                     exclude_self: bool = False) -> np.ndarray:
    """Neighbour count of every query point within ``grid.radius`` (an int32 NumPy array)."""
    n = query_points.shape[0]
    counts = wp.zeros(n, dtype=wp.int32, device=launcher.device)
    launcher.launch(nk.count_neighbours, n, [grid.id, query_points, grid.positions, grid.query_radius,
                                             grid.radius, int(exclude_self), counts])
    return counts.numpy()


def neighbour_counts_brute(launcher: Launcher, query_points: wp.array, source_points: wp.array,
                           radius: float, exclude_self: bool = False) -> np.ndarray:
    """Brute-force reference for :func:`neighbour_counts` (O(N M), for tests)."""
    n = query_points.shape[0]
    counts = wp.zeros(n, dtype=wp.int32, device=launcher.device)
    launcher.launch(nk.count_neighbours_brute, n, [query_points, source_points, float(radius),
                                                   int(exclude_self), counts])
    return counts.numpy()


def neighbour_list(launcher: Launcher, grid: NeighbourGrid, query_points: wp.array,
                   exclude_self: bool = False) -> tuple[wp.array, wp.array]:
    """CSR neighbour lists ``(offsets[n+1], indices[nnz])`` of query points in the grid's source set."""
    n = query_points.shape[0]
    counts = neighbour_counts(launcher, grid, query_points, exclude_self)
    offsets_np = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(counts, out=offsets_np[1:])
    offsets = wp.array(offsets_np, dtype=wp.int32, device=launcher.device)
    indices = wp.zeros(max(int(offsets_np[-1]), 1), dtype=wp.int32, device=launcher.device)
    launcher.launch(nk.fill_neighbours, n, [grid.id, query_points, grid.positions, grid.query_radius,
                                            grid.radius, int(exclude_self), offsets, indices])
    return offsets, indices


class NeighbourTable:
    """Neighbour lists with a fixed capacity per row, filled in one pass (the hot path of moving sets).

    Row ``i`` holds ``counts[i]`` source indices at ``indices[i*capacity : i*capacity + counts[i]]``.
    A fill that finds a row longer than the capacity grows the table (x1.25 of the longest row) and
    fills again, so no neighbour is ever dropped. Arrays are reused between fills of the same size.
    """

    def __init__(self, launcher: Launcher, capacity: int = 32):
        self.launcher = launcher
        self.capacity = max(1, int(capacity))
        self.counts: wp.array | None = None
        self.indices: wp.array | None = None
        self.grows = 0

    def _allocate(self, n: int) -> None:
        dev = self.launcher.device
        if self.counts is None or self.counts.shape[0] != n:
            self.counts = wp.zeros(max(n, 1), dtype=wp.int32, device=dev)
        size = max(n * self.capacity, 1)
        if self.indices is None or self.indices.shape[0] != size:
            self.indices = wp.zeros(size, dtype=wp.int32, device=dev)

    def fill(self, grid: NeighbourGrid, query_points: wp.array, exclude_self: bool = False) -> None:
        """Rows for every query point: the grid's source points within ``grid.radius``."""
        n = query_points.shape[0]
        while True:
            self._allocate(n)
            if n == 0:
                return
            self.launcher.launch(nk.fill_neighbour_table, n,
                                 [grid.id, query_points, grid.positions, grid.query_radius, grid.radius,
                                  int(exclude_self), self.capacity, self.counts, self.indices])
            longest = int(self.counts.numpy()[:n].max())
            if longest <= self.capacity:
                return
            self.capacity = int(math.ceil(1.25 * longest))
            self.grows += 1
