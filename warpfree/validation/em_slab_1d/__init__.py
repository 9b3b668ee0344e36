"""A lossless dielectric slab at normal incidence: Airy's reflectance, and the spectrum of the Gaussian pulse that
measures it; no data files, see ``README.md``.

Slab of index n = √εr and thickness d in vacuum, r12 = (1 - n)/(1 + n), δ = 2π n d f / c:

    R(f) = 4 r12² sin²δ / ((1 - r12²)² + 4 r12² sin²δ),   T(f) = 1 - R(f)      (Born & Wolf, §7.6.1)

The pulse g(t) = exp(-((t - t0)/τ)²) sin(2π f0 (t - t0)) has the transform G(f) = ∫ g e^{-2πift} dt =
e^{-2πift0} (τ√π / 2i) [e^{-(πτ(f - f0))²} - e^{-(πτ(f + f0))²}]. Units SI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["slab_reflectance", "gaussian_pulse_spectrum"]

C0 = 299_792_458.0


def slab_reflectance(frequency, eps_r: float, thickness: float) -> np.ndarray:
    """R(f) of a lossless slab of relative permittivity ``eps_r`` and ``thickness`` (m) in vacuum at normal incidence."""
    n = math.sqrt(eps_r)
    r12 = (1.0 - n) / (1.0 + n)
    delta = 2.0 * math.pi * n * thickness * np.asarray(frequency, float) / C0
    s = 4.0 * r12 * r12 * np.sin(delta) ** 2
    return s / ((1.0 - r12 * r12) ** 2 + s)


def gaussian_pulse_spectrum(frequency, centre: float, width: float, delay: float | None = None) -> np.ndarray:
    """G(f) (V s/m per V/m of amplitude) of the pulse exp(-((t - t0)/τ)²) sin(2π f0 (t - t0)), τ = ``width``,
    t0 = ``delay`` (default 4 τ)."""
    f = np.asarray(frequency, float)
    t0 = 4.0 * width if delay is None else delay
    a = np.exp(-(math.pi * width * (f - centre)) ** 2) - np.exp(-(math.pi * width * (f + centre)) ** 2)
    return np.exp(-2j * math.pi * f * t0) * (width * math.sqrt(math.pi) / 2j) * a
