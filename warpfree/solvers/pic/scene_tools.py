"""What the PIC scenes share: the periodic or walled box, lattice nodes, the per-step history as CSV and its plots."""

from __future__ import annotations

import csv
import math
import os

import numpy as np

from warpfree.errors import ParameterError, require_memory, require_positive
from warpfree.space import Space

__all__ = ["POTENTIAL_FRAMES", "periodic_box", "walled_box", "lattice_nodes", "write_history", "plot_history",
           "relative_drift", "momentum_change"]


#: memory per node of a PIC field solve, bytes: the EFG model's shape rows, the factorised Poisson matrix and the
#: deposit and gather rows; the thermal plasma's peak resident memory grows by 33 kB per node, rounded up
BYTES_PER_NODE = 40e3

#: the frame series every PIC scene writes beside its particle frames: the potential on the nodes
#: (``frames/nodes_potential_NNNNN.png``; ``warpfree.run.OutputOptions.extra_frames``)
POTENTIAL_FRAMES = (("nodes", "potential"),)


def periodic_box(length_x: float, length_y: float) -> Space:
    """The 2D box [0, Lx) × [0, Ly), periodic along x and y."""
    require_positive("length_x", length_x)
    require_positive("length_y", length_y)
    return Space(2, (0.0, 0.0, 0.0), (length_x, length_y, 1.0), periodic=(True, True, False))


def walled_box(length_x: float, length_y: float) -> Space:
    """The 2D box [0, Lx) × [0, Ly], periodic along x, with walls at y = 0 and y = Ly."""
    require_positive("length_x", length_x)
    require_positive("length_y", length_y)
    return Space(2, (0.0, 0.0, 0.0), (length_x, length_y, 1.0), periodic=(True, False, False))


def lattice_nodes(space: Space, spacing: float) -> np.ndarray:
    """Nodes on a regular lattice of about ``spacing`` (exactly Lx/nx, Ly/ny with n = round(L/spacing)), the first at
    the box's lower corner; along an axis that is not periodic (walls) the last row lies on the upper wall."""
    require_positive("node_spacing", spacing)
    spans = space.length[:2] / spacing
    require_memory("node_spacing", float(np.prod(spans + 1.0)), BYTES_PER_NODE, "nodes")
    counts = [int(round(spans[a])) for a in range(2)]
    if min(counts) < 2:
        raise ParameterError("node_spacing", f"{spacing} leaves fewer than 2 nodes along an axis of the box "
                                             f"{space.length[:2].tolist()}")
    axes = [space.lower[a] + np.arange(counts[a] + (0 if space.periodic[a] else 1)) * space.length[a] / counts[a]
            for a in range(2)]
    gx, gy = np.meshgrid(*axes, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def write_history(path: str, history: dict[str, list[float]]) -> str:
    """The solver's per-step diagnostics as CSV (one row per step, columns as in ``history``)."""
    keys = list(history)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for row in zip(*(history[k] for k in keys)):
            w.writerow([f"{v:.12g}" for v in row])
    return path


def plot_history(out_dir: str, history: dict[str, list[float]], mode_key: str | None = None,
                 solver=None) -> list[str]:
    """energy.png (kinetic, field, total), with ``mode_key`` mode.png (that mode's field energy, log scale), with
    ``solver`` potential.png (the nodal potential at the end, nodes coloured)."""
    from warpfree.io.frames import plot_series, render_frame

    t = np.asarray(history["time"])
    paths = [str(plot_series(os.path.join(out_dir, "energy.png"), t,
                             {k.replace("_", " "): np.asarray(history[k]) for k in
                              ("kinetic_energy", "field_energy", "total_energy")},
                             xlabel="t (1/ω_pe)", ylabel="energy (normalised)", title="PIC energies"))]
    if mode_key is not None:
        e = np.asarray(history[mode_key])
        paths.append(str(plot_series(os.path.join(out_dir, "mode.png"), t, {mode_key.replace("_", " "): e},
                                     xlabel="t (1/ω_pe)", ylabel="field energy", logy=bool(np.all(e > 0)),
                                     title="Fourier mode")))
    if solver is not None:
        model = solver.model
        lo, length = model.space.lower[:2], model.space.length[:2]
        paths.append(str(render_frame(os.path.join(out_dir, "potential.png"), model.nodes_np, solver.potential, 2,
                                      "potential", ((lo[0], lo[0] + length[0]), (lo[1], lo[1] + length[1])),
                                      title=f"potential at t = {solver.t:.4g} / ω_pe")))
    return paths


def relative_drift(values) -> float:
    """max |E - E_0| / E_0 of a series."""
    v = np.asarray(values, np.float64)
    return float(np.max(np.abs(v - v[0])) / abs(v[0])) if v[0] != 0 else math.inf


def momentum_change(history: dict[str, list[float]]) -> float:
    """max_t |P(t) - P(0)|: the total momentum's largest change (normalised units)."""
    p = np.c_[history["momentum_x"], history["momentum_y"]]
    return float(np.max(np.linalg.norm(p - p[0], axis=1)))
