"""Plots of EFG and NEM solutions (Matplotlib through its Agg canvas, headless): the deformed shape coloured by von
Mises stress. The validation figures (computed against reference, error with tolerance) are
:mod:`warpfree.io.validation_plots`'s."""

from __future__ import annotations

import numpy as np

__all__ = ["von_mises", "plot_deformed"]


def von_mises(stress: np.ndarray) -> np.ndarray:
    """In-plane von Mises stress sqrt(σxx² - σxx σyy + σyy² + 3 σxy²) from (n, 3) [σxx, σyy, σxy]."""
    s = np.asarray(stress)
    return np.sqrt(s[:, 0] ** 2 - s[:, 0] * s[:, 1] + s[:, 1] ** 2 + 3.0 * s[:, 2] ** 2)


def plot_deformed(path, points, displacement, stress, magnify: float, title: str, size=(8.0, 3.0),
                  stress_unit: str = "Pa", length_unit: str = "m") -> None:
    """The Gauss points before (grey) and after the displacement x ``magnify``, coloured by von Mises stress (in
    ``stress_unit``); axes in ``length_unit``."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(*size, dpi=120)
    ax = fig.subplots()
    ax.scatter(points[:, 0], points[:, 1], s=2, c="0.85", label="undeformed")
    moved = points + magnify * displacement
    sc = ax.scatter(moved[:, 0], moved[:, 1], s=3, c=von_mises(stress), cmap="viridis")
    fig.colorbar(sc, ax=ax, label=f"von Mises stress ({stress_unit})")
    ax.set_aspect("equal")
    ax.set_xlabel(f"x ({length_unit})")
    ax.set_ylabel(f"y ({length_unit})")
    ax.set_title(f"{title}, displacements x{magnify:g}")
    ax.legend(loc="best", fontsize=7)
    save_figure(fig, path)
