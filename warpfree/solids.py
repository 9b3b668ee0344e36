"""Solids the particles of a set must not enter: the true surfaces of containers and obstacles.

A scene hands its geometry over as it is (a trimesh mesh in 3D, a closed polygon in 2D) with the side
the particles belong on: ``containers`` hold the particles inside, ``obstacles`` keep them outside.
:meth:`Solids.penetration` measures on the device, for every particle, how deep it is on the wrong side of
any of them (``warpfree.kernels.solids``): a bounding box cannot see fluid inside an obstacle or outside a
tilted wall; the real surfaces can. Solvers run it as their audit at every output.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from .device import Launcher
from .errors import ParameterError
from warpfree.kernels import solids as sk

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
    ``trimesh.Trimesh`` (3D, watertight) or an (M, 2) polygon (2D, closed, any orientation)."""

    def __init__(self, launcher: Launcher, dim: int, containers=(), obstacles=()):
        if dim not in (2, 3):
            raise ParameterError("dim", f"solids are 2D polygons or 3D meshes, got dim={dim!r}")
        self.launcher = launcher
        self.dim = dim
        self._meshes: list[tuple[wp.Mesh, int, float]] = []  # (mesh, inside allowed, query distance)
        self.dim = dim
        self.names: list[str] = []
        for inside, shapes in ((1, containers), (0, obstacles)):
            for k, shape in enumerate(shapes):
                self.names.append(f"outside container {k}" if inside else f"inside obstacle {k}")
                vertices, faces = self._surface(shape)
                extent = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
                mesh = wp.Mesh(points=wp.array(vertices.astype(np.float32), dtype=wp.vec3, device=launcher.device),
                               indices=wp.array(faces.astype(np.int32).reshape(-1), dtype=wp.int32,
                                                device=launcher.device))
                self._meshes.append((mesh, inside, 4.0 * extent + 1.0))

    def __len__(self) -> int:
        return len(self._meshes)

    def _surface(self, shape) -> tuple[np.ndarray, np.ndarray]:
        import trimesh

        if self.dim == 3:
            if not isinstance(shape, trimesh.Trimesh) or not shape.is_watertight:
                raise ParameterError("solids", "3D solids must be watertight trimesh meshes")
            return np.asarray(shape.vertices, float), np.asarray(shape.faces)
        poly = np.asarray(shape, dtype=float)
        if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3 or not np.all(np.isfinite(poly)):
            raise ParameterError("solids", f"2D solids must be (M >= 3, 2) finite polygons, got shape {poly.shape}")
        return _prism(poly, 2.0 * float(np.ptp(poly, axis=0).max()))  # taller than wide: caps never closest

    def penalty(self, reach: float, speed: float) -> sk.SurfacePenalty:
        """The ``@wp.struct`` of :func:`warpfree.kernels.solids.add_surface_penalty`: reach r0 (m) and the
        stiffness speed²/r0² (speed: the largest signal speed, e.g. c0, m/s)."""
        p = sk.SurfacePenalty()
        dev = self.launcher.device
        p.meshes = wp.array(np.array([m.id for m, _, _ in self._meshes], dtype=np.uint64), dtype=wp.uint64, device=dev)
        p.inside_allowed = wp.array(np.array([inside for _, inside, _ in self._meshes], dtype=np.int32),
                                    dtype=wp.int32, device=dev)
        p.reach = float(reach)
        p.stiffness = float(speed) ** 2 / float(reach) ** 2
        p.planar = int(self.dim == 2)
        return p

    def signed_distance(self, points: np.ndarray, which: int = 0) -> np.ndarray:
        """Signed distance (m, negative inside) of (N, 3) NumPy points to solid ``which`` (in the order given:
        containers first), queried on the device."""
        mesh, _, reach = self._meshes[which]
        n = len(points)
        pts = wp.array(np.asarray(points, np.float32).reshape(-1, 3), dtype=wp.vec3, device=self.launcher.device)
        out = wp.zeros(max(n, 1), dtype=float, device=self.launcher.device)
        self.launcher.launch(sk.signed_distance, n, [mesh.id, reach, pts, out])
        return out.numpy()[:n].astype(np.float64)

    def penetration(self, positions: wp.array) -> Penetration:
        """Particles of ``positions`` (``wp.vec3``; z = 0 in 2D) on the wrong side of any solid (one read)."""
        n = positions.shape[0]
        depth = wp.zeros(max(n, 1), dtype=float, device=self.launcher.device)
        which = wp.zeros(max(n, 1), dtype=wp.int32, device=self.launcher.device)
        for k, (mesh, inside, reach) in enumerate(self._meshes):
            self.launcher.launch(sk.penetration_depth, n, [mesh.id, k, inside, reach, positions, depth, which])
        d = depth.numpy()[:n]
        bad = np.flatnonzero(d > 0.0)
        if not bad.size:
            return Penetration(0, 0.0, -1)
        deepest = int(bad[np.argmax(d[bad])])
        return Penetration(int(bad.size), float(d[deepest]), deepest, self.names[int(which.numpy()[deepest])],
                           tuple(float(c) for c in positions.numpy()[deepest]))


def _prism(polygon: np.ndarray, half_height: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism over ``polygon`` from z = -half_height to +half_height, faces wound outward.

    The side faces carry the polygon's edges; the caps are fans, which are only valid for convex polygons,
    but a query in the z = 0 plane never has a cap as its closest feature (the prism is taller than the
    polygon is wide), so concave polygons are measured correctly too.
    """
    p = np.asarray(polygon, dtype=float)
    if np.allclose(p[0], p[-1]):
        p = p[:-1]
    area2 = np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    if area2 == 0.0:
        raise ParameterError("solids", "a 2D solid must enclose an area")
    if area2 < 0:
        p = p[::-1]  # counter-clockwise: side normals point out
    m = len(p)
    bottom = np.column_stack([p, np.full(m, -half_height)])
    top = np.column_stack([p, np.full(m, half_height)])
    vertices = np.vstack([bottom, top])
    i = np.arange(m)
    j = (i + 1) % m
    sides = np.vstack([np.column_stack([i, j, m + j]), np.column_stack([i, m + j, m + i])])
    k = np.arange(1, m - 1)
    caps = np.vstack([np.column_stack([np.zeros_like(k), k + 1, k]), np.column_stack([m + 0 * k, m + k, m + k + 1])])
    return vertices, np.vstack([sides, caps])
