"""Particle generators and boundary-particle samplers (2D polygons, 3D trimesh meshes).

All lengths are in metres; every function returns float64 NumPy arrays of shape (N, d).

The lattice is cell-centred: points sit at ``origin + (k + 0.5) * dx`` for integer ``k``, so fluid
(:func:`lattice_box`, :func:`fill_mesh`, :func:`fill_polygon`) and walls (:func:`shell_lattice`,
:func:`polygon_boundary_layers`) line up when they are given the same ``origin`` and ``dx``.

Inside tests and distances are done here with vectorised NumPy rather than ``mesh.contains`` and
``trimesh.proximity`` (without Embree those take ~90 s for 200k points):

- inside (3D): one ray per lattice column along the longest lattice axis; every triangle is paired
  with the columns under its projected bounding box, crossings toggle a parity grid and a cumulative
  XOR along the column gives inside/outside for every lattice point at once. The rays are shifted by
  ~4e-7 cell so that they never run exactly through mesh edges or vertices of lattice-aligned meshes;
  points within 1e-6 cell of the surface (found with the distance pass below) count as outside, so
  "strictly inside" is symmetric even when lattice points lie exactly on faces.
- distance (3D): lattice points within the shell thickness of a mesh vertex are settled first (cheap);
  then every triangle is paired with the remaining candidate points of its bounding box grown by the
  shell thickness, a plane-distance test drops most pairs and exact point-triangle distances are
  computed for the rest. Work grows with the surface area in cells, not with the enclosed volume;
  memory is a few bytes per point of the mesh's (padded) bounding lattice block.
- 2D: crossing-number parity and point-to-segment distances, looping over polygon edges.

trimesh is imported inside the functions that take a mesh (importing it costs 0.7–1.2 s; a 2D scene never
needs it).
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import trimesh

from .errors import ParameterError, require_integer, require_memory, require_positive
from .parameters import Choice
from .progress import announced

__all__ = [
    "lattice_box",
    "jittered_lattice",
    "fill_mesh",
    "fill_mesh_box",
    "shell_lattice",
    "sample_surface",
    "polygon_boundary_layers",
    "fill_polygon",
    "mesh_section",
    "box_mesh",
    "load_mesh",
    "clip_polygon",
    "ccw_polygon",
    "circle_polygon",
    "Side",
]

_TOL = 1e-9  # relative tolerance, in lattice cells, for "on the lattice" and "within the shell"
_RAY_SHIFT = (3.1415926e-7, 2.7182818e-7)  # ray offset in cells (generic: off every lattice-aligned edge)
_ON_SURFACE = 1e-6  # lattice points this close to the surface (in cells) are not strictly inside
_PAIR_CHUNK = 100_000  # (triangle, lattice point) pairs processed per vectorised batch


class Side(Choice):
    """Which side of a closed surface (a watertight mesh, a closed polygon) wall layers lie on."""

    OUTSIDE = "outside", "not strictly inside: container walls (the fluid is inside)"
    INSIDE = "inside", "strictly inside: obstacle walls (the fluid is outside)"


# ----------------------------------------------------------------------------------------------
# validation helpers
# ----------------------------------------------------------------------------------------------


def _vector(name: str, value, dims=(2, 3)) -> np.ndarray:
    """A finite 1D float64 vector of length in ``dims``."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be a sequence of numbers, got {value!r}") from None
    if v.ndim != 1 or v.shape[0] not in dims:
        raise ParameterError(name, f"must have length {' or '.join(map(str, dims))}, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, f"must be finite, got {v.tolist()}")
    return v


def _box(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    lo = _vector("lo", lo)
    hi = _vector("hi", hi)
    if hi.shape != lo.shape:
        raise ParameterError("hi", f"must have the same length as lo ({lo.shape[0]}), got {hi.shape[0]}")
    if np.any(hi <= lo):
        raise ParameterError("hi", f"must be > lo in every axis, got lo={lo.tolist()}, hi={hi.tolist()}")
    return lo, hi


def _origin(origin, default: np.ndarray) -> np.ndarray:
    if origin is None:
        return np.asarray(default, dtype=np.float64).copy()
    return _vector("origin", origin, dims=(default.shape[0],))


def _layers(layers) -> int:
    return require_integer("layers", layers, minimum=1)


def is_mesh(shape) -> bool:
    """True for a trimesh.Trimesh, without importing trimesh (a mesh exists only once trimesh is imported)."""
    module = sys.modules.get("trimesh")
    return module is not None and isinstance(shape, module.Trimesh)


def _check_mesh(mesh, closed: bool = True) -> trimesh.Trimesh:
    """A non-empty Trimesh; with ``closed`` also watertight and enclosing a volume."""
    import trimesh

    if not isinstance(mesh, trimesh.Trimesh):
        raise ParameterError("mesh", f"must be a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0:
        raise ParameterError("mesh", "has no faces")
    if not np.all(np.isfinite(mesh.vertices)):
        raise ParameterError("mesh", "has non-finite vertices")
    if closed:
        if not mesh.is_watertight:
            raise ParameterError("mesh", "is not watertight (open edges or holes): "
                                 "cannot tell inside from outside")
        if abs(mesh.volume) <= 1e-12 * mesh.scale**3:
            raise ParameterError("mesh", "encloses no volume (flat or degenerate surface)")
    return mesh


def _polygon(polygon) -> np.ndarray:
    """(M, 2) finite vertices, M >= 3, non-zero area (closed implicitly)."""
    try:
        p = np.asarray(polygon, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError("polygon", "must be an (M, 2) array of vertices") from None
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 3:
        raise ParameterError("polygon", f"must have shape (M, 2) with M >= 3, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError("polygon", "contains non-finite vertices")
    if np.allclose(p[0], p[-1]) and p.shape[0] > 3:
        p = p[:-1]  # an explicitly closed ring: drop the repeated vertex
    if abs(_signed_area(p)) <= 1e-14 * np.ptp(p, axis=0).max() ** 2:
        raise ParameterError("polygon", "has zero area")
    return p


def polygon_area(polygon) -> float:
    """Area (m²) of a closed 2D polygon (M, 2), either orientation, checked as :func:`ccw_polygon` checks it."""
    return abs(float(_signed_area(_polygon(polygon))))


def ccw_polygon(polygon) -> np.ndarray:
    """The (M, 2) vertices of a closed 2D polygon, checked (finite, M >= 3, an area), counter-clockwise: then
    (t_y, -t_x) of an edge's unit tangent t is its outward normal."""
    p = _polygon(polygon)
    return p if _signed_area(p) > 0 else p[::-1]


def circle_polygon(radius: float, dx: float, centre=(0.0, 0.0)) -> np.ndarray:
    """A circle's section of ``radius`` (m) about ``centre``: a counter-clockwise polygon of at least 64 vertices on
    the circle, at most dx/8 apart (its chords then lie within (dx/8)²/(8 R) of the circle)."""
    count = max(64, float(np.ceil(2.0 * np.pi * radius / (dx / 8.0))))
    require_memory("dx", count, 48.0, "polygon vertices")
    count = int(count)
    angle = 2.0 * np.pi * np.arange(count) / count
    return np.asarray(centre, np.float64)[:2] + radius * np.column_stack([np.cos(angle), np.sin(angle)])


# ----------------------------------------------------------------------------------------------
# lattices
# ----------------------------------------------------------------------------------------------


def _index_range(lo, hi, origin, dx) -> tuple[np.ndarray, np.ndarray]:
    """Integer ``k`` range (inclusive) with ``origin + (k + 0.5) dx`` in [lo, hi] per axis."""
    kmin = np.ceil((lo - origin) / dx - 0.5 - _TOL).astype(np.int64)
    kmax = np.floor((hi - origin) / dx - 0.5 + _TOL).astype(np.int64)
    return kmin, kmax


def _lattice(origin, dx, kmin, shape) -> np.ndarray:
    """Points ``origin + (kmin + i + 0.5) dx`` for the dense index block ``shape``, C order."""
    # the grids, their stack and a float32 copy downstream: about 4 float64 per coordinate per point
    require_memory("dx", float(np.prod(np.asarray(shape, dtype=np.float64))), 32.0 * len(shape), "lattice points")
    axes = [origin[a] + (kmin[a] + np.arange(n) + 0.5) * dx for a, n in enumerate(shape)]
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def lattice_box(lo, hi, dx) -> np.ndarray:
    """Cell centres ``lo + (k + 0.5) dx`` of the whole cells filling the box [lo, hi] (m).

    ``len(lo)`` is 2 or 3; there are ``floor((hi - lo) / dx)`` cells per axis. Returns (N, d).
    """
    lo, hi = _box(lo, hi)
    dx = require_positive("dx", dx)
    n = np.floor((hi - lo) / dx + _TOL).astype(np.int64)
    if np.any(n < 1):
        raise ParameterError("hi", f"box {(hi - lo).tolist()} is thinner than dx={dx} in some axis")
    return _lattice(lo, dx, np.zeros_like(n), tuple(n))


def jittered_lattice(lo, hi, dx, amplitude, seed=0) -> np.ndarray:
    """:func:`lattice_box` plus uniform jitter in [-amplitude*dx, amplitude*dx] per axis.

    ``amplitude`` (fraction of dx) must be in [0, 0.5) so that every point stays in its own cell
    (and so inside the box); ``seed`` makes it reproducible. Returns (N, d).
    """
    a = require_positive("amplitude", amplitude, allow_zero=True)
    if a >= 0.5:
        raise ParameterError("amplitude", f"must be in [0, 0.5) (fraction of dx), got {a}")
    p = lattice_box(lo, hi, dx)
    rng = np.random.default_rng(seed)
    return p + rng.uniform(-a * float(dx), a * float(dx), size=p.shape)


# ----------------------------------------------------------------------------------------------
# 3D: pairs of triangles and lattice points, parity and distance on a dense index block
# ----------------------------------------------------------------------------------------------


def _box_pairs(lo, hi, chunk=_PAIR_CHUNK):
    """Yield (t, idx) batches of every (row t, integer point in box [lo[t], hi[t]]) pair.

    ``lo``/``hi`` are (T, d) inclusive integer bounds (empty where hi < lo); ``idx`` is (n, d).
    """
    ext = np.maximum(hi - lo + 1, 0)
    count = np.prod(ext, axis=1)
    start = np.concatenate([[0], np.cumsum(count)])
    total = int(start[-1])
    for s in range(0, total, chunk):
        p = np.arange(s, min(s + chunk, total), dtype=np.int64)
        t = np.searchsorted(start, p, side="right") - 1
        local = p - start[t]
        idx = np.empty((p.size, lo.shape[1]), dtype=np.int64)
        for a in range(lo.shape[1] - 1, -1, -1):
            idx[:, a] = lo[t, a] + local % ext[t, a]
            local //= ext[t, a]
        yield t, idx


def _parity_grid(tri: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """Inside flags (bool, ``shape``) by ray parity along the longest axis of a dense index block.

    ``tri`` is (T, 3, 3): triangle vertices in block index units (point ``i`` sits at coordinate ``i``).
    Exact for points farther than ~4e-7 cells from the surface (the ray shift).
    """
    ax = int(np.argmax(shape))
    a1, a2 = [a for a in range(3) if a != ax]
    n_ax, n1, n2 = shape[ax], shape[a1], shape[a2]
    u = tri[:, :, a1] - _RAY_SHIFT[0]  # shifting the mesh by -eps == shifting the rays by +eps
    v = tri[:, :, a2] - _RAY_SHIFT[1]
    w = tri[:, :, ax]
    area = (u[:, 1] - u[:, 0]) * (v[:, 2] - v[:, 0]) - (u[:, 2] - u[:, 0]) * (v[:, 1] - v[:, 0])
    keep = area != 0.0  # triangles parallel to the rays are never crossed by a generic ray
    u, v, w, area = u[keep], v[keep], w[keep], area[keep]
    lo = np.stack([np.ceil(u.min(1)), np.ceil(v.min(1))], axis=1).astype(np.int64)
    hi = np.stack([np.floor(u.max(1)), np.floor(v.max(1))], axis=1).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [n1 - 1, n2 - 1])
    toggle = np.zeros((n_ax + 1, n1, n2), dtype=np.uint8)
    for t, ij in _box_pairs(lo, hi):
        i, j = ij[:, 0].astype(np.float64), ij[:, 1].astype(np.float64)
        ut, vt = u[t], v[t]
        # edge functions; a column hits the triangle when all three have the sign of the area
        e0 = (ut[:, 2] - ut[:, 1]) * (j - vt[:, 1]) - (vt[:, 2] - vt[:, 1]) * (i - ut[:, 1])
        e1 = (ut[:, 0] - ut[:, 2]) * (j - vt[:, 2]) - (vt[:, 0] - vt[:, 2]) * (i - ut[:, 2])
        e2 = (ut[:, 1] - ut[:, 0]) * (j - vt[:, 0]) - (vt[:, 1] - vt[:, 0]) * (i - ut[:, 0])
        s = np.sign(area[t])
        hit = (e0 * s >= 0) & (e1 * s >= 0) & (e2 * s >= 0)
        if not hit.any():
            continue
        t, ci, cj = t[hit], ij[hit, 0], ij[hit, 1]
        wt = w[t]
        cross = (e0[hit] * wt[:, 0] + e1[hit] * wt[:, 1] + e2[hit] * wt[:, 2]) / area[t]
        first = np.clip(np.floor(cross).astype(np.int64) + 1, 0, n_ax)  # first point above the crossing
        np.bitwise_xor.at(toggle, (first, ci, cj), 1)
    inside = np.bitwise_xor.accumulate(toggle, axis=0)[:n_ax].astype(bool)
    order = [ax, a1, a2]
    return np.transpose(inside, np.argsort(order))


def _dist2_point_segment(px, py, pz, a, b) -> np.ndarray:
    """Squared distance from points (px, py, pz) to segments a-b, each (n, 3)."""
    ex, ey, ez = (b - a).T
    qx, qy, qz = px - a[:, 0], py - a[:, 1], pz - a[:, 2]
    t = np.clip((qx * ex + qy * ey + qz * ez) / np.maximum(ex * ex + ey * ey + ez * ez, 1e-300), 0.0, 1.0)
    return (qx - t * ex) ** 2 + (qy - t * ey) ** 2 + (qz - t * ez) ** 2


def _dist2_point_triangle(p, a, b, c, n) -> np.ndarray:
    """Squared distance from points p (n, 3) to triangles (a, b, c) with normals n = (b-a) x (c-a)."""
    px, py, pz = p.T
    nn = np.einsum("ij,ij->i", n, n)
    inside = nn > 0
    for q0, q1 in ((a, b), (b, c), (c, a)):
        e = q1 - q0
        rx, ry, rz = px - q0[:, 0], py - q0[:, 1], pz - q0[:, 2]
        # (e x r) . n >= 0: the projection of p is on the inner side of edge q0 -> q1
        inside &= ((e[:, 1] * rz - e[:, 2] * ry) * n[:, 0] + (e[:, 2] * rx - e[:, 0] * rz) * n[:, 1]
                   + (e[:, 0] * ry - e[:, 1] * rx) * n[:, 2]) >= 0
    s = (px - a[:, 0]) * n[:, 0] + (py - a[:, 1]) * n[:, 1] + (pz - a[:, 2]) * n[:, 2]
    d2 = s * s / np.where(inside, nn, 1.0)
    out = ~inside
    if out.any():
        pa, pb, pc = a[out], b[out], c[out]
        qx, qy, qz = px[out], py[out], pz[out]
        d2[out] = np.minimum(np.minimum(_dist2_point_segment(qx, qy, qz, pa, pb),
                                        _dist2_point_segment(qx, qy, qz, pb, pc)),
                             _dist2_point_segment(qx, qy, qz, pc, pa))
    return d2


def _near_grid(tri: np.ndarray, shape, radius: float, candidate: np.ndarray) -> np.ndarray:
    """Flags (bool, ``shape``) of candidate points within ``radius`` (index units) of any triangle.

    Each triangle is paired with the candidate points of its bounding box grown by ``radius``; a
    plane-distance test discards most pairs before the exact point-triangle distance.
    """
    r = radius * (1.0 + _TOL) + _TOL
    lo = np.maximum(np.ceil(tri.min(axis=1) - r), 0).astype(np.int64)
    hi = np.minimum(np.floor(tri.max(axis=1) + r), np.asarray(shape) - 1).astype(np.int64)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    offset = np.einsum("ij,ij->i", tri[:, 0], nrm)
    rn = r * np.linalg.norm(nrm, axis=1) + 1e-12
    cand = candidate.ravel()
    near = np.zeros(cand.size, dtype=bool)
    # vertices first: a cheap distance that settles most points when triangles are small
    vert = np.unique(tri.reshape(-1, 3), axis=0)
    vlo = np.maximum(np.ceil(vert - r), 0).astype(np.int64)
    vhi = np.minimum(np.floor(vert + r), np.asarray(shape) - 1).astype(np.int64)
    for t, idx in _box_pairs(vlo, vhi):
        flat = np.ravel_multi_index(idx.T, shape)
        d2 = np.sum((idx - vert[t]) ** 2, axis=1)
        near[flat[cand[flat] & (d2 <= r * r)]] = True
    for t, idx in _box_pairs(lo, hi):
        flat = np.ravel_multi_index(idx.T, shape)
        keep = cand[flat] & ~near[flat]
        t, idx, flat = t[keep], idx[keep], flat[keep]
        p = idx.astype(np.float64)
        keep = np.abs(np.einsum("ij,ij->i", p, nrm[t]) - offset[t]) <= rn[t]
        if not keep.any():
            continue
        t, p, flat = t[keep], p[keep], flat[keep]
        d2 = _dist2_point_triangle(p, tri[t, 0], tri[t, 1], tri[t, 2], nrm[t])
        near[flat[d2 <= r * r]] = True
    return near.reshape(shape)


def _inside_grid(tri: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """Strictly-inside flags: parity inside and farther than ``_ON_SURFACE`` cells from the surface."""
    inside = _parity_grid(tri, shape)
    return inside & ~_near_grid(tri, shape, _ON_SURFACE, inside)


def _mesh_block(mesh, dx, origin, pad):
    """Dense lattice index block covering the mesh bounds grown by ``pad`` (m).

    Returns (kmin, shape, tri) with ``tri`` the triangles in block index units.
    """
    b0, b1 = mesh.bounds
    kmin, kmax = _index_range(b0 - pad, b1 + pad, origin, dx)
    shape = tuple(int(n) for n in np.maximum(kmax - kmin + 1, 0))
    # the inside/near grids over the block and the points kept: about 64 bytes per cell
    require_memory("dx", float(np.prod(np.asarray(shape, dtype=np.float64))), 64.0, "lattice cells around the mesh")
    tri = (mesh.vertices[mesh.faces] - origin) / dx - 0.5 - kmin
    return kmin, shape, tri


@announced("mesh filled with particles")
def fill_mesh(mesh: trimesh.Trimesh, dx, origin=None, clearance=0.0) -> np.ndarray:
    """Lattice points ``origin + (k + 0.5) dx`` strictly inside a watertight mesh (m). Returns (N, 3).

    ``origin`` defaults to ``mesh.bounds[0]``. Points within 1e-6 dx of the surface count as outside,
    and so do points closer than ``clearance`` (m) to it: with ``clearance = dx/2`` a fluid filled into
    a container whose size is not a multiple of dx keeps its half-spacing gap to the walls (points at
    exactly dx/2, as on a commensurate lattice, are kept).
    """
    mesh = _check_mesh(mesh)
    dx = require_positive("dx", dx)
    clearance = require_positive("clearance", clearance, allow_zero=True)
    origin = _origin(origin, mesh.bounds[0])
    kmin, shape, tri = _mesh_block(mesh, dx, origin, 0.0)
    if min(shape) == 0:
        return np.zeros((0, 3))
    inside = _inside_grid(tri, shape)
    if clearance > 0.0:
        inside &= ~_near_grid(tri, shape, clearance / dx * (1.0 - 1e-6), inside)
    return _lattice(origin, dx, kmin, shape)[inside.ravel()]


def fill_mesh_box(mesh: trimesh.Trimesh, lo, hi, dx) -> tuple[np.ndarray, np.ndarray]:
    """The part of a watertight mesh's inside within the box [lo, hi] (m), filled with the centres of cells that
    divide the box exactly: n = round((hi - lo)/dx) cells per axis of size (hi - lo)/n (within dx/(2n) of dx),
    half a cell clear of the mesh's surface (as :func:`fill_mesh` keeps dx/2). Returns (points (N, 3), cell sizes
    (3,)): the water in a box-shaped region holds its volume exactly at any dx (each particle's volume the cell's),
    where a lattice of spacing dx would round its sides to whole spacings."""
    mesh = _check_mesh(mesh)
    dx = require_positive("dx", dx)
    lo, hi = _box(lo, hi)
    counts = np.maximum(1.0, np.round((hi - lo) / dx))
    cell = (hi - lo) / counts
    stretch = dx / cell  # in the stretched space the cells are dx wide: fill_mesh's lattice and clearance
    stretched = mesh.copy()
    stretched.apply_transform(np.diag([*stretch, 1.0]))
    points = fill_mesh(stretched, dx, origin=lo * stretch, clearance=0.5 * dx) / stretch
    inside = np.all((points > lo) & (points < hi), axis=1)
    return points[inside], cell


@announced("wall layers laid around the mesh")
def shell_lattice(mesh: trimesh.Trimesh, dx, layers, side, origin=None) -> np.ndarray:
    """Lattice points within ``layers * dx`` (m) of the surface of a watertight mesh, on one side.

    ``side="outside"``: points not strictly inside the mesh (container walls; fluid inside the mesh).
    ``side="inside"``: points strictly inside (obstacles; fluid outside). The lattice is the one of
    :func:`fill_mesh` (``origin`` defaults to ``mesh.bounds[0]``), so the two partition the lattice.
    Distances are exact Euclidean point-triangle distances (corners of the shell are rounded).
    Returns (N, 3).
    """
    mesh = _check_mesh(mesh)
    dx = require_positive("dx", dx)
    layers = _layers(layers)
    side = Side.of("side", side)
    origin = _origin(origin, mesh.bounds[0])
    kmin, shape, tri = _mesh_block(mesh, dx, origin, layers * dx)
    inside = _inside_grid(tri, shape)
    candidate = inside if side is Side.INSIDE else ~inside
    keep = _near_grid(tri, shape, float(layers), candidate)
    return _lattice(origin, dx, kmin, shape)[keep.ravel()]


# ----------------------------------------------------------------------------------------------
# 3D surface sampling
# ----------------------------------------------------------------------------------------------

_DISK_RADIUS = 0.71  # Poisson-disk radius / dx: the thinned sets then hold ~ area / dx^2 points
_OVERSAMPLE = 6  # random candidates per dx^2 of surface


def _maximal_disk_set(points: np.ndarray, radius: float, rng) -> np.ndarray:
    """Mask of a maximal subset with no two points closer than ``radius`` (greedy by random priority).

    Luby-style rounds: an undecided point whose priority beats all undecided neighbours is kept and
    its neighbours dropped; vectorised over the KD-tree neighbour pairs.
    """
    from scipy.spatial import cKDTree

    n = points.shape[0]
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    prio = rng.permutation(n)
    state = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 kept, -1 dropped
    while True:
        und = state == 0
        if not und.any():
            break
        live = und[i] & und[j]
        i, j = i[live], j[live]
        best = np.full(n, n, dtype=np.int64)
        np.minimum.at(best, i, prio[j])
        np.minimum.at(best, j, prio[i])
        keep = und & (prio < best)
        state[keep] = 1
        state[j[keep[i]]] = -1
        state[i[keep[j]]] = -1
    return state == 1


@announced("mesh surface sampled")
def sample_surface(mesh: trimesh.Trimesh, dx, seed=0) -> tuple[np.ndarray, np.ndarray]:
    """About ``area / dx^2`` points spread evenly on the mesh surface, and their unit face normals.

    Random surface samples (``trimesh.sample.sample_surface``, 6 per dx^2) thinned to a maximal
    Poisson-disk subset of radius 0.71 dx: no two points are closer than 0.71 dx, nearest-neighbour
    distances average ~0.8 dx and stay below ~1.5 dx. Normals are those of the sampled faces
    (outward for a consistently wound closed mesh). One layer, e.g. for Lennard-Jones ghost walls;
    the mesh need not be closed.
    Returns (points (N, 3), normals (N, 3)).
    """
    import trimesh

    mesh = _check_mesh(mesh, closed=False)
    dx = require_positive("dx", dx)
    area = float(mesh.area)
    if area <= 0:
        raise ParameterError("mesh", "has zero surface area")
    count = int(np.ceil(_OVERSAMPLE * area / dx**2))
    if count > 50_000_000:
        raise ParameterError("dx", f"too small for this mesh ({count} candidate samples)")
    points, face = trimesh.sample.sample_surface(mesh, max(count, 1), seed=seed)
    keep = _maximal_disk_set(points, _DISK_RADIUS * dx, np.random.default_rng(seed))
    normals = mesh.face_normals[face[keep]]
    return np.asarray(points[keep], dtype=np.float64), np.asarray(normals, dtype=np.float64)


# ----------------------------------------------------------------------------------------------
# 2D polygons
# ----------------------------------------------------------------------------------------------


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _polygon_inside_dist(polygon: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inside by crossing-number parity, distance to the boundary) for (N, 2) points."""
    px, py = points[:, 0], points[:, 1]
    inside = np.zeros(points.shape[0], dtype=bool)
    d2 = np.full(points.shape[0], np.inf)
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        crosses = (a[1] > py) != (b[1] > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = a[0] + (py - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        inside ^= crosses & (px < x_at)
        ab = b - a
        t = np.clip(((px - a[0]) * ab[0] + (py - a[1]) * ab[1]) / max(ab @ ab, 1e-300), 0.0, 1.0)
        d2 = np.minimum(d2, (px - a[0] - t * ab[0]) ** 2 + (py - a[1] - t * ab[1]) ** 2)
    return inside, np.sqrt(d2)


def _polygon_lattice(polygon, dx, origin, pad):
    """Lattice points covering the polygon bounds grown by ``pad`` (m)."""
    kmin, kmax = _index_range(polygon.min(axis=0) - pad, polygon.max(axis=0) + pad, origin, dx)
    shape = tuple(int(n) for n in np.maximum(kmax - kmin + 1, 0))
    return _lattice(origin, dx, kmin, shape)


def fill_polygon(polygon, dx, origin=None, clearance=0.0) -> np.ndarray:
    """Lattice points ``origin + (k + 0.5) dx`` strictly inside a closed 2D polygon (m). Returns (N, 2).

    ``polygon`` is (M, 2) vertices in either orientation, closed implicitly; ``origin`` defaults to
    the polygon's lower-left bound. ``clearance`` (m): keep only points at least that far from the
    boundary (dx/2 matches boundary particles placed by ``warpfree.solvers.wcsph.surface_layers``, whose first layer is
    dx/2 on the other side, so the wall the fluid feels is the true boundary, at any orientation).
    """
    polygon = _polygon(polygon)
    dx = require_positive("dx", dx)
    clearance = require_positive("clearance", clearance, allow_zero=True)
    origin = _origin(origin, polygon.min(axis=0))
    pts = _polygon_lattice(polygon, dx, origin, 0.0)
    inside, dist = _polygon_inside_dist(polygon, pts)
    return pts[inside & (dist > max(_TOL * dx, clearance * (1.0 - 1e-6)))]


def polygon_boundary_layers(polygon, dx, layers, side, origin=None) -> np.ndarray:
    """Lattice points within ``layers * dx`` (m) of a closed 2D polygon's boundary, on one side.

    ``side="outside"``: points not strictly inside (container walls); ``side="inside"``: strictly
    inside (obstacles). Same lattice as :func:`fill_polygon` / :func:`lattice_box` for the same
    ``origin`` (default: the polygon's lower-left bound). Euclidean distance, so convex corners are
    filled up to the circle of radius ``layers * dx`` around the corner. Returns (N, 2).
    """
    polygon = _polygon(polygon)
    dx = require_positive("dx", dx)
    layers = _layers(layers)
    side = Side.of("side", side)
    origin = _origin(origin, polygon.min(axis=0))
    pts = _polygon_lattice(polygon, dx, origin, layers * dx)
    inside, dist = _polygon_inside_dist(polygon, pts)
    strictly = inside & (dist > _TOL * dx)
    on_side = strictly if side is Side.INSIDE else ~strictly
    return pts[on_side & (dist <= layers * dx * (1.0 + _TOL))]


# ----------------------------------------------------------------------------------------------
# sections, primitives, loading
# ----------------------------------------------------------------------------------------------


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane axes (u, v) with (u, v, n) right-handed; u is the world axis after n's dominant one."""
    a = int(np.argmax(np.abs(normal)))
    u = np.eye(3)[(a + 1) % 3]
    u = u - (u @ normal) * normal
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def _chain_loops(edges: np.ndarray) -> list[np.ndarray] | None:
    """Vertex-index loops from undirected edges; None unless every vertex has degree 2."""
    nbr: dict[int, list[int]] = {}
    for a, b in edges:
        nbr.setdefault(int(a), []).append(int(b))
        nbr.setdefault(int(b), []).append(int(a))
    if any(len(v) != 2 for v in nbr.values()):
        return None
    loops, seen = [], set()
    for start in nbr:
        if start in seen:
            continue
        loop, prev, cur = [start], None, start
        seen.add(start)
        while True:
            a, b = nbr[cur]
            nxt = a if a != prev else b
            if nxt == start:
                break
            loop.append(nxt)
            seen.add(nxt)
            prev, cur = cur, nxt
        loops.append(np.asarray(loop))
    return loops


def _drop_collinear(p: np.ndarray, tol: float) -> np.ndarray:
    """Remove vertices lying on the segment between their neighbours (within ``tol`` m)."""
    while p.shape[0] > 3:
        prev, nxt = np.roll(p, 1, axis=0), np.roll(p, -1, axis=0)
        e = nxt - prev
        cross = np.abs(e[:, 0] * (p[:, 1] - prev[:, 1]) - e[:, 1] * (p[:, 0] - prev[:, 0]))
        off = cross / np.maximum(np.linalg.norm(e, axis=1), 1e-300)
        k = int(np.argmin(off))
        if off[k] > tol:
            break
        p = np.delete(p, k, axis=0)
    return p


def mesh_section(mesh: trimesh.Trimesh, plane_origin, plane_normal) -> list[np.ndarray]:
    """Cross-section of a watertight mesh by a plane, as a list of closed 2D polygons (M, 2) (m).

    2D coordinates are ``(p . u, p . v)`` in world units, not re-centred on ``plane_origin``, where
    (u, v, n) is right-handed and u is the world axis following the dominant axis of n, projected
    on the plane: n = +z gives world (x, y), n = +x gives (y, z), n = +y gives (z, x).
    Loops are counter-clockwise in (u, v), collinear vertices removed; holes are not marked.
    """
    import trimesh

    mesh = _check_mesh(mesh)
    plane_origin = _vector("plane_origin", plane_origin, dims=(3,))
    normal = _vector("plane_normal", plane_normal, dims=(3,))
    if np.linalg.norm(normal) == 0:
        raise ParameterError("plane_normal", "must be non-zero")
    normal = normal / np.linalg.norm(normal)
    segs = trimesh.intersections.mesh_plane(mesh, normal, plane_origin)
    if len(segs) == 0:
        return []
    from scipy.spatial import cKDTree

    pts = segs.reshape(-1, 3)
    tol = 1e-9 * mesh.scale
    rep = np.arange(pts.shape[0])
    pairs = cKDTree(pts).query_pairs(tol, output_type="ndarray")
    np.minimum.at(rep, pairs[:, 1], pairs[:, 0])
    for _ in range(8):  # resolve chains of merged points to their smallest index
        rep = rep[rep]
    edges = rep.reshape(-1, 2)
    edges = edges[edges[:, 0] != edges[:, 1]]
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    loops = _chain_loops(edges)
    if loops is None:
        raise ParameterError("plane_origin", "the section is not a set of closed loops "
                             "(plane through mesh vertices, edges or faces?)")
    u, v = _plane_basis(normal)
    out = []
    for loop in loops:
        q = np.stack([pts[loop] @ u, pts[loop] @ v], axis=1)
        q = _drop_collinear(q, tol)
        if _signed_area(q) < 0:
            q = q[::-1]
        out.append(q)
    return out


def clip_polygon(polygon, normal, offset: float) -> np.ndarray:
    """The part of a closed 2D polygon where normal·x <= offset (m), as a polygon (Sutherland–Hodgman against one
    half-plane; exact for convex polygons, and for any polygon the half-plane cuts into one piece)."""
    poly = _polygon(polygon)
    n = np.asarray(normal, dtype=float)
    if n.shape != (2,) or not np.all(np.isfinite(n)) or not np.any(n):
        raise ParameterError("normal", f"must be a non-zero 2D vector, got {normal!r}")
    side = poly @ n - float(offset)
    out = []
    for k in range(len(poly)):
        a, b, sa, sb = poly[k], poly[(k + 1) % len(poly)], side[k], side[(k + 1) % len(poly)]
        if sa <= 0.0:
            out.append(a)
        if (sa < 0.0 < sb) or (sb < 0.0 < sa):
            out.append(a + (b - a) * (sa / (sa - sb)))
    if len(out) < 3:
        raise ParameterError("offset", "the half-plane leaves nothing of the polygon")
    return np.asarray(out)


def box_mesh(lo, hi) -> trimesh.Trimesh:
    """Axis-aligned box mesh with bounds [lo, hi] (m, 3D), outward normals."""
    import trimesh

    lo, hi = _box(lo, hi)
    if lo.shape[0] != 3:
        raise ParameterError("lo", f"box_mesh is 3D: lo and hi need 3 components, got {lo.shape[0]}")
    return trimesh.creation.box(bounds=np.stack([lo, hi]))


def load_mesh(source) -> trimesh.Trimesh:
    """A trimesh.Trimesh from a path (STL/OBJ/PLY, ...) or an existing Trimesh (returned as is)."""
    import trimesh

    if isinstance(source, trimesh.Trimesh):
        mesh = source
    elif isinstance(source, (str, os.PathLike)):
        if not os.path.isfile(source):
            raise ParameterError("mesh", f"file not found: {os.fspath(source)!r}")
        try:
            mesh = trimesh.load(source, force="mesh")
        except Exception as exc:  # trimesh raises many types for unreadable files
            raise ParameterError("mesh", f"cannot read {os.fspath(source)!r}: {exc}") from None
    else:
        raise ParameterError("mesh", f"must be a path or a trimesh.Trimesh, got {type(source).__name__}")
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ParameterError("mesh", "is empty (no triangles)")
    return mesh
