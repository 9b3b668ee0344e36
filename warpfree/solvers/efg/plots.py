"""Plots of EFG solutions (Matplotlib, headless): the deformed shape coloured by von Mises stress."""

from __future__ import annotations

import numpy as np

__all__ = ["von_mises", "plot_deformed"]


def von_mises(stress: np.ndarray) -> np.ndarray:
    """In-plane von Mises stress sqrt(σxx² - σxx σyy + σyy² + 3 σxy²) from (n, 3) [σxx, σyy, σxy]."""
    s = np.asarray(stress)
    return np.sqrt(s[:, 0] ** 2 - s[:, 0] * s[:, 1] + s[:, 1] ** 2 + 3.0 * s[:, 2] ** 2)


def plot_deformed(path, points, displacement, stress, magnify: float, title: str, size=(8.0, 3.0)) -> None:
    """The Gauss points before (grey) and after the displacement x ``magnify``, coloured by von Mises stress."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=size, dpi=120)
    ax.scatter(points[:, 0], points[:, 1], s=2, c="0.85", label="undeformed")
    moved = points + magnify * displacement
    sc = ax.scatter(moved[:, 0], moved[:, 1], s=3, c=von_mises(stress), cmap="viridis")
    fig.colorbar(sc, ax=ax, label="von Mises stress (in plane)")
    ax.set_aspect("equal")
    ax.set_title(f"{title}, displacements x{magnify:g}")
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
