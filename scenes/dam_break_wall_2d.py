"""2D dam break against a wall (Buchner 2002): the wall pressure at the transducer P1 against the experiment.

A water column H = 0.6 m high and 2H wide collapses from the left wall of a tank 5.366 H = 3.22 m long and hits the
right wall, where Buchner measured the pressure at P1. The scene is ``dam_break_2d`` in that geometry with a panel
sensor ``P1`` on the right wall: the mean wall pressure over ten points from y = 0.07 to 0.16 m, a face 0.09 m tall
with its top at the experiment's middle, where the reference codes read it (Greco's shift; Adami et al. 2012;
``warpfree/validation/dam_break_2d/README.md``), every 1 ms into ``sensors/P1.csv``. It writes ``wall_pressure.png``
(P1's 5 ms mean against Buchner's points) and the figures into ``summary.json``; its checks
(``warpfree.validation.dam_break_2d.wall_pressure_checks``), in T = t sqrt(g/H) and p/(ρ g H): the water's arrival
(the 5 ms mean passing 0.05) within 5 % of T, no negative mean over the first impact (T = 2.6-3.0), the first peak
and the run-up's mean (T = 3-4) within 20 %. The second peak (the water falling back from the wall, T = 5-6.5) is
reported, not checked: it comes late (T = 6.35 against 5.83) and 24 % high, as late as the reference δ-SPH's.

Model: ``dam_break_2d``'s (Wendland C2, h = 1.6 dx, c0 = 10 sqrt(2 g H), Tait γ = 7, δ-SPH δ = 0.1, dynamic wall
particles), with the pair pressure from a Riemann solver (Zhang, Hu & Adams 2017, η = 3) in place of Monaghan's
artificial viscosity: measured on this case at dx = 0.03, 0.02 and 0.01 m against the artificial viscosity (α = 0.1)
and a fluid without tension, it is the one that brings the water on time (T = 2.45 against 2.47 at dx = 0.01; the
artificial viscosity 2.67) with no negative mean on the wall (``bench/results/buchner_pressure.md``). At dx = 0.02
and coarser the first contact hammers the wall (a 5 ms peak of 2-3 ρ g H under every option): the default is
dx = 0.01 (H/60).
"""

from typing import Annotated

import numpy as np

from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.scenes import dam_break_2d
from warpfree.sensors import PressureSensor
from warpfree.solvers.wcsph.parameters import (ArtificialViscosity, DensityDiffusion, DensityGradient, EndTime,
                                               FixedStep, FrameField, HFactor, OutputInterval, Riemann, SoundSpeed,
                                               Spacing, Tension)
from warpfree.solvers.wcsph import FluidField
from warpfree.time_loop import TimeLoop
from warpfree.validation.dam_break_2d import (BUCHNER_H, BUCHNER_P1_FACE, BUCHNER_P1_FIGURES, BUCHNER_TANK_LENGTH,
                                              plot_wall_pressure, wall_pressure_checks, wall_pressure_figures)

#: the smallest run of this scene worth making (literal values only)
SMALLEST = {"dx": 0.06, "t_end": 0.05, "output_interval": 0.025}

#: ``warpfree validate --quick``: the default spacing to t = 1 s (T = 4.04), past the first peak and the run-up's
#: window; the second peak needs the whole run
QUICK = {"t_end": 1.0}

#: the samples P1 reads its face at, and their interval (s)
FACE_POINTS = 10
SENSOR_INTERVAL = 1.0e-3


@checked_parameters
def build(dx: Spacing = 0.01, t_end: EndTime = 2.0, output_interval: OutputInterval = 0.02,
          riemann: Riemann = 3.0, alpha: ArtificialViscosity = 0.0, tension: Tension = True,
          delta: DensityDiffusion = 0.1, delta_gradient: DensityGradient = False,
          h_factor: HFactor = 1.6, sound_speed: SoundSpeed = 10.0,
          tank_height: Annotated[float, Param("m", "height of the tank", "(0.6, inf)")] = 1.5,
          checkpoint_every: CheckpointEvery = 0, dt: FixedStep = None, frames: Frames = True,
          frame_field: FrameField = FluidField.PRESSURE, vtk: Vtk = True) -> TimeLoop:
    """Build Buchner's dam break with the sensor P1 on the right wall; SI units."""
    params = dict(locals())
    width = 2.0 * BUCHNER_H
    run = dam_break_2d.build(a=width, dx=dx, t_end=t_end, output_interval=output_interval,
                             column_height=BUCHNER_H / width, tank_length=BUCHNER_TANK_LENGTH / width,
                             tank_height=tank_height / width, riemann=riemann, alpha=alpha, tension=tension,
                             delta=delta, delta_gradient=delta_gradient, h_factor=h_factor, sound_speed=sound_speed,
                             checkpoint_every=checkpoint_every, dt=dt, frames=frames, frame_field=frame_field, vtk=vtk)
    run.name, run.params = "dam_break_wall_2d", params
    face = [(BUCHNER_TANK_LENGTH, y) for y in np.linspace(BUCHNER_P1_FACE[1], BUCHNER_P1_FACE[0], FACE_POINTS)]
    run.add_sensor(PressureSensor("P1", face, SENSOR_INTERVAL, mean=True))
    g, rho0 = 9.81, 1000.0
    time_unit, pressure_unit = np.sqrt(BUCHNER_H / g), rho0 * g * BUCHNER_H

    def wall_pressure_analysis(sim: TimeLoop, out_dir: str) -> dict:
        rows = np.asarray(sim.sensor_rows["P1"])
        T, p = rows[:, 0] / time_unit, rows[:, 1] / pressure_unit
        figures = wall_pressure_figures(T, p, smoothing=0.005 / time_unit)
        if out_dir is not None:
            from warpfree.validation import running_mean

            sim.plot("warpfree.validation.dam_break_2d:plot_wall_pressure", path=f"{out_dir}/wall_pressure.png", T=T,
                     p=running_mean(T, p, 0.005 / time_unit), figures=figures, dx=dx)
        return {"wall_pressure": {"figures": figures, "experiment": BUCHNER_P1_FIGURES,
                                  "checks": wall_pressure_checks(figures)}}

    run.analyses = [a for a in run.analyses] + [wall_pressure_analysis]
    return run
