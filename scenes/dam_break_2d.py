"""2D dam break (Martin & Moyce 1952): WCSPH surge front against the experiments.

A water column of width a and height n² a (``column_height``, default 2) collapses in a tank of length 4a. The
surge front Z = x_front/a against Martin & Moyce's T = t sqrt(n² g/a) is compared with the experiments: for n² = 2 Martin & Moyce (1952) and Koshizuka &
Oka (1996), at T <= 2.5; for n² = 1 (the square column at the experiment's size, ``--set a=0.05715 --set
dx=0.00142875 --set column_height=1 --set tank_length=15 --set tank_height=2 --set t_end=0.74``) Martin & Moyce's
square-column series up to T = 9.5. The run writes ``front.png`` (the front against the experiments, and its error
with the checks' tolerance) and the errors into ``summary.json``; its checks
(``warpfree.validation.dam_break_2d.front_checks``): |ΔZ| <= 0.45 against Martin & Moyce over T <= 2.5 and <= 0.15
over T <= 1 (n² = 2), |ΔZ|/Z <= 20 % (n² = 1). Compare at the experiment's size: the water's viscosity slows a 5.7 cm
surge over the floor and not a 1 m one (the square column at a = 1 m runs 25 % ahead, at 2¼ in 17 %; without
viscosity 25 % at both), and most of the n² = 2 front's lead is the experiment's gate release, which the model opens
at once (``bench/results/surge_front_scale.md``).

Model: WCSPH (Monaghan 1994) with Wendland C2, h = 1.6 dx (the 2D default; the comparison with 1.3 dx: ``bench/results/scene_studies.md``), c0 = 10 sqrt(2 g 2a), Tait γ = 7, laminar
μ = 1e-3 Pa·s, Monaghan artificial viscosity α = 0.1 (as PySPH's dam_break_2d), δ-SPH δ = 0.1 and
dynamic (Adami 2012) wall particles, three layers, no-slip, with Monaghan's (1994) Lennard-Jones force
(D = 2gH) as a safety net below r0 = 0.75 dx (``wall_safety``; 0 switches it off). Options measured on Buchner's wall
pressure (``bench/results/buchner_pressure.md``): the Riemann pair pressure in place of the artificial viscosity
(``--set riemann=3 --set alpha=0``) and a fluid without tension (``--set tension=false``).

Time step: the CFL condition dt = C h/(c0 + max|v|), with C = 0.4, the largest step that keeps the error with a
margin (the study: ``bench/results/scene_studies.md``). (Chapter 5 of a Portuguese thesis on SPH fluids prints
0.1, its eq. 5-12; DualSPHysics' dam break uses 0.2.)
"""

import os
from typing import Annotated

import numpy as np

from warpfree.geometry import lattice_box
from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.smoothing import SmoothingKernel
from warpfree.solvers.wcsph.parameters import (ArtificialViscosity, Courant, DensityDiffusion, DensityGradient,
                                               DynamicViscosity, EndTime, FixedStep, FrameField, Gravity, HFactor,
                                               Kernel, OutputInterval, Pairs, RestDensity, Riemann, Shifting,
                                               SoundSpeed, Spacing, Tension, WallLayers, Walls, WallSafety)
from warpfree.solvers.wcsph.scene_tools import (box_2d, box_walls_2d, front_position, hydrostatic_density,
                                                 require_wall_cover)
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import BoundaryModel, FluidField, FluidPairs, FluidParams, WCSPHModel, WCSPHSolver
from warpfree.time_loop import TimeLoop
from warpfree.validation.dam_break_2d import front_checks, front_errors


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"dx": 0.1, "t_end": 0.1, "output_interval": 0.02}
#: what the benchmarks run of this scene for its family (bench/common.py ``benchmarks``): bench/core/gpu_check.py's
#: throughput at three sizes (``parameter`` set to each of ``values``, ``steps`` timed per block) and
#: bench/core/scaling.py's n and 2n work items on one and two ranks (the settings of each, per sweep size)
BENCHMARK = {"parameter": "dx", "values": [0.04, 0.02, 0.01], "steps": 40,
             "scaling": {"large": [{"t_end": 0.03, "dx": 0.0141}, {"t_end": 0.03, "dx": 0.01}],
                         "small": [{"t_end": 0.06, "dx": 0.0283}, {"t_end": 0.06, "dx": 0.02}]}}

#: ``warpfree validate --quick``: dx = a/20 to T = 2.5 (t = 0.564 s), the end of the checked window; the checks'
#: tolerances hold at every resolution from a/20 to a/50 (their basis: ``front_checks``)
QUICK = {"dx": 0.05, "t_end": 0.57}


@checked_parameters
def build(a: Annotated[float, Param("m", "width a of the water column", "(0, inf)")] = 1.0,
          dx: Spacing = 0.025, t_end: EndTime = 0.8, output_interval: OutputInterval = 0.02,
          column_height: Annotated[float, Param("a", "height of the water column, in column widths a", "(0, inf)")] = 2.0,
          tank_length: Annotated[float, Param("a", "length of the tank, in column widths a", "(1, inf)")] = 4.0,
          tank_height: Annotated[float, Param("a", "height of the tank, in column widths a", "(0, inf)")] = 4.0,
          h_factor: HFactor = 1.6, kernel: Kernel = SmoothingKernel.WENDLAND_C2, alpha: ArtificialViscosity = 0.1,
          wall_artificial: Annotated[bool, Param("", "artificial viscosity on fluid-wall pairs too")] = False,
          delta: DensityDiffusion = 0.1, delta_gradient: DensityGradient = False,
          mu: DynamicViscosity = 1.0e-3, boundary_model: Walls = BoundaryModel.DYNAMIC,
          wall_safety: WallSafety = 0.75, cfl: Courant = 0.4, g: Gravity = 9.81, rho0: RestDensity = 1000.0,
          wall_layers: WallLayers = 3, checkpoint_every: CheckpointEvery = 0, dt: FixedStep = None,
          frames: Frames = True, frame_field: FrameField = FluidField.SPEED, vtk: Vtk = True,
          sound_speed: SoundSpeed = 10.0, shifting: Shifting = 0.0, riemann: Riemann = 0.0,
          tension: Tension = True, fluid_pairs: Pairs = FluidPairs.ROWS) -> TimeLoop:
    """Build the dam break; lengths in units of a (tank_length, tank_height), SI otherwise."""
    params = dict(locals())
    if tank_height <= column_height:
        raise ParameterError("tank_height", f"the tank (in units of a) must hold the 1 x {column_height} column: got "
                                            f"{tank_length} x {tank_height}")
    height = column_height * a
    length, top = tank_length * a, tank_height * a
    c0 = sound_speed * np.sqrt(2.0 * g * height)
    fluid = lattice_box((0.0, 0.0), (a, height), dx)
    with reported_as(layers="wall_layers", lj_r0="wall_safety"):
        walls = box_walls_2d(length, top, dx, wall_layers)
        fp = FluidParams(dim=2, dx=dx, h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, alpha=alpha,
                         delta=delta, delta_gradient=delta_gradient, gravity=(0.0, -g, 0.0), boundary_model=boundary_model, cfl=cfl,
                         wall_artificial_viscosity=wall_artificial, lj_d=2.0 * g * height, shifting=shifting,
                         riemann=riemann, tension=tension, fluid_pairs=fluid_pairs,
                         lj_r0=dx if boundary_model is BoundaryModel.LENNARD_JONES else wall_safety * dx,
                         container_lo=(0.0, 0.0, -1.0), container_hi=(length, top, 1.0))
        require_wall_cover(wall_layers, dx, fp.support, fp.boundary_model)
        model = WCSPHModel(fluid, walls, fp, containers=[box_2d(length, top)])
        solver = WCSPHSolver(model, density=hydrostatic_density(fluid[:, 1], height, rho0, c0, g))

    t_max = 2.5 if column_height == 2.0 else None  # the n² = 2 comparison stops at T = 2.5 (see README)

    def front_analysis(sim: TimeLoop, out_dir: str) -> dict:
        t = np.asarray(sim.series["time"])
        xf = np.asarray(sim.series["front"])
        err = front_errors(t, xf, a, g, t_max=t_max, height_ratio=column_height)
        T = t * np.sqrt(column_height * g / a)
        if out_dir is not None:
            sim.plot("warpfree.validation.dam_break_2d:plot_front", path=os.path.join(out_dir, "front.png"), t=t,
                     x_front=xf, a=a, g=g, max_err=err["max_abs"], height_ratio=column_height, t_max=t_max)
        front = {"T": T.tolist(), "Z": (xf / a).tolist()}
        if err["max_abs"] is not None:  # a column some experiment has
            front.update(errors=err, max_abs_dZ=err["max_abs"], T_max=t_max,
                         checks=front_checks(err, float(T[-1]), column_height, t_max))
        return {"front": front}

    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="dam_break_2d",
                      params=params, probes={"front": front_position}, analyses=[front_analysis],
                      dt=dt, checkpoint_every=checkpoint_every,
                      output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field, plots=True,
                                           frame_bounds=((-0.1 * a, length + 0.1 * a), (-0.1 * a, top + 0.1 * a)),
                                           frame_range={"speed": (0.0, float(np.sqrt(2.0 * g * height))),
                                                        "pressure": (0.0, rho0 * g * height)}))
