"""Validation figures, shared by every family: what is compared above (the computed result over its reference), the
error below with the tolerance its check allows (:func:`warpfree.validation.tolerance_check`).

Matplotlib through its Agg canvas, no pyplot: safe in the output writer's process and in threads, no global
backend switch. Colours by role, the same in every figure: computed ``C0``, reference black, tolerance green.
Axis labels carry their units; the functions take them as written by the caller (``"t (s)"``, ``"Ez (V/m)"``).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["COMPUTED", "REFERENCE", "TOLERANCE", "new_figure", "comparison_axes", "draw_tolerance", "draw_bound",
           "annotate_checks", "save_figure", "plot_against_reference", "plot_series_check"]

#: the colours of the three roles a validation figure draws
COMPUTED, REFERENCE, TOLERANCE = "C0", "k", "C2"


def new_figure(width: float, height: float, dpi: float = 110):
    """A Matplotlib ``Figure`` of ``width`` x ``height`` inches on its own Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def comparison_axes(width: float = 7.0, height: float = 6.0, ratio: tuple = (3.0, 2.0), sharex: bool = True,
                    title: str | None = None):
    """Two axes stacked: the comparison above (``top``), the error below (``bottom``), sharing x; a light grid on
    both, ``title`` over the top one. Returns (figure, top, bottom); write it with :func:`save_figure`."""
    fig = new_figure(width, height)
    top, bottom = fig.subplots(2, 1, sharex=sharex, gridspec_kw={"height_ratios": list(ratio)})
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    if title is not None:
        top.set_title(title, fontsize=9)
    return fig, top, bottom


def draw_tolerance(ax, tolerance, x=None, centre=0.0, label: str = "tolerance", step: bool = False) -> None:
    """Shade the band ``centre`` ± ``tolerance`` on an error axis, edges dashed, labelled once: over the axis'
    whole width (``x`` None, a number), or over ``x`` with a half-width (and ``centre``) given there (numbers or
    arrays; ``step``: each value holds up to its x, as a tolerance that changes with the window it applies to)."""
    if x is None:
        lo, hi = centre - tolerance, centre + tolerance
        ax.axhspan(lo, hi, color=TOLERANCE, alpha=0.15, lw=0, label=label)
        for edge in (lo, hi):
            ax.axhline(edge, color=TOLERANCE, ls="--", lw=0.9)
        return
    x = np.asarray(x, np.float64)
    tol = np.broadcast_to(np.asarray(tolerance, np.float64), x.shape)
    mid = np.broadcast_to(np.asarray(centre, np.float64), x.shape)
    where = {"step": "pre"} if step else {}
    ax.fill_between(x, mid - tol, mid + tol, color=TOLERANCE, alpha=0.15, lw=0, label=label, **where)
    draw = ax.step if step else ax.plot
    for sign in (-1.0, 1.0):
        draw(x, mid + sign * tol, color=TOLERANCE, ls="--", lw=0.9, **({"where": "pre"} if step else {}))


def draw_bound(ax, bound: float, label: str, color: str = TOLERANCE) -> None:
    """A one-sided tolerance: a dotted line at ``bound`` on an axis of magnitudes (|error|, often logarithmic)."""
    ax.axhline(bound, color=color, ls=":", lw=1.3, label=label)


def annotate_checks(ax, checks: dict, loc: str = "below") -> None:
    """One line per check of ``checks`` (name -> :func:`warpfree.validation.tolerance_check` record): PASS/FAIL,
    value, reference, tolerance; in a box under ``ax``, below its x label (``loc="below"``), or in one of its corners
    (``"lower left"``, ``"upper right"``, ...)."""
    lines = []
    for name, c in checks.items():
        unit = f" {c['unit']}" if c.get("unit") else ""
        reference = f" − {c['reference']:.4g}" if c["reference"] else ""
        lines.append(f"{'PASS' if c['passed'] else 'FAIL'}  {name}: |{c['value']:.4g}{reference}| ≤ "
                     f"{c['tolerance']:.3g}{unit}")
    box = {"boxstyle": "round", "facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"}
    if loc == "below":
        ax.annotate("\n".join(lines), xy=(0.0, 0.0), xycoords="axes fraction", xytext=(0, -36),
                    textcoords="offset points", ha="left", va="top", fontsize=7, family="monospace", bbox=box)
        return
    vertical, horizontal = loc.split()
    ax.text(0.02 if horizontal == "left" else 0.98, 0.04 if vertical == "lower" else 0.96, "\n".join(lines),
            transform=ax.transAxes, ha=horizontal, va="bottom" if vertical == "lower" else "top", fontsize=7,
            family="monospace", bbox=box)


def save_figure(fig, path) -> str:
    """Lay the figure out so that no label is cut off and write it as a PNG at ``path`` (its folder made); in a
    distributed run the first rank writes it (every rank analyses alike)."""
    from warpfree.parallel.world import world, world_started

    path = str(path)
    if world_started() and not world().is_root:  # (the writer process, which draws the plots handed to it, has none)
        return path
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, format="png", bbox_inches="tight", pad_inches=0.08)
    return path


def plot_against_reference(path, x, computed: dict, reference, error: dict, tolerance, *, xlabel: str,
                           ylabel: str, error_label: str, title: str, tolerance_label: str = "tolerance",
                           reference_label: str = "reference", band_center: float = 0.0, logx: bool = False,
                           logy: bool = False, error_logy: bool = False, reference_x=None) -> str:
    """A validation figure of values at points ``x``: above, the ``reference`` (a black line over ``reference_x``,
    default ``x``; a number: a constant; None: no curve) and the ``computed`` series (label -> values at ``x``, markers
    joined by a dashed line); below, the ``error`` series (label -> values at ``x``) with the tolerance: a band
    ``band_center`` ± ``tolerance`` (a number), or with ``error_logy`` (errors as magnitudes on a log axis) a line at
    ``tolerance``; a dict (line label -> value): one dotted line per error series, in that series' colour."""
    fig, top, bottom = comparison_axes(title=title)
    x = np.asarray(x, dtype=np.float64)
    if reference is not None:
        rx = x if reference_x is None else np.asarray(reference_x, dtype=np.float64)
        top.plot(rx, np.broadcast_to(np.asarray(reference, dtype=np.float64), rx.shape), "-", color=REFERENCE,
                 lw=1.2, label=reference_label)
    for k, (label, values) in enumerate(computed.items()):
        top.plot(x, values, ls="--", marker="o", ms=3.5, lw=1.0, color=f"C{k}", label=label)
    top.set_ylabel(ylabel)
    top.legend(fontsize=8)
    for k, (label, values) in enumerate(error.items()):
        bottom.plot(x, values, ls="-", marker="o", ms=3.5, lw=1.0, color=f"C{k}", label=label)
    if isinstance(tolerance, dict):
        for k, (label, value) in enumerate(tolerance.items()):
            draw_bound(bottom, value, label, color=f"C{k}")
    elif tolerance is not None:
        if error_logy:
            draw_bound(bottom, tolerance, tolerance_label)
        else:
            draw_tolerance(bottom, tolerance, centre=band_center, label=tolerance_label)
            bottom.axhline(band_center, color="0.5", lw=0.8)
    bottom.set_ylabel(error_label)
    bottom.set_xlabel(xlabel)
    bottom.legend(fontsize=8)
    if logx:
        for ax in (top, bottom):
            ax.set_xscale("log")
    if logy:
        top.set_yscale("log")
    if error_logy:
        bottom.set_yscale("log")
    return save_figure(fig, path)


def plot_series_check(path, t, computed, reference, error, tolerance, *, computed_label: str, reference_label: str,
                      xlabel: str, ylabel: str, error_label: str, title: str, tolerance_label: str,
                      logy: bool = False) -> str:
    """A time series over its reference above (computed as open markers, the reference as a line), ``error`` below
    with the band |error| <= ``tolerance`` (a number, or an array over ``t``)."""
    fig, top, bottom = comparison_axes(title=title)
    top.plot(t, reference, "-", color=REFERENCE, lw=1.3, label=reference_label)
    top.plot(t, computed, "o", ms=3.5, mfc="none", color=COMPUTED, label=computed_label)
    if logy:
        top.set_yscale("log")
    top.set_ylabel(ylabel)
    top.legend(fontsize=8)
    draw_tolerance(bottom, tolerance, x=None if np.ndim(tolerance) == 0 else t, label=tolerance_label)
    bottom.plot(t, error, "o-", ms=3, color=COMPUTED, label=error_label)
    bottom.axhline(0.0, color="k", lw=0.6)
    bottom.set_xlabel(xlabel)
    bottom.set_ylabel(error_label)
    bottom.legend(fontsize=7, loc="best")
    return save_figure(fig, path)
