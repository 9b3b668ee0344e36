"""Wave makers against linear theory: the dispersion relation and Biesel's transfer functions.

A paddle oscillating at angular frequency ω in water of depth d makes a progressive wave of wavenumber k, the real
root of the linear dispersion relation (Airy)

    ω² = g k tanh(kd),

and, away from the paddle (its evanescent modes decay as e^{-k_n x} with k_n d > π: within about two depths), of
height H for a stroke S (the paddle's full excursion at the still water level) given by Biesel's transfer functions
(Biesel & Suquet 1951; Dean & Dalrymple 1991, §6.2, eqs 6.15-6.16):

- piston:                 H/S = 2 (cosh 2kd - 1)/(sinh 2kd + 2kd)
- flap hinged at the bed: H/S = 4 (sinh kd/kd) (kd sinh kd - cosh kd + 1)/(sinh 2kd + 2kd)

Energy travels at the group velocity c_g = (ω/2k)(1 + 2kd/sinh 2kd): a flume of length L_f returns the front's
reflection to a gauge at x after (2 L_f - x)/c_g.

The scene measures each gauge's first harmonic by a least-squares fit of a + b cos ωt + c sin ωt (+ the second
harmonic) over a window of whole periods where the waves are steady and no reflection has come back
(:func:`harmonics`): the height H = 2 sqrt(b² + c²) and the phase φ; the wavenumber is the slope -dφ/dx of the
phases along the gauges, and the height the paddle makes the gauges' heights fitted by H0 e^(-κx) at the paddle
(:func:`wave_checks`): a wave losing height as it travels (the fluid's dissipation) is told from the paddle's
transfer function. Both are the linear (first-harmonic) quantities the theory gives, so
a second harmonic bound to a steeper wave does not enter them.

README.md beside this file gives the sources.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from warpfree.validation import tolerance_check

__all__ = ["CASE", "PADDLES", "wavenumber", "transfer_function", "group_velocity", "harmonics", "height_decay",
           "wave_checks",
           "HEIGHT_TOLERANCE", "WAVELENGTH_TOLERANCE", "plot_waves"]

CASE = "wave_flume_2d"
#: the paddles whose transfer function is known
PADDLES = ("piston", "flap")

#: the largest difference of the height the paddle makes (the gauges' fit at the paddle) from Biesel's, as a fraction
HEIGHT_TOLERANCE = 0.05
#: the largest difference of the wavelength from the dispersion relation's, as a fraction of it
WAVELENGTH_TOLERANCE = 0.02

SOURCE = ("Biesel & Suquet 1951 (La Houille Blanche 6, 147-165); Dean & Dalrymple 1991, Water Wave Mechanics for "
          "Engineers and Scientists, sections 4.3 and 6.2; warpfree/validation/wave_flume_2d/README.md")


def wavenumber(omega: float, depth: float, g: float = 9.81) -> float:
    """k (1/m) with ω² = g k tanh(kd): the real root, bracketed between the shallow- and deep-water values."""
    lo = omega ** 2 / g  # deep water: k0 = ω²/g <= k
    hi = max(lo, omega / np.sqrt(g * depth)) * 2.0 + 1.0 / depth  # shallow water k = ω/sqrt(gd) >= k
    return float(brentq(lambda k: g * k * np.tanh(k * depth) - omega ** 2, lo * (1.0 - 1e-12), hi, xtol=1e-14,
                        rtol=1e-14))


def transfer_function(paddle: str, kd: float) -> float:
    """Biesel's H/S for a ``paddle`` ("piston" or "flap", hinged at the bed) at kd."""
    if paddle == "piston":
        return float(2.0 * (np.cosh(2 * kd) - 1.0) / (np.sinh(2 * kd) + 2 * kd))
    if paddle == "flap":
        return float(4.0 * np.sinh(kd) / kd * (kd * np.sinh(kd) - np.cosh(kd) + 1.0) / (np.sinh(2 * kd) + 2 * kd))
    raise ValueError(f"paddle must be one of {PADDLES}, got {paddle!r}")


def group_velocity(omega: float, k: float, depth: float) -> float:
    """c_g = (ω/2k)(1 + 2kd/sinh 2kd) (m/s)."""
    return float(0.5 * omega / k * (1.0 + 2 * k * depth / np.sinh(2 * k * depth)))


def harmonics(t: np.ndarray, elevation: np.ndarray, omega: float, window: tuple[float, float]) -> dict:
    """The first harmonic of each column of ``elevation`` ((samples, gauges), m) over the whole periods of ``window``
    (s) from its start: least squares for a + b cos ωt + c sin ωt + b2 cos 2ωt + c2 sin 2ωt. Returns ``height``
    (2 sqrt(b² + c²), m), ``phase`` (atan2(c, b), rad, unwrapped along the gauges), ``second`` (the second harmonic's
    height, m), ``periods`` (whole periods fitted) and ``samples``."""
    t = np.asarray(t, dtype=np.float64)
    elevation = np.asarray(elevation, dtype=np.float64).reshape(len(t), -1)
    period = 2.0 * np.pi / omega
    periods = max(0, int(np.floor((window[1] - window[0]) / period + 1e-9)))
    inside = (t >= window[0]) & (t <= window[0] + periods * period)
    if periods < 1 or inside.sum() < 8:
        return {"height": np.full(elevation.shape[1], np.nan), "phase": np.full(elevation.shape[1], np.nan),
                "second": np.full(elevation.shape[1], np.nan), "periods": periods, "samples": int(inside.sum())}
    ti = t[inside]
    basis = np.column_stack([np.ones_like(ti), np.cos(omega * ti), np.sin(omega * ti), np.cos(2 * omega * ti),
                             np.sin(2 * omega * ti)])
    coef, *_ = np.linalg.lstsq(basis, elevation[inside], rcond=None)
    return {"height": 2.0 * np.hypot(coef[1], coef[2]), "phase": np.unwrap(np.arctan2(coef[2], coef[1])),
            "second": 2.0 * np.hypot(coef[3], coef[4]), "periods": periods, "samples": int(inside.sum())}


def height_decay(x: np.ndarray, heights: np.ndarray) -> tuple[float, float]:
    """(H0, κ): the least-squares fit of log H = log H0 - κ x over the gauges at ``x`` (m): the height at x = 0 (m)
    and the decay rate (1/m)."""
    x, heights = np.asarray(x, float), np.asarray(heights, float)
    if len(x) < 2:
        return float(heights[0]), 0.0
    slope, log_h0 = np.polyfit(x, np.log(heights), 1)
    return float(np.exp(log_h0)), float(-slope)


def wave_checks(x: np.ndarray, fit: dict, paddle: str, stroke: float, omega: float, depth: float,
                g: float = 9.81, basis: str = "") -> dict:
    """The measured waves against linear theory. The height the paddle makes is the gauges' heights fitted by
    H(x) = H0 e^(-κx) (least squares on log H) at x = 0, against Biesel's (``generated_height``,
    ``generated_error``): the waves' loss of height as they travel (κ, ``loss_per_wavelength`` = 1 - e^(-κL)), which
    linear theory does not have, is the fluid's, reported beside it, and each gauge's height against Biesel's
    (``height_ratio``, the largest difference ``height_error``). The wavelength from the phases' slope against the
    dispersion relation's (``wavelength``, ``wavelength_error``). Checks: the generated height within
    :data:`HEIGHT_TOLERANCE`, the wavelength within :data:`WAVELENGTH_TOLERANCE`."""
    x = np.asarray(x, float)
    k = wavenumber(omega, depth, g)
    height_theory = transfer_function(paddle, k * depth) * stroke
    heights = np.asarray(fit["height"], float)
    ratio = heights / height_theory
    slope = np.polyfit(x, np.asarray(fit["phase"]), 1)[0] if len(x) > 1 else np.nan
    wavelength = 2.0 * np.pi / abs(slope) if np.isfinite(slope) and slope != 0 else np.nan
    wavelength_theory = 2.0 * np.pi / k
    generated, decay_rate = height_decay(x, heights)
    generated_error = float(abs(generated / height_theory - 1.0))
    wavelength_error = float(abs(wavelength / wavelength_theory - 1.0))
    return {"kd": k * depth, "wavelength_theory": wavelength_theory, "height_theory": height_theory,
            "transfer_function": transfer_function(paddle, k * depth), "height": heights.tolist(),
            "height_ratio": ratio.tolist(), "height_error": float(np.max(np.abs(ratio - 1.0))),
            "generated_height": generated, "generated_error": generated_error, "decay_rate": decay_rate,
            "loss_per_wavelength": float(1.0 - np.exp(-decay_rate * wavelength_theory)),
            "wavelength": float(wavelength), "wavelength_error": wavelength_error,
            "checks": {
                "generated_height": tolerance_check(
                    generated_error, HEIGHT_TOLERANCE, SOURCE,
                    basis=f"5 % of Biesel's {paddle} height, the gauges' heights fitted by H0 e^(-kx) at the paddle, "
                          f"{basis}"),
                "wavelength": tolerance_check(wavelength_error, WAVELENGTH_TOLERANCE, SOURCE,
                                              basis=f"2 % of the dispersion relation's wavelength, {basis}")}}


def plot_waves(path: str, t: np.ndarray, elevation: np.ndarray, x: np.ndarray, result: dict, window, label: str):
    """The elevation at the first and last gauges in time (the fitted window shaded), and the heights along the
    flume against Biesel's."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(10.5, 4.2)
    a1, a2 = fig.subplots(1, 2)
    for j, style in ((0, "-"), (len(x) - 1, "--")):
        a1.plot(t, elevation[:, j] - np.mean(elevation[:, j]), style, lw=1.0, label=f"gauge at x = {x[j]:.3g} m")
    a1.axvspan(window[0], window[1], color="0.9", zorder=0, label="fitted window")
    a1.set_xlabel("t (s)")
    a1.set_ylabel("elevation (m)")
    a2.plot(x, result["height"], "o", ms=4, label=label)
    xs = np.linspace(0.0, float(np.max(x)), 50)
    a2.plot(xs, result["generated_height"] * np.exp(-result["decay_rate"] * xs), "-", lw=1.0,
            label=f"H0 e^(-κx): H0 {100 * (result['generated_height'] / result['height_theory'] - 1):+.2f} %, "
                  f"{100 * result['loss_per_wavelength']:.1f} % lost a wavelength")
    a2.axhline(result["height_theory"], color="k", lw=1.0, label="Biesel (linear theory)")
    for f in (1 - HEIGHT_TOLERANCE, 1 + HEIGHT_TOLERANCE):
        a2.axhline(f * result["height_theory"], color="k", lw=0.6, ls=":")
    a2.set_xlabel("gauge x (m)")
    a2.set_ylabel("wave height H (m)")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"Wave maker: height made {100 * result['generated_error']:.2f} % from Biesel's, wavelength "
                 f"{result['wavelength']:.4g} m ({100 * result['wavelength_error']:.2f} % from the dispersion "
                 f"relation's {result['wavelength_theory']:.4g} m)", fontsize=10)
    save_figure(fig, path)
