"""Free-surface triangle meshes from particles (3D).

1. Colour function on a regular grid of nodes, spacing ``cell`` (m), covering the particle bounds plus
   a margin of one support radius and one cell on every side (χ vanishes beyond one support radius, so
   the outer node layer is exactly 0 and the surface always closes; a wider margin only adds empty
   nodes)::

       χ(x) = Σ_j V_j W(|x - x_j|, h)

   (a gather kernel per node over a HashGrid of the particles, :func:`warpfree.kernels.wcsph.colour_function_grid`).
2. Marching cubes (Warp's ``IsoSurfaceMarchingCubes``) at ``χ = iso`` (default 1/2), vertices in world
   coordinates, triangles wound counter-clockwise seen from outside (normals point out of the fluid).

The result is a :class:`trimesh.Trimesh` (``warpfree.io.meshes.write_mesh`` saves it as PLY, OBJ or STL).
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError, require_positive
from warpfree.kernels import wcsph as K
from warpfree.kernels.smoothing import kernel_id, support_factor
from warpfree.neighbours import NeighbourGrid
from warpfree.smoothing import SmoothingKernel
from warpfree.space import Space

__all__ = ["colour_function_grid", "free_surface_mesh"]

#: Refuse grids larger than this many nodes (a float32 field of 2e8 nodes is 800 MB).
MAX_NODES = 200_000_000


def _grid_layout(pts: np.ndarray, pad: float, cell: float) -> tuple[np.ndarray, tuple[int, int, int]]:
    lo = pts.min(axis=0).astype(np.float64) - pad
    hi = pts.max(axis=0).astype(np.float64) + pad
    shape = tuple(int(math.ceil((hi[a] - lo[a]) / cell)) + 1 for a in range(3))
    return lo, shape


def colour_function_grid(launcher: Launcher, positions: wp.array, volumes: wp.array, h: float,
                         kernel: SmoothingKernel = SmoothingKernel.WENDLAND_C2, cell: float | None = None,
                         padding: float | None = None,
                         max_nodes: int = MAX_NODES) -> tuple[wp.array, np.ndarray, float]:
    """Sample χ(x) = Σ_j V_j W(|x - x_j|, h) on a regular grid.

    Returns ``(chi, lower, cell)``: ``chi`` a ``wp.array3d(float)`` of shape (nx, ny, nz) whose node
    (ix, iy, iz) lies at ``lower + cell * (ix, iy, iz)`` (m). ``padding`` (m) defaults to one support
    radius plus one cell.
    """
    h = require_positive("h", h)
    kernel = SmoothingKernel.of("kernel", kernel)
    kind = kernel_id(kernel)
    support = support_factor(kernel) * h
    cell = 0.75 * h if cell is None else require_positive("cell", cell)
    pad = support + cell if padding is None else require_positive("padding", padding, allow_zero=True)
    if positions.dtype != wp.vec3:
        raise ParameterError("positions", f"must be a wp.array of wp.vec3, got dtype {positions.dtype}")
    if volumes.shape[0] != positions.shape[0]:
        raise ParameterError("volumes", f"must have one entry per particle ({positions.shape[0]}), "
                                        f"got {volumes.shape[0]}")
    n = positions.shape[0]
    if n == 0:
        raise ParameterError("positions", "must hold at least one particle")
    pts = positions.numpy()
    if not np.all(np.isfinite(pts)):
        raise ParameterError("positions", "must be finite")
    lower, shape = _grid_layout(pts, pad, cell)
    nodes = shape[0] * shape[1] * shape[2]
    if nodes > max_nodes:
        raise ParameterError("cell", f"{cell:g} gives a grid of {shape} = {nodes} nodes (> {max_nodes}); "
                                     "use a larger cell")
    device = launcher.device
    if str(positions.device) != device:
        positions = positions.to(device)
    if str(volumes.device) != device:
        volumes = volumes.to(device)
    grid = NeighbourGrid(launcher, support, Space.free(3), positions)
    chi = wp.zeros(nodes, dtype=float, device=device)
    launcher.launch(K.colour_function_grid, nodes,
                    [grid.id, positions, volumes, wp.vec3(*lower.astype(np.float32)), float(cell),
                     shape[1], shape[2], support, kind, h, chi])
    return chi.reshape(shape), lower, float(cell)


def free_surface_mesh(launcher: Launcher, positions: wp.array, volumes: wp.array, h: float,
                      kernel: SmoothingKernel = SmoothingKernel.WENDLAND_C2, cell: float | None = None, iso: float = 0.5,
                      dim: int = 3) -> trimesh.Trimesh:
    """Free-surface triangle mesh: the ``χ = iso`` iso-surface of the colour function (3D only).

    ``positions`` (m, ``wp.vec3``), ``volumes`` (m³, float32), ``h`` smoothing length (m), ``cell`` grid
    spacing (m, default 0.75 h ≈ dx at h = 1.3 dx: on a lattice-filled sphere of radius 10 dx this puts
    the mean vertex radius within 0.03 dx of R and the enclosed volume within 1.5 %; h/2 costs 3-4x
    more for a 0.5 % better volume). Returns a possibly empty :class:`trimesh.Trimesh` with outward normals.
    """
    if dim != 3:
        raise ParameterError("dim", f"free-surface meshes are 3D only, got dim={dim!r}")
    iso = float(iso)
    if not (math.isfinite(iso) and iso > 0.0):
        raise ParameterError("iso", f"must be a finite number > 0, got {iso}")
    chi, lower, cell = colour_function_grid(launcher, positions, volumes, h, kernel, cell)
    nx, ny, nz = chi.shape
    upper = lower + cell * np.array([nx - 1, ny - 1, nz - 1], dtype=np.float64)
    if launcher.device != "cpu":
        launcher.synchronize()
    verts, tris = _marching_cubes().extract(
        chi, iso, lower=wp.vec3(*lower.astype(np.float32)), upper=wp.vec3(*upper.astype(np.float32)))
    v = verts.numpy().astype(np.float64)
    f = tris.numpy().reshape(-1, 3)
    if len(f) == 0:
        return trimesh.Trimesh(vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), dtype=np.int64))
    # Warp winds faces outward for fields that are negative inside; χ is positive inside, so flip.
    return trimesh.Trimesh(vertices=v, faces=f[:, ::-1].astype(np.int64), process=True)


def _marching_cubes():
    try:
        from warp.geometry import IsoSurfaceMarchingCubes
    except ImportError:  # pragma: no cover - Warp < 1.18
        raise RuntimeError("free-surface meshes need warp-lang >= 1.18 "
                           "(warp.geometry.IsoSurfaceMarchingCubes), "
                           f"this is {wp.config.version}") from None
    return IsoSurfaceMarchingCubes
