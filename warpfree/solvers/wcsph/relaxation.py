"""Relaxed particle arrangements: particles that fill a region with a uniform kernel concentration.

A lattice is a poor start for a particle method: where it meets a boundary that is not one of its own
rows (a tilted wall, a corner of curved wall layers, a free surface) its particles do not see a full,
uniform support, and a square lattice under pressure is not even stable (a WCSPH tank at rest on one
rearranges along slip lines after about a second). :func:`relax_particles` moves the particles of a region
until every one sees a uniform concentration, ∇C_i = 0 (``warpfree.kernels.wcsph_relaxation``): fixed particles
(walls) count as the material behind the walled part of the boundary, and a continuum beyond the free part
is represented by quadrature points on it (:func:`free_boundary_points`). A small random offset first moves
the particles off the lattice, which is a stationary arrangement of the same iteration. The result is an
isotropic, body-fitted arrangement with the same particle count: about one particle per dx^dim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError, require_positive
from warpfree.geometry import ccw_polygon, is_mesh
from warpfree.neighbours import MovingNeighbours, empty_rows
from warpfree.particles import to_vec3
from warpfree.progress import announced, group_digits
from warpfree.reduce import Reduction
from warpfree.smoothing import SmoothingKernel
from .solids import Solids
from warpfree.space import Space
from warpfree.kernels import wcsph_relaxation as rk
from warpfree.kernels.smoothing import SIGMA, kernel_id, kernel_profile, support_factor

__all__ = ["Relaxation", "free_boundary_points", "relax_particles"]

#: spacing of the free-boundary quadrature points, in dx (midpoint rule: the kernel varies on the scale h)
BOUNDARY_SPACING = 0.25
#: random offset of every coordinate before relaxing, in dx (uniform in ±JITTER dx)
JITTER = 0.1


@dataclass
class Relaxation:
    """The relaxed positions (N, dim) and how the iteration went: the largest offset from the uniform
    arrangement, |∇C_i|/K in dx, at each iteration (``history``), the last one (``residual``), the iteration count."""

    positions: np.ndarray
    iterations: int
    residual: float
    history: list = field(default_factory=list)


def _region(region, dim: int):
    if dim == 3:
        if not is_mesh(region) or not region.is_watertight:
            raise ParameterError("region", "a 3D region must be a watertight trimesh mesh")
        return region
    return ccw_polygon(region)


def _boundary_pieces(shape, step: float):
    """(centres, outward unit normals, lengths or areas) of a polygon's edges or a mesh's triangles cut into
    pieces no longer than ``step`` (m)."""
    if is_mesh(shape):
        mesh = _region(shape, 3)
        import trimesh

        v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=step)
        tri = np.asarray(v, float)[np.asarray(f)]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = 0.5 * np.linalg.norm(cross, axis=1)
        keep = area > 0
        normals = cross[keep] / (2.0 * area[keep, None])
        return tri[keep].mean(axis=1), (-normals if mesh.volume < 0 else normals), area[keep]
    poly = _region(shape, 2)
    pts, nrm, wts = [], [], []
    for p, q in zip(poly, np.roll(poly, -1, axis=0)):
        length = float(np.linalg.norm(q - p))
        n = max(1, int(math.ceil(length / step)))
        t = (q - p) / length
        pts.append(p + ((np.arange(n) + 0.5) / n)[:, None] * (q - p))
        nrm.append(np.tile([t[1], -t[0]], (n, 1)))  # outward for a counter-clockwise polygon
        wts.append(np.full(n, length / n))
    return np.vstack(pts), np.vstack(nrm), np.concatenate(wts)


def free_boundary_points(region, dx: float, containers=(), obstacles=(), launcher: Launcher | None = None):
    """Quadrature points of the boundary of the empty space S next to the particles: (points (Q, dim), unit
    normals into S (Q, dim), weights (Q,) in m (2D) or m² (3D)).

    S is what is neither the ``region`` the particles fill nor wall material (outside the ``containers``, inside
    the ``obstacles``: polygons or meshes whose wall particles stand there). Its boundary is the free part of the
    region's boundary (pieces farther than ``BOUNDARY_SPACING`` dx from every wall surface) and the wall surfaces
    that face S rather than the region (pieces farther than that outside the region: a container's side above a
    free surface). Every piece is at most that spacing long, one point at its centre. The gradient of the
    concentration of a continuum filling S is then Σ_q s_q W(|x - y_q|) n_q (``warpfree.kernels.wcsph_relaxation``).
    """
    dx = require_positive("dx", dx)
    launcher = launcher or current_launcher()
    step = BOUNDARY_SPACING * dx
    dim = 3 if is_mesh(region) else 2
    walls = [(shape, -1.0) for shape in containers] + [(shape, 1.0) for shape in obstacles]

    def as3(points):
        return points if dim == 3 else np.column_stack([points, np.zeros(len(points))])

    points, normals, weights = _boundary_pieces(region, step)
    if walls:
        solids = Solids(launcher, dim, containers=[w for w, _ in walls])
        near = np.zeros(len(points), bool)
        for k in range(len(walls)):
            near |= np.abs(solids.signed_distance(as3(points), k)) < step
        points, normals, weights = points[~near], normals[~near], weights[~near]
        inside_region = Solids(launcher, dim, containers=[_region(region, dim)])
        parts = [(points, normals, weights)]
        for shape, into_space in walls:  # containers: S is on the inner side of their surface; obstacles: outer
            p, n, w = _boundary_pieces(shape, step)
            facing = inside_region.signed_distance(as3(p)) > step
            parts.append((p[facing], into_space * n[facing], w[facing]))
        points, normals, weights = (np.concatenate(a) for a in zip(*parts))
    return points, normals, weights


def _stiffness(kernel: SmoothingKernel, dim: int, h_factor: float, dx: float) -> float:
    """K = -(dx/h)^d σ_d f''(0)/h² (1/m²): the self-stiffness of ∇C of a particle in a lattice."""
    h = h_factor * dx
    f2 = float(kernel_profile(kernel, dim, 0.0, "grad_coef"))  # f''(0) = lim (df/dq)/q at q -> 0
    return -(1.0 / h_factor) ** dim * SIGMA[kernel][dim - 1] * f2 / (h * h)


@announced(lambda positions, *a, **k: f"fluid layout relaxed ({group_digits(len(positions))} particles)")
def relax_particles(positions, dx: float, region, walls=None, containers=(), obstacles=(), kernel: SmoothingKernel = SmoothingKernel.WENDLAND_C2,
                    h_factor: float = 1.3, beta: float = 0.1, tolerance: float = 0.01, max_iterations: int = 2000,
                    jitter: float = JITTER, seed: int = 0, launcher: Launcher | None = None) -> Relaxation:
    """Relax ``positions`` ((N, dim), m) inside ``region`` until the largest offset from the uniform arrangement,
    |∇C_i|/K (the shift of an iteration divided by ``beta``), is below ``tolerance`` dx, or ``max_iterations``.

    ``walls``: (M, dim) fixed particles (volume dx^dim), the wall particles of the ``containers`` and ``obstacles``
    (polygons or meshes); the empty space beyond the rest of the region's boundary enters through
    :func:`free_boundary_points`. ``kernel``, ``h_factor``:
    those of the method the particles are for. ``beta``: fraction of a particle's own offset removed per
    iteration (0 < beta <= 0.5; measured on a 2D tank: 0.1 converges, 0.25 and 0.5 oscillate at 1 % of dx).
    Particles found across a wall afterwards, or more than dx/2 beyond the region's free boundary, are an error
    naming their count.
    """
    launcher = launcher or current_launcher()
    dx = require_positive("dx", dx)
    x0 = np.asarray(positions, dtype=float)
    if x0.ndim != 2 or x0.shape[1] not in (2, 3) or len(x0) == 0:
        raise ParameterError("positions", f"must be a non-empty (N, 2) or (N, 3) array, got shape {x0.shape}")
    dim = x0.shape[1]
    if not 0.0 < beta <= 0.5:
        raise ParameterError("beta", f"must be in (0, 0.5], got {beta!r}")
    region = _region(region, dim)
    dev = launcher.device
    rng = np.random.default_rng(seed)
    x = x0 + require_positive("jitter", jitter, allow_zero=True) * dx * rng.uniform(-1.0, 1.0, x0.shape)
    pos = wp.array(to_vec3(x, "positions").astype(np.float32), dtype=wp.vec3, device=dev)

    h = h_factor * dx
    support = support_factor(kernel) * h
    c = rk.RelaxationConstants()
    space = Space.free(dim)
    c.box = space.box
    c.kind, c.dim = kernel_id(kernel), dim
    c.inv_h, c.support2 = 1.0 / h, support * support
    c.w_factor = SIGMA[kernel][dim - 1] / h ** dim
    c.grad_factor = c.w_factor / (h * h)
    c.volume = c.wall_volume = dx ** dim
    c.step = beta / _stiffness(kernel, dim, h_factor, dx)

    qp, qn, qw = free_boundary_points(region, dx, containers, obstacles, launcher)
    static = {}
    if walls is not None and len(walls):
        static["walls"] = wp.array(to_vec3(walls, "walls").astype(np.float32), dtype=wp.vec3, device=dev)
    if len(qp):
        static["surface"] = wp.array(to_vec3(qp, "surface").astype(np.float32), dtype=wp.vec3, device=dev)
    n = len(x)
    neighbours = MovingNeighbours(launcher, space, pos, support, 0.2 * support, static_sets=static)
    cap = 64 if dim == 2 else 256
    moving = neighbours.add_table("moving", "moving", "moving", cap, exclude_self=True)
    wall_table = neighbours.add_table("walls", "moving", "walls", cap) if "walls" in static else None
    surface_table = neighbours.add_table("surface", "moving", "surface", 4 * cap) if "surface" in static else None
    empty = empty_rows(n, dev)
    surf_normal = wp.array(to_vec3(qn, "normals").astype(np.float32) if len(qn) else np.zeros((1, 3), np.float32),
                           dtype=wp.vec3, device=dev)
    surf_weight = wp.array(qw.astype(np.float32) if len(qw) else np.zeros(1, np.float32), dtype=float, device=dev)
    surf_pos = static.get("surface", surf_normal)
    wall_pos = static.get("walls", surf_normal)
    shift = wp.zeros(n, dtype=wp.vec3, device=dev)
    shift2 = wp.zeros(n, dtype=float, device=dev)
    moved2 = wp.zeros(n, dtype=float, device=dev)
    largest, moved_max = Reduction(launcher, wp.float32, "max"), Reduction(launcher, wp.float32, "max")
    history, moved = [], math.inf
    for it in range(1, int(max_iterations) + 1):
        if neighbours.needs_rebuild(moved):
            neighbours.rebuild()
        launcher.launch(rk.relaxation_step, n, [
            c, pos, moving.rows, wall_pos, wall_table.rows if wall_table else empty,
            surf_pos, surf_normal, surf_weight, surface_table.rows if surface_table else empty, shift, shift2])
        launcher.launch(rk.apply_shift, n, [pos, shift, neighbours.position_at_build, moved2])
        largest.launch(shift2)
        moved_max.launch(moved2)
        history.append(math.sqrt(float(largest.value())) / (beta * dx))
        moved = math.sqrt(float(moved_max.value()))
        if history[-1] < tolerance:
            break
    out = pos.numpy()[:, :dim].astype(np.float64)
    if containers or obstacles:
        leak = Solids(launcher, dim, containers=containers, obstacles=obstacles).penetration(pos)
        if leak:
            raise ParameterError("walls", f"{leak.count} of {n} particles crossed a wall while relaxing ({leak.where}, "
                                          f"{leak.max_depth:.3g} m deep at {np.round(leak.position, 4).tolist()})")
    # beyond the free part of the boundary a particle centre may stand where its dx/2 of volume still meets the
    # region (the free surface is where the pressure vanishes, not a wall), not further
    p3 = out if dim == 3 else np.column_stack([out, np.zeros(n)])
    outside = np.flatnonzero(Solids(launcher, dim, containers=[region]).signed_distance(p3) > 0.5 * dx)
    if outside.size:
        raise ParameterError("region", f"{outside.size} of {n} particles left the region by more than dx/2 while "
                                       f"relaxing (first at {out[outside[0]].round(4).tolist()})")
    return Relaxation(out, len(history), history[-1], history)
