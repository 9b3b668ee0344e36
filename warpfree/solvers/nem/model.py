"""The NEM model: nodes, their Delaunay triangulation and Laplace shape functions at any set of points (Rocha 2012, §3.4).

A :class:`NEMModel` is a :class:`~warpfree.galerkin.shapes.ShapeModel`, as the MLS model is, for the EFG solvers
(``warpfree.solvers.efg.solver``): it has ``launcher``, ``node_count``, ``nodes_np``, ``spacing`` (per node), ``reach``,
``settings.interpolating`` (True), ``node_material`` (all -1), :meth:`shape_at` returning a
:class:`~warpfree.galerkin.shapes.ShapeData`, :meth:`evaluate` (its nodal parameters are nodal values: the
Laplace functions interpolate) and :meth:`describe`; and, NEM's own,
:meth:`integration_cells`: Gauss points on the Delaunay triangles (the thesis: 3 points per triangle, degree 2), and
:meth:`smoothing_cells`: the nodes' Voronoi cells for stabilized conforming nodal integration
(``warpfree.galerkin.nodal_integration``), the integration under which NEM converges (the Laplace gradients jump
across circumcircles inside the triangles, which no fixed triangle rule follows). Consistent integration on the
triangles stays at order 1 (the shape model's default ``consistency_order``): its correction is already a fixed
fraction of the gradients at every level, and a second-order one fitted to the same points only adds to that bias
(the Timoshenko beam, 637 / 2425 regular nodes: tip error +0.45 / +0.57 % at order 1, +4.1 / +3.5 % at order 2).

Shape functions: Laplace / non-Sibsonian (Belikov et al. 1997; Sukumar et al. 2001), Rocha (2012), eqs 3.45-3.46,

    φ_i(x) = α_i / Σ_j α_j,   α_i = s_i / h_i,

s_i the length of the Voronoi edge x shares with its natural neighbour i, h_i = |x - x_i| / 2 (m); dimensionless,
gradients per unit length; analytic gradients, the algebra in ``kernels/nem.py``. They interpolate (φ_i(x_j) = δ_ij),
so essential conditions go in by direct substitution (``method="direct"``), and are linear on the boundary of a
convex domain. Set-up on the host (SciPy): the Delaunay triangulation of the nodes (``scipy.spatial.Delaunay``, once)
and, per evaluation point, the triangle that holds it (``Delaunay.find_simplex``, vectorised); per point in a Warp
kernel: the Bowyer-Watson cavity, φ and ∇φ, written as CSR rows (a count pass, then a fill pass). float64
throughout.

Choices at special points (``kernels/nem.py`` has the details):

- at a node: φ = δ; ∇φ = the gradient of the linear interpolant on the triangle ``find_simplex`` gives (the
  Laplace gradient has no unique limit at a node, where the functions are only C⁰). Gauss points never lie on nodes.
- on a boundary edge (the convex hull, or a side left open by ``domain``): φ = the 1D linear interpolation between
  the edge's two nodes (Sukumar et al. 2001); ∇φ = the one-sided limit from inside, Richardson-extrapolated from
  the interior gradients at 3e-7 and 6e-7 of the way to the triangle's opposite vertex (about 1e-8 relative).
- non-convex domains (``domain``): Delaunay triangles whose centroid lies outside the polygon are removed from the
  integration cells and from the cavity walk, so no natural neighbour is found across a hole or a notch. This is a
  simple truncation, not the constrained Voronoi diagram of C-NEM (Yvonnet, Ryckelynck, Lorong & Chinesta 2004).
  The sides facing removed triangles are boundary sides like the hull's (φ linear on them). Near a re-entrant
  corner the truncated cavity need not be star-shaped around x; the signed Voronoi edge lengths keep the partition
  of unity and linear reproduction exact there, but φ could leave [0, 1] (not seen in the tests: a quarter ring
  and an L-shape with random nodes, φ >= 0 at every sampled point). The polygon should pass through the boundary
  nodes (as the layouts place them): a point inside the polygon but outside every kept triangle is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp
from scipy.spatial import Delaunay, QhullError, cKDTree

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError
from warpfree.kernels import nem as nk
from warpfree.neighbours import empty_rows, lay_out_rows
from warpfree.progress import announced, group_digits
from warpfree.galerkin.nodal_integration import SmoothingCells, triangle_smoothing_cells
from warpfree.galerkin.quadrature import QuadraturePoints, triangle_cells
from warpfree.galerkin.shapes import ShapeData, ShapeModel, material_array, points2d

__all__ = ["NEMModel", "NEMSettings"]

#: a point within this barycentric tolerance of a kept triangle (found when ``find_simplex`` misses, e.g. on the
#: side of a removed triangle or a rounding error outside the hull) counts as inside it
LOCATE_TOL = 1e-10
#: nodes whose coordinates span less than this fraction of the set's extent across its main direction are collinear
COLLINEAR_TOL = 1e-12

_STATUS = {nk.CAVITY_OVERFLOW: f"has a natural neighbour with more than {nk.MAX_CAVITY} cavity triangles "
                               "about it "
                               "(many nodes on one circle through it)",
           nk.NEIGHBOUR_OVERFLOW: f"has more than {nk.MAX_NEIGHBOURS} natural neighbours "
                                  "(many nodes on one circle through it)",
           nk.DEGENERATE: "gives a degenerate Voronoi cell (Σ α_i <= 0 or not finite, or a natural-neighbour cavity "
                          "that is not a disk: a non-star-shaped cavity at a re-entrant corner of the domain, or a "
                          "point a rounding error off a boundary edge)"}


@dataclass(frozen=True)
class NEMSettings:
    """What the solvers and ``describe()`` read: Laplace shape functions interpolate (direct substitution of
    essential conditions); ``basis`` and ``weight`` name the method in outputs."""

    basis: str = "laplace"
    weight: str = "voronoi"
    interpolating: bool = True


def _inside_polygon(points: np.ndarray, polygon: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """Crossing-number test of ``points`` (n, 2) against the closed ``polygon`` (k, 2) (vectorised, chunked)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    out = np.zeros(points.shape[0], dtype=bool)
    for lo in range(0, points.shape[0], chunk):
        x, y = points[lo: lo + chunk, 0:1], points[lo: lo + chunk, 1:2]
        straddle = (a[None, :, 1] > y) != (b[None, :, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
            cross_x = a[None, :, 0] + (y - a[None, :, 1]) * slope
        out[lo: lo + chunk] = np.count_nonzero(straddle & (x < cross_x), axis=1) % 2 == 1
    return out


def _domain(domain) -> np.ndarray:
    d = np.asarray(domain, dtype=np.float64)
    if d.ndim != 2 or d.shape[0] < 3 or d.shape[1] != 2 or not np.all(np.isfinite(d)):
        raise ParameterError("domain", f"must be a finite (k, 2) polygon with k >= 3 vertices, got shape {d.shape}")
    area2 = float(np.sum(d[:, 0] * np.roll(d[:, 1], -1) - np.roll(d[:, 0], -1) * d[:, 1]))
    if not area2 > 0.0:
        raise ParameterError("domain", f"must be counter-clockwise with a positive area, got signed area "
                                       f"{0.5 * area2:.6g}")
    return d


class NEMModel(ShapeModel):
    """Nodes, their Delaunay triangulation and Laplace shape functions (module docstring).

    nodes: (n, 2) positions (m), n >= 3, distinct, not all collinear; domain: optional counter-clockwise polygon
    (k, 2) of a non-convex domain (without it the convex hull of the nodes is the domain); launcher: the device and
    threads (default ``warpfree.device.current_launcher()``).
    """

    @announced(lambda self, nodes, *a, **k: f"natural-neighbour model made ({group_digits(len(nodes))} nodes)")
    def __init__(self, nodes, domain=None, launcher: Launcher | None = None):
        self.settings = NEMSettings()
        self.launcher = launcher or current_launcher()
        dev = self.launcher.device
        self.nodes_np = points2d(nodes, "nodes")
        n = self.node_count = self.nodes_np.shape[0]
        if n < 3:
            raise ParameterError("nodes", f"needs at least 3 nodes for a triangulation, got {n}")
        self._check_distinct()
        self._check_not_collinear()
        try:
            self.delaunay = Delaunay(self.nodes_np)
        except QhullError as exc:
            raise ParameterError("nodes", f"the Delaunay triangulation failed ({str(exc).splitlines()[0]})") from None
        if len(self.delaunay.coplanar):
            j, _, k = (int(v) for v in self.delaunay.coplanar[0])
            raise ParameterError("nodes", f"node {j} at {self.nodes_np[j].tolist()} is too close to node {k} at "
                                          f"{self.nodes_np[k].tolist()} to enter the triangulation")
        self.domain = None if domain is None else _domain(domain)
        self._build_triangles()
        self.nodes = wp.array(self.nodes_np, dtype=wp.vec2d, device=dev)
        self.node_material = material_array(None, n, "node_material", dev)
        self.mesh = nk.Triangulation()
        self.mesh.nodes = self.nodes
        self.mesh.triangles = wp.array(self.triangles.astype(np.int32), dtype=wp.vec3i, device=dev)
        self.mesh.adjacent = wp.array(self.adjacent.astype(np.int32), dtype=wp.vec3i, device=dev)
        self._tree = None

    # -- set-up ------------------------------------------------------------------------------------------------
    def _check_distinct(self) -> None:
        x = self.nodes_np
        order = np.lexsort((x[:, 1], x[:, 0]))
        same = np.all(x[order[1:]] == x[order[:-1]], axis=1)
        if np.any(same):
            k = int(np.flatnonzero(same)[0])
            i, j = sorted((int(order[k]), int(order[k + 1])))
            raise ParameterError("nodes", f"node {j} at {x[j].tolist()} duplicates node {i}")

    def _check_not_collinear(self) -> None:
        x = self.nodes_np - self.nodes_np.mean(axis=0)
        sv = np.linalg.svd(x, compute_uv=False)
        if not sv[-1] > COLLINEAR_TOL * sv[0]:
            raise ParameterError("nodes", f"all {self.node_count} nodes lie on one line: no triangulation")

    def _build_triangles(self) -> None:
        """Kept triangles (counter-clockwise), their adjacency (-1 across a boundary side), per-node spacing."""
        x = self.nodes_np
        tri = self.delaunay.simplices.astype(np.int64)
        adj = self.delaunay.neighbors.astype(np.int64)
        c = x[tri]
        e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
        tri[cw] = tri[cw][:, [0, 2, 1]]  # swap vertices 1 and 2 (and the sides opposite them)
        adj[cw] = adj[cw][:, [0, 2, 1]]
        keep = np.ones(len(tri), dtype=bool)
        if self.domain is not None:
            keep = _inside_polygon(c.mean(axis=1), self.domain)
            if not np.any(keep):
                raise ParameterError("domain", "no Delaunay triangle of the nodes has its centroid inside the polygon")
        new = np.full(len(tri) + 1, -1, dtype=np.int64)  # new[-1] = -1 for a missing neighbour
        new[np.flatnonzero(keep)] = np.arange(int(keep.sum()))
        self.kept_of = new[:-1]  # Delaunay simplex -> kept triangle (-1: removed)
        self.triangles = tri[keep]
        self.adjacent = new[adj[keep]]
        m = len(self.triangles)
        star_count = np.bincount(self.triangles.ravel(), minlength=self.node_count)
        if np.any(star_count == 0):
            j = int(np.flatnonzero(star_count == 0)[0])
            raise ParameterError("domain", f"node {j} at {x[j].tolist()} lies outside the domain (in no kept "
                                           "Delaunay triangle)")
        # vertex -> kept triangles, padded (-1), for locating points that find_simplex misses
        owner = np.repeat(np.arange(m), 3)
        order = np.argsort(self.triangles.ravel(), kind="stable")
        starts = np.concatenate([[0], np.cumsum(star_count)])
        self._star = np.full((self.node_count, int(star_count.max())), -1, dtype=np.int64)
        slot = np.arange(3 * m) - starts[self.triangles.ravel()[order]]
        self._star[self.triangles.ravel()[order], slot] = owner[order]
        # spacing: the mean length of each node's Delaunay edges
        e = np.sort(np.concatenate([self.triangles[:, [0, 1]], self.triangles[:, [1, 2]], self.triangles[:, [2, 0]]]),
                    axis=1)
        e = np.unique(e, axis=0)
        length = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)
        total = np.bincount(e.ravel(), weights=np.repeat(length, 2), minlength=self.node_count)
        self.spacing = total / np.bincount(e.ravel(), minlength=self.node_count)
        # reach: a node is a natural neighbour of x only as a vertex of a kept triangle whose circumcircle holds x,
        # so no shape function reaches farther than the largest circumcircle's diameter 2R = abc / (2 · area)
        c = x[self.triangles]
        sides = np.linalg.norm(c - np.roll(c, 1, axis=1), axis=2)
        e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        area2 = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        self.reach = float(np.max(np.prod(sides, axis=1) / area2)) * (1.0 + 1e-9)

    # -- shape functions ---------------------------------------------------------------------------------------
    def locate(self, points, name: str = "point") -> np.ndarray:
        """The kept triangle (int32) that holds each point ((n, 2), checked): ``Delaunay.find_simplex``, then for
        the points it misses (a removed triangle, or a rounding error outside the hull) the best of the kept
        triangles around their 4 nearest nodes within LOCATE_TOL. Raises ParameterError(name) naming the first
        point outside every kept triangle."""
        p = points2d(points, name)
        found = np.asarray(self.delaunay.find_simplex(p), dtype=np.int64)
        t = np.where(found >= 0, self.kept_of[found], -1)
        miss = np.flatnonzero(t < 0)
        if miss.size:
            if self._tree is None:
                self._tree = cKDTree(self.nodes_np)
            k = min(4, self.node_count)
            near = self._tree.query(p[miss], k=k)[1].reshape(miss.size, k)
            cand = self._star[near].reshape(miss.size, -1)  # (m, k·star)
            corner = self.nodes_np[self.triangles[np.maximum(cand, 0)]]  # (m, c, 3, 2)
            q = p[miss][:, None, :]
            a, b, c = corner[..., 0, :], corner[..., 1, :], corner[..., 2, :]

            def cross(u, v):
                return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

            area2 = cross(b - a, c - a)
            lam = np.stack([cross(b - q, c - q), cross(c - q, a - q), cross(a - q, b - q)], axis=-1) / area2[..., None]
            worst = np.where(cand >= 0, lam.min(axis=-1), -np.inf)
            best = np.argmax(worst, axis=1)
            ok = worst[np.arange(miss.size), best] >= -LOCATE_TOL
            t[miss[ok]] = cand[np.arange(miss.size), best][ok]
            if not np.all(ok):
                i = int(miss[np.flatnonzero(~ok)[0]])
                where = "the domain" if self.domain is not None else "the triangulation (the nodes' convex hull)"
                raise ParameterError(name, f"{name} {i} at ({p[i, 0]:.6g}, {p[i, 1]:.6g}) lies outside {where} "
                                           f"({int(np.count_nonzero(~ok))} such points)")
        return t.astype(np.int32)

    def shape_at(self, points, material=None, name: str = "point") -> ShapeData:
        """Laplace shape functions and gradients at ``points`` (n, 2): CSR rows of each point's natural neighbours
        with φ_i and ∇φ_i (float64). ``material`` is checked and otherwise ignored: every node serves every
        material (node_material is -1). ``rcond`` is 1 at every point (no moment matrix). Raises ParameterError
        (``name``) naming the first point outside the domain or whose cavity overflows the kernel's fixed sizes."""
        p = points2d(points, name)
        n, dev, L = p.shape[0], self.launcher.device, self.launcher
        material_array(material, n, "material", dev)
        triangle = wp.array(self.locate(p, name), dtype=wp.int32, device=dev)
        points64 = wp.array(p, dtype=wp.vec2d, device=dev)
        rows = empty_rows(n, dev)
        status = wp.zeros(n, dtype=wp.int32, device=dev)
        phi = wp.zeros(1, dtype=wp.float64, device=dev)
        dphi = wp.zeros(1, dtype=wp.vec2d, device=dev)
        L.launch(nk.laplace_rows, n, [self.mesh, points64, triangle, 0, rows, phi, dphi, status], once=True)
        self._check(p, status.numpy(), name)
        counts, total = lay_out_rows(rows, n, "nodes")
        phi = wp.zeros(max(total, 1), dtype=wp.float64, device=dev)
        dphi = wp.zeros(max(total, 1), dtype=wp.vec2d, device=dev)
        L.launch(nk.laplace_rows, n, [self.mesh, points64, triangle, 1, rows, phi, dphi, status], once=True)
        L.launch(nk.edge_gradients, n, [self.mesh, points64, triangle, rows, dphi], once=True)
        rcond = wp.array(np.ones(n), dtype=wp.float64, device=dev)
        return ShapeData(p, rows, counts, total, phi, dphi, rcond, self.node_count)

    @staticmethod
    def _check(p: np.ndarray, status: np.ndarray, name: str) -> None:
        bad = np.flatnonzero(status != nk.OK)
        if bad.size:
            i = int(bad[0])
            raise ParameterError(name, f"{name} {i} at ({p[i, 0]:.6g}, {p[i, 1]:.6g}) {_STATUS[int(status[i])]} "
                                       f"({bad.size} such points)")

    def integration_cells(self, degree: int = 2) -> QuadraturePoints:
        """Gauss points on the kept Delaunay triangles (``triangle_cells``): degree 2 = 3 points per triangle, the
        thesis's rule (Rocha 2012, §4.1.4); degree 1-5."""
        return triangle_cells(self.nodes_np, self.triangles, degree)

    def smoothing_cells(self, order: int = 1) -> SmoothingCells:
        """One smoothing cell per node for stabilized conforming nodal integration
        (``warpfree.galerkin.nodal_integration``): the node's Voronoi cell clipped to the kept triangles (exactly so
        where no triangle is obtuse), ``order`` Gauss points per cell side."""
        return triangle_smoothing_cells(self.nodes_np, self.triangles, self.adjacent, order)

    def describe(self) -> dict:
        """The model for ``summary.json``: nodes, triangles, domain and node spacing."""
        s = self.settings
        return {"nodes": self.node_count, "basis": s.basis, "weight": s.weight, "triangles": len(self.triangles),
                "domain": "convex hull" if self.domain is None else f"polygon of {len(self.domain)} vertices",
                "spacing_min": float(self.spacing.min()), "spacing_max": float(self.spacing.max())}
