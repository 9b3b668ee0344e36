"""Steady plane Poiseuille flow through an inlet and an outlet: the exact profile and the checks of the scene
``channel_flow_2d`` (no data files; see ``README.md`` in this folder).

Between no-slip plates at y = 0 and y = H, fully developed flow of mean velocity U has

    u(y) = 6U y(H − y)/H²,   u_max = 3U/2,   ΔP = 12 μ U L/H² over a length L.

The functions take NumPy arrays (float64).
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import tolerance_check

__all__ = ["profile", "pressure_drop", "binned_profile", "measured_window", "measured_drop", "channel_checks", "plot_channel",
           "PROFILE_TOLERANCE"]

#: where the profile is measured: from this many widths downstream of the inlet (the flow from a uniform inlet
#: develops the profile within about 0.6 H + 0.05 Re H, its last deviation decaying as e^(-4.2 x/H), the first Stokes
#: eigenvalue of a channel: 2e-4 of the inlet's deficit at 2 H) ...
DEVELOPED = 2.0
#: ... to this many widths before the outlet
OUTLET_CLEARANCE = 1.0

#: the largest bin error of the steady profile, in units of u_max: the goal the open boundaries are built to (1 %)
PROFILE_TOLERANCE = 0.01

SOURCE = ("plane Poiseuille flow, exact for fully developed laminar flow (e.g. White, Viscous Fluid Flow, 3rd ed., "
          "§3-3.3); warpfree/validation/channel_flow_2d/README.md")


def profile(y, mean_velocity: float, width: float) -> np.ndarray:
    """u(y) = 6U y(H − y)/H² (m/s)."""
    y = np.asarray(y, dtype=np.float64)
    return 6.0 * mean_velocity * y * (width - y) / width ** 2


def pressure_drop(mean_velocity: float, mu: float, width: float, length: float) -> float:
    """ΔP = 12 μ U L/H² (Pa) of fully developed flow over ``length``."""
    return 12.0 * mu * mean_velocity * length / width ** 2


def fitted_mean_velocity(y, u, width: float) -> float:
    """The mean velocity U' of the Poiseuille profile 6U' y(H − y)/H² that fits the velocities ``u`` at ``y`` best
    (least squares)."""
    shape = profile(y, 1.0, width)
    return float(np.dot(np.asarray(u, np.float64), shape) / np.dot(shape, shape))


def binned_profile(y, u, edges, mean_velocity: float, width: float):
    """(bin means of u, bin means of the exact profile over the same particles, bin means of y) in the bins
    ``edges`` across the channel."""
    y, u = np.asarray(y, np.float64), np.asarray(u, np.float64)
    bins = len(edges) - 1
    k = np.clip(np.digitize(y, edges) - 1, 0, bins - 1)
    count = np.maximum(np.bincount(k, minlength=bins), 1)
    mean = lambda v: np.bincount(k, weights=v, minlength=bins) / count  # noqa: E731
    return mean(u), mean(profile(y, mean_velocity, width)), mean(y)


def measured_window(length: float, width: float) -> tuple[float, float]:
    """The stretch of the channel (m along x from the inlet) where the profile is measured: from :data:`DEVELOPED`
    widths downstream of the inlet to :data:`OUTLET_CLEARANCE` widths before the outlet."""
    return DEVELOPED * width, length - OUTLET_CLEARANCE * width


def measured_drop(solver, length: float, width: float) -> float:
    """The pressure drop over ``length`` (Pa) from a straight line fitted to the particles' pressure along x in the
    measured stretch (:func:`measured_window`), away from the walls by a tenth of the width."""
    p = solver.fluid.numpy("position").astype(np.float64)
    pressure = solver.fluid.numpy("pressure").astype(np.float64)
    start, end = measured_window(length, width)
    keep = ((p[:, 0] > start) & (p[:, 0] < end) & (p[:, 1] > 0.1 * width) & (p[:, 1] < 0.9 * width))
    if np.count_nonzero(keep) < 2:
        return float("nan")
    slope = np.polyfit(p[keep, 0], pressure[keep], 1)[0]
    return float(-slope * length)


def channel_checks(series: dict, n: int, u_max: float, drop: float, bins: int, average_from: float) -> dict:
    """The checks over the outputs from ``average_from`` (s) on (a weakly compressible channel between a set velocity
    and a set pressure rings with its slowest sound mode, about 1 % of u_max from one output to the next: the average
    takes it out): the profile's shape, its bin errors against the Poiseuille profile fitted at each output
    (``bin_error_K``, in u_max), averaged, the largest within :data:`PROFILE_TOLERANCE`; the particles made at the inlet
    and taken out at the outlet over the same outputs equal within one buffer column (``n`` particles); every fluid
    particle accounted for (the count now is the first plus those made less those taken out). Reported: the fitted
    mean velocity over the inlet's (``mean_velocity_ratio``, U'/U, averaged: 0.3-1.2 % above 1, the weakly compressible
    water lighter and faster where its pressure has fallen) and the measured pressure drop
    against the theory's."""
    t = np.asarray(series["time"])
    half = int(np.searchsorted(t, average_from * (1.0 - 1e-9)))
    errors = np.array([np.mean(series[f"bin_error_{k}"][half:]) for k in range(bins)])
    averaged = np.array([np.mean(series[f"u_bin_{k}"][half:]) for k in range(bins)])
    flux = float(np.mean(series["mean_velocity_ratio"][half:]))
    made = np.asarray(series["inlet_made"])
    taken = np.asarray(series["outlet_taken_out"])
    count = np.asarray(series["particles"])
    made_all, taken_all = np.asarray(series["made"]), np.asarray(series["taken_out"])
    entered, left = made[-1] - made[half], taken[-1] - taken[half]
    error_max = float(np.max(np.abs(errors)))
    measured_drop = float(np.mean(series["pressure_drop"][half:]))
    res = {"averaged_from": float(t[half]), "t": float(t[-1]), "outputs_averaged": int(len(t) - half),
           "error_max": error_max, "error_rms": float(np.sqrt(np.mean(errors ** 2))),
           "u_bins_averaged": averaged.tolist(), "last_output_error_max": float(series["profile_error_max"][-1]),
           "mean_velocity_ratio": flux,
           "entered": int(entered), "left": int(left),
           "made_elsewhere": int(made_all[-1] - made[-1]), "taken_out_elsewhere": int(taken_all[-1] - taken[-1]),
           "pressure_drop": measured_drop, "pressure_drop_ratio": measured_drop / drop}
    res["checks"] = {
        "profile_error_max": tolerance_check(
            error_max, PROFILE_TOLERANCE, SOURCE, unit="u_max",
            basis=f"the 1 % of u_max that inlets and outlets are built to ({bins} bins, the profile averaged over "
                  f"{len(t) - half} outputs)"),
        "mass_balance": tolerance_check(
            abs(entered - left), n, "the steady flow's mass conservation: what enters leaves", unit="particles",
            basis=f"one buffer column ({n} particles): the outlet's buffer holds a column more or less as the water "
                  f"crosses its plane"),
        "particles_accounted": tolerance_check(
            count[-1] - (count[0] + made_all[-1] - taken_all[-1]), 0.0,
            "the fluid's particles: the first count plus those the openings made less those they took out",
            unit="particles", basis="exact: every particle is made and taken out whole")}
    return res


def plot_channel(path: str, series: dict, res: dict, width: float, n: int) -> None:
    """Left: the last output's bin means against the exact profile. Right: the errors and the particles made and taken
    out against time."""
    from warpfree.io.validation_plots import draw_bound, new_figure, save_figure

    t = np.asarray(series["time"])
    y_bins = np.asarray(res["y_bins"])
    u = np.asarray(res["u_bins_averaged"])
    yy = np.linspace(0.0, width, 201)
    u_max = res["u_max"]
    fig = new_figure(10.5, 4.4)
    a1, a2 = fig.subplots(1, 2)
    a1.plot(profile(yy, u_max / 1.5, width) / u_max, yy / width, "k-", lw=1.2, label="Poiseuille 6U y(H-y)/H²")
    a1.plot(u / u_max, y_bins / width, "o", mfc="none", ms=5,
            label=f"WCSPH, {DEVELOPED:g}H < x < L - {OUTLET_CLEARANCE:g}H, mean of t = {res['averaged_from']:.3g}-"
                  f"{t[-1]:.3g} s")
    a1.set_xlabel("u / u_max")
    a1.set_ylabel("y / H")
    a1.set_title(f"channel with an inlet and an outlet, n = {n}\nthe shape's largest error {res['error_max']:.3g} "
                 f"u_max; the flux U'/U = {res['mean_velocity_ratio']:.3f}", fontsize=9)
    a1.legend(fontsize=7, loc="lower right")
    a1.grid(alpha=0.3)
    a2.semilogy(t[1:], series["profile_error_max"][1:], "o-", ms=3, label="max |bin error| / u_max, each output")
    a2.semilogy(t[1:], series["profile_error_rms"][1:], "s-", ms=3, label="rms bin error / u_max, each output")
    draw_bound(a2, PROFILE_TOLERANCE, f"tolerance {PROFILE_TOLERANCE:g} (on the average)")
    a2.set_xlabel("t (s)")
    a2.set_ylabel("error / u_max")
    a2.axvline(res["averaged_from"], color="0.6", ls=":", lw=0.8)
    a2.set_title(f"from t = {res['averaged_from']:.3g} s: entered {res['entered']}, left {res['left']} particles\n"
                 f"pressure drop {res['pressure_drop_ratio']:.3f} x 12μUL/H²", fontsize=9)
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3, which="both")
    save_figure(fig, path)
