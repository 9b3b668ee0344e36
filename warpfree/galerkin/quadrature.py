"""Background integration for EFG and NEM in 2D: Gauss points over cells and over the boundary (host-side NumPy).

The weak form of EFG (Belytschko, Lu & Gu 1994, Rocha 2012) is integrated on a background mesh of cells that need not
match the nodes: every cell contributes Gauss points ``position`` with weights ``weight`` = Gauss weight × |det J|
(m², so that the weights of a domain sum to its area), and every boundary piece contributes points with weights
= Gauss weight × the length element (m) and the unit outward normal, for tractions and Nitsche/penalty terms.

Cells: equal rectangles of a box, bilinear (isoparametric) quadrilaterals (Cook's membrane), exact polar cells of a
ring sector (the thick cylinder), triangles (Strang & Fix 1973 / Dunavant 1985 symmetric rules, degree 1-5).
Boundaries: straight segments, polylines and exact circular arcs. All arrays are float64 (int64 indices).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.polynomial.legendre import leggauss

from warpfree.errors import ParameterError, require_finite, require_integer, require_memory

from .mls import MLSBasis

__all__ = ["CELL_ORDER", "BoundaryPoints", "QuadraturePoints", "cell_order", "annulus_cells", "arc_points",
           "bilinear_map", "gauss_legendre", "polyline_points", "quadrilateral_cells", "rectangle_cells", "segment_points", "structured_quadrilateral",
           "triangle_cells", "triangle_rule", "TRIANGLE_DEGREES"]

TRIANGLE_DEGREES = (1, 2, 3, 4, 5)  # the total degrees triangle_rule integrates exactly
_DEGENERATE = 1e-12  # a cell whose |det J| (or area) is below this × its size² counts as degenerate
#: memory per Gauss point of a Galerkin solve, bytes: position and weight, its support row, shape values and gradients
#: (float64) and its assembly slots; the Timoshenko beam's peak resident memory grows by 3.8 kB per Gauss point at
#: d_max 3.5 (38 nodes a support), doubled for larger supports
BYTES_PER_GAUSS_POINT = 8192.0


class QuadraturePoints(NamedTuple):
    """Gauss points of a 2D domain."""

    position: np.ndarray  # (n, 2) float64 (m)
    weight: np.ndarray  # (n,) float64: Gauss weight × |det J| (m²); the weights sum to the area
    cell: np.ndarray  # (n,) int64: the integration cell the point belongs to

    def subset(self, index) -> "QuadraturePoints":
        """The points ``index`` (e.g. a distributed run's rank's own)."""
        index = np.asarray(index)
        return QuadraturePoints(self.position[index], self.weight[index], self.cell[index])


class BoundaryPoints(NamedTuple):
    """Gauss points of a boundary curve."""

    position: np.ndarray  # (n, 2) float64 (m)
    weight: np.ndarray  # (n,) float64: Gauss weight × length element (m); the weights sum to the length
    normal: np.ndarray  # (n, 2) float64: unit outward normal
    segment: np.ndarray  # (n,) int64: the segment (or arc piece) the point belongs to


# --- input checks (also used by warpfree.galerkin.node_layouts) --------------------------------------------------


def _whole(name: str, value, minimum: int = 1) -> int:
    """``value`` as an int if it is a whole number >= ``minimum``, else raise naming ``name``."""
    return require_integer(name, value, minimum=minimum)


def _cell_counts(name: str, cells) -> tuple[int, int]:
    """``cells`` = (n1, n2), two integers >= 1."""
    if np.ndim(cells) != 1 or len(cells) != 2:
        raise ParameterError(name, f"must be a pair of integers >= 1 (n1, n2), got {cells!r}")
    for n in cells:
        require_integer(name, n, minimum=1)
    return int(cells[0]), int(cells[1])


def _finite_array(name: str, value, shape: tuple) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape`` (None = any length along that axis)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be an array of numbers of shape {_shape_text(shape)}") from None
    if array.ndim != len(shape) or any(s is not None and a != s for a, s in zip(array.shape, shape)):
        raise ParameterError(name, f"must have shape {_shape_text(shape)}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ParameterError(name, "must hold finite numbers only")
    return array


def _shape_text(shape: tuple) -> str:
    return "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"


def _box(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """The corners of a box, checked: finite and upper > lower along both axes."""
    lo = _finite_array("lower", lower, (2,))
    hi = _finite_array("upper", upper, (2,))
    if np.any(hi <= lo):
        raise ParameterError("upper", f"must exceed lower = {lo.tolist()} along both axes, got {hi.tolist()}")
    return lo, hi


def _angle_range(angle0, angle1, full_turn: bool = True) -> tuple[float, float]:
    """Angles (rad) with angle0 < angle1 <= angle0 + 2π (< with ``full_turn=False``)."""
    a0, a1 = require_finite("angle0", angle0), require_finite("angle1", angle1)
    span = a1 - a0
    too_wide = span > 2.0 * math.pi * (1.0 + 1e-12) if full_turn else span >= 2.0 * math.pi * (1.0 - 1e-12)
    if span <= 0.0 or too_wide:
        top = "<=" if full_turn else "<"
        raise ParameterError("angle1", f"must satisfy angle0 < angle1 {top} angle0 + 2π, got angle0 = {a0}, "
                                       f"angle1 = {a1}")
    return a0, a1


def _ring(inner, outer, inner_may_be_zero: bool = True) -> tuple[float, float]:
    """Radii (m) with 0 <= inner < outer (0 < inner with ``inner_may_be_zero=False``)."""
    r0, r1 = require_finite("inner", inner), require_finite("outer", outer)
    if r0 < 0.0 or (r0 == 0.0 and not inner_may_be_zero):
        raise ParameterError("inner", f"must be {'>= 0' if inner_may_be_zero else '> 0'}, got {r0}")
    if r1 <= r0:
        raise ParameterError("outer", f"must exceed inner = {r0}, got {r1}")
    return r0, r1


def _convex_ccw(name: str, corners) -> np.ndarray:
    """(4, 2) corners of a strictly convex quadrilateral given counter-clockwise, checked."""
    c = _finite_array(name, corners, (4, 2))
    edge = np.roll(c, -1, axis=0) - c
    turn = edge[:, 0] * np.roll(edge, -1, axis=0)[:, 1] - edge[:, 1] * np.roll(edge, -1, axis=0)[:, 0]
    size = np.max(np.sum(edge * edge, axis=1))
    if np.any(turn <= _DEGENERATE * size):
        raise ParameterError(name, "must be the corners of a convex quadrilateral given counter-clockwise "
                                   f"(every turn to the left), got {c.tolist()}")
    return c


# --- one-dimensional and tensor Gauss rules ---------------------------------------------------------------------


#: Gauss points per background-cell side by MLS basis: the fewest that keep the basis's L2 rate on a non-convex domain
#: with flux boundaries (``warpfree.validation.efg_l_shape``, ``bench/efg/l_shape_rates.py``): the linear basis keeps
#: its rate at 2 x 2, the quadratic one (with its quadratic consistency correction) needs 3 x 3 (2 x 2: rates 2.0,
#: 1.7, 2.0; 3 x 3: 2.7, 2.9, 2.7)
CELL_ORDER = {"linear": 2, "quadratic": 3}


def cell_order(basis: MLSBasis, order: int | None = None) -> int:
    """``order`` when given, else the basis's :data:`CELL_ORDER`."""
    if order is not None:
        return order
    return CELL_ORDER[MLSBasis.of("basis", basis)]


def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """``order`` Gauss-Legendre points and weights on [-1, 1]; exact for polynomials of degree 2·order - 1."""
    n = _whole("order", order)
    points, weights = leggauss(n)
    return points.astype(np.float64), weights.astype(np.float64)


def _tensor_gauss(order: int, cells: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The order × order product rule on [-1, 1]²: ξ, η, w (order² each, ξ running fastest), for ``cells`` cells
    (refused before anything is allocated when their Gauss points would not fit in memory)."""
    n = _whole("order", order)
    require_memory("cells, order", float(cells) * n * n, BYTES_PER_GAUSS_POINT, "Gauss points")
    g, w = gauss_legendre(n)
    eta, xi = np.meshgrid(g, g, indexing="ij")
    return xi.ravel(), eta.ravel(), np.outer(w, w).ravel()


def _cell_index(n1: int, n2: int) -> tuple[np.ndarray, np.ndarray]:
    """(i1, i2) of cells numbered c = i1 + n1·i2."""
    i2, i1 = np.divmod(np.arange(n1 * n2), n1)
    return i1, i2


def _cells_of(n_cells: int, per_cell: int) -> np.ndarray:
    return np.repeat(np.arange(n_cells, dtype=np.int64), per_cell)


# --- cells ---------------------------------------------------------------------------------------------------------


def rectangle_cells(lower, upper, cells, order: int) -> QuadraturePoints:
    """The box [lower, upper] split into ``cells`` = (nx, ny) equal rectangles, order × order Gauss points each.

    Cell index = ix + nx·iy; weight = w_i w_j · hx hy / 4 (the Jacobian of [-1, 1]² onto an hx × hy cell).
    """
    lo, hi = _box(lower, upper)
    nx, ny = _cell_counts("cells", cells)
    xi, eta, w = _tensor_gauss(order, nx * ny)
    h = (hi - lo) / (nx, ny)
    ix, iy = _cell_index(nx, ny)
    x = lo[0] + h[0] * ((ix + 0.5)[:, None] + 0.5 * xi[None, :])
    y = lo[1] + h[1] * ((iy + 0.5)[:, None] + 0.5 * eta[None, :])
    weight = np.tile(w * (h[0] * h[1] / 4.0), nx * ny)
    return QuadraturePoints(np.stack([x.ravel(), y.ravel()], axis=1), weight, _cells_of(nx * ny, xi.size))


def _bilinear_shape(xi: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear shape functions N_a(ξ, η) on [-1, 1]² (corners counter-clockwise from (-1, -1)) and dN/dξ, dN/dη."""
    sx = np.array([-1.0, 1.0, 1.0, -1.0])
    se = np.array([-1.0, -1.0, 1.0, 1.0])
    one_xi = 1.0 + np.outer(xi, sx)
    one_eta = 1.0 + np.outer(eta, se)
    return 0.25 * one_xi * one_eta, 0.25 * sx * one_eta, 0.25 * se * one_xi


def _jacobian_determinant(vertices: np.ndarray, xi: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """det(∂x/∂(ξ, η)) of the bilinear map of every cell at the points (ξ, η): (m, k)."""
    _, dn_dxi, dn_deta = _bilinear_shape(xi, eta)
    dx_dxi = np.einsum("ka,mad->mkd", dn_dxi, vertices)
    dx_deta = np.einsum("ka,mad->mkd", dn_deta, vertices)
    return dx_dxi[..., 0] * dx_deta[..., 1] - dx_dxi[..., 1] * dx_deta[..., 0]


def quadrilateral_cells(vertices, order: int) -> QuadraturePoints:
    """order × order Gauss points in each bilinear (isoparametric) quadrilateral of ``vertices`` (m, 4, 2).

    x(ξ, η) = Σ N_a(ξ, η) x_a with the corners counter-clockwise; weight = w_i w_j |det J(ξ_i, η_j)|. det J of a
    bilinear map is linear in ξ and in η, so its sign at the four corners decides it over the whole cell: a cell
    with det J <= 0 at a corner or a Gauss point (inverted, clockwise, non-convex or collapsed) raises.
    """
    v = _finite_array("vertices", vertices, (None, 4, 2))
    if v.shape[0] == 0:
        raise ParameterError("vertices", "needs at least one cell")
    xi, eta, w = _tensor_gauss(order, v.shape[0])
    corner_xi, corner_eta = np.array([-1.0, 1.0, 1.0, -1.0]), np.array([-1.0, -1.0, 1.0, 1.0])
    det = _jacobian_determinant(v, xi, eta)
    det_corners = _jacobian_determinant(v, corner_xi, corner_eta)
    size = np.sum((v.max(axis=1) - v.min(axis=1)) ** 2, axis=1)  # squared bounding-box diagonal
    bad = np.any(np.concatenate([det, det_corners], axis=1) <= _DEGENERATE * size[:, None], axis=1)
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        raise ParameterError("vertices", f"cell {first} is inverted or degenerate (det J <= 0 in it); give the four "
                                         f"corners of a convex cell counter-clockwise, got {v[first].tolist()}")
    shape, _, _ = _bilinear_shape(xi, eta)
    position = np.einsum("ka,mad->mkd", shape, v).reshape(-1, 2)
    return QuadraturePoints(position, (w[None, :] * det).ravel(), _cells_of(v.shape[0], xi.size))


def bilinear_map(corners, s, t) -> np.ndarray:
    """The point (..., 2) of parameters (s, t) in [0, 1]² on the quadrilateral ``corners`` (4, 2):

    x = (1-s)(1-t) c0 + s(1-t) c1 + s t c2 + (1-s) t c3 (corners counter-clockwise, c0 at (0, 0)).
    """
    c = np.asarray(corners, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)[..., None]
    t = np.asarray(t, dtype=np.float64)[..., None]
    return (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3]


def structured_quadrilateral(corners, cells) -> np.ndarray:
    """The convex quadrilateral ``corners`` (4, 2, counter-clockwise) split into ``cells`` = (nx, ny) cells by the
    bilinear map of a regular grid of [0, 1]² (:func:`bilinear_map`): vertices (nx·ny, 4, 2) for
    :func:`quadrilateral_cells`, cell index ix + nx·iy, corners[0]→corners[1] being the ξ direction.

    E.g. Cook's membrane: corners (0, 0), (48, 44), (48, 60), (0, 44).
    """
    c = _convex_ccw("corners", corners)
    nx, ny = _cell_counts("cells", cells)
    require_memory("cells", float(nx) * ny, 4.0 * BYTES_PER_GAUSS_POINT, "integration cells")
    t, s = np.meshgrid(np.linspace(0.0, 1.0, ny + 1), np.linspace(0.0, 1.0, nx + 1), indexing="ij")
    nodes = bilinear_map(c, s, t)  # (ny + 1, nx + 1, 2)
    ix, iy = _cell_index(nx, ny)
    return np.stack([nodes[iy, ix], nodes[iy, ix + 1], nodes[iy + 1, ix + 1], nodes[iy + 1, ix]], axis=1)


def annulus_cells(inner, outer, angle0, angle1, cells, order: int, centre=(0.0, 0.0)) -> QuadraturePoints:
    """The ring sector inner <= r <= outer, angle0 <= θ <= angle1 (rad) around ``centre``, split into
    ``cells`` = (n_r, n_θ) cells equal in r and θ, with Gauss-Legendre in r and θ on the exact polar map
    x = centre + r (cos θ, sin θ). Cell index = i_r + n_r·i_θ; weight = w_i w_j · (Δr/2)(Δθ/2) · r, so the weights
    sum to the exact area (angle1 - angle0)(outer² - inner²)/2.
    """
    r0, r1 = _ring(inner, outer)
    a0, a1 = _angle_range(angle0, angle1)
    c = _finite_array("centre", centre, (2,))
    n_r, n_t = _cell_counts("cells", cells)
    xi, eta, w = _tensor_gauss(order, n_r * n_t)
    dr, dt = (r1 - r0) / n_r, (a1 - a0) / n_t
    ir, it = _cell_index(n_r, n_t)
    r = r0 + dr * ((ir + 0.5)[:, None] + 0.5 * xi[None, :])
    theta = a0 + dt * ((it + 0.5)[:, None] + 0.5 * eta[None, :])
    position = c + np.stack([r * np.cos(theta), r * np.sin(theta)], axis=-1).reshape(-1, 2)
    weight = (w[None, :] * (0.25 * dr * dt) * r).ravel()
    return QuadraturePoints(position, weight, _cells_of(n_r * n_t, xi.size))


# --- triangles -------------------------------------------------------------------------------------------------


def _orbit_aab(b: float) -> list[tuple[float, float, float]]:
    """The 3 barycentric points with two equal coordinates b (and a = 1 - 2b)."""
    a = 1.0 - 2.0 * b
    return [(a, b, b), (b, a, b), (b, b, a)]


def _orbit_abc(a: float, b: float) -> list[tuple[float, float, float]]:
    """The 6 permutations of (a, b, 1 - a - b)."""
    c = 1.0 - a - b
    return [(a, b, c), (a, c, b), (b, a, c), (b, c, a), (c, a, b), (c, b, a)]


def _degree3_rule(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strang & Fix (1973) 6-point degree-3 rule, positive weights 1/6: the permutations of (a, b, c)."""
    return np.array(_orbit_abc(p[0], p[1])), np.full(6, 1.0 / 6.0)


def _degree4_rule(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dunavant (1985) 6-point degree-4 rule: two (a, b, b) orbits with weights w1 and 1/3 - w1."""
    weights = np.repeat([p[2], 1.0 / 3.0 - p[2]], 3)
    return np.array(_orbit_aab(p[0]) + _orbit_aab(p[1])), weights


def _triangle_moments(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Exponents (i, j) with i + j <= degree and the mean of λ1^i λ2^j over a triangle, 2 i! j! / (i + j + 2)!."""
    powers = np.array([(i, d - i) for d in range(degree + 1) for i in range(d + 1)])
    mean = np.array([2.0 * math.factorial(i) * math.factorial(j) / math.factorial(i + j + 2) for i, j in powers])
    return powers, mean


def _refine(rule, start, degree: int, iterations: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton on the moment equations Σ w_k λ1^i λ2^j = 2 i! j!/(i+j+2)! (i + j <= degree): polishes
    the tabulated parameters of ``rule`` (15 digits in the literature) to round-off."""
    powers, exact = _triangle_moments(degree)

    def residual(p):
        bary, weights = rule(p)
        return (bary[:, 0][None, :] ** powers[:, :1] * bary[:, 1][None, :] ** powers[:, 1:]) @ weights - exact

    p = np.array(start, dtype=np.float64)
    for _ in range(iterations):
        r = residual(p)
        h = 1e-6
        jac = np.stack([(residual(p + h * e) - residual(p - h * e)) / (2 * h) for e in np.eye(p.size)], axis=1)
        p = p - np.linalg.lstsq(jac, r, rcond=None)[0]
    return rule(p)


@lru_cache(maxsize=None)
def _triangle_rule_cached(degree: int) -> tuple[np.ndarray, np.ndarray]:
    if degree == 1:
        return np.array([[1.0, 1.0, 1.0]]) / 3.0, np.ones(1)
    if degree == 2:  # Strang & Fix: interior points (2/3, 1/6, 1/6)
        return np.array(_orbit_aab(1.0 / 6.0)), np.full(3, 1.0 / 3.0)
    if degree == 3:  # a, b, c are the roots of t³ - t² + t/4 - 1/60 (e2 = 1/4, e3 = 1/60)
        return _refine(_degree3_rule, (0.659027622374092, 0.231933368553031), 3)
    if degree == 4:
        return _refine(_degree4_rule, (0.445948490915965, 0.091576213509771, 0.223381589678011), 4)
    root = math.sqrt(15.0)  # degree 5: Radon's 7-point rule, in closed form
    bary = [(1 / 3, 1 / 3, 1 / 3)] + _orbit_aab((6 - root) / 21) + _orbit_aab((6 + root) / 21)
    weights = np.array([9 / 40] + [(155 - root) / 1200] * 3 + [(155 + root) / 1200] * 3)
    return np.array(bary), weights


def triangle_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """A symmetric rule on a triangle exact for polynomials of total degree ``degree`` (1-5), positive weights:

    barycentric points (k, 3) and weights (k,) summing to 1 (multiply by the area). Degree 1: centroid; 2: 3 points
    (2/3, 1/6, 1/6); 3: 6 points, weights 1/6 (Strang & Fix 1973); 4: 6 points (Dunavant 1985); 5: 7 points (Radon).
    """
    require_integer("degree", degree, minimum=TRIANGLE_DEGREES[0], maximum=TRIANGLE_DEGREES[-1])
    bary, weights = _triangle_rule_cached(int(degree))
    return bary.copy(), weights.copy()


def triangle_cells(points, triangles, degree: int) -> QuadraturePoints:
    """Gauss points of the triangles (m, 3) (vertex indices into ``points`` (n, 2)), exact for total degree
    ``degree``: position = Σ λ_a x_a, weight = rule weight × triangle area (either orientation). Cell = triangle."""
    p = _finite_array("points", points, (None, 2))
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0 or not np.issubdtype(tri.dtype, np.integer):
        raise ParameterError("triangles", f"must be an integer array of shape (m, 3), m >= 1, got {tri.shape} "
                                          f"of {tri.dtype}")
    if np.any(tri < 0) or np.any(tri >= len(p)):
        raise ParameterError("triangles", f"vertex indices must lie in [0, {len(p) - 1}]")
    bary, w = triangle_rule(degree)
    corner = p[tri]  # (m, 3, 2)
    e1, e2 = corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    size = np.max(np.sum((corner - np.roll(corner, 1, axis=1)) ** 2, axis=2), axis=1)
    bad = area <= 0.5 * _DEGENERATE * size
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        raise ParameterError("triangles", f"triangle {first} {tri[first].tolist()} has zero area")
    position = np.einsum("ka,mad->mkd", bary, corner).reshape(-1, 2)
    return QuadraturePoints(position, (w[None, :] * area[:, None]).ravel(), _cells_of(len(tri), w.size))


# --- boundaries ---------------------------------------------------------------------------------------------------


def _boundary_order(order: int, pieces: int) -> int:
    """``order`` Gauss points on each of ``pieces`` boundary pieces, refused when they would not fit in memory."""
    n = _whole("order", order)
    require_memory("order", float(pieces) * n, BYTES_PER_GAUSS_POINT, "boundary Gauss points")
    return n


def _segments(name: str, start: np.ndarray, end: np.ndarray, order: int) -> BoundaryPoints:
    """Gauss-Legendre points along each straight segment start[k] → end[k]; normal (dy, -dx)/L."""
    g, w = gauss_legendre(_boundary_order(order, len(start)))
    d = end - start
    length = np.hypot(d[:, 0], d[:, 1])
    scale = np.maximum(np.max(np.abs(start), axis=1), np.max(np.abs(end), axis=1))
    short = length <= _DEGENERATE * scale  # relative to the coordinates' size (and length 0 at the origin)
    if np.any(short):
        first = int(np.flatnonzero(short)[0])
        raise ParameterError(name, f"segment {first} from {start[first].tolist()} to {end[first].tolist()} "
                                   "has zero length")
    u = 0.5 * (1.0 + g)
    position = (start[:, None, :] + u[None, :, None] * d[:, None, :]).reshape(-1, 2)
    normal = np.repeat(np.stack([d[:, 1], -d[:, 0]], axis=1) / length[:, None], g.size, axis=0)
    weight = (0.5 * w[None, :] * length[:, None]).ravel()
    return BoundaryPoints(position, weight, normal, _cells_of(len(start), g.size))


def segment_points(start, end, order: int) -> BoundaryPoints:
    """``order`` Gauss-Legendre points on each straight segment start[k] → end[k] ((s, 2) each, or (2,) for one):
    weight = w_i L/2 (m), normal = (dy, -dx)/L — outward when the domain lies to the left of start → end
    (the boundary traversed counter-clockwise). Segment index = k."""
    a = np.atleast_2d(_finite_array("start", start, (2,) if np.ndim(start) == 1 else (None, 2)))
    b = np.atleast_2d(_finite_array("end", end, (2,) if np.ndim(end) == 1 else (None, 2)))
    if a.shape != b.shape:
        raise ParameterError("end", f"must have the shape of start {a.shape}, got {b.shape}")
    return _segments("end", a, b, order)


def polyline_points(vertices, order: int, closed: bool = False) -> BoundaryPoints:
    """Gauss points of the polyline through ``vertices`` (p, 2): one segment per consecutive pair (and the closing
    one last → first if ``closed``), normals as in :func:`segment_points`. Segment index = the pair's index."""
    v = _finite_array("vertices", vertices, (None, 2))
    least = 3 if closed else 2
    if len(v) < least:
        raise ParameterError("vertices", f"needs at least {least} points{' (closed)' if closed else ''}, got {len(v)}")
    end = np.roll(v, -1, axis=0) if closed else v[1:]
    return _segments("vertices", v[: len(end)], end, order)


def arc_points(centre, radius, angle0, angle1, pieces: int, order: int, outward: bool = True) -> BoundaryPoints:
    """The exact circular arc centre + r (cos θ, sin θ), angle0 <= θ <= angle1 (rad), split into ``pieces`` equal
    angular pieces with ``order`` Gauss-Legendre points in θ each: weight = w_i r Δθ/2 (m), normal = ±(cos θ, sin θ),
    away from the centre if ``outward`` (the outer surface of a ring), towards it otherwise (the inner surface)."""
    c = _finite_array("centre", centre, (2,))
    r = require_finite("radius", radius)
    if r <= 0.0:
        raise ParameterError("radius", f"must be > 0, got {r}")
    a0, a1 = _angle_range(angle0, angle1)
    n = _whole("pieces", pieces)
    g, w = gauss_legendre(_boundary_order(order, n))
    dt = (a1 - a0) / n
    theta = (a0 + dt * (np.arange(n)[:, None] + 0.5 + 0.5 * g[None, :])).ravel()
    radial = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    weight = np.tile(0.5 * w * r * dt, n)
    return BoundaryPoints(c + r * radial, weight, radial if outward else -radial, _cells_of(n, g.size))
