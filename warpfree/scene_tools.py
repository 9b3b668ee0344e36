"""Helpers shared by the scene scripts: hydrostatic initial density, box walls, front probes."""

from __future__ import annotations

import numpy as np

from .geometry import box_mesh, fill_mesh, lattice_box, polygon_boundary_layers, shell_lattice


def hydrostatic_density(y: np.ndarray, surface: float, rho0: float, c0: float, g: float,
                        gamma: float = 7.0) -> np.ndarray:
    """ρ(y) = ρ0 [1 + ρ0 g (surface - y)/B]^(1/γ), B = ρ0 c0²/γ: the Tait EOS inverted for p = ρ0 g depth."""
    b = rho0 * c0 ** 2 / gamma
    return rho0 * (1.0 + rho0 * g * (surface - np.asarray(y)) / b) ** (1.0 / gamma)


def box_walls_2d(width: float, height: float, dx: float, layers: int) -> np.ndarray:
    """Boundary particles outside the rectangle [0, width] x [0, height], aligned with the fluid lattice."""
    square = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    return polygon_boundary_layers(square, dx, layers, "outside", origin=(0.0, 0.0))


def front_position(solver, t: float) -> float:
    """Surge front: the largest x of any fluid particle (m)."""
    return float(solver.fluid_positions()[:, 0].max())
