"""Cold plasma oscillation: the leapfrog's discrete frequency (no data files, see ``README.md``).

Cold electrons on an immobile neutralising background, displaced by δ sin(kx), oscillate at ω_p for every k (the
cold plasma's Langmuir oscillation has no dispersion). The leapfrog (x^{n+1} - 2x^n + x^{n-1} = -ω_p² Δt² x^n) turns
that into

    ω_Δt = (2/Δt) asin(ω_p Δt / 2)        (Birdsall & Langdon, Plasma Physics via Computer Simulation, §4-4)

which the scene compares with (the target: within 1 %). Normalised units: ω_p = 1 for n_ref.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["leapfrog_frequency", "frequency_from_crossings"]


def leapfrog_frequency(omega_p: float, dt: float) -> float:
    """(2/Δt) asin(ω_p Δt / 2): the frequency at which the leapfrog rotates a harmonic oscillator of ω_p."""
    if not 0.0 < omega_p * dt < 2.0:
        raise ValueError(f"ω_p Δt must be in (0, 2), got {omega_p * dt}")
    return 2.0 / dt * math.asin(0.5 * omega_p * dt)


def frequency_from_crossings(time, signal) -> float:
    """Angular frequency from the mean spacing of the zero crossings of ``signal`` (linear interpolation between
    samples): ω = π / mean half-period. Needs at least two crossings."""
    t = np.asarray(time, np.float64)
    s = np.asarray(signal, np.float64)
    z = np.flatnonzero(np.sign(s[:-1]) * np.sign(s[1:]) < 0)
    if z.size < 2:
        raise ValueError(f"need at least two zero crossings, found {z.size}: run longer")
    crossing = t[z] - s[z] * (t[z + 1] - t[z]) / (s[z + 1] - s[z])
    return math.pi * (crossing.size - 1) / (crossing[-1] - crossing[0])
