"""EFG node layouts in 2D (host-side NumPy, float64): regular and stratified-random grids (Rocha 2012).

A layout is (nx+1)(ny+1) nodes of a regular grid of the parameter square [0, 1]², numbered i + (nx+1)·j, mapped
onto a box, a convex quadrilateral (Cook's membrane, bilinear map) or a ring sector (polar map, Rocha's (2012) "radial"
cylinder layout). A random layout moves every node by up to ``jitter`` × the cell size along each parameter axis,
uniformly (one random node per sub-cell, so it has the regular layout's node count); boundary nodes stay ON the
boundary, so essential conditions can be imposed on them and NEM's Delaunay hull is the domain: corner nodes stay,
edge nodes move along their edge only, interior nodes anywhere in their sub-cell (jitter 0.5: the whole sub-cell,
the cell-sized square around the node's regular place).
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from warpfree.errors import ParameterError, require_finite, require_memory
from warpfree.parameters import Choice
from warpfree.galerkin.quadrature import (_angle_range, _box, _cell_counts, _convex_ccw, _finite_array,
                                             _ring, _whole, bilinear_map)

#: memory per node of a Galerkin solve, bytes, besides its Gauss points: coordinates, support radius and rows, the
#: stiffness matrix's row and the fill of its factorisation; the Timoshenko beam's and Cook's membrane's peak resident
#: memory grows by 73-113 kB per node (Gauss points included) up to 17 k nodes
BYTES_PER_NODE = 100e3

__all__ = ["NodeLayout", "NodePlacement", "annulus_nodes", "box_sides", "grid_nodes", "nodes_on", "quadrilateral_nodes",
           "random_grid_nodes"]


class NodePlacement(Choice):
    """Where a layout's nodes sit on its grid."""

    REGULAR = "regular", "on the grid's points"
    RANDOM = "random", "one random node per sub-cell of the grid, boundary nodes along their edges"


class NodeLayout(NamedTuple):
    """Nodes of a 2D EFG discretisation."""

    position: np.ndarray  # (n, 2) float64 (m)
    spacing: float  # nominal spacing (m): sqrt(domain area / cell count), the side of a mean square cell
    boundary: np.ndarray  # (n,) bool: the node lies on the domain boundary


def _jitter(jitter) -> float:
    """The jitter, a fraction of the cell size in [0, 0.5] (0.5 = anywhere in the node's sub-cell)."""
    j = require_finite("jitter", jitter)
    if not 0.0 <= j <= 0.5:
        raise ParameterError("jitter", f"must lie in [0, 0.5] (a fraction of the cell size), got {j}")
    return j


def _rng(seed, jitter: float) -> np.random.Generator | None:
    """The generator of ``seed`` (an integer >= 0), needed only when ``jitter`` > 0: a random layout is reproducible."""
    if seed is None:
        if jitter > 0.0:
            raise ParameterError("seed", "must be an integer >= 0 when jitter > 0 (a random layout is reproducible)")
        return None
    return np.random.default_rng(_whole("seed", seed, minimum=0))


def _grid_indices(nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """(i, j) of the (nx+1)(ny+1) grid nodes numbered i + (nx+1)·j."""
    j, i = np.divmod(np.arange((nx + 1) * (ny + 1)), nx + 1)
    return i, j


def _on_edge(nx: int, ny: int) -> np.ndarray:
    """True for the grid nodes on the edges of the parameter square."""
    i, j = _grid_indices(nx, ny)
    return (i == 0) | (i == nx) | (j == 0) | (j == ny)


def _grid_counts(cells) -> tuple[int, int]:
    """``cells`` = (nx, ny) of a node grid, refused before anything is allocated when its (nx+1)(ny+1) nodes would not
    fit in memory."""
    nx, ny = _cell_counts("cells", cells)
    require_memory("cells", (nx + 1.0) * (ny + 1.0), BYTES_PER_NODE, "nodes")
    return nx, ny


def _unit_grid(nx: int, ny: int, rng: np.random.Generator | None, jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """Parameters (s, t) in [0, 1]² of the grid nodes, each moved uniformly by up to ``jitter``/n along each axis,
    except along an axis in which it lies on the square's edge (edge nodes slide along their edge, corners stay)."""
    i, j = _grid_indices(nx, ny)
    s, t = i / nx, j / ny
    if rng is None or jitter == 0.0:
        return s, t
    move = rng.uniform(-jitter, jitter, size=(s.size, 2))
    s = s + np.where((i == 0) | (i == nx), 0.0, move[:, 0] / nx)
    t = t + np.where((j == 0) | (j == ny), 0.0, move[:, 1] / ny)
    return s, t


def grid_nodes(lower, upper, cells) -> NodeLayout:
    """The (nx+1)(ny+1) nodes of a regular grid of the box [lower, upper], ``cells`` = (nx, ny); index i + (nx+1)·j."""
    lo, hi = _box(lower, upper)
    nx, ny = _grid_counts(cells)
    return _box_layout(lo, hi, nx, ny, _unit_grid(nx, ny, None, 0.0))


def random_grid_nodes(lower, upper, cells, seed: int, jitter: float = 0.5) -> NodeLayout:
    """:func:`grid_nodes` with every node moved uniformly by up to ``jitter`` (0-0.5) × the cell size along each
    axis (np.random.default_rng(seed)): interior nodes in their sub-cell, edge nodes along their edge, corners fixed.
    The node count is the regular layout's."""
    lo, hi = _box(lower, upper)
    nx, ny = _grid_counts(cells)
    j = _jitter(jitter)
    return _box_layout(lo, hi, nx, ny, _unit_grid(nx, ny, _rng(seed, j), j))


def _box_layout(lo: np.ndarray, hi: np.ndarray, nx: int, ny: int, st: tuple[np.ndarray, np.ndarray]) -> NodeLayout:
    s, t = st
    position = np.stack([lo[0] + s * (hi[0] - lo[0]), lo[1] + t * (hi[1] - lo[1])], axis=1)
    spacing = math.sqrt(float(np.prod(hi - lo)) / (nx * ny))
    return NodeLayout(position, spacing, _on_edge(nx, ny))


def quadrilateral_nodes(corners, cells, seed: int | None = None, jitter: float = 0.0) -> NodeLayout:
    """Nodes of the bilinear map (:func:`~warpfree.galerkin.quadrature.bilinear_map`) of a regular
    (nx+1)(ny+1) grid of [0, 1]² onto the convex quadrilateral ``corners`` (4, 2, counter-clockwise; Cook's
    membrane: (0, 0), (48, 44), (48, 60), (0, 44)), jittered in the parameter square as in :func:`random_grid_nodes`
    when ``jitter`` > 0 (then ``seed`` is required). The map takes the square's edges onto the straight edges."""
    c = _convex_ccw("corners", corners)
    nx, ny = _grid_counts(cells)
    j = _jitter(jitter)
    s, t = _unit_grid(nx, ny, _rng(seed, j), j)
    e1, e2 = c[2] - c[0], c[3] - c[1]
    area = 0.5 * abs(e1[0] * e2[1] - e1[1] * e2[0])  # a quadrilateral's area is half the cross of its diagonals
    return NodeLayout(bilinear_map(c, s, t), math.sqrt(area / (nx * ny)), _on_edge(nx, ny))


def annulus_nodes(inner, outer, angle0, angle1, cells, seed: int | None = None, jitter: float = 0.0,
                  centre=(0.0, 0.0)) -> NodeLayout:
    """A polar grid of (n_r+1)(n_θ+1) nodes x = centre + r (cos θ, sin θ), r = inner..outer, θ = angle0..angle1
    (rad) in equal steps, ``cells`` = (n_r, n_θ), index i_r + (n_r+1)·i_θ (Rocha's (2012) "radial" layout of the
    cylinder quarter); jittered in (r, θ) as in :func:`random_grid_nodes` when ``jitter`` > 0 (``seed`` required).
    Boundary: r = inner, r = outer, θ = angle0, θ = angle1. Needs inner > 0 and angle1 - angle0 < 2π (otherwise
    nodes would coincide)."""
    r0, r1 = _ring(inner, outer, inner_may_be_zero=False)
    a0, a1 = _angle_range(angle0, angle1, full_turn=False)
    c = _finite_array("centre", centre, (2,))
    n_r, n_t = _grid_counts(cells)
    j = _jitter(jitter)
    s, t = _unit_grid(n_r, n_t, _rng(seed, j), j)
    r, theta = r0 + s * (r1 - r0), a0 + t * (a1 - a0)
    position = c + np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)
    spacing = math.sqrt(0.5 * (a1 - a0) * (r1 * r1 - r0 * r0) / (n_r * n_t))
    return NodeLayout(position, spacing, _on_edge(n_r, n_t))


def nodes_on(layout: NodeLayout, predicate: Callable, tol: float = 1e-6) -> np.ndarray:
    """Indices (int64, ascending) of the nodes where ``predicate(x, y, tol)`` is true: x, y (n,) the node
    coordinates, tol = ``tol`` (in spacings) × layout.spacing (m), e.g. the nodes on x = 0:
    ``nodes_on(layout, lambda x, y, tol: np.abs(x) <= tol)``."""
    t = require_finite("tol", tol)
    if t < 0.0:
        raise ParameterError("tol", f"must be >= 0 (in spacings), got {t}")
    x, y = layout.position[:, 0], layout.position[:, 1]
    hit = np.asarray(predicate(x, y, t * layout.spacing))
    if hit.shape != x.shape or hit.dtype != np.bool_:
        raise ParameterError("predicate", f"must return a bool array of shape {x.shape} (one per node), got "
                                          f"{hit.dtype} {hit.shape}")
    return np.flatnonzero(hit).astype(np.int64)


def box_sides(nodes, lower, upper, tol: float = 1e-9) -> list[np.ndarray]:
    """The four sides of the box [lower, upper] as polylines through the nodes on them, counter-clockwise (the
    domain on the left, as the boundary integrals expect): bottom, right, top, left. ``tol``: relative to the box
    size. For essential conditions whose multipliers or substituted values sit at the boundary nodes."""
    p = np.asarray(nodes, dtype=np.float64)[:, :2]
    lo, hi = _box(lower, upper)
    eps = tol * float(np.max(hi - lo))
    sides = []
    for axis, value, along, reverse in ((1, lo[1], 0, False), (0, hi[0], 1, False), (1, hi[1], 0, True),
                                        (0, lo[0], 1, True)):
        on = p[np.abs(p[:, axis] - value) <= eps]
        if on.shape[0] < 2:
            raise ParameterError("nodes", f"fewer than two nodes lie on the side {'xy'[axis]} = {value:g} of the box")
        on = on[np.argsort(on[:, along])]
        sides.append(on[::-1] if reverse else on)
    return sides
