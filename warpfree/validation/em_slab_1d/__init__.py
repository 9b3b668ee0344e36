"""A dielectric or dispersive slab at normal incidence: Airy's reflectance and transmittance, and the spectrum of the
Gaussian pulse that measures them; no data files, see ``README.md``.

Slab of index n = √εr and thickness d in vacuum, r12 = (1 - n)/(1 + n), δ = 2π n d f / c:

    R(f) = 4 r12² sin²δ / ((1 - r12²)² + 4 r12² sin²δ),   T(f) = 1 - R(f)      (Born & Wolf, §7.6.1)

The pulse g(t) = exp(-((t - t0)/τ)²) sin(2π f0 (t - t0)) has the transform G(f) = ∫ g e^{-2πift} dt =
e^{-2πift0} (τ√π / 2i) [e^{-(πτ(f - f0))²} - e^{-(πτ(f + f0))²}]. Units SI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["slab_reflectance", "slab_coefficients", "gaussian_pulse_spectrum"]

C0 = 299_792_458.0


def slab_reflectance(frequency, eps_r: float, thickness: float) -> np.ndarray:
    """R(f) of a lossless slab of relative permittivity ``eps_r`` and ``thickness`` (m) in vacuum at normal incidence."""
    n = math.sqrt(eps_r)
    r12 = (1.0 - n) / (1.0 + n)
    delta = 2.0 * math.pi * n * thickness * np.asarray(frequency, float) / C0
    s = 4.0 * r12 * r12 * np.sin(delta) ** 2
    return s / ((1.0 - r12 * r12) ** 2 + s)


def slab_coefficients(frequency, permittivity, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, T) of a slab of complex relative permittivity ``permittivity`` (per frequency, e^{iωt}: Im ε <= 0 for a lossy
    medium) and ``thickness`` (m) in vacuum at normal incidence: n = √ε with Im n <= 0, r12 = (1 - n)/(1 + n),
    P = e^{-i n k0 d}, r = r12 (1 - P²)/(1 - r12² P²), t = (1 - r12²) P/(1 - r12² P²) (the Airy sums of the
    multiple reflections; for a real n, R is :func:`slab_reflectance`)."""
    f = np.asarray(frequency, float)
    n = np.sqrt(np.asarray(permittivity, complex) * np.ones_like(f))
    n = np.where(n.imag > 0, -n, n)  # the branch that decays along the wave
    n = np.where(n.real < 0, -n.conj(), n)
    r12 = (1.0 - n) / (1.0 + n)
    p = np.exp(-1j * n * 2.0 * math.pi * f / C0 * thickness)
    r = r12 * (1.0 - p * p) / (1.0 - r12 * r12 * p * p)
    t = (1.0 - r12 * r12) * p / (1.0 - r12 * r12 * p * p)
    return np.abs(r) ** 2, np.abs(t) ** 2


def gaussian_pulse_spectrum(frequency, centre: float, width: float, delay: float | None = None) -> np.ndarray:
    """G(f) (V s/m per V/m of amplitude) of the pulse exp(-((t - t0)/τ)²) sin(2π f0 (t - t0)), τ = ``width``,
    t0 = ``delay`` (default 4 τ)."""
    f = np.asarray(frequency, float)
    t0 = 4.0 * width if delay is None else delay
    a = np.exp(-(math.pi * width * (f - centre)) ** 2) - np.exp(-(math.pi * width * (f + centre)) ** 2)
    return np.exp(-2j * math.pi * f * t0) * (width * math.sqrt(math.pi) / 2j) * a
