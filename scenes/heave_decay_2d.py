"""Heave decay: a half-immersed circular cylinder released above its floating level, against Ursell's linear theory.

A horizontal cylinder of radius a = ``radius`` and half the water's density floats with its axis in the still water
level of deep water (``depth`` a deep, the tank ``2 half_length`` a long: its radiated waves come back after about
2 ``half_length`` a/c_g, past the run's end at the defaults). It is a rigid body of wall particles in rings inside its
true surface, free in heave alone. Held ``drop`` a above its floating level while the water settles with damping for
``settle`` (in sqrt(a/g)), it is released at t = 0; the waves it makes carry its energy away and it comes to rest
in a few periods.

The ``cylinder`` body sensor records it every ``sensor_interval``; the analysis compares its height above the floating
level, y(t)/y0 against t̂ = t sqrt(g/a), with the linear transient of Ursell's theory
(``warpfree.validation.heave_decay_2d``: the added mass and wave damping of the forced motion at every frequency, and
the free motion their Fourier integral gives; its damped period 7.13 sqrt(a/g) at ω̂_n = 0.893, added mass 0.596 of
the displaced mass, damping ratio 0.164). Checks: the period between the motion's first and third zero crossings
within 2 % of the theory's, the first trough within 0.05 y0 of its, the rms difference over the run within 0.05 y0.
It draws ``heave.png``.

Model: WCSPH, Wendland C2, h = 1.6 dx, δ-SPH δ = 0.1, the laminar viscosity of water, dynamic (Adami 2012) wall
particles, c0 = 10 sqrt(g d); the water starts at rest with its hydrostatic density.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.geometry import circle_polygon, lattice_box
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import BoundaryModel, FluidField, FluidParams, RigidBody, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.parameters import FrameField, WallLayers
from warpfree.solvers.wcsph.scene_tools import (clear_of, hydrostatic_density, require_wall_cover,
                                                  require_whole_spacings)
from warpfree.solvers.wcsph.sensors import BodySensor
from warpfree.solvers.wcsph.surface_layers import surface_layers
from warpfree.time_loop import TimeLoop
from warpfree.validation import heave_decay_2d as ursell

#: the smallest run of this scene worth making (literal values only)
SMALLEST = {"per_radius": 4, "depth": 3.0, "half_length": 4.0, "settle": 0.5, "t_end": 0.5, "output_interval": 0.25}

#: ``warpfree validate --quick``: 6 particles over the radius (about a minute on 2 cores; the default 10, four)
QUICK = {"per_radius": 6}

#: gravity (m/s²), the water's density (kg/m³), the settling's damping (in sqrt(g/a))
G, RHO0, DAMPING = 9.81, 1000.0, 1.0


@checked_parameters
def build(per_radius: Annotated[int, Param("", "particles over the cylinder's radius (dx = a/per_radius)", "[4, inf)")]
          = 10,
          radius: Annotated[float, Param("m", "the cylinder's radius a", "(0, inf)")] = 0.1,
          drop: Annotated[float, Param("a", "how far above its floating level the cylinder is released", "(0, 0.5]")]
          = 0.2,
          depth: Annotated[float, Param("a", "the water's depth d", "[3, inf)")] = 5.0,
          half_length: Annotated[float, Param("a", "the tank's half length, from the cylinder's axis to a wall",
                                              "[3, inf)")] = 12.0,
          settle: Annotated[float, Param("sqrt(a/g)", "the water settled with damping, the cylinder held, before t = 0",
                                         "(0, inf)")] = 10.0,
          t_end: Annotated[float, Param("sqrt(a/g)", "simulated time at which the run ends", "(0, inf)")] = 25.0,
          output_interval: Annotated[float, Param("sqrt(a/g)", "simulated time between outputs", "(0, inf)")] = 1.0,
          sensor_interval: Annotated[float, Param("sqrt(a/g)", "simulated time between the body sensor's samples",
                                                  "(0, inf)")] = 0.05,
          wall_layers: WallLayers = 3,
          checkpoint_every: CheckpointEvery = 0, frames: Frames = True, frame_field: FrameField = FluidField.PRESSURE,
          vtk: Vtk = True) -> TimeLoop:
    """The cylinder of ``radius`` a (m), ``per_radius`` particles over it, released ``drop`` a above its floating level;
    lengths in a, times in sqrt(a/g)."""
    params = dict(locals())
    dx = radius / per_radius
    require_whole_spacings({"depth": depth, "half_length": half_length}, per_radius, "a", "per_radius")
    support = 3.2 * dx
    require_wall_cover(wall_layers, dx, support)
    time_unit = math.sqrt(radius / G)
    width, level = 2.0 * half_length * radius, depth * radius
    c0 = 10.0 * math.sqrt(G * level)
    centre = (0.5 * width, level + drop * radius)
    w = wall_layers * dx
    top = level + 3.0 * radius
    with reported_as(dx="per_radius, depth, half_length", layers="wall_layers"):
        section = circle_polygon(radius, dx, centre)
        fluid = clear_of(lattice_box((0.0, 0.0), (width, level), dx), section, 0.5 * dx)
        rings = surface_layers(section, dx, wall_layers, "inside")
        walls = np.vstack([lattice_box((-w, -w), (width + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, top), dx),
                           lattice_box((width, 0.0), (width + w, top), dx)])
    fp = FluidParams(dim=2, dx=dx, h_factor=1.6, rho0=RHO0, c0=c0, mu=1.0e-3, delta=0.1, gravity=(0.0, -G, 0.0),
                     boundary_model=BoundaryModel.DYNAMIC, cfl=0.25, lj_d=G * level, lj_r0=0.75 * dx,
                     container_lo=(-w, -w, -1.0), container_hi=(width + w, 2.0 * top, 1.0))
    body = RigidBody(rings, None, surface=section, density=0.5 * RHO0, name="cylinder", free=("y",))
    model = WCSPHModel(fluid, walls, fp, bodies=[body],
                       containers=[np.array([(0.0, 0.0), (width, 0.0), (width, 2.0 * top), (0.0, 2.0 * top)])])
    solver = WCSPHSolver(model, density=hydrostatic_density(fluid[:, 1], level, RHO0, c0, G))
    settled = solver.settle(settle * time_unit, DAMPING / time_unit, hold_bodies=True)
    released = solver.body_state()[0][1]

    def heave_analysis(run: TimeLoop, out_dir: str) -> dict:
        rows = np.asarray(run.sensor_rows["cylinder"])
        t = rows[:, 0] / time_unit
        heave = (rows[:, 2] - level) / (drop * radius)
        theory = ursell.free_decay(t)
        res = ursell.compare(t, heave, theory)
        res.update({"released_at": (released - level) / radius, "settling": settled, "dx": dx,
                    "natural": ursell.natural_frequency()})
        res["checks"] = ursell.checks(res, f"{per_radius} particles over the radius, released {drop:g} a high, "
                                           f"{depth:g} a deep, the tank {2 * half_length:g} a long")
        if out_dir is not None:
            ursell.plot_heave(os.path.join(out_dir, "heave.png"), t, heave, theory, res,
                              f"warpfree, a = {per_radius} dx")
        return {"heave": res}

    run = TimeLoop(solver, t_end=t_end * time_unit, output_interval=output_interval * time_unit,
                   name="heave_decay_2d", params=params, analyses=[heave_analysis], checkpoint_every=checkpoint_every,
                   output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                        frame_bounds=((0.5 * width - 6.0 * radius, 0.5 * width + 6.0 * radius),
                                                      (level - 3.0 * radius, level + 2.0 * radius)),
                                        frame_range={"pressure": (0.0, RHO0 * G * 3.0 * radius)}))
    run.add_sensor(BodySensor("cylinder", 0, sensor_interval * time_unit))
    return run
