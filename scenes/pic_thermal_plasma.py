"""Thermal plasma in a periodic box: energy conservation with electrons and protons moving.

Marques (2008), §6.1/6.3.

Normalised units: electrons (charge -1, mass 1, density 1, temperature 1: ω_pe = 1, λ_D = 1) and protons (charge
+1, mass ``mass_ratio``, density 1, temperature ``ion_temperature``: Marques (2008), §6.3 has electrons at 10⁴ K and
protons at 10³ K, so 0.1) in a box of ``box`` Debye lengths (Marques 2008: 64 × 128), periodic both ways, neutral
without a background. EFG nodes on a lattice of ``node_spacing`` λ_D (supports d_max · spacing: about λ_D-sized
diffuse cells, as the thesis sized them), particles at random positions (``particles_per_node`` of each species
per node cell) with Maxwell–Boltzmann velocities. Measured: the total-energy drift (the target: below 1 % over 50
plasma periods), the heating rate of each species, momentum and charge.
Writes ``history.csv``, ``energy.png`` (with the total energy's drift and its 1 % target), ``potential.png``,
particle frames and VTU.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Seed, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.galerkin.mls import MLSModel, MLSSettings, SupportScale
from warpfree.solvers.pic import Gather, PICSolver, PlasmaPoisson, Species, load_species, random_positions
from warpfree.solvers.pic.parameters import (FieldSolveAt, NodeSpacing, OutputEvery, ParticleGather, Periods,
                                             TimeStep, Density, ElectronTemperature)
from warpfree.solvers.pic.scene_tools import (ENERGY_DRIFT_TARGET, POTENTIAL_FRAMES, lattice_nodes, momentum_change,
                                              periodic_box, plot_history, relative_drift, write_history)
from warpfree.solvers.pic.units import plasma_units
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"box": (8.0, 16.0), "periods": 1.0, "output_every": 10}
#: what the benchmarks run of this scene for its family (bench/common.py ``benchmarks``): bench/core/gpu_check.py's
#: throughput at three sizes (``parameter`` set to each of ``values``, ``steps`` timed per block) and
#: bench/core/scaling.py's n and 2n work items on one and two ranks (the settings of each, per sweep size)
BENCHMARK = {"parameter": "box", "values": [(16.0, 32.0), (32.0, 64.0), (64.0, 128.0)], "steps": 20,
             "scaling": {"large": [{"box": (32.0, 32.0)}, {"box": (32.0, 64.0)}],
                         "small": [{"box": (16.0, 32.0)}, {"box": (16.0, 64.0)}]}}

#: ``warpfree validate --quick``: a box of 8 × 16 λ_D for 10 plasma periods (the energy test of tests/pic), VTU and
#: frames off; the default (64 × 128 λ_D, 262 144 particles, 50 periods) runs for hours on 2 cores
QUICK = {"box": (8.0, 16.0), "periods": 10.0}

#: the momentum gather conserves momentum to round-off: |ΔP| over the thermal momentum sqrt(N) m v_th (tests/pic)
ROUND_OFF = 1e-10


@checked_parameters
def build(box: Annotated[tuple[float, float], Param("λ_D", "size (Lx, Ly) of the box, periodic both ways",
                                                    "(0, inf)")] = (64.0, 128.0),
          node_spacing: NodeSpacing = 1.0, d_max: SupportScale = 2.0,
          particles_per_node: Annotated[int, Param("", "macro-particles of each species per node cell", "[1, inf)")]
          = 16,
          mass_ratio: Annotated[float, Param("", "proton to electron mass ratio m_p/m_e", "(0, inf)")] = 1836.15,
          ion_temperature: Annotated[float, Param("T_e", "proton temperature T_p (0: cold)", "[0, inf)")] = 0.1,
          dt: TimeStep = 0.2, periods: Periods = 50.0, gather: ParticleGather = Gather.MOMENTUM, seed: Seed = 0,
          output_every: OutputEvery = 50, field_solve: FieldSolveAt = None, frames: Frames = True,
          vtk: Vtk = True, density: Density = None,
          electron_temperature: ElectronTemperature = None) -> TimeLoop:
    """``box`` (Lx, Ly) in λ_D; ``node_spacing`` in λ_D; ``particles_per_node``: macro-particles of each species per
    node cell; ``mass_ratio`` m_p/m_e; ``ion_temperature`` T_p/T_e; ``dt`` in 1/ω_pe; ``periods`` 2π/ω_pe.
    ``field_solve``: where the field is solved (None: the host's SuperLU on the CPU, the device on a GPU;
    ``PICSolver``). ``density`` (m⁻³) and ``electron_temperature`` (eV): the results also in SI
    (:mod:`warpfree.solvers.pic.units`)."""
    params = dict(locals())
    units = plasma_units(density, electron_temperature)
    lx, ly = box
    with reported_as(length_x="box", length_y="box", node_spacing="node_spacing, box"):
        space = periodic_box(lx, ly)
        nodes = lattice_nodes(space, node_spacing)
    model = MLSModel(nodes, MLSSettings(d_max=d_max), space=space)
    field = PlasmaPoisson(model)
    rng = np.random.default_rng(seed)
    count = particles_per_node * nodes.shape[0]
    with reported_as(count="particles_per_node", mass="mass_ratio", temperature="ion_temperature"):
        loads = [load_species(Species("electron", -1.0, 1.0, 1.0, 1.0), space, random_positions(space, count, rng),
                              rng),
                 load_species(Species("proton", 1.0, mass_ratio, 1.0, ion_temperature), space,
                              random_positions(space, count, rng), rng)]
    solver = PICSolver(field, loads, dt, modes=[(1, 0), (0, 1)], gather=gather, field_solve=field_solve)
    n_steps = int(math.ceil(periods * 2.0 * math.pi / dt))

    def energy_analysis(run, out_dir):
        h = run.solver.history
        t = np.asarray(h["time"])
        total = np.asarray(h["total_energy"])
        kinetic0 = h["kinetic_energy"][0]
        slope = float(np.polyfit(t, total, 1)[0]) if t.size > 2 else 0.0
        result = {
            "total_energy_drift": relative_drift(total),
            "end_drift": float((total[-1] - total[0]) / total[0]),
            "heating_rate_per_period": slope * 2.0 * math.pi / kinetic0,
            "momentum_change": momentum_change(h),
            "thermal_momentum": float(math.sqrt(count) * run.solver.macro_mass_np[0]),
            "charge_error": float(np.max(np.abs(np.asarray(h["deposited_charge"])))),
            "particles": run.solver.n, "nodes": model.node_count, "steps": int(t.size),
            # the first time in the per-step history: 0, also after a resume (checkpoints keep the history)
            "history_from": float(t[0]),
            "particles_per_support": float(count / nodes.shape[0] * math.pi * (d_max * node_spacing) ** 2
                                           / node_spacing ** 2)}
        result["checks"] = thermal_checks(result)
        if units is not None:
            result["si"] = units.describe({"box_x": (lx, "length"), "box_y": (ly, "length"),
                                           "duration": (float(t[-1]), "time")})
        if out_dir is not None:
            write_history(os.path.join(out_dir, "history.csv"), h)
            plot_history(out_dir, h, run.solver, ENERGY_DRIFT_TARGET, "± 1 % (the target over 50 plasma periods)")
        return {"thermal": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=output_every * dt, name="pic_thermal_plasma",
                    params=params, analyses=[energy_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field="velocity_x",
                                         extra_frames=POTENTIAL_FRAMES,
                                         frame_bounds=((0.0, lx), (0.0, ly)),
                                         # ±3 electron thermal speeds; the potential in k T_e/e (1)
                                         frame_range={"velocity_x": (-3.0, 3.0), "potential": (-1.0, 1.0)}))


def thermal_checks(result: dict) -> dict:
    """The validated quantities: the total-energy drift (below 1 %) and the momentum (conserved to round-off)."""
    return {"total_energy_drift": tolerance_check(
                result["total_energy_drift"], ENERGY_DRIFT_TARGET,
                "energy conservation of a thermal plasma, the case of Marques (2008), §6.1/6.3 (the scene's target)",
                basis="the target: below 1 % over 50 plasma periods (QUICK: over 10, a shorter span of the same "
                      "target)"),
            "momentum_change_over_thermal": tolerance_check(
                result["momentum_change"] / result["thermal_momentum"], ROUND_OFF,
                "exact: the momentum gather conserves momentum",
                basis="float64 round-off of the antisymmetric force over the run (tests/pic)")}
