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

The experiment's pressures and water heights are in ``warpfree.validation.dam_break_3d``; the loads at its sensors
(``--sensor``) against them, over three spacings and with the Riemann pair pressure (``--set riemann=3 --set
alpha=0``): ``bench/results/spheric2_pressure.md``.

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
from warpfree.solvers.wcsph.parameters import (ArtificialViscosity, Courant, DensityDiffusion, DynamicViscosity,
                                                EndTime, FixedStep, FrameField, Gravity, HFactor, Kernel,
                                                OutputInterval, RestDensity, Riemann, SoundSpeed, Spacing, Tension,
                                                WallLayers, WallSafety)
from warpfree.solvers.wcsph.scene_tools import clear_of, hydrostatic_density, require_wall_cover
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import FluidField, FluidParams, WCSPHModel, WCSPHSolver
from warpfree.time_loop import TimeLoop

HERE = os.path.dirname(os.path.abspath(__file__))


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"dx": 0.1, "t_end": 0.04, "output_interval": 0.02, "surface": True}

#: ``warpfree validate --quick``: dx = 0.1 m to t = 0.6 s, past the water's impact on the obstacle (about 0.4 s)
QUICK = {"dx": 0.1, "t_end": 0.6}


@checked_parameters
def build(dx: Spacing = 0.05, t_end: EndTime = 1.0, output_interval: OutputInterval = 0.05,
          tank_mesh: Annotated[str, Param("", "the tank: a watertight STL, OBJ or PLY file")] =
          os.path.join(HERE, "meshes", "spheric2_tank.stl"),
          obstacle_mesh: Annotated[str, Param("", "the obstacle: a watertight STL, OBJ or PLY file (empty: none)")] =
          os.path.join(HERE, "meshes", "spheric2_obstacle.stl"),
          column_length: Annotated[float, Param("m", "length of the water column along x", "(0, inf)")] = 1.228,
          column_height: Annotated[float, Param("m", "height of the water column", "(0, inf)")] = 0.55,
          h_factor: HFactor = 1.3, kernel: Kernel = SmoothingKernel.WENDLAND_C2, alpha: ArtificialViscosity = 0.1,
          delta: DensityDiffusion = 0.1, mu: DynamicViscosity = 1.0e-3, wall_safety: WallSafety = 0.75,
          cfl: Courant = 0.3, g: Gravity = 9.81, rho0: RestDensity = 1000.0, wall_layers: WallLayers = 3,
          checkpoint_every: CheckpointEvery = 0, dt: FixedStep = None, frames: Frames = True,
          frame_field: FrameField = FluidField.SPEED, vtk: Vtk = True,
          surface: Annotated[bool, Param("", "write the free surface as PLY meshes at every output")] = False,
          sound_speed: SoundSpeed = 10.0, riemann: Riemann = 0.0,
          tension: Tension = True) -> TimeLoop:
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
                         riemann=riemann, tension=tension,
                         delta=delta, gravity=(0.0, 0.0, -g), cfl=cfl, lj_d=2.0 * g * column_height,
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
                      probes=probes, analyses=[obstacle_analysis], dt=dt, checkpoint_every=checkpoint_every,
                      output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field, frame_bounds=b,
                                           meshes=surface,
                                           frame_range={"speed": (0.0, float(np.sqrt(2.0 * g * column_height))),
                                                        "pressure": (0.0, rho0 * g * column_height)}))
