"""A floating box against Archimedes' principle (exact): its draft and its rest.

A box of breadth B, height H and density ρ_b floats upright in water of density ρ0 at the draft where the water it
displaces weighs what it weighs, T = (ρ_b/ρ0) H (per metre of depth in 2D, as in 3D). Upright is stable when its
metacentric height B²/(12 T) - (H - T)/2 is positive (a box 0.4 m by 0.2 m at ρ_b/ρ0 = 1/2: +0.083 m; a square one
of that density has -0.017 m and rolls onto a corner). The scene measures the draft as the water's level at gauges
off the box less the box's bottom, and its rest as the range of its position and its largest angle (:func:`checks`).
README.md beside this file gives the source.
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import tolerance_check

__all__ = ["CASE", "archimedes_draft", "metacentric_height", "DRAFT_TOLERANCE", "REST_TOLERANCES", "checks",
           "plot_draft"]

CASE = "floating_box_2d"
#: the largest difference of the mean draft from Archimedes', as a fraction of it
DRAFT_TOLERANCE = 0.01
#: the box at rest: range of its height (m), range of its sideways position (m), largest angle (rad)
REST_TOLERANCES = (1.0e-3, 1.0e-2, 1.0e-2)
SOURCE = "Archimedes' principle (exact): T = (rho_b/rho0) H; warpfree/validation/floating_box_2d/README.md"


def archimedes_draft(density: float, rho0: float, height: float) -> float:
    """T = (ρ_b/ρ0) H (m): the draft of a box of that density and height floating upright."""
    return float(density / rho0 * height)


def metacentric_height(breadth: float, height: float, draft: float) -> float:
    """GM = B²/(12 T) - (H - T)/2 (m) of an upright box: positive when upright is stable."""
    return float(breadth ** 2 / (12.0 * draft) - 0.5 * (height - draft))


def checks(draft: np.ndarray, x: np.ndarray, y: np.ndarray, angle: np.ndarray, expected: float, basis: str) -> dict:
    """The mean draft within :data:`DRAFT_TOLERANCE` of ``expected``; the box at rest: the ranges of y and x and the
    largest |angle| within :data:`REST_TOLERANCES`."""
    rest_y, rest_x, rest_angle = REST_TOLERANCES
    return {
        "draft": tolerance_check(abs(float(np.mean(draft)) / expected - 1.0), DRAFT_TOLERANCE, SOURCE,
                                 basis=f"1 % of Archimedes' draft, the mean over the run, {basis}"),
        "heave_range": tolerance_check(float(np.ptp(y)), rest_y, "a body floating at rest (exact)", unit="m",
                                       basis=f"1 mm, {basis}"),
        "sway_range": tolerance_check(float(np.ptp(x)), rest_x, "a body floating at rest (exact)", unit="m",
                                      basis=f"1 cm, {basis}"),
        "largest_angle": tolerance_check(float(np.max(np.abs(angle))), rest_angle, "a body floating at rest (exact)",
                                         unit="rad", basis=f"0.01 rad, {basis}")}


def plot_draft(path: str, t: np.ndarray, draft: np.ndarray, x: np.ndarray, angle: np.ndarray, expected: float,
               label: str) -> None:
    """The draft against Archimedes', the sideways position and the angle, in time."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(10.5, 3.8)
    a1, a2 = fig.subplots(1, 2)
    a1.plot(t, draft / expected, lw=1.0, label=label)
    a1.axhline(1.0, color="k", lw=1.0, label="Archimedes")
    for f in (1 - DRAFT_TOLERANCE, 1 + DRAFT_TOLERANCE):
        a1.axhline(f, color="k", lw=0.6, ls=":")
    a1.set_xlabel("t (s)")
    a1.set_ylabel("draft / Archimedes' draft")
    a2.plot(t, 1e3 * (x - x[0]), lw=1.0, label="sideways drift (mm)")
    a2.plot(t, 1e3 * angle, lw=1.0, label="angle (mrad)")
    a2.set_xlabel("t (s)")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"Floating box: mean draft {100 * (np.mean(draft) / expected - 1):+.2f} % from Archimedes'",
                 fontsize=10)
    save_figure(fig, path)
