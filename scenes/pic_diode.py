"""Planar vacuum diode: an injected cold electron beam's space-charge potential against the steady beam equations.

Absorbing walls, electrodes and injection: a cold electron beam injected at the cathode, its steady space-charge
potential against the beam equations' solution.

Normalised units (ε0 = 1, electron charge -1, mass 1). The cathode at y = 0 (potential 0) emits a cold beam at speed
``injection_speed`` v0 with particle flux Γ = ``injected_fraction`` Γ_CL, Γ_CL = (4/9) sqrt(2) V^{3/2}/d² the
Child–Langmuir flux; the anode at y = d (potential V = ``voltage``) absorbs it, and so does the cathode any electron
turned back. The box is periodic along x (``width``: a slab of the infinite planar diode). No background charge.

Below the space-charge limit the flow becomes steady: measured are the nodal potential averaged over the second
half of the run, evaluated along y, against the steady monotone profile (``warpfree.validation.pic_diode``: φ'' =
Γ / sqrt(v0² + 2φ)), the anode current against the injected one, and the charge balance (in the box = injected -
absorbed). Steady beam-through states exist up to Γ_max (``beam_through_limit``, reported over Γ_CL; 1.112 Γ_CL at
v0 = 0.05, V = 1); above it a virtual cathode turns part of the beam back: the scene reports the transmitted and
returned currents. Writes ``history.csv``, ``energy.png``,
``profile.png`` (mean potential and the reference along y), ``phase_space.png`` (y, v_y at the end), particle
frames and VTU.
"""

import math
import os

import numpy as np

from warpfree.errors import reported_as, require_integer, require_positive
from warpfree.io.frames import plot_series
from warpfree.run import OutputOptions
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.solvers.pic import Injection, PICSolver, PlasmaPoisson, Species
from warpfree.solvers.pic.scene_tools import POTENTIAL_FRAMES, lattice_nodes, plot_history, walled_box, write_history
from warpfree.time_loop import TimeLoop
from warpfree.validation.pic_diode import beam_through_limit, child_langmuir_flux, steady_potential


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"node_spacing": 0.0625, "width": 0.5, "particles_per_step": 20.0, "t_end": 0.6,
            "output_every": 5}


def build(voltage: float = 1.0, gap: float = 1.0, injected_fraction: float = 0.5, injection_speed: float = 0.1,
          node_spacing: float = 1.0 / 32.0, width: float = 0.25, d_max: float = 2.0, particles_per_step: float = 20.0,
          dt: float = 0.02, t_end: float = 20.0, output_every: int = 100,
          field_solve: str | None = None, frames: bool = True,
          vtk: bool = True) -> TimeLoop:
    """``voltage`` V and ``gap`` d of the diode; ``injected_fraction``: Γ / Γ_CL; ``injection_speed`` v0; ``width``
    of the periodic slab along x; ``particles_per_step``: macro-particles the cathode emits per step; ``dt``,
    ``t_end`` in the normalised time unit (the potential is averaged over the second half). ``field_solve``: where
    the field is solved (None: the host's SuperLU on the CPU, the device on a GPU; ``PICSolver``)."""
    params = dict(locals())
    for name in ("voltage", "gap", "injected_fraction", "injection_speed", "width", "dt"):
        require_positive(name, params[name])
    every = require_integer("output_every", output_every, minimum=1)
    with reported_as(node_spacing="node_spacing, width, gap"):
        space = walled_box(width, gap)
        nodes = lattice_nodes(space, node_spacing)
    model = MLSModel(nodes, MLSSettings(d_max=d_max), space=space)
    field = PlasmaPoisson(model, walls=(0.0, voltage))
    flux = injected_fraction * child_langmuir_flux(voltage, gap)
    v0 = injection_speed
    beam = Species("electrons", -1.0, 1.0, flux / v0, drift=(0.0, v0))
    n_steps = int(math.ceil(t_end / dt))
    solver = PICSolver(field, [], dt, modes=(), particle_walls="absorb",
                       injections=[Injection(beam, "lower", particles_per_step)],
                       average_from=0.5 * n_steps * dt, field_solve=field_solve)

    def diode_analysis(run, out_dir):
        s = run.solver
        h = s.history
        t = np.asarray(h["time"])
        late = t >= 0.5 * t[-1]
        # currents per unit wall length: slopes of the walls' charge tallies over the second half (electrons: < 0)
        anode = -np.polyfit(t[late], np.asarray(h["wall_charge_upper"])[late], 1)[0] / width
        returned = -np.polyfit(t[late], np.asarray(h["wall_charge_lower"])[late], 1)[0] / width
        balance = (np.asarray(h["deposited_charge"]) - np.asarray(h["injected_charge"])
                   + np.asarray(h["wall_charge_lower"]) + np.asarray(h["wall_charge_upper"]))
        y = np.linspace(0.0, gap, 65)
        points = np.stack([np.full_like(y, 0.5 * width), y], axis=1)
        mean = model.evaluate(s.mean_potential(), model.shape_at(points))[0][:, 0]
        result = {"child_langmuir_flux": child_langmuir_flux(voltage, gap), "injected_flux": flux,
                  "anode_flux": float(anode) + 0.0, "returned_flux": float(returned) + 0.0,
                  "anode_over_injected": float(anode / flux),
                  "anode_over_child_langmuir": float(anode / child_langmuir_flux(voltage, gap)),
                  "returned_over_injected": float(returned / flux) + 0.0,
                  "returned_charge": float(-h["wall_charge_lower"][-1]) + 0.0,
                  "beam_through_limit_over_child_langmuir": float(beam_through_limit(v0, voltage, gap)
                                                                  / child_langmuir_flux(voltage, gap)),
                  "charge_balance_error": float(np.max(np.abs(balance)) / max(abs(h["injected_charge"][-1]), 1e-300)),
                  "particles": s.count, "nodes": model.node_count}
        curves = {"PIC (mean over the second half)": (y, mean)}
        reference = None
        try:
            ref = steady_potential(y, flux, v0, voltage, gap)
        except ValueError as exc:  # above the space-charge limit: no steady monotone profile
            result["reference"] = str(exc)
        else:
            reference = {"steady beam (Child–Langmuir–Jaffé)": (y[::4], ref[::4])}
            result["potential_max_error"] = float(np.max(np.abs(mean - ref)) / voltage)
        write_history(os.path.join(out_dir, "history.csv"), h)
        plot_history(out_dir, h, None, s)
        plot_series(os.path.join(out_dir, "profile.png"), None, curves, reference=reference, xlabel="y",
                    ylabel="potential", title=f"diode at Γ = {injected_fraction:g} Γ_CL")
        values = s.particle_values()
        p, v = values["position"], values["velocity"]
        plot_series(os.path.join(out_dir, "phase_space.png"), None, {}, reference={"electrons": (p[:, 1], v[:, 1])},
                    xlabel="y", ylabel="v_y", title=f"phase space at t = {s.t:.3g}")
        return {"diode": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=every * dt, name="pic_diode",
                    params=params, analyses=[diode_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, extra_frames=POTENTIAL_FRAMES,
                                         frame_bounds=((0.0, width), (0.0, gap))))
