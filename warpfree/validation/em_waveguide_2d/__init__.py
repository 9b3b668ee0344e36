"""TM1 wave in a parallel-plate waveguide driven from its end (Mendes 2010, §4.4): the exact field of the signalling
problem, evaluated by Fourier transform (no data files, see ``README.md``).

Plates (PEC) at x = 0 and x = a, propagation along +y. A source imposing Ez(x, 0, t) = E0 sin(πx/a) s(t) (s = 0
for t < 0) excites the TM1 mode alone: Ez = E0 sin(πx/a) u(y, t) with u_tt = c² (u_yy - k_c² u), k_c = π/a,
u(0, t) = s(t), outgoing. Its exact solution is

    u(y, t) = (1/2π) ∫ S(ω) exp(i(ω t - β(ω) y)) dω,   β = sign(ω) sqrt(ω² - ω_c²)/c  (|ω| > ω_c),
                                                      β = -i sqrt(ω_c² - ω²)/c       (|ω| < ω_c, evanescent),

S the Fourier transform of s, ω_c = c k_c. :func:`tm1_field` evaluates it with an FFT over a window many times
longer than the times asked for (the response to s is causal; the window's wrap-around is the only
approximation, checked against the closed form of the steady state in the tests). Units SI.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["tm1_field", "cutoff_frequency"]

C0 = 299_792_458.0


def cutoff_frequency(a: float) -> float:
    """f_c = c/(2a) (Hz) of the TM1 mode between plates a apart."""
    return C0 / (2.0 * a)


def tm1_field(y, t: float, a: float, source: Callable[[float], float], frequency: float,
              window_periods: int = 4096, samples_per_period: int = 512) -> np.ndarray:
    """u(y, t) for the source signal ``source(t)`` (zero before 0) of carrier ``frequency`` (Hz): Ez/(E0 sin(πx/a))."""
    y = np.atleast_1d(np.asarray(y, np.float64))
    k = max(1, int(math.ceil(t * frequency * samples_per_period)))
    dt = t / k  # t falls on a sample
    n = max(int(window_periods * samples_per_period), 4 * k)
    times = np.arange(n) * dt
    # the field at t depends on s up to t only: s is continued for 8 periods past t, then tapered (cos², 8 periods)
    # to zero, so that the transform sees no jump (a jump at t would ring before t in the sampled spectrum)
    end = min(n, k + 16 * samples_per_period)
    signal = np.zeros(n)
    signal[:end] = [source(s) for s in times[:end]]
    tail = np.arange(k + 8 * samples_per_period, end)
    signal[tail] *= np.cos(0.5 * np.pi * (tail - tail[0]) / max(1, tail.size)) ** 2
    spectrum = np.fft.rfft(signal)
    omega = 2.0 * np.pi * np.fft.rfftfreq(n, dt)
    wc = C0 * math.pi / a
    beta = np.where(omega > wc, np.sqrt(np.maximum(omega**2 - wc**2, 0.0)), -1j * np.sqrt(np.maximum(wc**2 - omega**2, 0.0))) / C0
    phase = np.exp(1j * omega * k * dt) / n  # the inverse transform at the one time asked for
    weight = np.where((np.arange(omega.size) == 0) | ((n % 2 == 0) & (np.arange(omega.size) == omega.size - 1)), 1.0, 2.0)
    return np.array([float(np.real(np.sum(weight * spectrum * np.exp(-1j * beta * yy) * phase))) for yy in y])
