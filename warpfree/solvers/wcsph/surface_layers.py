"""Boundary particles placed from the true surface of a solid, in layers along its normals.

Layer k (k = 0 .. layers-1) lies at distance (k + 1/2) dx from the surface, on the wall side: outside a
container (the fluid is inside it) or inside an obstacle (the fluid is around it). The first layer at
dx/2 mirrors a fluid filled with a clearance of dx/2 (``fill_mesh(..., clearance=dx/2)``), so the wall
the fluid feels is the true surface, whatever the orientation of the solid and wherever the fluid
lattice is anchored (a lattice anchored elsewhere puts the wall up to dx behind the surface).

- 2D polygons: along each edge, points at a spacing that fits the edge exactly (closest to dx), offset
  along the edge's normal; where the wall side wraps around a corner, arcs at the layer's radius.
- 3D meshes with planar faces (containers, boxes, ducts: the solids of the scenes): on every facet
  (coplanar faces), a grid in the facet's plane whose spacings fit its bounding rectangle exactly
  (closest to dx), aligned with its longest edge, clipped to the facet; around the edges where the wall
  side wraps, cylinder arcs; at such corners, sphere patches.

Points that fall where the wall side closes in (concave corners, overlaps of two faces' layers: closer
to the surface than their layer), or on the wrong side, are removed, measured against the true surface
on the device (``warpfree.solvers.wcsph.solids``); points closer than 0.6 dx to one kept before them are merged. The
result is a set whose volume per particle is dx^dim to within the fitted spacings.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.device import current_launcher
from warpfree.errors import ParameterError, require_integer, require_memory, require_positive
from warpfree.geometry import Side, ccw_polygon, is_mesh
from warpfree.neighbours import NeighbourGrid, NeighbourList
from warpfree.particles import to_vec3
from .solids import Solids
from warpfree.space import Space

__all__ = ["surface_layers"]

#: points of a layer closer than this fraction of dx to a point kept before them are merged
MERGE = 0.6
#: a point must be within this fraction of dx of its layer's distance from the surface
BAND = 0.05


def surface_layers(shape, dx: float, layers: int, side: Side) -> np.ndarray:
    """Boundary particles along the surface of ``shape`` ((M, 2) polygon or watertight planar-faced trimesh
    mesh), ``layers`` layers on ``side`` ("outside": container walls; "inside": obstacle walls), layer k at
    (k + 1/2) ``dx`` from the surface (m). Returns (N, 2) for a polygon, (N, 3) for a mesh."""
    dx = require_positive("dx", dx)
    layers = require_integer("layers", layers, minimum=1)
    sign = 1.0 if Side.of("side", side) is Side.OUTSIDE else -1.0
    if is_mesh(shape):
        if not shape.is_watertight:
            raise ParameterError("mesh", "must be watertight (closed) to have an inside and an outside")
        require_memory("dx, layers", shape.area * layers / dx ** 2, 200.0, "boundary particles")
        candidates = [_mesh_layer(shape, dx, (k + 0.5) * dx, sign) for k in range(int(layers))]
        solids = Solids(current_launcher(), 3, containers=[shape])
    else:
        poly = ccw_polygon(shape)
        perimeter = float(np.sum(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1)))
        require_memory("dx, layers", perimeter * layers / dx, 100.0, "boundary particles")
        candidates = [_polygon_layer(poly, dx, (k + 0.5) * dx, sign) for k in range(int(layers))]
        solids = Solids(current_launcher(), 2, containers=[poly])
    kept = []
    for k, pts in enumerate(candidates):
        d = (k + 0.5) * dx
        p3 = pts if pts.shape[1] == 3 else np.column_stack([pts, np.zeros(len(pts))])
        signed = solids.signed_distance(p3)  # > 0 outside the solid's surface
        on_band = np.abs(sign * signed - d) <= BAND * dx
        kept.append(_merge(pts[on_band], MERGE * dx))
    return np.vstack(kept) if kept else np.zeros((0, 3 if is_mesh(shape) else 2))


# -- 2D ------------------------------------------------------------------------------------------------

def _fit(length: float, dx: float) -> tuple[int, float]:
    """Points that fit ``length`` at a spacing closest to dx, and that spacing."""
    n = max(1, int(round(length / dx)))
    return n, length / n


def _polygon_layer(poly: np.ndarray, dx: float, d: float, sign: float) -> np.ndarray:
    """Candidate points of one layer at distance d: edges offset along their normals, arcs at wrapping corners."""
    a, b = poly, np.roll(poly, -1, axis=0)
    edge = b - a
    length = np.linalg.norm(edge, axis=1)
    tangent = edge / length[:, None]
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])  # outward for a counter-clockwise polygon
    pts = []
    for i in range(len(poly)):
        n, step = _fit(length[i], dx)
        s = (np.arange(n) + 0.5) * step
        pts.append(a[i] + s[:, None] * tangent[i] + sign * d * normal[i])
    for i in range(len(poly)):  # corner i between edge i-1 and edge i
        n0, n1 = sign * normal[i - 1], sign * normal[i]
        turn = float(n0[0] * n1[1] - n0[1] * n1[0])  # > 0: the wall side wraps counter-clockwise around the corner
        angle = math.atan2(turn, float(n0 @ n1))
        if angle <= 1e-9:
            continue  # the wall side closes in here: the edges' layers overlap, the distance filter trims them
        m = int(round(angle * d / dx))
        if m < 1:
            continue
        phis = np.arange(1, m + 1) * angle / (m + 1)
        base = math.atan2(n0[1], n0[0])
        pts.append(poly[i] + d * np.column_stack([np.cos(base + phis), np.sin(base + phis)]))
    return np.vstack(pts)


# -- 3D ------------------------------------------------------------------------------------------------

def _facets(mesh) -> list[np.ndarray]:
    """Face indices grouped into planar facets (single faces included)."""
    grouped = [np.asarray(f) for f in mesh.facets]
    seen = np.zeros(len(mesh.faces), dtype=bool)
    for f in grouped:
        seen[f] = True
    return grouped + [np.array([i]) for i in np.flatnonzero(~seen)]


def _mesh_layer(mesh, dx: float, d: float, sign: float) -> np.ndarray:
    pts = [_facet_grid(mesh, faces, dx, d, sign) for faces in _facets(mesh)]
    pts.append(_edge_arcs(mesh, dx, d, sign))
    pts.append(_corner_patches(mesh, dx, d, sign))
    return np.vstack([p for p in pts if len(p)])


def _facet_grid(mesh, faces: np.ndarray, dx: float, d: float, sign: float) -> np.ndarray:
    """A grid on the facet's plane, spacings fitted to its bounding rectangle along its longest edge,
    clipped to its triangles, offset by sign·d along its normal."""
    normal = mesh.face_normals[faces[0]]
    tri = mesh.vertices[mesh.faces[faces]]                      # (F, 3, 3)
    corners = mesh.faces[faces]
    pairs = np.sort(np.concatenate([corners[:, [0, 1]], corners[:, [1, 2]], corners[:, [2, 0]]]), axis=1)
    unique, count = np.unique(pairs, axis=0, return_counts=True)
    boundary = unique[count == 1]                                # edges of the facet's outline, not its diagonals
    edges = mesh.vertices[boundary[:, 1]] - mesh.vertices[boundary[:, 0]]
    u = edges[np.argmax(np.linalg.norm(edges, axis=1))]
    u = u / np.linalg.norm(u)
    v = np.cross(normal, u)
    origin = tri[0, 0]
    uv = np.stack([(tri - origin) @ u, (tri - origin) @ v], axis=-1)  # (F, 3, 2)
    lo, hi = uv.reshape(-1, 2).min(axis=0), uv.reshape(-1, 2).max(axis=0)
    nu, du = _fit(hi[0] - lo[0], dx)
    nv, dv = _fit(hi[1] - lo[1], dx)
    gu, gv = np.meshgrid(lo[0] + (np.arange(nu) + 0.5) * du, lo[1] + (np.arange(nv) + 0.5) * dv, indexing="ij")
    q = np.column_stack([gu.ravel(), gv.ravel()])
    inside = np.zeros(len(q), dtype=bool)
    for t in uv:
        inside |= _in_triangle(q, t)
    q = q[inside]
    return origin + q[:, :1] * u + q[:, 1:] * v + sign * d * normal


def _in_triangle(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points q (N, 2) inside or on triangle t (3, 2)."""
    def cross(o, a, b):
        return (a[0] - o[..., 0]) * (b[1] - o[..., 1]) - (a[1] - o[..., 1]) * (b[0] - o[..., 0])

    c0 = (t[1, 0] - t[0, 0]) * (q[:, 1] - t[0, 1]) - (t[1, 1] - t[0, 1]) * (q[:, 0] - t[0, 0])
    c1 = (t[2, 0] - t[1, 0]) * (q[:, 1] - t[1, 1]) - (t[2, 1] - t[1, 1]) * (q[:, 0] - t[1, 0])
    c2 = (t[0, 0] - t[2, 0]) * (q[:, 1] - t[2, 1]) - (t[0, 1] - t[2, 1]) * (q[:, 0] - t[2, 0])
    eps = 1e-12 * max(1.0, float(np.abs(t).max()))
    return ((c0 >= -eps) & (c1 >= -eps) & (c2 >= -eps)) | ((c0 <= eps) & (c1 <= eps) & (c2 <= eps))


def _edge_arcs(mesh, dx: float, d: float, sign: float) -> np.ndarray:
    """Cylinder arcs of radius d around the edges where the wall side wraps (convex edges for walls outside,
    concave ones for walls inside), between the two faces' offset planes."""
    pts = []
    adjacency = mesh.face_adjacency
    convex = mesh.face_adjacency_convex
    edges = mesh.face_adjacency_edges
    normals = mesh.face_normals
    for (f0, f1), is_convex, (e0, e1) in zip(adjacency, convex, edges):
        n0, n1 = sign * normals[f0], sign * normals[f1]
        if np.allclose(n0, n1):
            continue  # inside a facet
        if (sign > 0) != bool(is_convex):
            continue  # the wall side closes in here
        p0, p1 = mesh.vertices[e0], mesh.vertices[e1]
        axis = p1 - p0
        length = float(np.linalg.norm(axis))
        axis /= length
        angle = math.acos(float(np.clip(n0 @ n1, -1.0, 1.0)))
        m = int(round(angle * d / dx))
        if m < 1:
            continue
        n, step = _fit(length, dx)
        s = (np.arange(n) + 0.5) * step
        w = np.cross(axis, n0)
        if w @ n1 < 0:
            w = -w
        for j in range(1, m + 1):
            phi = j * angle / (m + 1)
            direction = math.cos(phi) * n0 + math.sin(phi) * w
            pts.append(p0 + s[:, None] * axis + d * direction)
    return np.vstack(pts) if pts else np.zeros((0, 3))


def _corner_patches(mesh, dx: float, d: float, sign: float) -> np.ndarray:
    """Sphere patches of radius d at vertices where the wall side wraps: directions on a Fibonacci sphere
    with spacing about dx at radius d, kept where the vertex is the closest point of the surface (every
    adjacent face normal at or beyond 90° of the direction... on the wall side)."""
    pts = []
    count = max(8, int(round(4.0 * math.pi * d * d / (dx * dx))))
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (1.0 + 5.0 ** 0.5) * k
    dirs = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    faces_of = mesh.vertex_faces
    normals = mesh.face_normals
    edges = mesh.edges_unique
    for vi, vertex in enumerate(mesh.vertices):
        fs = faces_of[vi][faces_of[vi] >= 0]
        wall_normals = sign * normals[fs]
        # the vertex is the closest point for a direction that points away from every adjacent face's plane
        # and from every adjacent edge (its projection on each edge direction is <= 0)
        ok = np.all(dirs @ wall_normals.T >= -1e-9, axis=1)
        if not ok.any():
            continue
        adjacent = edges[(edges[:, 0] == vi) | (edges[:, 1] == vi)]
        for e in adjacent:
            other = mesh.vertices[e[1] if e[0] == vi else e[0]]
            ok &= dirs @ (other - vertex) <= 1e-9
        ok &= np.all(dirs @ wall_normals.T < 1.0 - 1e-9, axis=1)  # not on a face (the grids cover those)
        if ok.any():
            pts.append(vertex + d * dirs[ok])
    return np.vstack(pts) if pts else np.zeros((0, 3))


def _merge(points: np.ndarray, radius: float) -> np.ndarray:
    """Drop every point closer than ``radius`` to one kept before it (in order). The close pairs come from the
    engine's own hash-grid neighbour rows (Warp is loaded anyway; a KD-tree would cost a 0.3 s SciPy import)."""
    if len(points) < 2:
        return points
    launcher = current_launcher()
    x = wp.array(to_vec3(points, "points"), dtype=wp.vec3, device=launcher.device)
    rows = NeighbourList(NeighbourGrid(launcher, radius, Space(3), x), x, exclude_self=True)
    offsets, index = rows.offsets(), rows.indices()
    if len(index) == 0:
        return points
    keep = np.ones(len(points), dtype=bool)
    for i in range(len(points)):
        if keep[i]:
            later = index[offsets[i]:offsets[i + 1]]
            keep[later[later > i]] = False
    return points[keep]
