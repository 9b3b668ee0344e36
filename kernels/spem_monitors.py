"""SPEM's monitors on the device: running discrete Fourier transforms of a field at monitored particles
(``warpfree/solvers/spem/monitors.py``), a module of their own so that a scene without monitors never compiles it.

Precision: the field is float32 (the state's), the sums float64 (thousands of steps of phases up to ~10³ rad).
"""

import warp as wp

from .clock import STEP, TIME


@wp.kernel
def accumulate_dft(
    first: int,
    particles: wp.array(dtype=wp.int32),
    field: wp.array(dtype=float),
    clock: wp.array(dtype=wp.float64),
    offset: wp.float64,
    start: wp.float64,
    frequencies: wp.array(dtype=wp.float64),
    real: wp.array2d(dtype=wp.float64),
    imag: wp.array2d(dtype=wp.float64),
):
    """Running DFT F(f) += u(t) e^{-2πi f t} Δt of ``field`` at monitored particles (item ``first + tid`` = particle s ×
    frequency q), the sample's time t = t^n + ``offset`` Δt (Ez after the E phase: offset ½; H after the H phase: 1),
    each sample standing for the step [t - Δt/2, t + Δt/2] (the midpoint rule), counted once that interval starts at
    ``start`` (s) or later: over whole periods the samples of both fields then cover exactly the window. float64 sums
    (thousands of steps), race-free: each item its own slot."""
    item = first + wp.tid()
    count = frequencies.shape[0]
    s = item / count
    q = item - s * count
    dt = clock[STEP]
    t = clock[TIME] + offset * dt
    if t - wp.float64(0.5) * dt < start - wp.float64(1.0e-6) * dt:
        return
    v = wp.float64(field[particles[s]]) * dt
    phase = wp.float64(6.283185307179586) * frequencies[q] * t
    real[s, q] = real[s, q] + v * wp.cos(phase)
    imag[s, q] = imag[s, q] - v * wp.sin(phase)
