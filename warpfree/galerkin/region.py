"""2D regions bounded by exact curves: shapes and their unions and differences, nodes at a spacing, integration cells
and boundary Gauss points on the true curves, and the boundary conditions of a Galerkin solve on tagged pieces
(host-side NumPy, float64, m).

A :class:`Region` is one or more closed loops of :class:`~warpfree.galerkin.curves.Piece` (segments, circular and
elliptic arcs, splines), each piece tagged for boundary conditions; outer loops run counter-clockwise and holes
clockwise, so that the outward normal is the tangent turned clockwise everywhere. Made from shapes
(:meth:`Region.rectangle`, :meth:`Region.disc`, :meth:`Region.ellipse`, :meth:`Region.polygon`, :meth:`Region.spline`),
from files (``warpfree.galerkin.region_files``: polygon and spline files, meshes through meshio), and combined with
:meth:`union`, :meth:`difference`, :meth:`intersection`: the pieces are split where the boundaries cross (the
crossing found on the exact curves) and the parts kept by where their midpoints lie, so a disc cut from a plate keeps
its exact arc.

:meth:`Region.nodes` fills the region at a spacing (or a size function: graded toward corners, curved edges or any
place the user asks): nodes along every piece at equal arc length (every corner a node), a lattice (or, graded, a
balanced quadtree's leaves) inside, none closer to the boundary than 0.45 of the local spacing. :meth:`Region.cells`
integrates over the region exactly bounded: the nodes' Delaunay triangles, those with a side on the boundary as
three fans from their centroid g, one over each side E(σ), the exact curve for a boundary side (x = g + ρ (E(σ) - g),
dA = ρ (E - g) × E' dσ dρ: a smooth integrand, so a tensor Gauss rule sums the true area to round-off), so the cells
tile the true region, not a polygon. (The blending of Gordon & Hall maps such a triangle too, but its Jacobian is
rational in the barycentric coordinates: a degree-5 rule left 7e-5 of a ring's area at 0.2 spacings.)
:meth:`Region.boundary_points` and :meth:`Region.essential_quadrature` give Gauss points on the exact pieces between
consecutive boundary nodes, for fluxes or tractions and for Dirichlet conditions (multipliers at the boundary nodes,
hats linear in the curve's parameter); ``warpfree.solvers.efg.region_conditions`` makes the EFG solvers' conditions
of them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from warpfree.errors import ParameterError, require_integer, require_memory, require_positive

from .curves import CircleCurve, Curve, EllipseCurve, Piece, Segment, SplineCurve
from .quadrature import BoundaryPoints, QuadraturePoints, gauss_legendre, triangle_cells

__all__ = ["Region", "RegionNodes", "CurveQuadrature"]

#: relative tolerance (of the region's size) for ends that meet and points on a boundary
_TOLERANCE = 1e-9
#: interior nodes stay this many local spacings clear of the boundary (the boundary nodes stand on it)
_CLEARANCE = 0.45
#: the sampled boundary's chords are no longer than the region's size over this (its distance queries stay local)
_SEGMENT_SAMPLES = 256


@dataclass
class CurveQuadrature:
    """An essential boundary's Gauss points on an exact curve: point g lies between multipliers ``multiplier[g]``
    (2,) with hat values ``hat[g]`` (2,), linear in the curve's parameter; ``n_multipliers`` in all."""

    points: BoundaryPoints
    multiplier: np.ndarray
    hat: np.ndarray
    n_multipliers: int


@dataclass
class RegionNodes:
    """Nodes filling a region: ``position`` (n, 2); the boundary's edges between consecutive boundary nodes,
    ``edge_nodes`` (e, 2) in the loops' direction, on piece ``edge_piece`` (e,) from its own parameter ``edge_s``
    (e, 0) to (e, 1); ``boundary`` (n,) True for a node on the boundary; ``spacing`` (n,) the local spacing asked."""

    position: np.ndarray
    edge_nodes: np.ndarray
    edge_piece: np.ndarray
    edge_s: np.ndarray
    boundary: np.ndarray
    spacing: np.ndarray

    @property
    def count(self) -> int:
        return int(self.position.shape[0])


class Region:
    """A region of the plane bounded by loops of exact pieces (module docstring). ``loops``: lists of
    :class:`~warpfree.galerkin.curves.Piece`, each closed (a piece ends where the next starts); nested loops are
    holes (even-odd), and each loop is turned to run counter-clockwise if outer, clockwise if a hole."""

    def __init__(self, loops: Sequence[Sequence[Piece]]):
        loops = [list(loop) for loop in loops if len(loop)]
        if not loops:
            raise ParameterError("region", "needs at least one closed loop of pieces")
        samples = [self._sample_loop(loop) for loop in loops]
        size = max(float(np.ptp(np.vstack(samples), axis=0).max()), 1e-300)
        samples = [self._sample_loop(loop, size / _SEGMENT_SAMPLES) for loop in loops]
        self.tolerance = _TOLERANCE * size
        for k, loop in enumerate(loops):
            for j, piece in enumerate(loop):
                gap = float(np.linalg.norm(piece.end - loop[(j + 1) % len(loop)].start))
                if gap > 1e3 * self.tolerance:
                    raise ParameterError("region", f"loop {k} is open: piece {j} ({piece.tag}) ends at "
                                                   f"{np.round(piece.end, 9).tolist()}, {gap:.3g} m from the next "
                                                   f"piece's start")
        from warpfree.shapes import Polygon

        areas = [_signed_area(s) for s in samples]
        for k, a in enumerate(areas):
            if abs(a) <= 1e-12 * size ** 2:
                raise ParameterError("region", f"loop {k} encloses no area")
        self._polygon = Polygon(samples)
        depth = [sum(1 for j, other in enumerate(samples) if j != k and _inside_loop(samples[k][0], other))
                 for k in range(len(loops))]
        self.loops = []
        for loop, area, d in zip(loops, areas, depth):
            want_ccw = d % 2 == 0
            if (area > 0) != want_ccw:
                loop = [p.reversed() for p in reversed(loop)]
            self.loops.append(loop)
        self._samples = [self._sample_loop(loop, size / _SEGMENT_SAMPLES) for loop in self.loops]

    # -- shapes ---------------------------------------------------------------------------------------------------
    @classmethod
    def polygon(cls, vertices, tags: str | Sequence[str] = "boundary") -> "Region":
        """The polygon through ``vertices`` (m, 2) (not repeated at the end); ``tags``: one for every edge, or edge k
        (from vertex k to k + 1) tagged ``tags[k]``."""
        v = np.asarray(vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3 or not np.all(np.isfinite(v)):
            raise ParameterError("vertices", f"must be (m, 2) finite vertices with m >= 3, got shape {v.shape}")
        if np.allclose(v[0], v[-1]):
            v = v[:-1]
        tags = _edge_tags(tags, len(v))
        return cls([[Piece(Segment(v[k], v[(k + 1) % len(v)]), 0.0, 1.0, tags[k]) for k in range(len(v))]])

    @classmethod
    def rectangle(cls, lower, upper, tags: str | Sequence[str] = "boundary") -> "Region":
        """The box lower..upper; ``tags``: one, or four for the bottom, right, top and left sides."""
        lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
        if lo.shape != (2,) or hi.shape != (2,) or np.any(hi <= lo):
            raise ParameterError("upper", f"the rectangle needs lower < upper, got {lower!r} .. {upper!r}")
        return cls.polygon([(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])], tags)

    @classmethod
    def disc(cls, centre, radius: float, tag: str = "boundary") -> "Region":
        """The disc |x - centre| < radius, its circle exact."""
        circle = CircleCurve(centre, radius)
        return cls([[Piece(circle, 0.0, 2.0 * math.pi, tag)]])

    @classmethod
    def ellipse(cls, centre, semi_axes, angle: float = 0.0, tag: str = "boundary") -> "Region":
        """The ellipse of ``semi_axes`` (a, b), its first axis at ``angle`` (rad), exact."""
        return cls([[Piece(EllipseCurve(centre, semi_axes, angle), 0.0, 2.0 * math.pi, tag)]])

    @classmethod
    def spline(cls, points, tag: str = "boundary") -> "Region":
        """The region inside the closed cubic spline through ``points`` (m, 2)."""
        curve = SplineCurve(points, closed=True)
        return cls([[Piece(curve, 0.0, curve.t_range[1], tag)]])

    @classmethod
    def of_shape(cls, shape, tag: str = "boundary") -> "Region":
        """The region of a :mod:`warpfree.shapes` shape: a ``Disc`` or ``Ellipse`` exact, a ``Polygon`` (its loops,
        holes by the even-odd rule)."""
        from warpfree import shapes

        if isinstance(shape, shapes.Disc):
            return cls.disc(shape.centre, shape.radius, tag)
        if isinstance(shape, shapes.Ellipse):
            return cls.ellipse(shape.centre, shape.semi_axes, shape.angle, tag)
        if isinstance(shape, shapes.Polygon):
            return cls([[Piece(Segment(p[k], p[(k + 1) % len(p)]), 0.0, 1.0, tag) for k in range(len(p))]
                        for p in shape.loops])
        raise ParameterError("shape", f"a region is made from a Disc, Ellipse or Polygon, got {type(shape).__name__}")

    # -- queries --------------------------------------------------------------------------------------------------
    @property
    def pieces(self) -> list[Piece]:
        """Every piece, loop after loop."""
        return [p for loop in self.loops for p in loop]

    @property
    def tags(self) -> list[str]:
        """The pieces' tags, each once, in order."""
        return list(dict.fromkeys(p.tag for p in self.pieces))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        s = np.vstack(self._samples)
        return s.min(axis=0), s.max(axis=0)

    def signed_distance(self, points) -> np.ndarray:
        """(n,) distance to the boundary (m), negative inside: to the boundary sampled within 1e-7 of its size."""
        return self._polygon.signed_distance(np.asarray(points, dtype=np.float64)[:, :2])

    def contains(self, points) -> np.ndarray:
        """(n,) True for points inside (the even-odd rule on the sampled loops)."""
        from matplotlib.path import Path

        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        inside = np.zeros(len(p), bool)
        for loop in self._samples:
            inside ^= Path(loop).contains_points(p)
        return inside

    @property
    def area(self) -> float:
        """The area enclosed (m²): ½ ∮ (x dy - y dx) on the exact pieces (Gauss-Legendre on each piece's
        partition)."""
        def twice_area_rate(piece):
            return lambda s: _cross(piece.point(s), piece.tangent(s))

        return 0.5 * sum(piece.integrate(twice_area_rate(piece)) for piece in self.pieces)

    def describe(self) -> dict:
        lo, hi = self.bounds()
        return {"loops": len(self.loops), "pieces": [p.describe() for p in self.pieces], "area": self.area,
                "lower": lo.tolist(), "upper": hi.tolist()}

    # -- booleans -------------------------------------------------------------------------------------------------
    def union(self, other: "Region") -> "Region":
        """The region inside either."""
        return _combine(self, other, keep_self_inside=False, keep_other_inside=False, reverse_other=False)

    def intersection(self, other: "Region") -> "Region":
        """The region inside both."""
        return _combine(self, other, keep_self_inside=True, keep_other_inside=True, reverse_other=False)

    def difference(self, other: "Region") -> "Region":
        """The region inside this one and outside ``other`` (a hole where ``other`` lies wholly inside)."""
        return _combine(self, other, keep_self_inside=False, keep_other_inside=True, reverse_other=True)

    __or__, __and__, __sub__ = union, intersection, difference

    def retagged(self, tag: str, where: Callable[[Piece], bool] | None = None) -> "Region":
        """The region with the pieces ``where`` selects (all by default) tagged ``tag``."""
        return Region([[Piece(p.curve, p.t0, p.t1, tag if where is None or where(p) else p.tag) for p in loop]
                       for loop in self.loops])

    # -- nodes ----------------------------------------------------------------------------------------------------
    def nodes(self, spacing: float, size: Callable[[np.ndarray], np.ndarray] | None = None,
              relax: int = 25) -> RegionNodes:
        """Nodes at ``spacing`` (m), or at the local spacing ``size(points)`` -> (n,) (m): along every piece at equal
        arc length (or equal ∫ ds/h), inside on a lattice of ``spacing`` (with a size function: the leaves of a
        balanced quadtree, each no larger than the size at its centre), none within 0.45 of the local spacing of the
        boundary; then ``relax`` steps of DistMesh's bar forces (Persson & Strang 2004) move the inside nodes apart
        where the lattice meets a curve (the boundary nodes stay; 0: the lattice as it is). Measured on a coaxial
        ring's surface field (r = 1 to 2, quadratic basis, largest error): the relaxed layout's falls at second order
        (1.0e-2, 2.4e-3, 6.5e-4 at spacings 0.2, 0.1, 0.05), the lattice's by 1.2e-2, 2.3e-3, 1.3e-3."""
        h0 = require_positive("spacing", spacing)
        relax = require_integer("relax", relax, minimum=0)
        local = _size_function(size, h0)
        lo, hi = self.bounds()
        require_memory("spacing", float(np.prod((hi - lo) / h0 + 2.0)), 64.0, "region nodes")
        boundary, edges = [], []
        for li, loop in enumerate(self.loops):
            first = sum(len(b) for b in boundary)
            loop_nodes, loop_edges, count = [], [], 0
            for pj, piece in enumerate(loop):
                s = _piece_stations(piece, local, h0, single=len(loop) == 1)
                pts = piece.point(s[:-1])
                start = first + count
                count += len(pts)
                loop_nodes.append(pts)
                for k in range(len(s) - 1):
                    loop_edges.append((start + k, start + k + 1, self._piece_index(li, pj), s[k], s[k + 1]))
            pts = np.vstack(loop_nodes)
            n_loop = len(pts)
            loop_edges[-1] = (*loop_edges[-1][:1], first, *loop_edges[-1][2:])  # the loop closes on its first node
            boundary.append(pts)
            edges += loop_edges
            if n_loop < 3:
                raise ParameterError("spacing", f"loop {li} gets {n_loop} boundary nodes: the spacing {h0:g} m is "
                                                "too coarse for it")
        xb = np.vstack(boundary)
        inner = self._interior(local, h0)
        if relax and len(inner):
            inner = self._relaxed(xb, inner, local, relax)
        position = np.vstack([xb, inner])
        e = np.array(edges, dtype=object)
        return RegionNodes(position=position, edge_nodes=e[:, :2].astype(np.int64),
                           edge_piece=e[:, 2].astype(np.int64), edge_s=e[:, 3:5].astype(np.float64),
                           boundary=np.r_[np.ones(len(xb), bool), np.zeros(len(inner), bool)],
                           spacing=local(position))

    def _piece_index(self, loop: int, piece: int) -> int:
        return sum(len(lp) for lp in self.loops[:loop]) + piece

    def _interior(self, local, h0: float) -> np.ndarray:
        lo, hi = self.bounds()
        if local.uniform:
            counts = np.maximum(1, np.floor((hi - lo) / h0).astype(int))
            offset = lo + 0.5 * ((hi - lo) - (counts - 1) * h0)
            gx = offset[0] + h0 * np.arange(counts[0])
            gy = offset[1] + h0 * np.arange(counts[1])
            candidates = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
        else:
            candidates = _quadtree_leaves(lo, hi, local, h0)
        if len(candidates) == 0:
            return np.zeros((0, 2))
        d = self.signed_distance(candidates)
        return candidates[d < -_CLEARANCE * local(candidates)]

    def _relaxed(self, fixed: np.ndarray, inner: np.ndarray, local, steps: int) -> np.ndarray:
        """DistMesh's relaxation of the inside nodes (Persson & Strang 2004): the bars of the Delaunay triangles
        inside push their ends apart where shorter than 1.2 times the local spacing (scaled so that the bars' sizes
        match the region's), each inside node moving 0.2 of its net force a step; a move that would take a node
        within 0.45 of its spacing of the boundary is not made. Stops early once no node moves 1e-3 of its spacing."""
        from scipy.spatial import Delaunay

        nb = len(fixed)
        x = np.vstack([fixed, inner])
        h_inner = local(inner)
        for _ in range(steps):
            tri = Delaunay(x).simplices
            tri = tri[self.contains(x[tri].mean(axis=1))]
            bars = np.unique(np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1), axis=0)
            v = x[bars[:, 1]] - x[bars[:, 0]]
            length = np.linalg.norm(v, axis=1)
            h_bar = local(0.5 * (x[bars[:, 0]] + x[bars[:, 1]]))
            target = 1.2 * h_bar * math.sqrt(np.sum(length ** 2) / np.sum(h_bar ** 2))
            push = (np.maximum(target - length, 0.0) / np.maximum(length, 1e-300))[:, None] * v
            force = np.zeros_like(x)
            np.add.at(force, bars[:, 0], -push)
            np.add.at(force, bars[:, 1], push)
            move = 0.2 * force[nb:]
            moved = x[nb:] + move
            ok = self.signed_distance(moved) < -_CLEARANCE * h_inner
            x[nb:][ok] = moved[ok]
            if np.max(np.linalg.norm(move[ok], axis=1) / h_inner[ok], initial=0.0) < 1e-3:
                break
        return x[nb:]

    # -- integration ----------------------------------------------------------------------------------------------
    def triangles(self, nodes: RegionNodes) -> np.ndarray:
        """(m, 3) the nodes' Delaunay triangles inside the region, each boundary edge a side of one of them (else
        refused, naming where)."""
        from scipy.spatial import Delaunay

        tri = Delaunay(nodes.position).simplices
        x = nodes.position
        keep = self.contains(x[tri].mean(axis=1))
        tri = tri[keep]
        sides = _side_keys(tri, len(x)).ravel()
        missing = np.flatnonzero(~np.isin(_edge_keys(nodes.edge_nodes, len(x)), sides))
        if missing.size:
            a, b = (int(v) for v in nodes.edge_nodes[missing[0]])
            mid = 0.5 * (x[a] + x[b])
            raise ParameterError("nodes", f"the boundary between nodes {a} and {b} (near ({mid[0]:.6g}, "
                                          f"{mid[1]:.6g})) is not a side of the nodes' triangles: a node stands too "
                                          "close to it, or the spacing is too coarse for the boundary's curvature "
                                          "there")
        return tri

    def cells(self, nodes: RegionNodes, degree: int = 5) -> QuadraturePoints:
        """Gauss points of the region's triangles (:meth:`triangles`): a triangle inside, the symmetric rule exact for
        total degree ``degree`` (1-5); a triangle with a side on the boundary, as three fans from its centroid g, one
        over each side E(σ) (the exact curve for a boundary side): x(σ, ρ) = g + ρ (E(σ) - g), dA = ρ (E - g) × E'
        dσ dρ, with ceil((degree + 2)/2) Gauss-Legendre points in σ and in ρ, so that the cells tile the true region
        and their weights sum to its area to round-off. Cell = triangle."""
        tri = self.triangles(nodes)
        x = nodes.position
        edge_of = {(int(a), int(b)): k for k, (a, b) in enumerate(nodes.edge_nodes)}
        curved = np.isin(_side_keys(tri, len(x)), _edge_keys(nodes.edge_nodes, len(x))).any(axis=1)
        straight = triangle_cells(x, tri[~curved], degree) if np.any(~curved) else None
        n = int(math.ceil((require_integer("degree", degree, minimum=1, maximum=5) + 2) / 2))
        g, w = gauss_legendre(n)
        u, wu = 0.5 * (g + 1.0), 0.5 * w                                     # Gauss-Legendre on [0, 1]
        sigma, rho = np.repeat(u, n), np.tile(u, n)                           # (n², ) tensor points
        w_tensor = np.repeat(wu, n) * np.tile(wu, n)
        pieces = self.pieces
        pos, wt, cell = [], [], []
        for t in np.flatnonzero(curved):
            corner = x[tri[t]]
            centre = corner.mean(axis=0)
            orientation = math.copysign(1.0, _cross(corner[1] - corner[0], corner[2] - corner[0]))
            for ia, ib in ((0, 1), (1, 2), (2, 0)):
                a, b = int(tri[t][ia]), int(tri[t][ib])
                k, forward = edge_of.get((a, b)), True
                if k is None:
                    k, forward = edge_of.get((b, a)), False
                if k is None:  # a straight side
                    e, de = x[a] + sigma[:, None] * (x[b] - x[a]), np.broadcast_to(x[b] - x[a], (len(sigma), 2))
                else:
                    s_a, s_b = nodes.edge_s[k] if forward else nodes.edge_s[k][::-1]
                    piece = pieces[nodes.edge_piece[k]]
                    s = s_a + sigma * (s_b - s_a)
                    e, de = piece.point(s), piece.tangent(s) * (s_b - s_a)
                jac = rho * _cross(e - centre, de) * orientation
                if np.any(jac <= 0.0):
                    raise ParameterError("spacing", f"the triangle near ({centre[0]:.6g}, {centre[1]:.6g}) folds when "
                                                    "its side is laid on the boundary curve: the curve turns too fast "
                                                    "for the spacing there (refine)")
                pos.append(centre + rho[:, None] * (e - centre))
                wt.append(w_tensor * jac)
                cell.append(np.full(len(sigma), t, dtype=np.int64))
        kept = np.flatnonzero(~curved)
        if straight is not None:
            pos.append(straight.position)
            wt.append(straight.weight)
            cell.append(kept[straight.cell])
        return QuadraturePoints(np.vstack(pos), np.concatenate(wt), np.concatenate(cell))

    def boundary_points(self, nodes: RegionNodes, tags: str | Sequence[str] | None = None,
                        order: int = 3) -> BoundaryPoints:
        """Gauss-Legendre points (``order`` a side) on the exact pieces between consecutive boundary nodes of the
        pieces tagged ``tags`` (all by default): weight = w |dx/ds| Δs/2 (m), the unit outward normal.
        ``segment``: the boundary edge (index into ``nodes.edge_nodes``)."""
        edges = self._edges(nodes, tags)
        g, w = gauss_legendre(require_integer("order", order, minimum=1))
        pieces = self.pieces
        pos, wt, nrm, seg = [], [], [], []
        for k in edges:
            piece = pieces[nodes.edge_piece[k]]
            s0, s1 = nodes.edge_s[k]
            s = s0 + 0.5 * (g + 1.0) * (s1 - s0)
            tangent = piece.tangent(s)
            speed = np.linalg.norm(tangent, axis=1)
            pos.append(piece.point(s))
            wt.append(0.5 * w * speed * abs(s1 - s0))
            nrm.append(np.stack([tangent[:, 1], -tangent[:, 0]], axis=1) / speed[:, None] * math.copysign(1.0, s1 - s0))
            seg.append(np.full(len(g), k, dtype=np.int64))
        if not pos:
            return BoundaryPoints(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0, np.int64))
        return BoundaryPoints(np.vstack(pos), np.concatenate(wt), np.vstack(nrm), np.concatenate(seg))

    def _edges(self, nodes: RegionNodes, tags) -> np.ndarray:
        if tags is None:
            return np.arange(len(nodes.edge_nodes))
        tags = [tags] if isinstance(tags, str) else list(tags)
        known = set(self.tags)
        for t in tags:
            if t not in known:
                raise ParameterError("tags", f"no piece is tagged {t!r}; the region's tags: {sorted(known)}")
        piece_tags = np.array([p.tag for p in self.pieces], dtype=object)
        return np.flatnonzero(np.isin(piece_tags[nodes.edge_piece], tags))

    # -- essential boundaries -------------------------------------------------------------------------------------
    def essential_quadrature(self, nodes: RegionNodes, tags: str | Sequence[str],
                             order: int = 3) -> list[tuple[np.ndarray, "CurveQuadrature"]]:
        """The Gauss points and multiplier hats of an essential boundary on the pieces tagged ``tags``, on the exact
        curves: for each piece, its boundary nodes' positions (the multipliers' places) and a
        :class:`CurveQuadrature` (multipliers at those nodes, hats linear in the curve's parameter between them). One
        set a piece: a corner node gets a multiplier for each side, so the flux may jump there (continuous hats
        across a corner fail the patch test). ``warpfree.solvers.efg.region_conditions`` makes the solvers'
        conditions of them."""
        edges = self._edges(nodes, tags)
        g, _ = gauss_legendre(require_integer("order", order, minimum=1))
        points = self.boundary_points(nodes, None, order)
        chains = [c for piece in np.unique(nodes.edge_piece[edges])
                  for c in _chains(nodes.edge_nodes, edges[nodes.edge_piece[edges] == piece])]
        out = []
        for chain in chains:
            pick = np.concatenate([np.flatnonzero(points.segment == k) for k in chain])
            pts = BoundaryPoints(points.position[pick], points.weight[pick], points.normal[pick],
                                 np.repeat(np.arange(len(chain), dtype=np.int64), len(g)))
            vertex_nodes = [int(nodes.edge_nodes[chain[0], 0])] + [int(nodes.edge_nodes[k, 1]) for k in chain]
            closed = vertex_nodes[-1] == vertex_nodes[0]
            n_mult = len(chain) if closed else len(chain) + 1
            local = np.arange(len(chain))
            multiplier = np.stack([local, (local + 1) % n_mult if closed else local + 1], axis=1)
            tau = np.tile(0.5 * (g + 1.0), len(chain))
            out.append((nodes.position[vertex_nodes],
                        CurveQuadrature(pts, np.repeat(multiplier, len(g), axis=0),
                                        np.stack([1.0 - tau, tau], axis=1), n_mult)))
        return out

    def chords(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The boundary as chords within 1e-7 of each curved piece's length of its curve (a segment: one chord):
        (start (c, 2), end (c, 2), the index of the piece each lies on, into :attr:`pieces`), in the loops' order."""
        start, end, piece = [], [], []
        for k, p in enumerate(self.pieces):
            n = 1 if isinstance(p.curve, Segment) else _samples(p)
            points = p.point(np.arange(n + 1) / n)
            start.append(points[:-1])
            end.append(points[1:])
            piece.append(np.full(n, k, dtype=np.int64))
        return np.vstack(start), np.vstack(end), np.concatenate(piece)

    # -- sampling -------------------------------------------------------------------------------------------------
    @staticmethod
    def _sample_loop(loop: Sequence[Piece], longest: float | None = None) -> np.ndarray:
        """Points along the loop (each piece from its start, its end left to the next), the chords within 1e-7 of
        a curved piece's length of the curve, and no chord longer than ``longest`` (the distance queries look at the
        chords within the nearest sample's distance plus the longest chord)."""
        out = []
        for piece in loop:
            n = 1 if isinstance(piece.curve, Segment) else _samples(piece)
            if longest is not None:
                n = max(n, int(math.ceil(piece.length / longest)))
            out.append(piece.point(np.arange(n) / n))
        return np.vstack(out)


# -- helpers --------------------------------------------------------------------------------------------------------
def _edge_keys(edges: np.ndarray, n: int) -> np.ndarray:
    """One int64 key for each undirected edge (a, b) (e, 2) of n nodes."""
    e = np.sort(np.asarray(edges, dtype=np.int64), axis=1)
    return e[:, 0] * n + e[:, 1]


def _side_keys(triangles: np.ndarray, n: int) -> np.ndarray:
    """(m, 3) the keys of each triangle's sides (:func:`_edge_keys`)."""
    t = np.asarray(triangles, dtype=np.int64)
    sides = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1).reshape(-1, 2)
    return _edge_keys(sides, n).reshape(-1, 3)


def _cross(u: np.ndarray, v: np.ndarray):
    """The z-component of u × v (rows or single vectors)."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _signed_area(p: np.ndarray) -> float:
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


def _inside_loop(point: np.ndarray, loop: np.ndarray) -> bool:
    from matplotlib.path import Path

    return bool(Path(loop).contains_point(point))


def _samples(piece: Piece) -> int:
    """Samples of a curved piece whose chords lie within 1e-7 of its length of the curve (doubling from 32)."""
    n, length = 32, max(piece.length, 1e-300)
    while n < 1 << 16:
        s = np.arange(n + 1) / n
        p, mid = piece.point(s), piece.point((np.arange(n) + 0.5) / n)
        if np.max(np.linalg.norm(mid - 0.5 * (p[:-1] + p[1:]), axis=1)) <= 1e-7 * length:
            return n
        n *= 2
    return n


def _edge_tags(tags, count: int) -> list[str]:
    if isinstance(tags, str):
        return [tags] * count
    tags = [str(t) for t in tags]
    if len(tags) != count:
        raise ParameterError("tags", f"must be one tag or one for each of the {count} edges, got {len(tags)}")
    return tags


class _Size:
    """A local spacing function (m), with ``uniform`` when it is the constant spacing."""

    def __init__(self, function, h0: float):
        self.function, self.h0 = function, h0
        self.uniform = function is None

    def __call__(self, points) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if self.uniform:
            return np.full(len(points), self.h0)
        h = np.asarray(self.function(points), dtype=np.float64).reshape(-1)
        if h.shape != (len(points),) or not np.all(np.isfinite(h)) or np.any(h <= 0.0):
            raise ParameterError("size", "must map (n, 2) points to (n,) finite spacings > 0")
        return h


def _size_function(size, h0: float) -> _Size:
    if size is not None and not callable(size):
        raise ParameterError("size", f"must be a function of the points (n, 2) -> (n,) spacings, got {size!r}")
    return _Size(size, h0)


def _piece_stations(piece: Piece, local: _Size, h0: float, single: bool) -> np.ndarray:
    """The piece's own parameters of its boundary nodes, both ends included: equal arc length at the spacing, or
    equal ∫ ds/h with a size function; at least 3 sides on a piece that is a whole loop."""
    length = piece.length
    if local.uniform:
        n = max(3 if single else 1, int(math.ceil(length / h0 - 1e-9)))
        return piece.at_lengths(np.arange(n + 1) / n)
    grid = np.linspace(0.0, 1.0, 513)
    arc = piece.arc_lengths(grid)
    density = 1.0 / local(piece.point(grid))
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(arc))])
    n = max(3 if single else 1, int(math.ceil(cumulative[-1] - 1e-9)))
    require_memory("size", float(n), 64.0, "boundary nodes")
    fractions = np.interp(np.arange(n + 1) / n * cumulative[-1], cumulative, arc) / arc[-1]
    return piece.at_lengths(fractions)


def _quadtree_leaves(lo, hi, local: _Size, h0: float) -> np.ndarray:
    """Centres of a quadtree's leaves over the box: a cell splits while its side exceeds the spacing at its centre,
    then leaves split until no two neighbours differ by more than a factor 2 in side."""
    side = float(max(hi - lo))
    root = (lo + hi) / 2.0 - side / 2.0
    cells = [(root[0], root[1], side)]
    leaves = []
    while cells:
        x, y, s = cells.pop()
        c = np.array([[x + s / 2.0, y + s / 2.0]])
        if s > local(c)[0] and s > 0.5 * h0 * 1e-3:
            h = s / 2.0
            cells += [(x, y, h), (x + h, y, h), (x, y + h, h), (x + h, y + h, h)]
            require_memory("size", float(len(cells) + len(leaves)), 64.0, "quadtree cells")
        else:
            leaves.append((x, y, s))
    changed = True
    while changed:  # 2:1 balance: split a leaf with a neighbour less than half its side
        changed = False
        arr = np.array(leaves)
        from scipy.spatial import cKDTree

        centres = arr[:, :2] + arr[:, 2:3] / 2.0
        tree = cKDTree(centres)
        out = []
        for (x, y, s), c in zip(leaves, centres):
            near = tree.query_ball_point(c, 0.75 * s * math.sqrt(2.0) + 1e-12)
            if np.any(arr[near, 2] < 0.5 * s - 1e-15):
                h = s / 2.0
                out += [(x, y, h), (x + h, y, h), (x, y + h, h), (x + h, y + h, h)]
                changed = True
            else:
                out.append((x, y, s))
        leaves = out
    arr = np.array(leaves)
    return arr[:, :2] + arr[:, 2:3] / 2.0


def _chains(edge_nodes: np.ndarray, edges: np.ndarray) -> list[list[int]]:
    """The selected boundary edges as chains of consecutive edges (each edge's end the next one's start), in the
    loops' direction; a chain that goes all round a loop closes on its first node."""
    by_start = {int(edge_nodes[k, 0]): int(k) for k in edges}
    ends = {int(edge_nodes[k, 1]) for k in edges}
    left, chains = set(int(k) for k in edges), []
    starts = [int(k) for k in edges if int(edge_nodes[k, 0]) not in ends]
    for first in starts + sorted(left):
        if first not in left:
            continue
        chain, k = [], first
        while k in left:
            chain.append(k)
            left.discard(k)
            k = by_start.get(int(edge_nodes[k, 1]), -1)
        chains.append(chain)
    return chains


def _crossings(p: Piece, q: Piece, tolerance: float) -> list[tuple[float, float]]:
    """The own parameters (s, u) where pieces p and q cross: crossings of their sampled chords, refined by Newton on
    p(s) - q(u) = 0."""
    def samples(piece):
        n = 1 if isinstance(piece.curve, Segment) else _samples(piece)
        s = np.arange(n + 1) / n
        return s, piece.point(s)

    sp, xp = samples(p)
    sq, xq = samples(q)
    a0, a1 = xp[:-1, None, :], xp[1:, None, :]
    b0, b1 = xq[None, :-1, :], xq[None, 1:, :]
    da, db = a1 - a0, b1 - b0
    cross = da[..., 0] * db[..., 1] - da[..., 1] * db[..., 0]
    r = b0 - a0
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = (r[..., 0] * db[..., 1] - r[..., 1] * db[..., 0]) / cross
        tb = (r[..., 0] * da[..., 1] - r[..., 1] * da[..., 0]) / cross
    hit = (np.abs(cross) > 0) & (ta >= -1e-9) & (ta <= 1 + 1e-9) & (tb >= -1e-9) & (tb <= 1 + 1e-9)
    out = []
    for i, j in zip(*np.nonzero(hit)):
        s = sp[i] + ta[i, j] * (sp[i + 1] - sp[i])
        u = sq[j] + tb[i, j] * (sq[j + 1] - sq[j])
        for _ in range(50):  # Newton on p(s) - q(u) = 0
            f = p.point(s)[0] - q.point(u)[0]
            jac = np.stack([p.tangent(s)[0], -q.tangent(u)[0]], axis=1)
            try:
                step = np.linalg.solve(jac, f)
            except np.linalg.LinAlgError:
                break
            s, u = float(np.clip(s - step[0], 0.0, 1.0)), float(np.clip(u - step[1], 0.0, 1.0))
            if np.linalg.norm(f) <= 1e-3 * tolerance:
                break
        out.append((s, u))
    return out


def _split(piece: Piece, at: list[float]) -> list[Piece]:
    cuts = sorted(set([0.0, 1.0] + [s for s in at if 1e-12 < s < 1.0 - 1e-12]))
    merged = [cuts[0]]
    for c in cuts[1:]:
        if c - merged[-1] > 1e-12:
            merged.append(c)
    return [piece.part(a, b) for a, b in zip(merged[:-1], merged[1:])]


def _combine(a: Region, b: Region, keep_self_inside: bool, keep_other_inside: bool, reverse_other: bool) -> Region:
    """The boolean of two regions: pieces split where the boundaries cross, each part kept by where its midpoint lies
    (inside or outside the other region), the parts chained into loops."""
    tol = max(a.tolerance, b.tolerance)
    pa, pb = a.pieces, b.pieces
    cuts_a, cuts_b = [[] for _ in pa], [[] for _ in pb]
    for i, p in enumerate(pa):
        for j, q in enumerate(pb):
            for s, u in _crossings(p, q, tol):
                cuts_a[i].append(s)
                cuts_b[j].append(u)
    kept = []
    for pieces, cuts, other, inside, reverse in ((pa, cuts_a, b, keep_self_inside, False),
                                                 (pb, cuts_b, a, keep_other_inside, reverse_other)):
        for piece, at in zip(pieces, cuts):
            for part in _split(piece, at):
                mid = part.point(0.5)
                d = float(other.signed_distance(mid)[0])
                if abs(d) <= 1e3 * tol:
                    raise ParameterError("region", f"the two regions' boundaries run together near "
                                                   f"({mid[0, 0]:.6g}, {mid[0, 1]:.6g}): a boolean of overlapping "
                                                   "boundaries is not supported (move one a little)")
                if (d < 0.0) == inside:
                    kept.append(part.reversed() if reverse else part)
    if not kept:
        raise ParameterError("region", "the result of the boolean is empty")
    loops, left = [], list(range(len(kept)))
    while left:
        loop = [kept[left.pop(0)]]
        while np.linalg.norm(loop[-1].end - loop[0].start) > 1e3 * tol:
            end = loop[-1].end
            gaps = [float(np.linalg.norm(kept[k].start - end)) for k in left]
            if not gaps or min(gaps) > 1e3 * tol:
                raise ParameterError("region", f"the boolean's boundary does not close near "
                                               f"({end[0]:.6g}, {end[1]:.6g})")
            loop.append(kept[left.pop(int(np.argmin(gaps)))])
        loops.append(loop)
    return Region(loops)
