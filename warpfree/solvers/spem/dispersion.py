"""Numerical dispersion of SPEM's staggered leapfrog on the uniform 2D layouts, and the phase lag it gives a wave.

On the uniform layout the conservative pair reaches only the nearest particles of the other set (support 1.1 Δ), so
the scheme is a finite-difference one whose plane waves e^{i(k̃·x - ωt)} obey, with S = c Δt/Δ (the Courant number),
a = k̃_x Δ/2 and b = k̃_y Δ/2:

    Yee's staggering (``h_staggering="edges"``):  sin²(ωΔt/2) / S² = sin² a + sin² b
    H at the cell centres (``"centres"``):        sin²(ωΔt/2) / S² = sin² a cos² b + cos² a sin² b

(the first is Yee's relation, Taflove & Hagness, *Computational Electrodynamics*, 3rd ed., ch. 4; the second is
the same scheme with each difference averaged over the cell's two sides, the four corners' rows being
g = (x_j - x_i)/Δ²). The numerical wave is slower than c: k̃ > k = ω/c, so after a distance L it lags the exact
wave by δφ = (k̃ - k) L, and the largest difference between the two, for amplitude A, is 2A sin(δφ/2) ≈ A δφ.
Both relations are second order: k̃/k - 1 ∝ (kΔ)². Float64, NumPy; angles in degrees from +y towards +x (the
plane-wave scene's convention).
"""

from __future__ import annotations

import math

from warpfree.errors import ParameterError

__all__ = ["wavenumber_ratio", "phase_lag", "largest_lag_error"]


def _symbol(h_staggering: str):
    if h_staggering == "edges":
        return lambda a, b: math.sin(a) ** 2 + math.sin(b) ** 2
    if h_staggering == "centres":
        return lambda a, b: (math.sin(a) * math.cos(b)) ** 2 + (math.cos(a) * math.sin(b)) ** 2
    raise ParameterError("h_staggering", f"must be 'edges' or 'centres', got {h_staggering!r}")


def wavenumber_ratio(particles_per_wavelength: float, courant_number: float, angle: float = 0.0,
                     h_staggering: str = "edges") -> float:
    """k̃/k of the uniform layout's plane wave travelling at ``angle`` degrees from +y, at λ/Δ =
    ``particles_per_wavelength`` and S = c Δt/Δ = ``courant_number`` (the relations in the module docstring, solved
    for |k̃| by bisection to 1e-15)."""
    n, s = float(particles_per_wavelength), float(courant_number)
    if not (math.isfinite(n) and n > 2.0):
        raise ParameterError("particles_per_wavelength", f"must be > 2 (a resolved wave), got {n}")
    if not (math.isfinite(s) and 0.0 < s <= 1.0):
        raise ParameterError("courant_number", f"c Δt/Δ must be in (0, 1], got {s}")
    symbol = _symbol(h_staggering)
    theta = math.radians(angle)
    target = (math.sin(math.pi * s / n) / s) ** 2
    k = 2.0 * math.pi / n  # k Δ

    def residual(ratio):
        kd = ratio * k
        return symbol(0.5 * kd * math.sin(theta), 0.5 * kd * math.cos(theta)) - target

    lo, hi = 0.5, 2.0
    if residual(lo) > 0.0 or residual(hi) < 0.0:
        raise ParameterError("courant_number", f"no propagating wave at λ/Δ = {n:g}, S = {s:g}, {angle:g}°")
    while hi - lo > 1e-15:
        mid = 0.5 * (lo + hi)
        if residual(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def phase_lag(distance_in_wavelengths: float, particles_per_wavelength: float, courant_number: float,
              angle: float = 0.0, h_staggering: str = "edges") -> float:
    """δφ = 2π (k̃/k - 1) L/λ (rad): how far the numerical wave falls behind the exact one over L."""
    return 2.0 * math.pi * (wavenumber_ratio(particles_per_wavelength, courant_number, angle, h_staggering) - 1.0) \
        * float(distance_in_wavelengths)


def largest_lag_error(distance_in_wavelengths: float, particles_per_wavelength: float, courant_number: float,
                      angle: float = 0.0, h_staggering: str = "edges") -> float:
    """max_t |sin(ωt - δφ) - sin(ωt)| = 2 sin(|δφ|/2): the largest error of a unit wave lagging by δφ over L."""
    lag = phase_lag(distance_in_wavelengths, particles_per_wavelength, courant_number, angle, h_staggering)
    return 2.0 * math.sin(min(0.5 * abs(lag), 0.5 * math.pi))
