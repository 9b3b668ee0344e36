"""Cold two-stream instability: the growth rate of the fastest mode against cold-beam theory.

Normalised units (ω_pe = 1 for the two beams together). Two cold electron beams of density 1/2 each drift at ±v0
along x on an immobile neutralising background, in a periodic box one wavelength of the seeded mode long (by
default the fastest-growing one, k v0 = sqrt(3/8) ω_p = 0.612 ω_p, so Lx = 2π v0 / 0.612; ``wavenumber`` sets k v0,
below ω_p where the mode grows). Both beams start on quiet lattices, their velocities
perturbed by ``amplitude`` v0 sin(kx) with opposite signs (a pure density bunching seed). Measured: the growth rate
γ, half the slope of log(field energy of mode (1, 0)) fitted while that energy lies between ``fit_window`` times
the beams' initial kinetic energy (the linear phase: above the seed's transient, below saturation), against the
cold-beam theory's γ at that k (γ_max = ω_p/(2√2) at the default; ``warpfree.validation.pic_two_stream``; the
target: within 10 %). Writes ``history.csv``,
``energy.png`` (with the total energy's drift),
``mode.png`` (the mode's energy against the theory's e^{2γt} over the fitted window, and the local growth rate), ``phase_space.png`` (x, v_x at the end), particle frames and VTU.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.galerkin.mls import MLSModel, MLSSettings, SupportScale
from warpfree.solvers.pic import Gather, PICSolver, PlasmaPoisson, Species, lattice_positions, load_species
from warpfree.solvers.pic.parameters import (EndTime, FieldSolveAt, LengthY, NodeSpacing, OutputEvery, ParticleGather,
                                             TimeStep, Density, ElectronTemperature)
from warpfree.solvers.pic.scene_tools import (ENERGY_DRIFT_TARGET, POTENTIAL_FRAMES, lattice_nodes, momentum_change,
                                              periodic_box, plot_growth, plot_history, relative_drift, write_history)
from warpfree.solvers.pic.units import plasma_units
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.pic_two_stream import GAMMA_MAX, K_V0_FASTEST, growth_rate


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"node_spacing": 1.0, "length_y": 4.0, "particles_per_node": 2, "d_max": 1.8, "t_end": 2.4,
            "output_every": 4}

#: ``warpfree validate --quick``: the default resolution up to t = 30 (past the fit window, which ends near t = 22;
#: about 10 s on 2 cores), VTU and frames off
QUICK = {"t_end": 30.0}

#: the growth rate's tolerance, relative to γ_max (the validation README's target)
GROWTH_TOLERANCE = 0.10
#: the momentum gather conserves momentum to round-off: |ΔP| over one beam's momentum (float64; tests/pic)
ROUND_OFF = 1e-12


@checked_parameters
def build(beam_speed: Annotated[float, Param("λ_D ω_pe", "drift speed v0 of the beams (at ±v0)", "(0, inf)")] = 1.0,
          wavenumber: Annotated[float, Param("ω_pe/v0", "wavenumber k of the seeded mode, as k v0/ω_pe (the box is "
                                                        "2π/k long; unstable below 1, fastest at √(3/8) = 0.612)",
                                             "(0, 1)")] = K_V0_FASTEST,
          length_y: LengthY = 4.0, node_spacing: NodeSpacing = 0.5, d_max: SupportScale = 2.0,
          particles_per_node: Annotated[int, Param("", "electrons of each beam per node spacing along each axis (a "
                                                       "quiet lattice)", "[1, inf)")] = 4,
          amplitude: Annotated[float, Param("v0", "velocity perturbation of the beams, δv/v0", "(0, inf)")] = 1e-4,
          dt: TimeStep = 0.1, t_end: EndTime = 40.0,
          fit_window: Annotated[tuple[float, float], Param("", "the mode's field energy, as fractions (low, high) of "
                                                               "the beams' kinetic energy, between which γ is fitted",
                                                           "(0, inf)")] = (1e-6, 1e-3),
          gather: ParticleGather = Gather.MOMENTUM, output_every: OutputEvery = 20, field_solve: FieldSolveAt = None,
          frames: Frames = True, vtk: Vtk = True, density: Density = None,
          electron_temperature: ElectronTemperature = None) -> TimeLoop:
    """``beam_speed`` v0; ``wavenumber``: k v0/ω_pe of the seeded mode (the box one wavelength long);
    ``amplitude``: the velocity perturbation / v0; ``dt``, ``t_end`` in 1/ω_pe; ``fit_window``:
    the mode's field energy, as fractions of the beams' kinetic energy, between which γ is fitted; ``gather``
    "momentum" or "energy" (``warpfree.solvers.pic.field``). ``field_solve``: where the field is solved (None: the
    host's SuperLU on the CPU, the device on a GPU; ``PICSolver``). ``density`` (m⁻³) and ``electron_temperature``
    (eV): the results also in SI (:mod:`warpfree.solvers.pic.units`)."""
    params = dict(locals())
    units = plasma_units(density, electron_temperature)
    v0 = beam_speed
    lo, hi = fit_window
    if not lo < hi:
        raise ParameterError("fit_window", f"must be two fractions 0 < low < high, got {fit_window!r}")
    k = wavenumber / v0
    length = 2.0 * math.pi / k
    gamma_theory = growth_rate(wavenumber)  # the cold-beam dispersion relation at this k
    with reported_as(length_y="length_y", node_spacing="node_spacing, beam_speed, length_y"):
        space = periodic_box(length, length_y)
        nodes = lattice_nodes(space, node_spacing)
    model = MLSModel(nodes, MLSSettings(d_max=d_max), space=space)
    field = PlasmaPoisson(model)
    counts = [int(round(space.length[a] / node_spacing)) * particles_per_node for a in range(2)]
    loads = []
    for name, sign in (("beam+", 1.0), ("beam-", -1.0)):
        with reported_as(counts="particles_per_node"):
            position = lattice_positions(space, counts)
        velocity = np.zeros_like(position)
        velocity[:, 0] = sign * v0 * (1.0 + sign * amplitude * np.sin(k * position[:, 0]))
        loads.append(load_species(Species(name, -1.0, 1.0, 0.5, drift=(sign * v0, 0.0)), space, position,
                                  velocity=velocity))
    solver = PICSolver(field, loads, dt, modes=[(1, 0)], gather=gather, field_solve=field_solve)
    n_steps = int(math.ceil(t_end / dt))

    def growth_analysis(run, out_dir):
        h = run.solver.history
        t = np.asarray(h["time"])
        e = np.asarray(h["mode_1_0_energy"])
        kinetic0 = h["kinetic_energy"][0]
        inside = (e > lo * kinetic0) & (e < hi * kinetic0)
        result = {"growth_rate_theory": gamma_theory, "growth_rate_max": GAMMA_MAX, "k_v0": wavenumber,
                  "total_energy_drift": relative_drift(h["total_energy"]),
                  "momentum_change": momentum_change(h),
                  "particles": run.solver.n, "nodes": model.node_count, "box": [length, length_y]}
        # the first contiguous run of steps inside the window: the linear phase
        idx = np.flatnonzero(inside)
        if idx.size >= 10:
            first = idx[: np.argmax(np.diff(np.r_[idx, idx[-1] + 2]) > 1) + 1]
            slope = np.polyfit(t[first], np.log(e[first]), 1)[0]
            gamma = 0.5 * slope
            result.update(growth_rate=gamma, growth_rate_rel_error=gamma / gamma_theory - 1.0,
                          fit_from=float(t[first[0]]), fit_to=float(t[first[-1]]))
        else:
            result["growth_rate_error"] = (f"the mode's energy spent {idx.size} steps inside the fit window "
                                           f"{fit_window}: run longer or widen it")
        result["beam_momentum"] = 0.5 * v0 * length * length_y     # one beam's: density 1/2, mass 1, speed v0
        result["checks"] = two_stream_checks(result)
        if units is not None:
            result["si"] = units.describe({"growth_rate": (result.get("growth_rate", math.nan), "rate"),
                                           "growth_rate_theory": (gamma_theory, "rate"),
                                           "beam_speed": (v0, "speed"), "wavelength": (length, "length")})
        if out_dir is not None:
            write_history(os.path.join(out_dir, "history.csv"), h)
            plot_history(out_dir, h, energy_tolerance=ENERGY_DRIFT_TARGET,
                         tolerance_label="1 % (the thermal plasma's target; not checked here)")
            window = (result["fit_from"], result["fit_to"]) if "growth_rate" in result else None
            plot_growth(os.path.join(out_dir, "mode.png"), t, e, gamma_theory, result.get("growth_rate"), window,
                        GROWTH_TOLERANCE, 0.01 * lo * kinetic0,
                        "two-stream instability: mode (1, 0) against cold-beam linear theory")
            _phase_space(os.path.join(out_dir, "phase_space.png"), run.solver)
        return {"two_stream": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=output_every * dt, name="pic_two_stream",
                    params=params, analyses=[growth_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field="velocity_x",
                                         extra_frames=POTENTIAL_FRAMES,
                                         frame_bounds=((0.0, length), (0.0, length_y)),
                                         # the beams at ±v0 spread to about ±2 v0 once trapped; the potential saturates
                                         # near m v0²/e
                                         frame_range={"velocity_x": (-2.0 * v0, 2.0 * v0),
                                                      "potential": (-v0 ** 2, v0 ** 2)}))


def two_stream_checks(result: dict) -> dict:
    """The validated quantities: the growth rate against γ_max (within 10 %) and the momentum (conserved to
    round-off)."""
    return {"growth_rate_rel_error": tolerance_check(
                result.get("growth_rate_rel_error", math.nan), GROWTH_TOLERANCE,
                f"cold-beam dispersion relation at k v0 = {result['k_v0']:.4g} ω_p: γ = "
                f"{result['growth_rate_theory']:.4g} ω_p (γ_max = ω_p/(2√2) at 0.612), Birdsall & Langdon §5-10 "
                "(warpfree/validation/pic_two_stream)",
                basis="the validation README's target (10 % of the theory's γ); measured -2.1 % at the default"),
            "momentum_change_over_beam": tolerance_check(
                result["momentum_change"] / result["beam_momentum"], ROUND_OFF,
                "exact: the momentum gather conserves momentum",
                basis="float64 round-off of the antisymmetric force over the run, relative to one beam's momentum")}


def _phase_space(path, solver):
    """phase_space.png: both beams' (x, v_x) at the end of the run (past saturation: no linear theory there)."""
    from warpfree.solvers.pic.scene_tools import plot_phase_space

    values = solver.particle_values()
    x, vx, s = values["position"][:, 0], values["velocity"][:, 0], values["species"]
    plot_phase_space(path, {f"beam {'+-'[b]}": (x[s == b], vx[s == b]) for b in (0, 1)}, "x (λ_D)",
                     "v_x (λ_D ω_pe)", f"phase space at t = {solver.t:.3g} / ω_pe")
