"""What the PIC scenes share: the periodic or walled box, lattice nodes, the per-step history as CSV and the
validation plots (each a comparison with its reference above and the error with its tolerance below)."""

from __future__ import annotations

import csv
import math
import os

import numpy as np

from warpfree.errors import ParameterError, require_memory, require_positive
from warpfree.io.validation_plots import comparison_axes, draw_tolerance, save_figure
from warpfree.space import Space

__all__ = ["POTENTIAL_FRAMES", "ENERGY_DRIFT_TARGET", "periodic_box", "walled_box", "lattice_nodes", "write_history",
           "plot_history", "plot_energy", "plot_phase_space", "plot_oscillation", "plot_growth", "plot_profile", "relative_drift", "momentum_change"]


#: memory per node of a PIC field solve, bytes: the EFG model's shape rows, the factorised Poisson matrix and the
#: deposit and gather rows; the thermal plasma's peak resident memory grows by 33 kB per node, rounded up
BYTES_PER_NODE = 40e3

#: the frame series every PIC scene writes beside its particle frames: the potential on the nodes
#: (``frames/nodes_potential_NNNNN.png``; ``warpfree.run.OutputOptions.extra_frames``)
POTENTIAL_FRAMES = (("nodes", "potential"),)

#: the relative total-energy drift a PIC run is to stay below: 1 % over 50 plasma periods, the thermal plasma's
#: target (``scenes/pic_thermal_plasma.py``, after Marques 2008, §6.3)
ENERGY_DRIFT_TARGET = 0.01


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
    """The solver's per-step diagnostics as CSV (one row per step, columns as in ``history``); in a distributed run
    the first rank writes it (every rank's history is the whole run's)."""
    from warpfree.parallel.world import world, world_started

    if world_started() and not world().is_root:
        return path
    keys = list(history)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for row in zip(*(history[k] for k in keys)):
            w.writerow([f"{v:.12g}" for v in row])
    return path


def plot_history(out_dir: str, history: dict[str, list[float]], solver=None, energy_tolerance: float | None = None,
                 tolerance_label: str = "", below: dict | None = None, units: dict | None = None) -> list[str]:
    """energy.png (:func:`plot_energy`: the energies and, below, the total energy's relative drift with the band ±
    ``energy_tolerance``, or the series ``below`` names) and, with ``solver``, potential.png (the nodal potential at
    the end, nodes coloured, labelled in ``units``: the solver's ``UNITS`` by default)."""
    from warpfree.io.frames import render_frame
    from warpfree.solvers.pic.solver import UNITS

    units = units or UNITS
    paths = [plot_energy(os.path.join(out_dir, "energy.png"), history, energy_tolerance, tolerance_label, below)]
    if solver is not None:
        model = solver.model
        space = getattr(solver.field, "space", model.space)   # a region's field: the box enclosing it
        lo, length = space.lower[:2], space.length[:2]
        paths.append(str(render_frame(os.path.join(out_dir, "potential.png"), model.nodes_np, solver.potential, 2,
                                      "potential", ((lo[0], lo[0] + length[0]), (lo[1], lo[1] + length[1])),
                                      title="potential at the nodes", time=solver.t, time_unit=solver.time_unit,
                                      field_unit=units["potential"], length_unit=units["position"])))
    return paths


def _two_panels(title: str):
    """The comparison above, the error below (:func:`warpfree.io.validation_plots.comparison_axes`), with room for
    the legend above the curves."""
    fig, top, bottom = comparison_axes(7.0, 6.2, title=title)
    top.margins(y=0.22)
    return fig, top, bottom


def plot_energy(path: str, history: dict[str, list[float]], tolerance: float | None = None,
                tolerance_label: str = "", below: dict | None = None) -> str:
    """The kinetic, field and total energy against time (top) and the total energy's relative drift
    (E(t) - E(0)) / E(0) (bottom), with the band ± ``tolerance`` (a fraction; none when None) labelled
    ``tolerance_label``. Where the total energy is not conserved (open boundaries) ``below`` gives the lower panel
    instead: {"values", "label", "ylabel", "title"[, "xlabel"]} (the band as before). Normalised units (ω_pe = λ_D = 1)."""
    t = np.asarray(history["time"])
    fig, top, bottom = _two_panels("PIC energies and " + ("the total energy's drift" if below is None
                                                           else below["title"]))
    for key in ("kinetic_energy", "field_energy", "total_energy"):
        top.plot(t, np.asarray(history[key]), lw=1.5, label=key.replace("_", " "))
    top.set_ylabel("energy (normalised)")
    top.legend(fontsize=8, framealpha=0.85, ncol=3, loc="upper center")
    if below is None:
        total = np.asarray(history["total_energy"], np.float64)
        values = (total - total[0]) / total[0]
        below = {"values": values, "label": "(E(t) - E(0)) / E(0)", "ylabel": "relative drift of E"}
    values = np.asarray(below["values"], np.float64)
    bottom.plot(t, values, color="k", lw=1.4, label=f"{below['label']}; max |.| = {np.max(np.abs(values)):.3g}")
    if tolerance is not None:
        draw_tolerance(bottom, tolerance, x=t, label=tolerance_label)
    bottom.set_xlabel(below.get("xlabel", "t (1/ω_pe)"))
    bottom.set_ylabel(below["ylabel"])
    bottom.legend(fontsize=8, framealpha=0.85, loc="best")
    return save_figure(fig, path)


def plot_oscillation(path: str, time, signal, omega: float, rel_tolerance: float, title: str) -> str:
    """A mode's potential coefficient u_k(t) against the undamped cosine u_k(0) cos(ω t) of frequency ``omega``
    (top) and their difference over |u_k(0)| (bottom) with the band a frequency error of ``rel_tolerance`` makes,
    |cos((1 + ε) ω t) - cos(ω t)| <= min(ε ω t, 2) (ε = ``rel_tolerance``)."""
    t = np.asarray(time, np.float64)
    u = np.asarray(signal, np.float64)
    amplitude = abs(u[0]) if u[0] != 0 else float(np.max(np.abs(u)))
    theory = u[0] * np.cos(omega * t)
    fig, top, bottom = _two_panels(title)
    top.plot(t, u, lw=1.6, label="PIC: mode (1, 0) of the potential, Re u_k")
    top.plot(t, theory, "k--", lw=1.1, label=f"theory: u_k(0) cos(ω t), ω = {omega:.5g} ω_pe")
    top.set_ylabel("Re u_k (normalised potential)")
    top.legend(fontsize=8, framealpha=0.85, loc="upper right")
    bottom.plot(t, (u - theory) / amplitude, color="k", lw=1.3, label="(PIC - theory) / |u_k(0)|")
    draw_tolerance(bottom, np.minimum(rel_tolerance * omega * t, 2.0), x=t,
                   label=f"a {100 * rel_tolerance:g} % frequency error")
    bottom.set_xlabel("t (1/ω_pe)")
    bottom.set_ylabel("relative difference")
    bottom.legend(fontsize=8, framealpha=0.85, loc="upper left")
    return save_figure(fig, path)


def plot_growth(path: str, time, energy, gamma_theory: float, gamma_fit: float | None, window: tuple | None,
                rel_tolerance: float, floor: float, title: str) -> str:
    """A growing mode's field energy (log axis from ``floor`` up to a decade above its peak) with the theory's
    exponential growth e^{2 γ t} over the fitted ``window`` (t0, t1), anchored at the measured energy at t0, and the
    fit (top); below, the local growth rate ½ d ln W / dt against the theory's γ with the band ± ``rel_tolerance`` γ
    over the window."""
    t = np.asarray(time, np.float64)
    w = np.asarray(energy, np.float64)
    fig, top, bottom = _two_panels(title)
    top.plot(t, w, lw=1.6, label="PIC: field energy of mode (1, 0)")
    positive = w > floor
    if window is not None:
        t0, t1 = window
        tw = np.linspace(t0, t1, 50)
        w0 = float(np.interp(t0, t, w))
        top.plot(tw, w0 * np.exp(2.0 * gamma_theory * (tw - t0)), "k--", lw=1.3,
                 label=f"theory: e^(2γt), γ = {gamma_theory:.4g} ω_pe")
        if gamma_fit is not None:
            top.plot(tw, w0 * np.exp(2.0 * gamma_fit * (tw - t0)), color="tab:orange", lw=1.0,
                     label=f"fit over t = {t0:.3g}-{t1:.3g}: γ = {gamma_fit:.4g} ω_pe")
    top.set_yscale("log")
    top.set_ylim(floor, 10.0 * float(np.max(w)) if np.any(positive) else 1.0)
    top.set_ylabel("field energy (normalised)")
    top.legend(fontsize=8, framealpha=0.85, loc="lower right")
    local = np.full_like(w, np.nan)
    ok = w > 0
    local[ok] = 0.5 * np.gradient(np.log(np.where(ok, w, 1.0)), t)[ok]
    local[~positive] = np.nan
    bottom.plot(t, local, color="k", lw=1.2, label="PIC: ½ d ln W / dt")
    span = t if window is None else np.linspace(window[0], window[1], 50)
    draw_tolerance(bottom, rel_tolerance * gamma_theory, x=span, centre=gamma_theory,
                   label=f"γ theory ± {100 * rel_tolerance:g} %")
    bottom.axhline(gamma_theory, color="k", ls="--", lw=1.0)
    bottom.set_ylim(-0.5 * gamma_theory, 2.0 * gamma_theory)
    bottom.set_xlabel("t (1/ω_pe)")
    bottom.set_ylabel("growth rate (ω_pe)")
    bottom.legend(fontsize=8, framealpha=0.85, loc="upper right")
    return save_figure(fig, path)


def plot_profile(path: str, y, computed, reference, scale: float, tolerance: float, tolerance_label: str,
                 title: str, xlabel: str = "y (normalised length)", ylabel: str = "potential φ (normalised)",
                 reference_label: str = "steady beam (Child–Langmuir–Jaffé)",
                 scale_label: str = "V, V the anode potential", checked_from: float | None = None) -> str:
    """A computed profile against its reference (``reference_label``; top) and their difference over ``scale``
    (``scale_label`` says what it is; bottom) with the band ± ``tolerance`` labelled ``tolerance_label``, drawn where
    it is checked (from ``checked_from`` on; None: everywhere); without a reference (None) the computed profile
    alone."""
    y = np.asarray(y, np.float64)
    fig, top, bottom = _two_panels(title)
    top.plot(y, computed, lw=1.6, label="PIC (mean over the second half)")
    if reference is not None:
        top.plot(y, reference, "k--", lw=1.2, label=reference_label)
        divided = f" / {scale_label.split(',')[0]}" if scale_label else ""
        bottom.plot(y, (np.asarray(computed) - np.asarray(reference)) / scale, color="k", lw=1.3,
                    label=f"(PIC - {reference_label.split(' (')[0]}){divided}")
        draw_tolerance(bottom, tolerance, x=y if checked_from is None else y[y >= checked_from], label=tolerance_label)
        bottom.legend(fontsize=8, framealpha=0.85, loc="lower right")
    else:
        bottom.text(0.5, 0.5, "no steady monotone profile: no reference", ha="center", va="center",
                    transform=bottom.transAxes)
    top.set_ylabel(ylabel)
    top.legend(fontsize=8, framealpha=0.85)
    bottom.set_xlabel(xlabel)
    bottom.set_ylabel(f"(φ − φ_steady) / {scale_label}" if scale_label else "φ − φ_steady")
    return save_figure(fig, path)


def plot_phase_space(path: str, groups: dict, xlabel: str, ylabel: str, title: str, theory: tuple | None = None) -> str:
    """Every particle as a point (position, velocity), one colour per group (label -> (positions, velocities)), and
    ``theory`` (positions, velocities, label) as a black line where there is one."""
    from warpfree.io.validation_plots import REFERENCE, new_figure

    fig = new_figure(7.0, 4.6)
    ax = fig.subplots()
    for k, (label, (x, v)) in enumerate(groups.items()):
        ax.plot(x, v, "o", ms=2.5, mfc="none", mew=0.7, color=f"C{k}", label=f"{label} ({np.size(x)} particles)")
    if theory is not None:
        ax.plot(theory[0], theory[1], "-", color=REFERENCE, lw=1.2, label=theory[2])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, framealpha=0.85)
    return save_figure(fig, path)


def relative_drift(values) -> float:
    """max |E - E_0| / E_0 of a series."""
    v = np.asarray(values, np.float64)
    return float(np.max(np.abs(v - v[0])) / abs(v[0])) if v[0] != 0 else math.inf


def momentum_change(history: dict[str, list[float]]) -> float:
    """max_t |P(t) - P(0)|: the total momentum's largest change (normalised units)."""
    p = np.c_[history["momentum_x"], history["momentum_y"]]
    return float(np.max(np.linalg.norm(p - p[0], axis=1)))
