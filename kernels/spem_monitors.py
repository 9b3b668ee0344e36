"""SPEM's monitors on the device: running discrete Fourier transforms of a field at monitored particles
(``warpfree/solvers/spem/monitors.py``), a module of their own so that a scene without monitors never compiles it.

Precision: the field is float32 (the state's), the sums float64 (thousands of steps of phases up to ~10³ rad).
"""

import warp as wp

from .clock import STEP, TIME


@wp.func
def window_weight(t: wp.float64, dt: wp.float64, start: wp.float64, stop: wp.float64):
    """The length (s) of the sample's step [t - Δt/2, t + Δt/2] inside [start, stop]: Δt itself when the step lies
    inside (to 1e-6 Δt), else the overlap (0 outside). ``monitors.window_weights`` is the same rule on the host."""
    half = wp.float64(0.5) * dt
    slack = wp.float64(1.0e-6) * dt
    low = t - half
    high = t + half
    if low >= start - slack and high <= stop + slack:
        return dt
    return wp.max(wp.float64(0.0), wp.min(high, stop) - wp.max(low, start))


@wp.kernel
def accumulate_dft(
    first: int,
    particles: wp.array(dtype=wp.int32),
    field: wp.array(dtype=float),
    clock: wp.array(dtype=wp.float64),
    offset: wp.float64,
    start: wp.float64,
    stop: wp.float64,
    frequencies: wp.array(dtype=wp.float64),
    real: wp.array2d(dtype=wp.float64),
    imag: wp.array2d(dtype=wp.float64),
):
    """Running DFT F(f) += u(t) e^{-2πi f t} w of ``field`` at monitored particles (item ``first + tid`` = particle s ×
    frequency q), the sample's time t = t^n + ``offset`` Δt (Ez after the E phase: offset ½; H after the H phase: 1),
    each sample standing for its step [t - Δt/2, t + Δt/2] (the midpoint rule) and w the part of that step inside the
    window [``start``, ``stop``] (s): the samples of both fields cover exactly the window, whether or not its ends
    fall on the steps' (ends within 1e-6 Δt of them taken as on them). float64 sums (thousands of steps), race-free:
    each item its own slot."""
    item = first + wp.tid()
    count = frequencies.shape[0]
    s = item / count
    q = item - s * count
    w = window_weight(clock[TIME] + offset * clock[STEP], clock[STEP], start, stop)
    if w <= wp.float64(0.0):
        return
    t = clock[TIME] + offset * clock[STEP]
    v = wp.float64(field[particles[s]]) * w
    phase = wp.float64(6.283185307179586) * frequencies[q] * t
    real[s, q] = real[s, q] + v * wp.cos(phase)
    imag[s, q] = imag[s, q] - v * wp.sin(phase)
