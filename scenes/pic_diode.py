"""Planar vacuum diode: an injected cold electron beam's space-charge potential against the steady beam equations.

Absorbing walls, electrodes and injection: a cold electron beam injected at the cathode, its steady space-charge
potential against the beam equations' solution.

Normalised units: ε0 = 1, electron charge -1, mass 1, lengths in a unit L and times in a unit T (``UNITS``: speeds
in L/T, potentials in m_e L²/(e T²)). A cold beam has no Debye length: its only scales are the gap d and the voltage
V, given in these units; at the defaults (``gap`` 1, ``voltage`` 1) L is the gap d and T = d/sqrt(e V/m_e). The
cathode at y = 0 (potential 0) emits a cold beam at speed ``injection_speed`` v0 with particle flux
Γ = ``injected_fraction`` Γ_CL, Γ_CL = (4/9) sqrt(2) V^{3/2}/d² the Child–Langmuir flux; the anode at y = d
(potential V = ``voltage``) absorbs it, and so does the cathode any electron turned back. The box is periodic along
x (``width``: a slab of the infinite planar diode). No background charge.

Below the space-charge limit the flow becomes steady: measured are the nodal potential averaged over the second
half of the run, evaluated along y, against the steady monotone profile (``warpfree.validation.pic_diode``: φ'' =
Γ / sqrt(v0² + 2φ)), the anode current against the injected one, and the charge balance (in the box = injected -
absorbed). Steady beam-through states exist up to Γ_max (``beam_through_limit``, reported over Γ_CL; 1.112 Γ_CL at
v0 = 0.05, V = 1); above it a virtual cathode turns part of the beam back: the scene reports the transmitted and
returned currents, the steady virtual cathode's transmitted flux (``virtual_cathode_transmitted_flux``) and, for the
cases the one-dimensional sheet model has tabulated (``sheet_model_transmitted_flux``: the oscillating virtual
cathode's time-averaged flux, above the steady one), checks the transmitted current against it.

The particles feel -∇u^h (the energy gather, ``gather="energy"``): a particle's kinetic energy then follows the
potential the field solve holds, v = sqrt(v0² + 2φ), on which the space-charge limit rests. The momentum gather's
nodal fields are, within about three node spacings of a wall, either off the node (plain lumped projection) or not a
partition of unity (wall-corrected test functions), so where the field changes sign within a spacing, as at a virtual
cathode, the particles' energy drifts from the potential's (``bench/results/pic_design.md``). Writes
``history.csv``, ``energy.png`` (with the charge balance), ``profile.png`` (mean potential and the reference along y,
and their difference), ``phase_space.png`` (y, v_y at the end), particle frames coloured by speed and VTU.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.galerkin.mls import MLSModel, MLSSettings, SupportScale
from warpfree.solvers.pic import Gather, Injection, ParticleWall, PICSolver, PlasmaPoisson, SourceWall, Species
from warpfree.solvers.pic.parameters import FieldSolveAt, OutputEvery, ParticleGather
from warpfree.solvers.pic.scene_tools import (POTENTIAL_FRAMES, lattice_nodes, plot_history, plot_phase_space,
                                              plot_profile, walled_box, write_history)
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.pic_diode import (beam_through_limit, child_langmuir_flux, sheet_model_transmitted_flux,
                                          steady_potential, virtual_cathode_floor, virtual_cathode_transmitted_flux)


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"node_spacing": 0.0625, "width": 0.5, "particles_per_step": 20.0, "t_end": 0.6,
            "output_every": 5}

#: ``warpfree validate --quick``: the default (32 node spacings across the gap, t = 20; about 15 s on 2 cores), VTU
#: and frames off
QUICK = {"t_end": 20.0}

#: the mean potential's largest error over V at 32 node spacings across the gap (tests/pic/test_pic_diode.py:
#: measured 4.7e-5 there, 2.4e-4 at 16 spacings, 1.2e-5 at 64)
POTENTIAL_TOLERANCE = 2e-4
#: the charge balance (in the box = injected - absorbed) holds to round-off (float64 tallies)
BALANCE_TOLERANCE = 1e-11
#: above Γ_max: the anode flux over Γ_CL against the sheet model's time average, and why (tests/pic/test_pic_diode.py)
TRANSMITTED_TOLERANCE = 0.02
TRANSMITTED_BASIS = ("the sheet model's spread (1.0498-1.0512 Γ_CL over its Δt, sheet weight and seed), a mean over "
                     "15 time units of an oscillating flux (2-unit windows scatter by 0.02 Γ_CL) and the resolution: "
                     "1.049 Γ_CL at 64 node spacings per unit length, 1.0525 at 128 (V = 2.5, d = 1.5, v0 = 0.1, "
                     "3 Γ_CL; at 32 spacings the virtual cathode lies 0.2 of a spacing from the cathode: 0.980)")

#: the units of the outputs (the PIC solver's are λ_D and 1/ω_pe, which a cold beam does not have): lengths in L, times
#: in T (at the defaults L = d, T = d/sqrt(e V/m_e)), with ε0 = e = m_e = 1
UNITS = {"position": "L", "velocity": "L/T", "speed": "L/T", "e_field": "m_e L/(e T²)",
         "potential": "m_e L²/(e T²)", "charge": "ε0 m_e L²/(e T²)"}
TIME_UNIT = "T"


@checked_parameters
def build(voltage: Annotated[float, Param(UNITS["potential"], "anode potential V (the cathode at 0)", "(0, inf)")] = 1.0,
          gap: Annotated[float, Param("L", "distance d from the cathode to the anode", "(0, inf)")] = 1.0,
          injected_fraction: Annotated[float, Param("", "injected flux over the Child–Langmuir flux, Γ/Γ_CL",
                                                    "(0, inf)")] = 0.5,
          injection_speed: Annotated[float, Param("L/T", "speed v0 of the beam at the cathode", "(0, inf)")] = 0.1,
          node_spacing: Annotated[float, Param("L", "spacing of the lattice of EFG nodes", "(0, inf)")] = 1.0 / 32.0,
          width: Annotated[float, Param("L", "width of the slab, periodic along x", "(0, inf)")] = 0.25,
          d_max: SupportScale = 2.0,
          particles_per_step: Annotated[float, Param("", "macro-particles the cathode emits per step, on average",
                                                     "(0, inf)")] = 20.0,
          dt: Annotated[float, Param("T", "time step Δt of the leapfrog", "(0, inf)")] = 0.02,
          t_end: Annotated[float, Param("T", "time at which the run ends", "(0, inf)")] = 20.0,
          output_every: OutputEvery = 100, gather: ParticleGather = Gather.ENERGY, field_solve: FieldSolveAt = None,
          frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """``voltage`` V and ``gap`` d of the diode; ``injected_fraction``: Γ / Γ_CL; ``injection_speed`` v0; ``width``
    of the periodic slab along x; ``particles_per_step``: macro-particles the cathode emits per step; ``dt``,
    ``t_end`` in T (the potential is averaged over the second half). ``gather``: the field at the particles, energy
    (-∇u^h: the particles' energy follows the potential) or momentum (``PICSolver``). ``field_solve``: where the field
    is solved (None: the host's SuperLU on the CPU, the device on a GPU; ``PICSolver``)."""
    params = dict(locals())
    with reported_as(node_spacing="node_spacing, width, gap"):
        space = walled_box(width, gap)
        nodes = lattice_nodes(space, node_spacing)
    model = MLSModel(nodes, MLSSettings(d_max=d_max), space=space)
    field = PlasmaPoisson(model, walls=(0.0, voltage))
    flux = injected_fraction * child_langmuir_flux(voltage, gap)
    v0 = injection_speed
    beam = Species("electrons", -1.0, 1.0, flux / v0, drift=(0.0, v0))
    n_steps = int(math.ceil(t_end / dt))
    solver = PICSolver(field, [], dt, modes=(), gather=gather, particle_walls=ParticleWall.ABSORB,
                       injections=[Injection(beam, SourceWall.LOWER, particles_per_step)],
                       average_from=0.5 * n_steps * dt, field_solve=field_solve)
    solver.time_unit = TIME_UNIT

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
                  "particles": s.n, "nodes": model.node_count}
        if flux > virtual_cathode_floor(v0, voltage, gap):
            result["steady_virtual_cathode_over_child_langmuir"] = float(
                virtual_cathode_transmitted_flux(flux, v0, voltage, gap) / child_langmuir_flux(voltage, gap))
        tabulated = sheet_model_transmitted_flux(flux, v0, voltage, gap)
        if tabulated is not None:
            result["sheet_model_over_child_langmuir"], result["sheet_model_window_std"] = tabulated
        ref = None
        try:
            ref = steady_potential(y, flux, v0, voltage, gap)
        except ValueError as exc:  # above the space-charge limit: no steady monotone profile
            result["reference"] = str(exc)
        else:
            result["potential_max_error"] = float(np.max(np.abs(mean - ref)) / voltage)
        result["checks"] = diode_checks(result)
        if out_dir is not None:
            write_history(os.path.join(out_dir, "history.csv"), h)
            plot_history(out_dir, h, s, BALANCE_TOLERANCE, f"± {BALANCE_TOLERANCE:g} (round-off)", units=UNITS,
                         below={"values": balance / max(abs(h["injected_charge"][-1]), 1e-300),
                                "label": "(Q_box - Q_injected + Q_absorbed) / Q_injected(end)",
                                "ylabel": "charge balance error", "title": "the charge balance",
                                "xlabel": f"t ({TIME_UNIT})"})
            plot_profile(os.path.join(out_dir, "profile.png"), y, mean, ref, voltage, POTENTIAL_TOLERANCE,
                         f"± {POTENTIAL_TOLERANCE:g} (the tolerance at 32 node spacings)",
                         f"diode at Γ = {injected_fraction:g} Γ_CL: mean potential against the steady beam",
                         xlabel=f"y (L; the gap d = {gap:g} L)", ylabel=f"potential φ ({UNITS['potential']})")
            _phase_space(os.path.join(out_dir, "phase_space.png"), s, y, ref, v0, gap)
        return {"diode": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=output_every * dt, name="pic_diode",
                    params=params, analyses=[diode_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field="velocity_y",
                                         extra_frames=POTENTIAL_FRAMES,
                                         frame_bounds=((0.0, width), (0.0, gap)),
                                         # the beam's speed across the gap: v0 at the cathode, sqrt(v0² + 2V) at the
                                         # anode; the potential between the electrodes' 0 and V
                                         frame_range={"velocity_y": (0.0, float(np.sqrt(v0 ** 2 + 2.0 * voltage))),
                                                      "potential": (0.0, voltage)}, units=UNITS))


def diode_checks(result: dict) -> dict:
    """The validated quantities: below the space-charge limit the mean potential against the steady beam, the
    transmitted current (all of it); above Γ_max, for a case the sheet model has tabulated, the transmitted current
    against its time average; in every case the charge balance."""
    checks = {"charge_balance_error": tolerance_check(
        result["charge_balance_error"], BALANCE_TOLERANCE, "exact: charge in the box = injected - absorbed",
        basis="float64 round-off of the injection and wall tallies (tests/pic/test_pic_diode.py)")}
    if "potential_max_error" in result:
        source = ("steady beam equations φ'' = Γ / sqrt(v0² + 2φ) (Child 1911, Langmuir 1913, Jaffé 1944; "
                  "warpfree/validation/pic_diode)")
        checks["potential_max_error"] = tolerance_check(
            result["potential_max_error"], POTENTIAL_TOLERANCE, source,
            basis="the EFG solve's error at 32 node spacings across the gap (measured 4.7e-5; 2.4e-4 at 16)")
        checks["anode_over_injected"] = tolerance_check(
            result["anode_over_injected"], 1e-6, source + ": a beam-through state passes the whole beam",
            reference=1.0, basis="the fitted slope of the anode tally over the second half: round-off of a "
                                 "steady, fully transmitted beam")
    if "sheet_model_over_child_langmuir" in result:
        checks["anode_over_child_langmuir"] = tolerance_check(
            result["anode_over_child_langmuir"], TRANSMITTED_TOLERANCE,
            "the oscillating virtual cathode's time-averaged flux by the one-dimensional sheet model (exact field, no "
            "grid; warpfree/validation/pic_diode/sheet_model.csv)", reference=result["sheet_model_over_child_langmuir"],
            basis=TRANSMITTED_BASIS)
    return checks


def _phase_space(path, solver, y, steady, v0: float, gap: float):
    """phase_space.png: the electrons' (y, v_y) at the end of the run, and below the space-charge limit the steady
    beam's speed sqrt(v0² + 2 φ(y)) (energy conservation, e = m_e = 1) along the steady potential ``steady``."""
    values = solver.particle_values()
    p, v = values["position"], values["velocity"]
    theory = None if steady is None else (y, np.sqrt(v0 ** 2 + 2.0 * np.asarray(steady)),
                                          "steady beam: v = sqrt(v0² + 2φ(y))")
    plot_phase_space(path, {"electrons": (p[:, 1], v[:, 1])}, f"y (L; the gap d = {gap:g} L)",
                     f"v_y ({UNITS['velocity']})", f"phase space at t = {solver.t:.3g} {TIME_UNIT}", theory)
