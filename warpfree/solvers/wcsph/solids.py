"""Solids the particles of a set must not enter: the true surfaces of containers and obstacles.

A scene hands its geometry over as it is (a trimesh mesh in 3D, a closed polygon in 2D) with the side
the particles belong on: ``containers`` hold the particles inside, ``obstacles`` keep them outside.
:meth:`Solids.penetration` measures on the device, for every particle, how deep it is on the wrong side of
any of them (``warpfree.kernels.wcsph_solids``): a bounding box cannot see fluid inside an obstacle or outside a
tilted wall; the real surfaces can. Solvers run it as their audit at every output, and
:meth:`Solids.penalty` gives the stiff penalty that keeps fluid off the surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.geometry import is_mesh
from warpfree.kernels import wcsph_bodies as bk
from warpfree.kernels import wcsph_solids as sk

__all__ = ["Solids", "Penetration"]


@dataclass
class Penetration:
    """The particles on the wrong side of a solid: how many, the deepest (m), its index (-1: none), where it is
    (a description of that solid, e.g. "inside obstacle 1") and its position."""

    count: int
    max_depth: float
    first_index: int
    where: str = ""
    position: tuple = ()

    def __bool__(self) -> bool:
        return self.count > 0


class Solids:
    """Closed surfaces in a ``dim``-D scene (2 or 3): ``containers`` and ``obstacles``, each a
    ``trimesh.Trimesh`` (3D, watertight) or an (M, 2) polygon (2D, closed, any orientation); ``bodies``: the surfaces
    of rigid bodies as (surface, body index, the body's reference point at t = 0, whether it holds the fluid: a
    container, else an obstacle), which :meth:`follow` their bodies (``warpfree.solvers.wcsph.bodies``)."""

    def __init__(self, launcher: Launcher, dim: int, containers=(), obstacles=(), bodies=()):
        if dim not in (2, 3):
            raise ParameterError("dim", f"solids are 2D polygons or 3D meshes, got dim={dim!r}")
        self.launcher = launcher
        self.dim = dim
        dev = launcher.device
        bodies = list(bodies)
        shapes = ([(1, s) for s in containers] + [(0, s) for s in obstacles]
                  + [(int(inside), s) for s, _, _, inside in bodies])
        self.names = [f"outside container {k}" for k in range(len(containers))] + \
                     [f"inside obstacle {k}" for k in range(len(obstacles))] + \
                     [f"{'outside' if inside else 'inside'} body {b}" for _, b, _, inside in bodies]
        first_body = len(containers) + len(obstacles)
        #: the solids that do not move (containers and obstacles, before the bodies' surfaces)
        self.static_count = first_body
        #: the moving surfaces: 2D, (each vertex's body or -1, its offset) over all vertices; 3D, (mesh, body, offsets)
        self._moving = None
        s = sk.Solids()
        s.count, s.planar = len(shapes), int(dim == 2)
        s.inside_allowed = wp.array(np.array([i for i, _ in shapes] or [0], dtype=np.int32), dtype=wp.int32, device=dev)
        self._meshes = []  # kept alive: the struct holds their ids
        if dim == 3:
            extent = 0.0
            for _, shape in shapes:
                vertices, faces = _mesh(shape)
                extent = max(extent, float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))))
                self._meshes.append(wp.Mesh(
                    points=wp.array(vertices.astype(np.float32), dtype=wp.vec3, device=dev),
                    indices=wp.array(faces.astype(np.int32).reshape(-1), dtype=wp.int32, device=dev)))
            s.meshes = wp.array(np.array([m.id for m in self._meshes] or [0], dtype=np.uint64), dtype=wp.uint64,
                                device=dev)
            s.vertices = wp.zeros(1, dtype=wp.vec2, device=dev)
            s.start = wp.zeros(1, dtype=wp.int32, device=dev)
            s.max_dist = 4.0 * extent + 1.0
        else:
            polygons = [_polygon(shape) for _, shape in shapes]
            start = np.concatenate([[0], np.cumsum([len(p) for p in polygons])]).astype(np.int32)
            s.vertices = wp.array(np.vstack(polygons).astype(np.float32) if polygons else np.zeros((1, 2), np.float32),
                                  dtype=wp.vec2, device=dev)
            s.start = wp.array(start, dtype=wp.int32, device=dev)
            s.meshes = wp.zeros(1, dtype=wp.uint64, device=dev)
            s.max_dist = 1.0e30
        self.struct = s
        if bodies and dim == 2:
            body_of_vertex = np.concatenate([np.full(len(p), -1 if k < first_body else bodies[k - first_body][1],
                                                     np.int32) for k, p in enumerate(polygons)])
            centre = np.vstack([np.tile(np.zeros(3) if k < first_body else bodies[k - first_body][2], (len(p), 1))
                                for k, p in enumerate(polygons)])
            vertices = np.vstack(polygons).astype(np.float32).astype(np.float64)
            offset = np.column_stack([vertices, np.zeros(len(vertices))]) - centre
            self._moving = (wp.array(body_of_vertex, dtype=wp.int32, device=dev),
                            wp.array(offset, dtype=wp.vec3d, device=dev))
        elif bodies:
            self._moving = [(self._meshes[first_body + m], b, wp.array(
                np.asarray(self._meshes[first_body + m].points.numpy(), np.float64) - centre, dtype=wp.vec3d,
                device=dev)) for m, (_, b, centre, _) in enumerate(bodies)]

    def follow(self, body_state: wp.array) -> None:
        """The bodies' surfaces where their state ((count, BODY_COLUMNS) float64, ``kernels/wcsph_bodies.py``) puts
        them: 2D polygons' vertices moved, 3D meshes' points moved and refitted."""
        if self._moving is None:
            return
        if self.dim == 2:
            body_of_vertex, offset = self._moving
            self.launcher.launch(bk.rigid_vertices, offset.shape[0], [body_of_vertex, offset, body_state,
                                                                      self.struct.vertices])
            return
        for mesh, body, offset in self._moving:
            self.launcher.launch(bk.rigid_mesh_points, offset.shape[0], [int(body), offset, body_state, mesh.points])
            mesh.refit()

    def __len__(self) -> int:
        return self.struct.count

    def penalty(self, reach: float, speed: float) -> sk.SurfacePenalty:
        """The ``@wp.struct`` of :func:`warpfree.kernels.wcsph_solids.add_surface_penalty`: reach r0 (m) and the
        stiffness speed²/r0² (speed: the largest signal speed, e.g. c0, m/s)."""
        p = sk.SurfacePenalty()
        p.solids = self.struct
        p.reach = float(reach)
        p.stiffness = float(speed) ** 2 / float(reach) ** 2
        return p

    def signed_distance(self, points: np.ndarray, which: int = 0) -> np.ndarray:
        """Signed distance (m, negative inside) of (N, 3) NumPy points to solid ``which`` (containers first, in
        the order given), computed on the device."""
        n = len(points)
        dev = self.launcher.device
        pts = wp.array(np.asarray(points, np.float32).reshape(-1, 3), dtype=wp.vec3, device=dev)
        out = wp.zeros(max(n, 1), dtype=float, device=dev)
        self.launcher.launch(sk.signed_distance, n, [self.struct, int(which), pts, out])
        return out.numpy()[:n].astype(np.float64)

    def penetration(self, positions: wp.array) -> Penetration:
        """Particles of ``positions`` (``wp.vec3``; z = 0 in 2D) on the wrong side of any solid (one read)."""
        n = positions.shape[0]
        dev = self.launcher.device
        depth = wp.zeros(max(n, 1), dtype=float, device=dev)
        which = wp.zeros(max(n, 1), dtype=wp.int32, device=dev)
        self.launcher.launch(sk.penetration_depth, n, [self.struct, positions, depth, which])
        d = depth.numpy()[:n]
        bad = np.flatnonzero(d > 0.0)
        if not bad.size:
            return Penetration(0, 0.0, -1)
        deepest = int(bad[np.argmax(d[bad])])
        return Penetration(int(bad.size), float(d[deepest]), deepest, self.names[int(which.numpy()[deepest])],
                           tuple(float(c) for c in positions.numpy()[deepest]))


def _mesh(shape) -> tuple[np.ndarray, np.ndarray]:
    if not is_mesh(shape) or not shape.is_watertight:
        raise ParameterError("solids", "3D solids must be watertight trimesh meshes")
    return np.asarray(shape.vertices, float), np.asarray(shape.faces)


def _polygon(shape) -> np.ndarray:
    poly = np.asarray(shape, dtype=float)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3 or not np.all(np.isfinite(poly)):
        raise ParameterError("solids", f"2D solids must be (M >= 3, 2) finite polygons, got shape {poly.shape}")
    if np.allclose(poly[0], poly[-1]):
        poly = poly[:-1]
    area2 = np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])
    if area2 == 0.0:
        raise ParameterError("solids", "a 2D solid must enclose an area")
    return poly
