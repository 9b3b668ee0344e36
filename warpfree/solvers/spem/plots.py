"""Validation plots of the SPEM scenes, on :mod:`warpfree.io.validation_plots`.

Each figure shows what is compared and, below it, the error with the tolerance it is checked against: a computed
profile (one marker per particle) over its exact one, the difference computed − exact beneath, the tolerance as a
band (a bound on each point) or as a line (a bound on the mean |error|, drawn beside the measured mean); time series
of an error measure against its tolerance. Lengths in m, times in ns, fields in V/m.
"""

from __future__ import annotations

import numpy as np

from warpfree.io.validation_plots import (COMPUTED, REFERENCE, comparison_axes, draw_bound, draw_tolerance,
                                          save_figure)

__all__ = ["draw_profile", "draw_error", "draw_series", "plot_profile_check"]


def draw_profile(ax, x, computed, exact, computed_label: str, exact_label: str, ylabel: str, title: str) -> None:
    """``exact`` as a line and ``computed`` as one open marker per particle, against ``x`` (m)."""
    ax.plot(x, exact, "-", color=REFERENCE, lw=1.0, label=exact_label, zorder=2)
    ax.plot(x, computed, "o", color=COMPUTED, ms=3.0, mfc="none", mew=0.8, label=computed_label, zorder=3)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, frameon=True, framealpha=0.85, loc="best")


def draw_error(ax, x, error, tolerance: float, tolerance_label: str, xlabel: str, ylabel: str,
               pointwise: bool, measure: float | None = None, measure_label: str = "") -> None:
    """The error ``error`` (computed − exact) against ``x`` and the ``tolerance`` (same unit as ``error``):
    ``pointwise``, a band ±tolerance (each point is bounded); else lines at ±tolerance (the bound is on the mean
    |error|), a line at +tolerance beside the measured ``measure`` (the checked mean |error|) as a dashed line."""
    ax.axhline(0.0, color="0.6", lw=0.6)
    if pointwise:
        draw_tolerance(ax, tolerance, label=tolerance_label)
    else:
        draw_bound(ax, tolerance, tolerance_label)
    ax.plot(x, error, ".-", color=COMPUTED, lw=0.8, ms=2.5, label="computed − exact")
    if measure is not None:
        ax.axhline(measure, color=COMPUTED, lw=1.0, ls="--", label=measure_label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, frameon=True, framealpha=0.85, loc="best")


def draw_series(ax, t_ns, series: dict, tolerances: dict, xlabel: str, ylabel: str, title: str,
                logy: bool = False) -> None:
    """Error measures over time: ``series`` label -> values at ``t_ns`` (ns), ``tolerances`` label -> bound (a
    horizontal line, in the series' colour order when the labels match)."""
    for k, (label, values) in enumerate(series.items()):
        ax.plot(t_ns, values, "o-", color=f"C{k}", lw=1.2, ms=3.0, label=label)
    for k, (label, bound) in enumerate(tolerances.items()):
        if len(tolerances) > 1:
            draw_bound(ax, bound, label, color=f"C{k}")
        else:
            draw_bound(ax, bound, label)
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3, which="both" if logy else "major")
    ax.legend(fontsize=7, frameon=True, framealpha=0.85, loc="best")


def plot_profile_check(path, x, computed, exact, *, xlabel: str, ylabel: str, error_ylabel: str, title: str,
                       computed_label: str, exact_label: str, tolerance: float, tolerance_label: str,
                       pointwise: bool, measure: float | None = None, measure_label: str = "") -> str:
    """One profile over its exact one (above) and computed − exact with the tolerance (below), written to ``path``
    (:func:`draw_profile`, :func:`draw_error`)."""
    fig, top, bottom = comparison_axes(7.2, 5.6)
    x, computed, exact = (np.asarray(a, float) for a in (x, computed, exact))
    draw_profile(top, x, computed, exact, computed_label, exact_label, ylabel, title)
    draw_error(bottom, x, computed - exact, tolerance, tolerance_label, xlabel, error_ylabel, pointwise, measure,
               measure_label)
    return save_figure(fig, path)
