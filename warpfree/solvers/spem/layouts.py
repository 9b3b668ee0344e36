"""Particle layouts of SPEM: an E set and an H set interleaved in space.

The layout (Mendes (2010) fixes none in 2D): E particles at the nodes of a lattice of
spacing Δ; in 1D H at the midpoints; in 2D H in Yee's staggering by default (``h_staggering="edges"``: Hx at the
midpoints of the cell sides along y, Hy of those along x, none on a box's faces, each H particle carrying its one
component, ``StaggeredLayout.h_carries``), or both components at the cell centres (``"centres"``, the layout the
thesis's CSPM and SPH schemes are printed for). The cell-centred layout's nearest-shell stencil is Yee's rotated
by 45°: its E particles form two sub-lattices (i + j even / odd) that do not couple in the interior (the
checkerboard has no curl, a one-particle source drives only its own), which the split-field PML mixes and
reflects; Yee's staggering has neither. "Particles per wavelength" is λ/Δ, as FDTD counts cells.

Layouts: ``uniform``; ``jittered`` (every particle not on a wall moved by a random offset of up to
``jitter``·Δ per axis); ``graded`` (1D: the spacing grows geometrically by ``ratio`` per cell from
``grade_from`` on; 2D boxes: ``grading`` = the largest over the smallest spacing along each axis, varying
smoothly, so cells of different sizes and aspect ratios meet, to test particles of varying size). Walls: E particles on the boundary of
the region (a box's faces, a disk's circle) are flagged ``on_wall``: a scene holds them at Ez = 0 (a
perfect conductor) or leaves them free.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from warpfree.errors import ParameterError, require_memory, require_positive
from warpfree.parameters import Choice

#: the component an H particle carries under Yee's staggering (``StaggeredLayout.h_carries``)
HX, HY = 0, 1


class HStaggering(Choice):
    """Where the H particles sit in 2D, relative to the lattice of E particles."""

    EDGES = "edges", ("Yee's staggering: Hx at the midpoints of the cell sides along y, Hy of those along x, each "
                      "carrying its one component")
    CENTRES = "centres", "both components at the cell centres (the layout the thesis's CSPM and SPH are printed for)"

#: memory per particle (E or H) of a SPEM run, bytes: positions, fields, PML, cross-set neighbour lists, derivative
#: rows and the energy-conserving pair's sparse operators; the peak resident memory of the line, cavity and plane-wave
#: scenes grows by 2.4-3.4 kB per particle, rounded up
BYTES_PER_PARTICLE = 4096.0

__all__ = ["HX", "HY", "HStaggering", "StaggeredLayout", "staggered_line", "staggered_box", "staggered_disk",
           "carve_conductors"]


@dataclass
class StaggeredLayout:
    """Positions (N, 3) of the E and H sets, each particle's local spacing Δ (m), and the wall flags of E."""

    dim: int
    e_position: np.ndarray
    h_position: np.ndarray
    e_spacing: np.ndarray
    h_spacing: np.ndarray
    on_wall: np.ndarray
    spacing: float  # the nominal Δ
    lower: np.ndarray | None = None  # the region's bounding box (m)
    upper: np.ndarray | None = None
    inside: Callable | None = None  # inside(points (M, dim)) -> (M,) bool: the region the particles fill
    #: per H particle, the one component it carries (HX or HY: Yee's staggering, ``h_staggering="edges"``); None: both
    #: components on every H particle (``"centres"``, and 1D, where only Hy exists)
    h_carries: np.ndarray | None = None

    @property
    def n_e(self) -> int:
        """The number of E particles."""
        return self.e_position.shape[0]

    @property
    def n_h(self) -> int:
        """The number of H particles."""
        return self.h_position.shape[0]

    def h_subsets(self) -> list[np.ndarray]:
        """Per axis a, the indices of the H particles whose field is differentiated along a and which the a-derivative
        of Ez updates: axis x ↔ Hy (∂Hy/∂x, ∂Ez/∂x), axis y ↔ Hx; every H particle on every axis when each carries
        both components."""
        every = np.arange(self.n_h)
        if self.h_carries is None:
            return [every] * self.dim
        return [np.flatnonzero(self.h_carries == HY), np.flatnonzero(self.h_carries == HX)][:self.dim]

    def e_cell_volume(self) -> np.ndarray:
        """Each E particle's volume (m^dim), its spacing to the power dim."""
        return self.e_spacing ** self.dim

    def h_cell_volume(self) -> np.ndarray:
        """Each H particle's volume (m^dim), its spacing to the power dim."""
        return self.h_spacing ** self.dim

    def quadrature_volumes(self, e_position: np.ndarray | None = None,
                           h_position: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Each particle's Voronoi cell within the region, per set (m^dim): the quadrature of the energy-conserving
        pair (``SPEMModel(conservative=True)``), of the layout's positions or of the given ones (the model passes
        the float32 positions its kernels see, so that the volumes and the derivative rows describe one geometry)."""
        if self.inside is None:
            raise ParameterError("layout", "this layout has no region (lower, upper, inside) to measure volumes in")
        e = self.e_position if e_position is None else e_position
        h = self.h_position if h_position is None else h_position
        volumes = lambda p: voronoi_volumes(p, self.dim, self.lower, self.upper, self.inside, self.spacing)  # noqa: E731
        if self.h_carries is None:
            return volumes(e), volumes(h)
        vh = np.empty(h.shape[0])
        for component in (HX, HY):  # each component's particles tile the region on their own
            on = self.h_carries == component
            vh[on] = volumes(h[on])
        return volumes(e), vh


#: fine samples per spacing and axis measuring the Voronoi cells cut by the region's boundary 
FINE_SAMPLES = 16


def voronoi_volumes(points: np.ndarray, dim: int, lower, upper, inside: Callable, spacing: float) -> np.ndarray:
    """Volume (m^dim) of each point's Voronoi cell within the region: in 1D exactly (midpoints, clipped to
    [lower, upper]); in 2D the shoelace area of every cell whose vertices are all inside, and for the cells the
    boundary cuts (or leaves open) a count of fine samples (``FINE_SAMPLES`` per spacing and axis) inside the
    region that lie nearer to that point than to any other."""
    from scipy.spatial import Voronoi, cKDTree

    x = points[:, :dim]
    if dim == 1:
        order = np.argsort(x[:, 0])
        xs = x[order, 0]
        edges = np.concatenate([[lower[0]], 0.5 * (xs[1:] + xs[:-1]), [upper[0]]])
        out = np.empty(xs.size)
        out[order] = np.diff(edges)
        return out
    vor = Voronoi(x)
    regions = [vor.regions[r] for r in vor.point_region]
    length = np.array([len(r) for r in regions])
    flat = np.fromiter((v for r in regions for v in r), dtype=np.int64, count=int(length.sum()))
    start = np.concatenate([[0], np.cumsum(length)[:-1]])
    bad = np.ones(x.shape[0], bool)  # open (a vertex at infinity), empty, or with a vertex outside the region
    ok_vertex = np.concatenate([inside(vor.vertices), [False]])[np.where(flat < 0, -1, flat)]
    closed = np.add.reduceat(ok_vertex.astype(np.int64), start[length > 0]) == length[length > 0]
    bad[length > 0] = ~closed
    nxt = np.arange(flat.size) + 1  # each polygon's next vertex, wrapping to its first
    nxt[start + length - 1] = start
    v, w = vor.vertices[np.maximum(flat, 0)], vor.vertices[np.maximum(flat[nxt], 0)]
    cross = v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]
    out = np.zeros(x.shape[0])
    out[length > 0] = 0.5 * np.abs(np.add.reduceat(cross, start[length > 0]))
    out[bad] = 0.0
    cut = np.flatnonzero(bad)
    if cut.size:
        tree = cKDTree(x)
        h = spacing / FINE_SAMPLES
        k = np.arange(-int(1.5 * FINE_SAMPLES), int(1.5 * FINE_SAMPLES)) + 0.5
        patch = np.stack(np.meshgrid(k * h, k * h, indexing="ij"), -1).reshape(-1, 2)
        for chunk in np.array_split(cut, max(1, cut.size // 256)):
            samples = (x[chunk][:, None, :] + patch[None, :, :]).reshape(-1, 2)
            owner_wanted = np.repeat(chunk, patch.shape[0])
            ok = inside(samples)
            _, owner = tree.query(samples[ok])
            mine = owner == owner_wanted[ok]
            out += np.bincount(owner[mine], minlength=x.shape[0]) * h * h
    return out


def _pad3(p: np.ndarray) -> np.ndarray:
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    return np.hstack([p, np.zeros((p.shape[0], 3 - p.shape[1]))])


def _jitter(points: np.ndarray, keep: np.ndarray, amplitude: float, dim: int, rng) -> np.ndarray:
    out = points.copy()
    move = ~keep
    out[move, :dim] += rng.uniform(-amplitude, amplitude, (int(move.sum()), dim))
    return out


def _check_jitter(jitter: float) -> float:
    j = require_positive("jitter", jitter, allow_zero=True)
    if j >= 0.5:
        raise ParameterError("jitter", f"must be below 0.5 (a fraction of the spacing), got {j}")
    return j


def _edge_points(x_nodes: np.ndarray, y_nodes: np.ndarray, interior: bool = True):
    """Yee's H points on a lattice of nodes: Hx at (x_i, ½(y_j + y_j+1)), Hy at (½(x_i + x_i+1), y_j); with
    ``interior``, not on the box's faces (there Hx, Hy would be the normal field on a wall: zero on a conductor).
    Returns (points (M, 2), carries (M,), the lattice indices (i, j) of each point's node and its axis)."""
    xm, ym = 0.5 * (x_nodes[1:] + x_nodes[:-1]), 0.5 * (y_nodes[1:] + y_nodes[:-1])
    lo = 1 if interior else 0
    ix, jy = np.meshgrid(np.arange(lo, x_nodes.size - lo), np.arange(ym.size), indexing="ij")
    hx = np.stack([x_nodes[ix.ravel()], ym[jy.ravel()]], axis=1)
    iy, jx = np.meshgrid(np.arange(xm.size), np.arange(lo, y_nodes.size - lo), indexing="ij")
    hy = np.stack([xm[iy.ravel()], y_nodes[jx.ravel()]], axis=1)
    carries = np.r_[np.full(hx.shape[0], HX, np.int8), np.full(hy.shape[0], HY, np.int8)]
    return np.vstack([hx, hy]), carries, (ix.ravel(), jy.ravel(), iy.ravel(), jx.ravel())


def _require_cells(name: str, cells: float, dim: int, per_axis=None, per_cell: int = 2) -> None:
    """Refuse a spacing that leaves fewer than 2 cells along an axis, or more particles (``per_cell`` a cell: an E and
    an H, or an E and two H under Yee's staggering) than the memory available holds
    (:func:`warpfree.errors.require_memory`), before anything is allocated."""
    per_axis = np.atleast_1d(cells if per_axis is None else per_axis)
    if np.any(np.round(per_axis) < 2):
        raise ParameterError(name, f"leaves fewer than 2 cells along an axis (the region spans {per_axis.tolist()} "
                                   "spacings)")
    require_memory(name, per_cell * float(cells), BYTES_PER_PARTICLE, "particles (E and H)")


def staggered_line(x0: float, x1: float, spacing: float, jitter: float = 0.0, seed: int = 0,
                   grade_from: float | None = None, ratio: float = 1.0) -> StaggeredLayout:
    """1D: E at x0 + kΔ (both ends included, on the walls), H at the midpoints; Δ is adjusted so that the
    line holds a whole number of cells. ``grade_from``/``ratio``: beyond x = grade_from the spacing grows by
    ``ratio`` per cell (graded layout; the line then ends at the first node past x1)."""
    spacing = require_positive("spacing", spacing)
    if not x1 > x0:
        raise ParameterError("x1", f"must exceed x0 = {x0}, got {x1}")
    j = _check_jitter(jitter)
    _require_cells("spacing", (x1 - x0) / spacing, 1)
    if grade_from is None or ratio == 1.0:
        cells = int(round((x1 - x0) / spacing))
        nodes = x0 + (x1 - x0) * np.arange(cells + 1) / cells
    else:
        if not 1.0 <= ratio <= 1.2:
            raise ParameterError("ratio", f"must be in [1, 1.2] (a smooth grading), got {ratio}")
        nodes, d = [x0], spacing
        while nodes[-1] < x1 - 1e-12 * spacing:
            nodes.append(nodes[-1] + d)
            if nodes[-1] > grade_from:
                d *= ratio
        nodes = np.asarray(nodes)
    widths = np.diff(nodes)
    mids = 0.5 * (nodes[1:] + nodes[:-1])
    e_spacing = np.empty(nodes.size)
    e_spacing[1:-1] = 0.5 * (widths[1:] + widths[:-1])
    e_spacing[0], e_spacing[-1] = widths[0], widths[-1]
    on_wall = np.zeros(nodes.size, bool)
    on_wall[[0, -1]] = True
    e = _pad3(nodes[:, None])
    h = _pad3(mids[:, None])
    if j > 0:
        rng = np.random.default_rng(seed)
        e = _jitter(e, on_wall, j * float(np.min(widths)), 1, rng)
        h = _jitter(h, np.zeros(h.shape[0], bool), j * float(np.min(widths)), 1, rng)
    return StaggeredLayout(1, e, h, e_spacing, widths.copy(), on_wall, float((x1 - x0) / max(1, widths.size)),
                           np.array([nodes[0]]), np.array([nodes[-1]]),
                           lambda p: (p[:, 0] >= nodes[0]) & (p[:, 0] <= nodes[-1]))


def graded_nodes(lo: float, hi: float, cells: int, grading: float) -> np.ndarray:
    """``cells`` + 1 nodes on [lo, hi] whose spacing varies smoothly by the factor ``grading`` (largest over
    smallest): x(ξ) = lo + L (ξ + a sin(2πξ)/(2π)), ξ = k/cells, dx/dξ = L (1 + a cos 2πξ),
    a = (grading − 1)/(grading + 1): coarsest at the ends, finest in the middle."""
    a = (grading - 1.0) / (grading + 1.0)
    xi = np.arange(cells + 1) / cells
    return lo + (hi - lo) * (xi + a * np.sin(2.0 * np.pi * xi) / (2.0 * np.pi))


def staggered_box(lower, upper, spacing: float, jitter: float = 0.0, seed: int = 0,
                  grading: float = 1.0, h_staggering: HStaggering = HStaggering.EDGES) -> StaggeredLayout:
    """2D box: E at the lattice nodes (those on the faces flagged ``on_wall``), H in Yee's staggering
    (``h_staggering="edges"``, the default: Hx at the midpoints of the cell sides along y, Hy along x, none on the
    faces) or at the cell centres (``"centres"``);
    Δ is adjusted per axis to fit whole cells (the larger of the two adjusted spacings is the nominal Δ).
    ``grading`` > 1: the nodes along each axis from :func:`graded_nodes` (the mean spacing stays Δ); each
    particle's local spacing is the larger side of its cell (of the cells around an E node)."""
    spacing = require_positive("spacing", spacing)
    lo, hi = np.asarray(lower, float)[:2], np.asarray(upper, float)[:2]
    if lo.shape != (2,) or hi.shape != (2,) or np.any(hi <= lo):
        raise ParameterError("upper", f"a 2D box needs lower < upper per axis, got {lower}, {upper}")
    j = _check_jitter(jitter)
    h_staggering = HStaggering.of("h_staggering", h_staggering)
    if not (np.isfinite(grading) and 1.0 <= grading <= 3.0):
        raise ParameterError("grading", f"must be in [1, 3] (largest over smallest spacing), got {grading}")
    _require_cells("spacing", np.prod((hi - lo) / spacing), 2, per_axis=(hi - lo) / spacing,
                   per_cell=3 if h_staggering is HStaggering.EDGES else 2)
    cells = np.round((hi - lo) / spacing).astype(int)
    nodes = [graded_nodes(lo[a], hi[a], cells[a], grading) for a in range(2)]
    widths = [np.diff(x) for x in nodes]
    ix, iy = np.meshgrid(np.arange(cells[0] + 1), np.arange(cells[1] + 1), indexing="ij")
    e = np.stack([nodes[0][ix.ravel()], nodes[1][iy.ravel()]], axis=1)
    on_wall = (ix.ravel() == 0) | (ix.ravel() == cells[0]) | (iy.ravel() == 0) | (iy.ravel() == cells[1])
    cx, cy = np.meshgrid(np.arange(cells[0]), np.arange(cells[1]), indexing="ij")
    h = np.stack([0.5 * (nodes[0][cx.ravel()] + nodes[0][cx.ravel() + 1]),
                  0.5 * (nodes[1][cy.ravel()] + nodes[1][cy.ravel() + 1])], axis=1)
    h_spacing = np.maximum(widths[0][cx.ravel()], widths[1][cy.ravel()])
    node_width = [np.maximum(np.r_[w[0], w], np.r_[w, w[-1]]) for w in widths]  # the larger adjacent cell
    carries = None
    if h_staggering is HStaggering.EDGES:
        h, carries, (ix_x, jy_x, iy_y, jx_y) = _edge_points(nodes[0], nodes[1])
        h_spacing = np.r_[np.maximum(node_width[0][ix_x], widths[1][jy_x]),
                          np.maximum(widths[0][iy_y], node_width[1][jx_y])]
    e_spacing = np.maximum(node_width[0][ix.ravel()], node_width[1][iy.ravel()])
    smallest = float(min(w.min() for w in widths))
    e, h = _pad3(e), _pad3(h)
    if j > 0:
        rng = np.random.default_rng(seed)
        e = _jitter(e, on_wall, j * smallest, 2, rng)
        h = _jitter(h, np.zeros(h.shape[0], bool), j * smallest, 2, rng)
    nominal = float(((hi - lo) / cells).max())
    return StaggeredLayout(2, e, h, e_spacing, h_spacing, on_wall, nominal,
                           lo, hi, lambda p: np.all((p[:, :2] >= lo) & (p[:, :2] <= hi), axis=1), carries)


def staggered_disk(centre, radius: float, spacing: float, jitter: float = 0.0, seed: int = 0,
                   h_staggering: HStaggering = HStaggering.EDGES) -> StaggeredLayout:
    """2D disk: lattice nodes (E) farther than Δ/2 from the circle, H points (Yee's side midpoints, the default
    ``h_staggering="edges"``, or the cell centres) farther than Δ/10 (Yee's) or Δ/5 (centres) from the circle (so
    that every E node has H particles on its wall side too), and
    a ring of E particles on the circle at about Δ apart (``on_wall``): the cavity wall."""
    radius = require_positive("radius", radius)
    spacing = require_positive("spacing", spacing)
    j = _check_jitter(jitter)
    h_staggering = HStaggering.of("h_staggering", h_staggering)
    c = np.asarray(centre, float)[:2]
    _require_cells("spacing", np.pi * (radius / spacing) ** 2, 2, per_axis=np.full(2, 2.0 * radius / spacing),
                   per_cell=3 if h_staggering is HStaggering.EDGES else 2)
    n = int(np.ceil(radius / spacing)) + 1
    k = np.arange(-n, n + 1)
    gx, gy = np.meshgrid(k * spacing, k * spacing, indexing="ij")
    nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
    centres = nodes + 0.5 * spacing
    e_in = nodes[np.hypot(nodes[:, 0], nodes[:, 1]) < radius - 0.5 * spacing]
    carries = None
    if h_staggering is HStaggering.EDGES:
        centres, carries, _ = _edge_points(k * spacing, k * spacing, interior=False)
    # H between the last nodes and the ring, at least ``gap`` spacings inside the circle: cell centres 0.2, Yee's side
    # midpoints 0.1 (measured on the εr = 10 cavity at 10-80 cells per radius: 0.2 -> 0.1 raised the computed step
    # from 0.62, 0.26, 0.21 to 0.66, 0.54, 0.38 of Δ√εr/c at 20, 40, 80 cells and lowered the error by 6-28 %;
    # 0.05 and 0.3 were worse): with fewer H next to the wall the last E nodes' rows become one-sided extrapolations
    # (large coefficients, a small step), with H nearer the ring their own rows lean on the ring particle beside them
    gap = 0.1 if h_staggering is HStaggering.EDGES else 0.2
    inside = np.hypot(centres[:, 0], centres[:, 1]) < radius - gap * spacing
    h_in = centres[inside]
    carries = None if carries is None else carries[inside]
    m = max(8, int(round(2 * np.pi * radius / spacing)))
    a = 2 * np.pi * np.arange(m) / m
    ring = radius * np.stack([np.cos(a), np.sin(a)], axis=1)
    e = _pad3(np.vstack([e_in, ring]) + c)
    h = _pad3(h_in + c)
    on_wall = np.zeros(e.shape[0], bool)
    on_wall[e_in.shape[0]:] = True
    if j > 0:
        rng = np.random.default_rng(seed)
        e = _jitter(e, on_wall, j * spacing, 2, rng)
        h = _jitter(h, np.zeros(h.shape[0], bool), j * spacing, 2, rng)
    return StaggeredLayout(2, e, h, np.full(e.shape[0], spacing), np.full(h.shape[0], spacing), on_wall, spacing,
                           c - radius, c + radius, lambda p: np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) <= radius,
                           carries)


#: the nearest an H particle may sit to a conductor's surface, in spacings: Yee's side midpoints, cell centres (as
#: :func:`staggered_disk` measured them on the cavity)
H_GAP = {"edges": 0.1, "centres": 0.2}


def carve_conductors(layout: StaggeredLayout, shapes) -> StaggeredLayout:
    """``layout`` with perfect conductors cut out of it: the E particles inside ``shapes`` or nearer their surface than
    half their spacing removed, a row of E particles placed on each surface about a spacing apart (``on_wall``: held at
    Ez = 0, the wall where the geometry puts it, as :func:`staggered_disk`'s ring), the H particles inside or nearer
    than ``H_GAP`` spacings removed; the region (for the volumes) then excludes the conductors. Set-up, NumPy."""
    if not shapes:
        return layout
    dim = layout.dim

    def distance(points):
        return np.min([s.signed_distance(points[:, :dim]) for s in shapes], axis=0)

    keep_e = distance(layout.e_position) > 0.5 * layout.e_spacing * (1.0 - 1e-9)
    gap = H_GAP["edges" if layout.h_carries is not None or dim == 1 else "centres"]
    keep_h = distance(layout.h_position) > gap * layout.h_spacing
    surface = []
    for k, shape in enumerate(shapes):
        points = _pad3(shape.boundary_points(layout.spacing))
        others = [s for j, s in enumerate(shapes) if j != k]
        if others:  # a surface inside another conductor is no surface
            points = points[np.min([s.signed_distance(points[:, :dim]) for s in others], axis=0) >= 0.0]
        if layout.inside is not None:
            points = points[layout.inside(points)]
        surface.append(points)
    ring = np.vstack(surface)
    if not np.any(keep_e) or not np.any(keep_h):
        raise ParameterError("objects", "the perfect conductors cover the whole domain")
    region = layout.inside

    def inside(p):
        out = distance(p) >= -1e-9 * layout.spacing
        return out & region(p) if region is not None else out

    return StaggeredLayout(dim, np.vstack([layout.e_position[keep_e], ring]), layout.h_position[keep_h],
                           np.r_[layout.e_spacing[keep_e], np.full(ring.shape[0], layout.spacing)],
                           layout.h_spacing[keep_h], np.r_[layout.on_wall[keep_e], np.ones(ring.shape[0], bool)],
                           layout.spacing, layout.lower, layout.upper, inside,
                           None if layout.h_carries is None else layout.h_carries[keep_h])
