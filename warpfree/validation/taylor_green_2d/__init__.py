"""Taylor–Green vortex in a doubly periodic square: the exact solution of the incompressible
Navier–Stokes equations (no data files; see ``README.md`` in this folder).

On the square [0, L)², k = 2π/L, kinematic viscosity ν, velocity scale U, density ρ0:

    u(x, y, t) = −U e^{−2νk²t} cos(kx) sin(ky)
    v(x, y, t) =  U e^{−2νk²t} sin(kx) cos(ky)
    p(x, y, t) = −(ρ0 U²/4) e^{−4νk²t} [cos(2kx) + cos(2ky)]

The kinetic energy (per unit depth) is E(t) = ρ0 U² L²/4 · e^{−4νk²t}. The functions take NumPy
arrays (float64 recommended) and broadcast.
"""

from __future__ import annotations

import numpy as np

__all__ = ["wavenumber", "decay_rate", "velocity", "pressure", "kinetic_energy", "energy_ratio",
           "time_for_energy_ratio", "inverse_tait_density"]


def wavenumber(length: float) -> float:
    """k = 2π/L (1/m)."""
    return 2.0 * np.pi / length


def decay_rate(nu: float, length: float) -> float:
    """b = 2νk²: the velocity decays as e^{−bt}, the kinetic energy as e^{−2bt} (1/s)."""
    return 2.0 * nu * wavenumber(length) ** 2


def velocity(x, y, t, u0: float, nu: float, length: float) -> np.ndarray:
    """(…, 2) exact velocity (m/s) at the points (x, y) and time t."""
    k = wavenumber(length)
    a = u0 * np.exp(-decay_rate(nu, length) * np.asarray(t, dtype=np.float64))
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    return np.stack([-a * np.cos(k * x) * np.sin(k * y), a * np.sin(k * x) * np.cos(k * y)], axis=-1)


def pressure(x, y, t, u0: float, nu: float, length: float, rho0: float) -> np.ndarray:
    """Exact pressure (Pa), zero mean: −(ρ0 U²/4) e^{−4νk²t} [cos 2kx + cos 2ky]."""
    k = wavenumber(length)
    a2 = u0 ** 2 * np.exp(-2.0 * decay_rate(nu, length) * np.asarray(t, dtype=np.float64))
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    return -0.25 * rho0 * a2 * (np.cos(2.0 * k * x) + np.cos(2.0 * k * y))


def kinetic_energy(t, u0: float, nu: float, length: float, rho0: float) -> np.ndarray:
    """Exact kinetic energy per unit depth (J/m): ρ0 U² L²/4 · e^{−4νk²t}."""
    return 0.25 * rho0 * u0 ** 2 * length ** 2 * energy_ratio(t, nu, length)


def energy_ratio(t, nu: float, length: float) -> np.ndarray:
    """E(t)/E(0) = e^{−4νk²t}."""
    return np.exp(-2.0 * decay_rate(nu, length) * np.asarray(t, dtype=np.float64))


def time_for_energy_ratio(ratio: float, nu: float, length: float) -> float:
    """The time at which E(t)/E(0) = ratio (s): −ln(ratio)/(4νk²)."""
    return float(-np.log(ratio) / (2.0 * decay_rate(nu, length)))


def inverse_tait_density(p, rho0: float, c0: float, gamma: float = 7.0) -> np.ndarray:
    """ρ = ρ0 (1 + p/B)^{1/γ}, B = ρ0 c0²/γ: the density whose Tait pressure is p (kg/m³)."""
    b = rho0 * c0 ** 2 / gamma
    return rho0 * (1.0 + np.asarray(p, dtype=np.float64) / b) ** (1.0 / gamma)
