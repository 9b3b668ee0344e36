"""Domain decomposition: which rank owns which part of space.

A :class:`Decomposition` gives each rank an axis-aligned box; the boxes tile the domain (the outer faces open,
or a periodic axis's period) and every cut lies on a face of the neighbour grid's cells (width ``cell``: the
support radius), so a box is whole cells. Two ways of cutting, both balancing a cost per item (its neighbour
count, or 1):

- ``slabs``: cuts across one axis (the domain's longest), at the cost's quantiles;
- ``rcb``: recursive coordinate bisection: the longest side of the items' extent in a box is cut so that each half
  holds the cost of the ranks it will hold (Berger & Bokhari 1987), then each half again, down to one rank a box.

An item belongs to the box that holds it (lower faces closed, upper open). A rank needs, besides its own items,
every item within ``depth`` of its box (its ghosts: :mod:`warpfree.parallel.halo`); :meth:`Decomposition.near`
finds them, by the distance to each box (the minimum image across periodic axes). Where a rank also reads items
across a plane (an opening's buffer particle takes its values from the fluid about its mirror image, the point as far
in front of the plane as it is behind), :class:`Mirrors` adds the items whose mirror image lies within ``depth`` of
the box.

Refused: more ranks than cells to cut along the decomposition's axes (a box would hold no whole cell).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from warpfree.errors import ParameterError
from warpfree.parameters import Choice

__all__ = ["Decomposition", "CutMethod", "Mirrors", "imbalance"]


class CutMethod(Choice):
    """How space is cut between the ranks."""

    SLABS = "slabs", "cuts across one axis, at the work's quantiles"
    RCB = "rcb", "recursive coordinate bisection over grid cells, each cut across the longest side"


def imbalance(costs) -> float:
    """max / mean of the ranks' costs (1: balanced)."""
    costs = np.asarray(costs, dtype=np.float64)
    mean = costs.mean() if costs.size else 0.0
    return float(costs.max() / mean) if mean > 0 else 1.0


@dataclass(frozen=True)
class Mirrors:
    """Planes across which a rank reads items: plane k through ``point[k]`` with unit normal ``normal[k]`` ((k, 3)
    each) reflects an item at signed distance d = (x - point)·normal in ``[-behind[k], reach[k]]`` (m) to
    x - 2 d normal. A rank whose box lies within ``depth`` of that image holds the item as a ghost: its own items
    behind the plane read the items about their mirror images."""

    point: np.ndarray
    normal: np.ndarray
    reach: np.ndarray
    behind: np.ndarray

    def images(self, points: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """For each plane: (the rows of ``points`` (n, 3) in its range, their mirror images (m, 3))."""
        out = []
        for point, normal, reach, behind in zip(self.point, self.normal, self.reach, self.behind):
            d = (points - point) @ normal
            rows = np.flatnonzero((d >= -behind) & (d <= reach))
            out.append((rows, points[rows] - 2.0 * d[rows, None] * normal))
        return out


@dataclass
class Decomposition:
    """``lower`` and ``upper`` (ranks, 3): each rank's box; ``period`` (3): the period of each periodic axis (0: not
    periodic); ``dim``; ``method`` and ``cell`` as made."""

    lower: np.ndarray
    upper: np.ndarray
    period: np.ndarray
    dim: int
    method: CutMethod
    cell: float
    #: the owner of each bin of the grid the boxes' faces make (:meth:`owner`), made at its first use
    _bins: tuple | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def size(self) -> int:
        """The number of ranks (subdomains)."""
        return self.lower.shape[0]

    # -- making one -------------------------------------------------------------------------------------
    @classmethod
    def build(cls, size: int, points: np.ndarray, cost: np.ndarray | None, cell: float, dim: int,
              method: CutMethod = CutMethod.RCB, domain_lower=None, domain_upper=None, periodic=(False, False, False)):
        """Cut for ``size`` ranks the items at ``points`` (n, 3) with ``cost`` (n,; None: 1 each) into boxes of whole
        cells of width ``cell`` (m), counted from ``domain_lower`` (default: the items' lower corner). Periodic axes
        take their period from ``domain_lower`` .. ``domain_upper``."""
        method = CutMethod.of("decomposition", method)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        cost = np.ones(len(points)) if cost is None else np.asarray(cost, dtype=np.float64)
        lo_items = points.min(axis=0) if len(points) else np.zeros(3)
        hi_items = points.max(axis=0) if len(points) else np.zeros(3)
        origin = np.array(lo_items if domain_lower is None else np.asarray(domain_lower, float), dtype=np.float64)
        period = np.zeros(3)
        for a in range(3):
            if periodic[a]:
                period[a] = float(domain_upper[a]) - float(domain_lower[a])
        # the items' cells: integer coordinates of the cell grid (cuts fall on its faces)
        cells = np.floor((points - origin) / cell).astype(np.int64)
        lower = np.full((size, 3), -np.inf)
        upper = np.full((size, 3), np.inf)
        for a in range(3):
            if period[a] > 0:
                lower[:, a], upper[:, a] = origin[a], origin[a] + period[a]
        axes = list(range(dim))
        if method is CutMethod.SLABS:
            extent = (hi_items - lo_items)[:dim]
            axes = [int(np.argmax(extent))]
        span = {a: (int(cells[:, a].min()), int(cells[:, a].max()) + 1) if len(points) else (0, 1) for a in axes}
        room = int(np.prod([span[a][1] - span[a][0] for a in axes]))
        if size > max(room, 1) and size > 1:
            along = " and ".join("xyz"[a] for a in axes)
            raise ParameterError("ranks", f"{size} ranks cannot cut the domain at the support size: it spans "
                                          f"{room} cells of side {cell:.4g} (in the scene's length unit) along "
                                          f"{along}, and each rank needs at least one (fewer ranks, or a finer "
                                          "resolution)")
        _cut(np.arange(len(points)), list(range(size)), cells, cost, axes, lower, upper, origin, cell, method)
        return cls(lower, upper, period, dim, method, float(cell))

    # -- using one --------------------------------------------------------------------------------------
    def owner(self, points: np.ndarray) -> np.ndarray:
        """The rank whose box holds each point ((n, 3) -> (n,) int32), lower faces closed and upper open; a point
        outside every box (beyond an open face cannot happen: outer faces are at infinity) goes to the nearest box.

        The boxes' faces cut each axis into a few intervals; every bin of that grid lies in one box, found once
        (:meth:`_box_of`), so a point's owner is a lookup of its intervals (a binary search per axis)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if self._bins is None:
            faces = [np.unique(np.concatenate([self.lower[:, a], self.upper[:, a]])) for a in range(3)]
            faces = [f[np.isfinite(f)] for f in faces]
            centres = []
            for f in faces:
                edges = np.concatenate([[f[0] - 1.0], f, [f[-1] + 1.0]]) if f.size else np.zeros(2)
                centres.append(0.5 * (edges[:-1] + edges[1:]))
            grid = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).reshape(-1, 3)
            self._bins = (faces, self._box_of(grid).reshape([c.size for c in centres]))
        faces, table = self._bins
        index = []
        for a in range(3):
            x = p[:, a]
            if self.period[a] > 0:
                base = self.lower[:, a].min()
                x = base + np.mod(x - base, self.period[a])
            index.append(np.searchsorted(faces[a], x, side="right"))
        return table[tuple(index)]

    def _box_of(self, points: np.ndarray) -> np.ndarray:
        """:meth:`owner` by testing each point against each box (the bins' owners)."""
        p = self._wrapped(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        out = np.full(len(p), -1, dtype=np.int32)
        for r in range(self.size):
            inside = np.all((p >= self.lower[r]) & (p < self.upper[r]), axis=1) & (out < 0)
            out[inside] = r
        if np.any(out < 0):  # a point exactly on a periodic upper face after wrapping: the nearest box
            miss = np.flatnonzero(out < 0)
            d = np.stack([self._distance(p[miss], r) for r in range(self.size)], axis=1)
            out[miss] = np.argmin(d, axis=1)
        return out

    def held_by(self, points: np.ndarray, rank: int, depth: float, mirrors: Mirrors | None = None) -> np.ndarray:
        """Which points ``rank`` holds (bool (n,)): those its box owns and, as ghosts, those within ``depth`` of it
        (or whose mirror image is, :meth:`near`)."""
        return (self.owner(points) == rank) | self.near(points, rank, depth, mirrors)

    def near(self, points: np.ndarray, rank: int, depth: float, mirrors: Mirrors | None = None) -> np.ndarray:
        """Which points lie within ``depth`` of ``rank``'s box (bool (n,)), across periodic faces too; with
        ``mirrors``, also those whose mirror image across one of its planes does."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = self._distance(self._wrapped(p), rank) <= depth
        if mirrors is not None:
            for rows, image in mirrors.images(p):
                out[rows] |= self._distance(self._wrapped(image), rank) <= depth
        return out

    def _wrapped(self, p: np.ndarray) -> np.ndarray:
        out = p.copy()
        for a in range(3):
            if self.period[a] > 0:
                base = self.lower[:, a].min()
                out[:, a] = base + np.mod(p[:, a] - base, self.period[a])
        return out

    def _distance(self, p: np.ndarray, rank: int) -> np.ndarray:
        """Euclidean distance from each point to ``rank``'s box (minimum image along periodic axes)."""
        gap2 = np.zeros(len(p))
        for a in range(self.dim):
            lo, hi = self.lower[rank, a], self.upper[rank, a]
            g = np.maximum(np.maximum(lo - p[:, a], p[:, a] - hi), 0.0)
            if self.period[a] > 0:
                length = self.period[a]
                g = np.minimum(g, np.maximum(np.maximum(lo - (p[:, a] + length), (p[:, a] + length) - hi), 0.0))
                g = np.minimum(g, np.maximum(np.maximum(lo - (p[:, a] - length), (p[:, a] - length) - hi), 0.0))
            gap2 += g * g
        return np.sqrt(gap2)

    def describe(self) -> dict:
        """The decomposition for ``summary.json``: method, ranks, cell size, each rank's box (None for an unbounded
        side)."""
        return {"method": self.method, "ranks": self.size, "cell": self.cell,
                "lower": np.where(np.isfinite(self.lower), self.lower, None).tolist(),
                "upper": np.where(np.isfinite(self.upper), self.upper, None).tolist()}

    def to_dict(self) -> dict:
        """Plain numbers (a checkpoint manifest): :meth:`from_dict` gives it back."""
        return {"lower": self.lower.tolist(), "upper": self.upper.tolist(), "period": self.period.tolist(),
                "dim": self.dim, "method": self.method, "cell": self.cell}

    @classmethod
    def from_dict(cls, d: dict) -> "Decomposition":
        """A decomposition from its saved form (a checkpoint's manifest)."""
        return cls(np.array(d["lower"], float), np.array(d["upper"], float), np.array(d["period"], float),
                   int(d["dim"]), CutMethod.of("method", d["method"]), float(d["cell"]))


def _cut(items: np.ndarray, ranks: list[int], cells: np.ndarray, cost: np.ndarray, axes: list[int],
         lower: np.ndarray, upper: np.ndarray, origin: np.ndarray, cell: float, method: CutMethod) -> None:
    """Split ``items`` (in the box every rank of ``ranks`` now shares) between the ranks, writing their boxes."""
    if len(ranks) == 1:
        return
    if method is CutMethod.SLABS:  # every cut across the one axis, at the cost's quantiles
        axis = axes[0]
        k = len(ranks)
        faces = _quantile_faces(items, cells[:, axis], cost, [j / k for j in range(1, k)])
        edges = [lower[ranks[0], axis]] + [origin[axis] + f * cell for f in faces] + [upper[ranks[-1], axis]]
        for j, r in enumerate(ranks):
            lower[r, axis], upper[r, axis] = edges[j], edges[j + 1]
        return
    left, right = ranks[: len(ranks) // 2], ranks[len(ranks) // 2:]
    sub = cells[items] if len(items) else np.zeros((0, 3), np.int64)
    extent = [(sub[:, a].max() - sub[:, a].min() + 1) if len(items) else 0 for a in axes]
    axis = axes[int(np.argmax(extent))]
    face = _quantile_faces(items, cells[:, axis], cost, [len(left) / len(ranks)])[0]
    x = origin[axis] + face * cell
    for r in left:
        upper[r, axis] = x
    for r in right:
        lower[r, axis] = x
    in_left = cells[items, axis] < face
    _cut(items[in_left], left, cells, cost, axes, lower, upper, origin, cell, method)
    _cut(items[~in_left], right, cells, cost, axes, lower, upper, origin, cell, method)


def _quantile_faces(items: np.ndarray, cell_index: np.ndarray, cost: np.ndarray, fractions: list[float]) -> list[int]:
    """Cell faces (integer coordinates along one axis) that split the cost of ``items`` at ``fractions``: of the two
    faces around the cell where the running cost reaches a fraction, the one whose cost below is nearer it; every
    face distinct and strictly inside the items' span where it has room."""
    if len(items) == 0:
        return [0 for _ in fractions]
    c = cell_index[items]
    lo, hi = int(c.min()), int(c.max()) + 1
    per_cell = np.bincount(c - lo, weights=cost[items], minlength=hi - lo)
    running = np.cumsum(per_cell)
    total = running[-1]
    faces, previous = [], lo
    for j, f in enumerate(fractions):
        # the face after the first cell whose running cost reaches the fraction, at least one cell past the last
        # face, and leaving a cell for every face still to place
        target = f * total
        k = int(np.searchsorted(running, target, side="left")) + 1  # the face after the cell that reaches it
        if k > 1 and abs(running[k - 2] - target) < abs(running[k - 1] - target):
            k -= 1  # the face before that cell leaves the cost closer to the target
        face = lo + k
        face = max(face, previous + 1)
        face = min(face, hi - (len(fractions) - j))
        faces.append(int(face))
        previous = face
    return faces
