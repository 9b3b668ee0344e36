"""A standing wave in a rectangular tank: linear water-wave theory (Lamb 1932, §227-228; no data files, see
``README.md`` in this folder).

Water of depth d in a tank of length L (walls at x = 0 and x = L), a standing wave of mode n (k = nπ/L) and
amplitude A ≪ d, started at the phase where the surface is flat and the water moves fastest:

    η(x, t) = A cos(kx) sin(ωt),   ω² = g k tanh(k d)
    φ(x, y, t) = (A ω / k) cos(kx) cosh(k y)/sinh(k d) cos(ωt)        (y: height above the bottom)
    u = ∂φ/∂x = -A ω sin(kx) cosh(k y)/sinh(k d),  v = ∂φ/∂y = A ω cos(kx) sinh(k y)/sinh(k d)  at t = 0

The horizontal centre of mass of the water follows the wave: for mode 1,
x_cm - L/2 = (1/(L d)) ∫_0^L (x - L/2) η dx = -(2 A L)/(π² d) sin(ωt), which the whole particle set measures.
The functions take NumPy arrays (float64) and broadcast. Units SI.
"""

from __future__ import annotations

import numpy as np

__all__ = ["frequency", "initial_velocity", "centre_of_mass_amplitude", "fit_damped_oscillation"]


def frequency(g: float, length: float, depth: float, mode: int = 1) -> float:
    """ω = sqrt(g k tanh(k d)), k = mode π/L (rad/s): linear theory for a standing wave in a tank."""
    k = mode * np.pi / length
    return float(np.sqrt(g * k * np.tanh(k * depth)))


def initial_velocity(x, y, amplitude: float, g: float, length: float, depth: float, mode: int = 1) -> np.ndarray:
    """(N, 2) velocity (m/s) of the standing wave η = A cos(kx) sin(ωt) at t = 0, at x and the height y above the
    bottom (m): the gradient of the potential in the module docstring."""
    k = mode * np.pi / length
    omega = frequency(g, length, depth, mode)
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    scale = amplitude * omega / np.sinh(k * depth)
    return np.stack([-scale * np.sin(k * x) * np.cosh(k * y), scale * np.cos(k * x) * np.sinh(k * y)], axis=-1)


def centre_of_mass_amplitude(amplitude: float, length: float, depth: float) -> float:
    """|x_cm - L/2| at the wave's largest elevation, 2 A L/(π² d) (m), mode 1."""
    return 2.0 * amplitude * length / (np.pi ** 2 * depth)


def fit_damped_oscillation(t, signal, omega_guess: float) -> dict:
    """Least-squares fit of signal(t) = c + B e^(-βt) sin(ωt + ϕ): returns ω (rad/s), β (1/s), B, ϕ, c and the
    rms residual relative to |B|. The start is ``omega_guess`` and the signal's own offset and range."""
    from scipy.optimize import curve_fit

    t = np.asarray(t, np.float64)
    s = np.asarray(signal, np.float64)
    if t.size < 6:
        raise ValueError(f"the fit of 5 parameters needs at least 6 samples, got {t.size}: run longer or output "
                         "more often")

    def model(tt, c, b, beta, omega, phase):
        return c + b * np.exp(-beta * tt) * np.sin(omega * tt + phase)

    b0 = 0.5 * (s.max() - s.min())
    guesses = [(s.mean(), sign * b0, 0.0, omega_guess, 0.0) for sign in (1.0, -1.0)]
    best = None
    for p0 in guesses:
        try:
            p, _ = curve_fit(model, t, s, p0=p0, maxfev=20000)
        except RuntimeError:
            continue
        rms = float(np.sqrt(np.mean((model(t, *p) - s) ** 2)))
        if best is None or rms < best[1]:
            best = (p, rms)
    if best is None:
        raise ValueError("the oscillation fit did not converge")
    (c, b, beta, omega, phase), rms = best
    if b < 0:
        b, phase = -b, phase + np.pi
    return {"omega": float(omega), "beta": float(beta), "amplitude": float(b), "phase": float(phase),
            "offset": float(c), "relative_residual": rms / max(abs(b), 1e-300)}
