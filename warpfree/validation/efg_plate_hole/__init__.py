"""A plate with an elliptical hole under remote tension: the exact stresses of the infinite plate (Muskhelishvili's
complex potentials; no data files, see ``README.md``).

The hole x²/a² + y²/b² = 1 is traction-free and the stress far away is a uniaxial tension ``p`` along the x axis.
With the exterior of the unit circle mapped onto the plate's, z = ω(ζ) = R (ζ + m/ζ), R = (a + b)/2,
m = (a - b)/(a + b) (Muskhelishvili 1953, §81):

    φ(ζ) = (p R / 4) (ζ + (2 - m)/ζ),
    ψ(ζ) = -(p R / 2) (ζ + (ζ² (1 + m² - m) - 1) / (ζ (ζ² - m))),

and the stresses (Kolosov) σ_xx + σ_yy = 4 Re Φ, σ_yy - σ_xx + 2i σ_xy = 2 (z̄ Φ'(z) + Ψ), Φ = φ'(z), Ψ = ψ'(z).
At the hole's tip on the y axis σ_xx = p (1 + 2 b/a) (Inglis 1913). Plane stress or strain alike (the stresses do
not depend on the elastic constants). Any part of the plate with these stresses as tractions on its outer sides has
them as its exact solution: the scenes and tests load a quarter plate so (symmetry on the axes).
"""

from __future__ import annotations

import numpy as np

__all__ = ["stresses", "tip_stress"]


def _zeta(z: np.ndarray, radius: float, m: float) -> np.ndarray:
    """ζ outside the unit circle with ω(ζ) = z (the root of ζ² - (z/R) ζ + m = 0 of the larger modulus)."""
    w = z / radius
    root = np.sqrt(w * w - 4.0 * m + 0j)
    zeta = 0.5 * (w + root)
    other = 0.5 * (w - root)
    return np.where(np.abs(zeta) >= np.abs(other), zeta, other)


def stresses(points, a: float, b: float, p: float = 1.0) -> np.ndarray:
    """(n, 3) σ_xx, σ_yy, σ_xy at ``points`` (n, 2) outside the hole (semi-axes ``a`` along x, ``b`` along y), for a
    remote tension ``p`` along x (the stresses in p's units)."""
    x = np.asarray(points, dtype=np.float64)
    z = x[:, 0] + 1j * x[:, 1]
    radius, m = 0.5 * (a + b), (a - b) / (a + b)
    zeta = _zeta(z, radius, m)
    q = 0.25 * p * radius
    d_omega = radius * (1.0 - m / zeta ** 2)
    dd_omega = 2.0 * radius * m / zeta ** 3
    d_phi = q * (1.0 - (2.0 - m) / zeta ** 2)
    dd_phi = 2.0 * q * (2.0 - m) / zeta ** 3
    big_phi = d_phi / d_omega
    d_big_phi = (dd_phi * d_omega - d_phi * dd_omega) / d_omega ** 2 / d_omega   # dΦ/dz
    a2, den = 1.0 + m * m - m, zeta ** 3 - m * zeta
    d_fraction = (2.0 * a2 * zeta * den - (a2 * zeta ** 2 - 1.0) * (3.0 * zeta ** 2 - m)) / den ** 2
    big_psi = -2.0 * q * (1.0 + d_fraction) / d_omega
    trace = 4.0 * big_phi.real
    deviator = 2.0 * (np.conj(z) * d_big_phi + big_psi)
    sxx = 0.5 * (trace - deviator.real)
    syy = 0.5 * (trace + deviator.real)
    return np.stack([sxx, syy, 0.5 * deviator.imag], axis=1)


def tip_stress(a: float, b: float, p: float = 1.0) -> float:
    """σ_xx at the hole's tip (0, b): p (1 + 2 b/a) (Inglis 1913)."""
    return p * (1.0 + 2.0 * b / a)
