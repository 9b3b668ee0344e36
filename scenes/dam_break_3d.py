"""3D dam break with an obstacle (SPHERIC benchmark test 2, Kleefsman et al. 2005): tank and obstacle from STL meshes.

A water column 1.228 m long, 1 m wide and 0.55 m high at the far end of a 3.22 x 1 x 1 m tank hits a
0.161 x 0.403 x 0.161 m box. Tank and obstacle are read from the STL files in ``scenes/meshes/``
(any watertight STL/OBJ/PLY can be passed instead). Wall particles are placed from the meshes' true
surfaces (``warpfree.solvers.wcsph.surface_layers``): three layers outside the tank and three inside the obstacle, the
first dx/2 from the surface. The column is filled with cells that divide it exactly (about dx a side), so it
holds its 1.228 x 1 x 0.55 m of water at any dx, half a cell from the tank; the fluid keeps dx/2 from the obstacle. At every output the solver checks
the fluid against the true tank and obstacle surfaces (``warpfree.solvers.wcsph.solids``): a fluid particle inside a
solid stops the run with the count and the depth. The probe ``inside_obstacle`` records how many fluid
particles are inside the obstacle (0 throughout).

Writes frames (an oblique view and a side view), VTU files, and free-surface meshes with
``--set surface=true``. z is up.

In the experiment's geometry (these meshes and column) the scene records the experiment's sensors: the pressures P1
and P3 on the obstacle's face (the wall pressure, every 1 ms) and the water heights H2 and H4 (every 5 ms), in
``sensors/``, drawn against Kleefsman's record (``warpfree.validation.dam_break_3d``) in ``sensors.png``; it checks the
heights (rms within 10 % of the record's range, for runs of 1 s or more) and reports the pressures' figures in
``summary.json``. Over three spacings and with the Riemann pair pressure (``--set riemann=3 --set alpha=0``):
``bench/results/spheric2_pressure.md``.

Time step: the CFL condition dt = C h/(c0 + max|v|), with C = 0.3, the largest
number whose end state matches C = 0.2 at h = 1.3 dx (the study: ``bench/results/scene_studies.md``).
"""

import os
from typing import Annotated

import numpy as np

from warpfree.geometry import fill_mesh_box, load_mesh
from warpfree.solvers.wcsph.surface_layers import surface_layers
from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.smoothing import SmoothingKernel
from warpfree.solvers.wcsph.parameters import (ArtificialViscosity, Courant, DensityDiffusion, DensityGradient,
                                               DynamicViscosity, EndTime, FixedStep, FrameField, Gravity, HFactor,
                                               Kernel, OutputInterval, Pairs, RestDensity, Riemann, SoundSpeed,
                                               Spacing, Tension, WallLayers, WallSafety)
from warpfree.solvers.wcsph.scene_tools import clear_of, hydrostatic_density, require_wall_cover
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import FluidField, FluidPairs, FluidParams, WCSPHModel, WCSPHSolver
from warpfree.sensors import PressureSensor
from warpfree.solvers.wcsph.sensors import WaterGauge
from warpfree.time_loop import TimeLoop
from warpfree.validation import dam_break_3d as kleefsman

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OBSTACLE = os.path.join(HERE, "meshes", "spheric2_obstacle.stl")
#: the experiment's sensors' intervals (s): the pressures at the record's 1 kHz, the water heights every 5 ms
PRESSURE_INTERVAL, HEIGHT_INTERVAL = 1.0e-3, 5.0e-3


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"dx": 0.1, "t_end": 0.04, "output_interval": 0.02, "surface": True}

#: ``warpfree validate --quick``: the default run (dx = 0.05 m to t = 1 s): past the water's impact on the obstacle
#: (about 0.4 s) and its rise at the gauges, which are checked from 1 s on (at dx = 0.1 m the column is five
#: particles tall and the gauges read 37-47 % of the record's range off)
QUICK = {"t_end": 1.0}


@checked_parameters
def build(dx: Spacing = 0.05, t_end: EndTime = 1.0, output_interval: OutputInterval = 0.05,
          tank_mesh: Annotated[str, Param("", "the tank: a watertight STL, OBJ or PLY file")] =
          os.path.join(HERE, "meshes", "spheric2_tank.stl"),
          obstacle_mesh: Annotated[str, Param("", "the obstacle: a watertight STL, OBJ or PLY file (empty: none)")] =
          DEFAULT_OBSTACLE,
          column_length: Annotated[float, Param("m", "length of the water column along x", "(0, inf)")] = 1.228,
          column_height: Annotated[float, Param("m", "height of the water column", "(0, inf)")] = 0.55,
          h_factor: HFactor = 1.3, kernel: Kernel = SmoothingKernel.WENDLAND_C2, alpha: ArtificialViscosity = 0.1,
          delta: DensityDiffusion = 0.1, delta_gradient: DensityGradient = False,
          mu: DynamicViscosity = 1.0e-3, wall_safety: WallSafety = 0.75,
          cfl: Courant = 0.3, g: Gravity = 9.81, rho0: RestDensity = 1000.0, wall_layers: WallLayers = 3,
          checkpoint_every: CheckpointEvery = 0, dt: FixedStep = None, frames: Frames = True,
          frame_field: FrameField = FluidField.SPEED, vtk: Vtk = True,
          surface: Annotated[bool, Param("", "write the free surface as PLY meshes at every output")] = False,
          sound_speed: SoundSpeed = 10.0, riemann: Riemann = 0.0,
          tension: Tension = True, fluid_pairs: Pairs = FluidPairs.ROWS) -> TimeLoop:
    params = dict(locals())
    with reported_as(mesh="tank_mesh"):
        tank = load_mesh(tank_mesh)
    lo, hi = tank.bounds
    for name, value, room in (("column_length", column_length, hi[0] - lo[0]), ("column_height", column_height,
                                                                               hi[2] - lo[2])):
        if value >= room:
            raise ParameterError(name, f"must be below the tank's {room:.4g} m, got {value}")
    with reported_as(mesh="obstacle_mesh"):
        obstacle = load_mesh(obstacle_mesh) if obstacle_mesh else None
    # fluid: cells dividing the column's box exactly (its length, the tank's width and its height at any dx), half a
    # cell clear of the tank and dx/2 of the obstacle; each particle the volume of its cell
    fluid, cell = fill_mesh_box(tank, (hi[0] - column_length, lo[1], lo[2]), (hi[0], hi[1], lo[2] + column_height), dx)
    with reported_as(layers="wall_layers", lj_r0="wall_safety"):
        walls = surface_layers(tank, dx, wall_layers, "outside")
        obstacle_walls = None
        if obstacle is not None:
            fluid = clear_of(fluid, obstacle, 0.5 * dx)
            obstacle_walls = surface_layers(obstacle, dx, wall_layers, "inside")
        c0 = sound_speed * np.sqrt(2.0 * g * column_height)
        fp = FluidParams(dim=3, dx=dx, h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, alpha=alpha,
                         riemann=riemann, tension=tension, fluid_pairs=fluid_pairs,
                         delta=delta, delta_gradient=delta_gradient, gravity=(0.0, 0.0, -g), cfl=cfl, lj_d=2.0 * g * column_height,
                         lj_r0=wall_safety * dx, container_lo=tuple(lo), container_hi=tuple(hi))
        require_wall_cover(wall_layers, dx, fp.support, fp.boundary_model)
        density = hydrostatic_density(fluid[:, 2], lo[2] + column_height, rho0, c0, g)
        model = WCSPHModel(fluid, walls, fp, obstacle_boundary=obstacle_walls, containers=[tank],
                           obstacles=[obstacle] if obstacle is not None else [], fluid_volume=float(np.prod(cell)))
        solver = WCSPHSolver(model, density=density)

    probes = {"front": lambda s, t: float(s.fluid_positions()[:, 0].min())}
    if obstacle is not None:
        def inside_obstacle(s, t):
            """Fluid particles inside the obstacle's true surface."""
            x = s.fluid_positions()
            return float(len(x) - len(clear_of(x, obstacle, 0.0)))

        probes["inside_obstacle"] = inside_obstacle

    # the experiment's geometry: its sensors recorded and compared with Kleefsman's record
    experiment = (os.path.abspath(tank_mesh) == os.path.abspath(os.path.join(HERE, "meshes", "spheric2_tank.stl"))
                  and os.path.abspath(obstacle_mesh or "") == os.path.abspath(DEFAULT_OBSTACLE)
                  and (column_length, column_height, g) == (1.228, 0.55, 9.81))
    sensors = []
    if experiment:
        sensors = ([PressureSensor(n, [kleefsman.SENSORS[n]], PRESSURE_INTERVAL) for n in kleefsman.PRESSURE_SENSORS]
                   + [WaterGauge(n, [kleefsman.SENSORS[n] + (0.0,)], HEIGHT_INTERVAL)
                      for n in kleefsman.HEIGHT_SENSORS])

    def spheric2_analysis(sim, out_dir):
        if not experiment:
            return {}
        names = kleefsman.PRESSURE_SENSORS + kleefsman.HEIGHT_SENSORS
        series = {name: np.asarray(sim.sensor_rows[name]) for name in names}
        figures = kleefsman.compare(series)
        if out_dir is not None:
            sim.plot("warpfree.validation.dam_break_3d:plot_sensors", path=os.path.join(out_dir, "sensors.png"),
                     series=series, figures=figures, dx=dx)
        return {"spheric2": {"figures": figures, "checks": kleefsman.height_checks(figures, sim.time)}}

    def obstacle_analysis(sim, out_dir):
        if obstacle is None:
            return {}
        from warpfree.validation import tolerance_check

        inside = float(max(sim.series["inside_obstacle"]))
        return {"obstacle": {"max_fluid_particles_inside": inside, "checks": {"fluid_particles_inside": tolerance_check(
            inside, 0.0, "no penetration: fluid cannot enter a solid (the obstacle's true surface, "
            f"{os.path.basename(obstacle_mesh)}); warpfree/validation/dam_break_3d/README.md", unit="particles",
            basis="a physical requirement, not an accuracy: a fluid particle inside the obstacle is wrong at any "
                  "resolution, so the tolerance is 0")}}}

    b = tuple(zip(lo, hi))
    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="dam_break_3d", params=params,
                      probes=probes, analyses=[obstacle_analysis, spheric2_analysis], dt=dt,
                      checkpoint_every=checkpoint_every, sensors=sensors,
                      output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field, frame_bounds=b,
                                           meshes=surface, plots=experiment,
                                           frame_range={"speed": (0.0, float(np.sqrt(2.0 * g * column_height))),
                                                        "pressure": (0.0, rho0 * g * column_height)}))
