"""Shapes with a signed distance, and the fraction of a cell each covers: what material objects and regions are made
of (m, float64, NumPy: set-up only).

A shape answers ``signed_distance(points)`` (negative inside, m) and ``bounds()``. Shapes: :class:`Interval` (1D),
:class:`Disc`, :class:`Ellipse`, :class:`Polygon` (one or more closed loops, inside by the even-odd rule, so a loop
inside another is a hole), :func:`curve` (any closed parametric curve, as a polygon within a stated distance of it)
and :func:`section` (a watertight mesh's section by a plane, as a polygon).

:func:`cell_means` averages a quantity over square cells (intervals in 1D) that several shapes, layered in order,
cover in part: the cells the shapes' boundaries cross are split into quarters (halves in 1D) ``depth`` times, and
each final piece takes the fraction of the half-plane through it that the shape's distance at its centre and its
normal give (exact for a straight boundary, an error of the curvature times the piece's size squared otherwise).
This is the volume fraction subpixel averaging needs (Farjadpour et al. 2006) at a cost that grows with the length
of the boundaries in cells, not with the cells.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence

import numpy as np

from .errors import ParameterError, require_integer, require_memory, require_positive

__all__ = ["Shape", "Interval", "Disc", "Ellipse", "Polygon", "curve", "section", "cell_means", "half_plane_fraction"]


def _point(name: str, value, dim: int) -> np.ndarray:
    try:
        p = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be {dim} numbers, got {value!r}") from None
    if p.shape != (dim,) or not np.all(np.isfinite(p)):
        raise ParameterError(name, f"must be {dim} finite numbers, got {value!r}")
    return p


class Shape(ABC):
    """A region of space of dimension ``dim`` with a signed distance (m): negative inside, zero on its boundary."""

    dim: int = 2

    @abstractmethod
    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """(N,) distance (m) of ``points`` (N, >= dim) to the boundary, negative inside. Away from the boundary it
        may be any value of the right sign whose size is at most the true distance (an ellipse's is estimated)."""

    @abstractmethod
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) corners (m) of a box that holds the shape."""

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: ``points`` strictly inside."""
        return self.signed_distance(points) < 0.0

    def boundary_points(self, spacing: float) -> np.ndarray:
        """(M, dim) points on the boundary about ``spacing`` apart (m): its corners among them, the rest spread evenly
        along each piece between corners."""
        raise ParameterError("shape", f"a {type(self).__name__} cannot place points on its boundary")

    def normal(self, points: np.ndarray, step) -> np.ndarray:
        """(N, dim) outward unit normal: the distance's gradient by central differences of ``step`` (m, one or one per
        point)."""
        p = np.asarray(points, dtype=np.float64)[:, :self.dim]
        step = np.broadcast_to(np.asarray(step, dtype=np.float64), (p.shape[0],))
        g = np.empty_like(p)
        for a in range(self.dim):
            e = np.zeros_like(p)
            e[:, a] = step
            g[:, a] = self.signed_distance(p + e) - self.signed_distance(p - e)
        norm = np.linalg.norm(g, axis=1)
        g[norm > 0] /= norm[norm > 0, None]
        g[norm == 0, 0] = 1.0  # the centre of a disc: any direction (the cell then lies wholly inside or outside)
        return g

    def describe(self) -> dict:
        """The shape for ``summary.json``."""
        lo, hi = self.bounds()
        return {"kind": type(self).__name__.lower(), "lower": lo.tolist(), "upper": hi.tolist()}


class Interval(Shape):
    """[lower, upper] on a line (m)."""

    dim = 1

    def __init__(self, lower: float, upper: float):
        self.lower = float(_point("interval.lower", lower, 1)[0])
        self.upper = float(_point("interval.upper", upper, 1)[0])
        if not self.upper > self.lower:
            raise ParameterError("interval.upper", f"must exceed lower = {self.lower}, got {self.upper}")

    def signed_distance(self, points):
        x = np.asarray(points, dtype=np.float64).reshape(len(points), -1)[:, 0]
        return np.maximum(self.lower - x, x - self.upper)

    def bounds(self):
        return np.array([self.lower]), np.array([self.upper])

    def boundary_points(self, spacing):
        return np.array([[self.lower], [self.upper]])


class Disc(Shape):
    """A disc of ``radius`` (m) about ``centre``: signed distance |x - c| - r, exact."""

    def __init__(self, centre, radius: float):
        self.centre = _point("disc.centre", centre, 2)
        self.radius = require_positive("disc.radius", radius)

    def signed_distance(self, points):
        p = np.asarray(points, dtype=np.float64)[:, :2] - self.centre
        return np.hypot(p[:, 0], p[:, 1]) - self.radius

    def bounds(self):
        return self.centre - self.radius, self.centre + self.radius

    def boundary_points(self, spacing):
        count = max(8, int(round(2.0 * math.pi * self.radius / require_positive("spacing", spacing))))
        require_memory("spacing", count, 64.0, "boundary points")
        angle = 2.0 * math.pi * np.arange(count) / count
        return self.centre + self.radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)

    def describe(self):
        return {"kind": "disc", "centre": self.centre.tolist(), "radius": self.radius}


class Ellipse(Shape):
    """An ellipse of semi-axes (a, b) (m) about ``centre``, its a-axis turned ``angle`` radians from x. Signed distance
    estimated as g/|∇g|, g = sqrt((u/a)² + (v/b)²) - 1 scaled to length: exact on the boundary and to first order near
    it (what the cell fractions use), of the right sign everywhere."""

    def __init__(self, centre, semi_axes, angle: float = 0.0):
        self.centre = _point("ellipse.centre", centre, 2)
        self.semi_axes = _point("ellipse.semi_axes", semi_axes, 2)
        if np.any(self.semi_axes <= 0):
            raise ParameterError("ellipse.semi_axes", f"must be > 0, got {self.semi_axes.tolist()}")
        self.angle = float(angle)
        c, s = math.cos(self.angle), math.sin(self.angle)
        self._axes = np.array([[c, s], [-s, c]])  # world -> ellipse frame

    def signed_distance(self, points):
        q = (np.asarray(points, dtype=np.float64)[:, :2] - self.centre) @ self._axes.T
        a, b = self.semi_axes
        r = np.hypot(q[:, 0] / a, q[:, 1] / b)
        grad = np.hypot(q[:, 0] / (a * a), q[:, 1] / (b * b))  # |∇r| r
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where(grad > 0, (r - 1.0) * r / grad, -min(a, b))
        return d

    def boundary_points(self, spacing):
        spacing = require_positive("spacing", spacing)
        a, b = self.semi_axes
        fine = np.linspace(0.0, 2.0 * math.pi, 4097)
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(a * np.diff(np.cos(fine)), b * np.diff(np.sin(fine))))])
        count = max(8, int(round(arc[-1] / spacing)))
        require_memory("spacing", count, 64.0, "boundary points")
        t = np.interp(arc[-1] * np.arange(count) / count, arc, fine)  # even in arc length
        local = np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
        return self.centre + local @ self._axes

    def bounds(self):
        a, b = self.semi_axes
        c, s = math.cos(self.angle), math.sin(self.angle)
        half = np.array([math.hypot(a * c, b * s), math.hypot(a * s, b * c)])
        return self.centre - half, self.centre + half

    def describe(self):
        return {"kind": "ellipse", "centre": self.centre.tolist(), "semi_axes": self.semi_axes.tolist(),
                "angle": self.angle}


class Polygon(Shape):
    """One or more closed loops of vertices (m), inside by the even-odd rule (a loop inside another is a hole); the
    signed distance is the exact distance to the nearest edge (the edges with a vertex within the nearest vertex's
    distance plus the longest edge, from a KD-tree: the cost grows with the points, not with the edges)."""

    def __init__(self, loops):
        from matplotlib.path import Path
        from scipy.spatial import cKDTree

        one = isinstance(loops, np.ndarray) or (len(loops) > 0 and np.ndim(loops[0]) == 1)  # vertices, not loops
        loops = [loops] if one else list(loops)
        checked = []
        for k, loop in enumerate(loops):
            try:
                p = np.asarray(loop, dtype=np.float64)
            except (TypeError, ValueError):
                raise ParameterError("polygon", f"loop {k} must be an (M, 2) array of vertices") from None
            if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 3 or not np.all(np.isfinite(p)):
                raise ParameterError("polygon", f"loop {k} must be (M, 2) finite vertices with M >= 3, got shape "
                                                f"{p.shape}")
            if np.allclose(p[0], p[-1]) and p.shape[0] > 3:
                p = p[:-1]
            area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
            if abs(area) <= 1e-14 * np.ptp(p, axis=0).max() ** 2:
                raise ParameterError("polygon", f"loop {k} encloses no area")
            checked.append(p)
        if not checked:
            raise ParameterError("polygon", "needs at least one loop")
        self.loops = checked
        self._a = np.vstack(checked)  # edge k runs from _a[k] to _b[k]
        self._b = np.vstack([np.roll(p, -1, axis=0) for p in checked])
        first = np.cumsum([0] + [len(p) for p in checked])[:-1]
        self._previous = np.arange(len(self._a)) - 1  # the edge ending at vertex k
        self._previous[first] = first + np.array([len(p) for p in checked]) - 1
        self._longest = float(np.max(np.linalg.norm(self._b - self._a, axis=1)))
        self._tree = cKDTree(self._a)
        self._paths = [Path(p) for p in checked]

    def signed_distance(self, points):
        p = np.asarray(points, dtype=np.float64)[:, :2]
        if p.shape[0] == 0:
            return np.zeros(0)
        nearest, _ = self._tree.query(p)
        near = self._tree.query_ball_point(p, nearest * (1.0 + 1e-12) + self._longest + 1e-300)
        count = np.fromiter((len(v) for v in near), dtype=np.int64, count=p.shape[0])
        vertex = np.fromiter((k for v in near for k in v), dtype=np.int64, count=int(count.sum()))
        owner = np.repeat(np.arange(p.shape[0]), count)
        edge = np.concatenate([vertex, self._previous[vertex]])
        owner = np.concatenate([owner, owner])
        a, ab = self._a[edge], self._b[edge] - self._a[edge]
        rel = p[owner] - a
        t = np.clip(np.einsum("ij,ij->i", rel, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        d2 = np.full(p.shape[0], np.inf)
        np.minimum.at(d2, owner, np.einsum("ij,ij->i", rel - t[:, None] * ab, rel - t[:, None] * ab))
        inside = np.zeros(p.shape[0], bool)
        for path in self._paths:
            inside ^= path.contains_points(p)
        return np.where(inside, -1.0, 1.0) * np.sqrt(d2)

    def bounds(self):
        return self._a.min(axis=0), self._a.max(axis=0)

    def boundary_points(self, spacing):
        """Each loop's corners (vertices turning by more than 1°) and points spread evenly between them about
        ``spacing`` apart (a curve's many vertices then give way to points at the spacing)."""
        spacing = require_positive("spacing", spacing)
        out = []
        for loop in self.loops:
            prev, nxt = loop - np.roll(loop, 1, axis=0), np.roll(loop, -1, axis=0) - loop
            cos = np.einsum("ij,ij->i", prev, nxt) / np.maximum(np.linalg.norm(prev, axis=1) *
                                                                np.linalg.norm(nxt, axis=1), 1e-300)
            corners = np.flatnonzero(cos < math.cos(math.radians(1.0)))
            if corners.size == 0:
                corners = np.array([0])
            closed = np.vstack([loop, loop[:1]])
            length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
            # arc length at each corner, the first again one perimeter on
            at = np.r_[length[corners], length[corners[0]] + length[-1]]
            for k in range(corners.size):
                s0, s1 = at[k], at[k + 1]
                count = max(1, int(round((s1 - s0) / spacing)))
                require_memory("spacing", count, 64.0, "boundary points")
                arc = (s0 + (s1 - s0) * np.arange(count) / count) % length[-1]
                out.append(np.stack([np.interp(arc, length, closed[:, 0]), np.interp(arc, length, closed[:, 1])],
                                    axis=1))
        return np.vstack(out)

    def describe(self):
        lo, hi = self.bounds()
        return {"kind": "polygon", "loops": len(self.loops), "vertices": int(self._a.shape[0]), "lower": lo.tolist(),
                "upper": hi.tolist()}


def curve(function: Callable[[np.ndarray], np.ndarray], tolerance: float, samples: int = 64) -> Polygon:
    """A closed curve x(s), s in [0, 1) (``function`` maps (M,) parameters to (M, 2) points, m), as a polygon whose
    chords lie within ``tolerance`` (m) of the curve: the samples double until the largest gap between a chord's
    midpoint and the curve's point between its ends is below it."""
    tolerance = require_positive("tolerance", tolerance)
    count = require_integer("samples", samples, minimum=8)
    while True:
        require_memory("tolerance", count, 64.0, "curve samples")
        s = np.arange(count) / count
        p = np.asarray(function(s), dtype=np.float64)
        if p.shape != (count, 2) or not np.all(np.isfinite(p)):
            raise ParameterError("curve", f"the function must map (M,) parameters to (M, 2) finite points, got "
                                          f"{p.shape}")
        mid = np.asarray(function(s + 0.5 / count), dtype=np.float64)
        gap = np.max(np.linalg.norm(mid - 0.5 * (p + np.roll(p, -1, axis=0)), axis=1))
        if gap <= tolerance:
            return Polygon(p)
        count *= 2


def section(mesh, plane_origin=(0.0, 0.0, 0.0), plane_normal=(0.0, 0.0, 1.0)) -> Polygon:
    """A watertight mesh's section by a plane as a :class:`Polygon` (its loops; ``warpfree.geometry.mesh_section``
    gives the 2D coordinates)."""
    from .geometry import mesh_section

    loops = mesh_section(mesh, plane_origin, plane_normal)
    if not loops:
        raise ParameterError("plane_origin", "the plane misses the mesh: its section is empty")
    return Polygon(loops)


def half_plane_fraction(distance: np.ndarray, normal: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Fraction of a square of side ``size`` (an interval in 1D) where d(x) = distance + n·(x - centre) < 0: the
    distribution function of n·u for u uniform on the square, a trapezoid's (exact for a straight boundary)."""
    t = -np.asarray(distance, dtype=np.float64) / size
    n = np.abs(np.asarray(normal, dtype=np.float64))
    if n.ndim == 1 or n.shape[1] == 1:
        return np.clip(0.5 + t, 0.0, 1.0)
    p, q = np.min(n, axis=1), np.max(n, axis=1)
    q = np.maximum(q, 1e-300)
    lo, mid = 0.5 * (p + q), 0.5 * (q - p)
    out = np.where(t <= -lo, 0.0, np.where(t >= lo, 1.0, 0.0))
    thin = p < 1e-12 * q  # an axis-aligned boundary: the uniform distribution of width q
    with np.errstate(divide="ignore", invalid="ignore"):
        rise = (t + lo) ** 2 / (2.0 * p * q)
        fall = 1.0 - (lo - t) ** 2 / (2.0 * p * q)
        middle = p / (2.0 * q) + (t + mid) / q
    inner = (t > -lo) & (t < lo)
    value = np.where(t <= -mid, rise, np.where(t >= mid, fall, middle))
    value = np.where(thin, np.clip(0.5 + t / q, 0.0, 1.0), value)
    out = np.where(inner, value, out)
    return np.clip(out, 0.0, 1.0)  # rounding of the closed form at its ends (values within 1e-16 of 0 or 1)


def cell_means(shapes: Sequence[Shape], values: np.ndarray, centres: np.ndarray, sizes: np.ndarray, background,
               depth: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The mean over each cell (a square of side ``sizes`` (N,) about ``centres`` (N, dim); an interval in 1D) of
    quantities that are ``values[k]`` (Q,) inside shape k and ``background`` (N, Q) outside every shape, a later shape
    covering an earlier one where they overlap. Returns (means (N, Q), normals (N, dim): the outward normal of the
    boundary nearest each cell's centre, for direction-aware averages).

    Cells whose half-diagonal reaches a boundary are split ``depth`` times, only where a boundary crosses a piece; a
    final piece covered in part by several shapes counts them as layered independently (exact unless two boundaries
    cross one piece, 1/2^depth of a cell)."""
    shapes = list(shapes)
    values = np.asarray(values, dtype=np.float64).reshape(len(shapes), -1)
    centres = np.asarray(centres, dtype=np.float64)
    dim = shapes[0].dim if shapes else centres.shape[1]
    centres = centres[:, :dim]
    sizes = np.broadcast_to(np.asarray(sizes, dtype=np.float64), (centres.shape[0],))
    background = np.broadcast_to(np.asarray(background, dtype=np.float64).reshape(centres.shape[0], -1),
                                 (centres.shape[0], values.shape[1]))
    depth = require_integer("depth", depth, minimum=0, maximum=8)
    n = centres.shape[0]
    means = np.zeros((n, values.shape[1]))
    normals = np.zeros((n, dim))
    normals[:, 0] = 1.0
    if not shapes:
        return background.copy(), normals
    nearest = np.full(n, np.inf)
    for shape in shapes:
        d = shape.signed_distance(centres)
        closer = np.abs(d) < nearest
        if np.any(closer):
            normals[closer] = shape.normal(centres[closer], 1e-3 * sizes[closer])
            nearest[closer] = np.abs(d[closer])
    corners = np.array(np.meshgrid(*[[-0.25, 0.25]] * dim, indexing="ij")).reshape(dim, -1).T  # child offsets
    owner = np.arange(n)
    piece_centre, piece_size, weight = centres, sizes.copy(), np.ones(n)
    half_diagonal = 0.5 * math.sqrt(dim)
    for level in range(depth + 1):
        d = np.stack([s.signed_distance(piece_centre) for s in shapes], axis=1)  # (P, K)
        reach = half_diagonal * piece_size[:, None]
        cut = np.any(np.abs(d) < reach, axis=1)
        last = level == depth
        settle = ~cut | last
        if np.any(settle):
            idx = np.flatnonzero(settle)
            fraction = (d[idx] < 0).astype(np.float64)
            if last:
                for k, s in enumerate(shapes):
                    partial = np.abs(d[idx, k]) < reach[idx, 0]
                    if np.any(partial):
                        at = idx[partial]
                        fraction[partial, k] = half_plane_fraction(d[at, k], s.normal(piece_centre[at],
                                                                                      1e-3 * piece_size[at]),
                                                                   piece_size[at])
            covered = np.zeros(idx.size)  # of the piece, by the shapes above the current one
            piece_mean = np.zeros((idx.size, values.shape[1]))
            for k in range(len(shapes) - 1, -1, -1):
                visible = fraction[:, k] * (1.0 - covered)
                piece_mean += visible[:, None] * values[k]
                covered += visible
            piece_mean += (1.0 - covered)[:, None] * background[owner[idx]]
            np.add.at(means, owner[idx], weight[idx, None] * piece_mean)
        if last or not np.any(cut):
            break
        idx = np.flatnonzero(cut)
        require_memory("depth", float(idx.size) * corners.shape[0], 64.0, "cell pieces")
        piece_centre = (piece_centre[idx, None, :] + corners[None] * piece_size[idx, None, None]).reshape(-1, dim)
        piece_size = np.repeat(0.5 * piece_size[idx], corners.shape[0])
        weight = np.repeat(weight[idx] / corners.shape[0], corners.shape[0])
        owner = np.repeat(owner[idx], corners.shape[0])
    return means, normals
