"""Cold plasma oscillation: electrons displaced by δ sin(kx) on a neutralising background oscillate at ω_p.

Normalised units (ω_pe = 1). A box of one wavelength 2π/k along x, periodic both ways; EFG nodes on a lattice
(``node_spacing``, linear basis, cubic spline, d_max), electrons on a quiet lattice of ``particles_per_node`` per
node cell per axis, displaced by ``amplitude`` sin(kx). Measured: the frequency from the zero crossings of the
potential's k-mode against the leapfrog value (2/Δt) asin(ω_pΔt/2) (``warpfree.validation.pic_plasma_oscillation``),
the total-energy drift, the momentum and the deposited charge. Writes ``history.csv`` (every step),
``energy.png`` (the energies and the total energy's drift), ``mode.png`` (the k-mode of the potential against
the leapfrog's cosine, and their difference), particle frames coloured by speed (|v| = δ ω_p |sin kx sin ω_p t|: the oscillation's
velocity, along x) and VTU (particles, nodes with potential and charge).

The frequency error against node spacing and support radius: ``bench/results/scene_studies.md``.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.galerkin.mls import MLSModel, MLSSettings, SupportScale
from warpfree.solvers.pic import Gather, PICSolver, PlasmaPoisson, Species, lattice_positions, load_species
from warpfree.solvers.pic.parameters import (FieldSolveAt, LengthY, NodeSpacing, OutputEvery, ParticleGather, Periods,
                                             TimeStep, Density, ElectronTemperature)
from warpfree.solvers.pic.scene_tools import (ENERGY_DRIFT_TARGET, POTENTIAL_FRAMES, lattice_nodes, momentum_change,
                                              periodic_box, plot_history, plot_oscillation, relative_drift,
                                              write_history)
from warpfree.solvers.pic.units import plasma_units
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.pic_plasma_oscillation import frequency_from_crossings, leapfrog_frequency


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"node_spacing": 0.5, "periods": 1.0, "output_every": 8}

#: ``warpfree validate --quick``: the default resolution (4 periods, about 6 s on 2 cores) with VTU and frames off;
#: its frequency error (-0.25 %) is the default's
QUICK = {"periods": 4.0}

#: the frequency's tolerance, relative to the leapfrog value (the validation README's target)
FREQUENCY_TOLERANCE = 0.01
#: the deposit conserves charge and the momentum gather momentum to round-off (float64; tests/pic)
ROUND_OFF = 1e-12


@checked_parameters
def build(wavenumber: Annotated[float, Param("1/λ_D", "wavenumber k of the displacement (the box is 2π/k long)",
                                             "(0, inf)")] = 0.5,
          length_y: LengthY = 4.0, node_spacing: NodeSpacing = 0.25, d_max: SupportScale = 2.0,
          particles_per_node: Annotated[int, Param("", "electrons per node spacing along each axis (a quiet lattice)",
                                                   "[1, inf)")] = 2,
          amplitude: Annotated[float, Param("λ_D", "displacement δ of the electrons, δ sin(kx)", "(0, inf)")] = 0.01,
          dt: TimeStep = 0.1, periods: Periods = 4.0, gather: ParticleGather = Gather.MOMENTUM,
          output_every: OutputEvery = 16, field_solve: FieldSolveAt = None, frames: Frames = True,
          vtk: Vtk = True, density: Density = None,
          electron_temperature: ElectronTemperature = None) -> TimeLoop:
    """``wavenumber`` k (1/λ_D units; the box is 2π/k long); ``amplitude`` δ of the displacement; ``dt`` in 1/ω_pe;
    ``periods`` of ω_p to run; ``gather`` "momentum" or "energy" (``warpfree.solvers.pic.field``); outputs every
    ``output_every`` steps. ``field_solve``: where the field is solved (None: the host's SuperLU on the CPU, the
    device on a GPU; ``PICSolver``). ``density`` (m⁻³) and ``electron_temperature`` (eV): the results also in SI
    (:mod:`warpfree.solvers.pic.units`)."""
    params = dict(locals())
    units = plasma_units(density, electron_temperature)
    k = wavenumber
    length = 2.0 * math.pi / k
    with reported_as(length_y="length_y", node_spacing="node_spacing, wavenumber, length_y"):
        space = periodic_box(length, length_y)
        nodes = lattice_nodes(space, node_spacing)
    model = MLSModel(nodes, MLSSettings(d_max=d_max), space=space)
    field = PlasmaPoisson(model)
    counts = [int(round(space.length[a] / node_spacing)) * particles_per_node for a in range(2)]
    with reported_as(counts="particles_per_node"):
        position = lattice_positions(space, counts)
    position[:, 0] = np.mod(position[:, 0] + amplitude * np.sin(k * position[:, 0]), length)
    electrons = load_species(Species("electron", -1.0, 1.0, 1.0), space, position)
    solver = PICSolver(field, [electrons], dt, modes=[(1, 0)], gather=gather, field_solve=field_solve)
    n_steps = int(math.ceil(periods * 2.0 * math.pi / dt))

    def oscillation_analysis(run, out_dir):
        h = run.solver.history
        reference = leapfrog_frequency(run.solver.plasma_frequency, dt)
        try:
            omega = frequency_from_crossings(h["time"], h["mode_1_0_potential_re"])
        except ValueError as exc:  # a run too short to cross zero twice (or an interrupted one) has no frequency
            result = {"frequency_error": str(exc), "leapfrog_frequency": reference}
        else:
            result = {"frequency": omega, "leapfrog_frequency": reference, "frequency_rel_error": omega / reference - 1.0}
        result.update(total_energy_drift=relative_drift(h["total_energy"]), momentum_change=momentum_change(h),
                      charge_rel_error=float(np.max(np.abs(np.asarray(h["deposited_charge"])
                                                           / run.solver.initial_particle_charge - 1.0))),
                      particles=run.solver.n, nodes=model.node_count, steps=len(h["time"]))
        result["checks"] = oscillation_checks(result)
        if units is not None:
            result["si"] = units.describe({"frequency": (result.get("frequency", math.nan), "angular_frequency"),
                                           "leapfrog_frequency": (reference, "angular_frequency"),
                                           "wavelength": (length, "length"), "amplitude": (amplitude, "length")})
        if out_dir is not None:
            write_history(os.path.join(out_dir, "history.csv"), h)
            plot_history(out_dir, h, energy_tolerance=ENERGY_DRIFT_TARGET,
                         tolerance_label="1 % (the thermal plasma's target; not checked here)")
            plot_oscillation(os.path.join(out_dir, "mode.png"), h["time"], h["mode_1_0_potential_re"], reference,
                             FREQUENCY_TOLERANCE, f"plasma oscillation, k = {k:g} / λ_D: PIC against the leapfrog's "
                                                  f"cold oscillation")
        return {"oscillation": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=output_every * dt, name="pic_plasma_oscillation",
                    params=params, analyses=[oscillation_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field="velocity_x",
                                         extra_frames=POTENTIAL_FRAMES,
                                         frame_bounds=((0.0, length), (0.0, length_y)),
                                         # the cold oscillation's amplitudes: v δ ω_p, φ δ/k (n = 1, ω_p = 1)
                                         frame_range={"velocity_x": (-amplitude, amplitude),
                                                      "potential": (-amplitude / k, amplitude / k)}))


def oscillation_checks(result: dict) -> dict:
    """The validated quantities: the frequency against the leapfrog's (within 1 %), the deposited charge and the
    momentum (both conserved to round-off)."""
    source = "leapfrog cold plasma oscillation, Birdsall & Langdon §4-4 (warpfree/validation/pic_plasma_oscillation)"
    checks = {"charge_rel_error": tolerance_check(
                  result["charge_rel_error"], ROUND_OFF, "exact: the deposit conserves charge",
                  basis="float64 round-off of the deposit's partition of unity (tests/pic)"),
              "momentum_change": tolerance_check(
                  result["momentum_change"], ROUND_OFF, "exact: the momentum gather conserves momentum",
                  basis="float64 round-off of the antisymmetric force over the run (tests/pic)")}
    checks["frequency_rel_error"] = tolerance_check(
        result.get("frequency_rel_error", math.nan), FREQUENCY_TOLERANCE, source,
        basis="the validation README's target (1 % of the leapfrog frequency); measured -0.25 % at the default")
    return checks
