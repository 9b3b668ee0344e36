"""Helpers shared by the fluid scenes: hydrostatic initial density, box walls, walls from a mesh section, front probe."""

from __future__ import annotations

import numpy as np

from warpfree.errors import ParameterError, require_positive


def require_scene_values(positive: dict | None = None, layers: dict | None = None) -> None:
    """Check a scene's parameters at build time: ``positive`` name -> value (> 0), ``layers`` name -> value
    (an integer >= 1). The error names the scene's parameter, not a quantity derived from it."""
    for name, value in (positive or {}).items():
        require_positive(name, value)
    for name, value in (layers or {}).items():
        if isinstance(value, bool) or int(value) != value or value < 1:
            raise ParameterError(name, f"must be an integer >= 1, got {value!r}")


def hydrostatic_density(y: np.ndarray, surface: float, rho0: float, c0: float, g: float,
                        gamma: float = 7.0) -> np.ndarray:
    """ρ(y) = ρ0 [1 + ρ0 g (surface - y)/B]^(1/γ), B = ρ0 c0²/γ: the Tait EOS inverted for p = ρ0 g depth."""
    b = rho0 * c0 ** 2 / gamma
    return rho0 * (1.0 + rho0 * g * (surface - np.asarray(y)) / b) ** (1.0 / gamma)


def box_2d(width: float, height: float) -> np.ndarray:
    """The rectangle [0, width] x [0, height] as a polygon (a container for ``WCSPHSolver(containers=...)``)."""
    return np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])


def box_walls_2d(width: float, height: float, dx: float, layers: int) -> np.ndarray:
    """Boundary particles in ``layers`` layers outside the rectangle [0, width] x [0, height], layer k at
    (k + 1/2) dx from its sides (:func:`warpfree.surface_layers.surface_layers`)."""
    from warpfree.surface_layers import surface_layers

    return surface_layers(box_2d(width, height), dx, layers, "outside")


def front_position(solver, t: float) -> float:
    """Surge front: the largest x of any fluid particle (m)."""
    return float(solver.fluid_positions()[:, 0].max())


def walls_from_section(mesh, plane_origin, plane_normal, dx: float, layers: int) -> tuple[np.ndarray, list]:
    """2D boundary particles from the cross-section of a 3D container mesh (a path or trimesh mesh).

    The section's polygons (see :func:`warpfree.geometry.mesh_section` for the in-plane axes) get ``layers``
    layers outside them along their true edges (:func:`warpfree.surface_layers.surface_layers`, any
    orientation). Returns (walls (N, 2), the polygons) — the polygons are the containers to check the fluid
    against and to fill (``fill_polygon(..., clearance=dx/2)``).
    """
    from warpfree.geometry import load_mesh, mesh_section
    from warpfree.surface_layers import surface_layers

    polygons = mesh_section(load_mesh(mesh), plane_origin, plane_normal)
    if not polygons:
        raise ParameterError("plane_origin", "the plane does not cut the mesh")
    return np.vstack([surface_layers(p, dx, layers, "outside") for p in polygons]), polygons


def clear_of(points: np.ndarray, solid, clearance: float) -> np.ndarray:
    """The points at least ``clearance`` (m) outside ``solid`` (a watertight trimesh mesh or a 2D polygon):
    fluid filled around an obstacle, measured against its true surface on the device."""
    from warpfree.device import current_launcher
    from warpfree.solids import Solids

    dim = 3 if not isinstance(solid, np.ndarray) else 2
    p3 = points if points.shape[1] == 3 else np.column_stack([points, np.zeros(len(points))])
    signed = Solids(current_launcher(), dim, containers=[solid]).signed_distance(p3)
    return points[signed >= clearance * (1.0 - 1e-6)]
