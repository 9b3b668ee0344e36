"""Transient plane Poiseuille flow driven by a body force (Morris, Fox & Zhu 1997): the series solution
(no data files; see ``README.md`` in this folder).

Fluid at rest at t = 0 between two no-slip plates at y = 0 and y = L, driven by a uniform body force
(acceleration) F along x, kinematic viscosity ν:

    u(y, t) = F/(2ν) y (L − y)
              − Σ_{n≥0} 4 F L² / (ν π³ (2n+1)³) sin(π y (2n+1)/L) exp(−(2n+1)² π² ν t / L²)

The steady profile is F/(2ν) y (L − y), with the centre-line velocity F L²/(8ν). The functions take
NumPy arrays (float64) and broadcast.
"""

from __future__ import annotations

import numpy as np

__all__ = ["velocity", "steady_velocity", "centre_velocity", "slowest_time_scale", "TERMS"]

#: terms of the series; at t = 0 the truncation error is below 1e-7 of the centre velocity, later far less
TERMS = 200


def steady_velocity(y, force: float, nu: float, length: float) -> np.ndarray:
    """F/(2ν) y (L − y) (m/s)."""
    y = np.asarray(y, dtype=np.float64)
    return force / (2.0 * nu) * y * (length - y)


def centre_velocity(force: float, nu: float, length: float) -> float:
    """The steady centre-line velocity F L²/(8ν) (m/s)."""
    return force * length ** 2 / (8.0 * nu)


def velocity(y, t, force: float, nu: float, length: float, terms: int = TERMS) -> np.ndarray:
    """u(y, t) of the series (m/s) at the heights y (m, 0 ≤ y ≤ L) and time t (s, a scalar)."""
    y = np.asarray(y, dtype=np.float64)
    t = float(t)
    m = 2.0 * np.arange(terms, dtype=np.float64) + 1.0
    amp = 4.0 * force * length ** 2 / (nu * np.pi ** 3 * m ** 3) * np.exp(-(m * np.pi / length) ** 2 * nu * t)
    keep = amp > 1e-17 * amp[0] * np.exp((np.pi / length) ** 2 * nu * t)  # terms below 1e-17 of the first one at t = 0
    modes = np.sin(np.pi * y[..., None] * m[keep] / length)
    return steady_velocity(y, force, nu, length) - modes @ amp[keep]


def slowest_time_scale(nu: float, length: float) -> float:
    """L²/(π² ν): the e-folding time of the slowest transient mode (s)."""
    return length ** 2 / (np.pi ** 2 * nu)
