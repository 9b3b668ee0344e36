"""No fluid inside any solid, measured against the true surfaces at every output: the 3D dam break with its
obstacle over 4 s, a thin plate hit head on, containers rotated by several angles in 2D and 3D.

Each run audits the fluid against the true container and obstacle surfaces at every output
(``WCSPHSolver.audit``): one particle inside a solid would stop the run with a RunError, so a run that ends
with status "ok" had none at any output; the tests also count at the end, independently of the audit."""

from __future__ import annotations


import numpy as np
import pytest
import trimesh

from warpfree import device
from warpfree.scene_loader import load_scene
from warpfree.geometry import fill_mesh, fill_polygon
from warpfree.solvers.wcsph.solids import Solids
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.scene_tools import box_2d, box_walls_2d, clear_of, hydrostatic_density
from warpfree.solvers.wcsph.surface_layers import surface_layers
from warpfree.time_loop import TimeLoop
from warpfree.run import OutputOptions



def outputs_audited(run) -> int:
    return len(run.series["time"])


@pytest.mark.slow
def test_3d_dam_break_with_obstacle_for_4_seconds():
    """SPHERIC test 2 geometry at the scene's dx = 0.05 (the obstacle 3.2 dx wide) for 4 s: the surge hits the
    obstacle, runs up the far wall and sloshes back. Before the walls followed the true surfaces the obstacle's
    wall particles stood up to 0.4 dx behind its faces and fluid entered it (up to 21 particles, 1.9 cm deep);
    measured now (2026-11-23): none at any of the 81 outputs."""
    device.use("cpu", 2)
    run = load_scene("dam_break_3d").build(t_end=4.0, frames=False, vtk=False)
    summary = run.run(None, progress=False)
    assert summary["status"] == "ok" and outputs_audited(run) == 81
    assert max(run.series["inside_obstacle"]) == 0
    assert not run.solver.solids.penetration(run.solver.fluid.position)


def test_thin_plate_hit_head_on():
    """A vertical plate two spacings thick in the path of the 2D surge (x = 2a, 0.6a high): its wall layers from
    both faces meet inside it and the surge hits it at about 4 m/s; no fluid particle enters it or crosses it."""
    device.use("cpu", 2)
    dx, a, g, height = 0.04, 1.0, 9.81, 2.0
    length = 4.0
    plate = np.array([[2.0, 0.0], [2.0 + 2 * dx, 0.0], [2.0 + 2 * dx, 0.6], [2.0, 0.6]])
    tank = box_2d(length, 4.0)
    fluid = clear_of(fill_polygon(np.array([[0, 0], [a, 0], [a, height], [0, height]]), dx, origin=(0, 0),
                                  clearance=0.5 * dx), plate, 0.5 * dx)
    c0 = 10.0 * np.sqrt(2.0 * g * height)
    params = FluidParams(dim=2, dx=dx, c0=c0, alpha=0.1, delta=0.1, gravity=(0.0, -g, 0.0), cfl=0.2,
                         lj_d=2 * g * height, lj_r0=0.75 * dx, container_lo=(0, 0, -1), container_hi=(length, 4.0, 1))
    model = WCSPHModel(fluid, box_walls_2d(length, 4.0, dx, 3), params, containers=[tank], obstacles=[plate],
                       obstacle_boundary=surface_layers(plate, dx, 3, "inside"))
    solver = WCSPHSolver(model, density=hydrostatic_density(fluid[:, 1], height, 1000.0, c0, g))
    run = TimeLoop(solver, t_end=1.0, output_interval=0.02, output=OutputOptions(vtk=False, frames=False))
    summary = run.run(None, progress=False)
    assert summary["status"] == "ok" and outputs_audited(run) == 51
    x = solver.fluid.numpy("position")
    assert np.any(x[:, 0] > 2.0 + 2 * dx)      # the surge went over the plate (it had to be stopped or turned)
    assert not Solids(solver.launcher, 2, obstacles=[plate]).penetration(solver.fluid.position)


@pytest.mark.parametrize("tilt", [15.0, 30.0, 45.0])
def test_tilted_2d_tanks_hold_their_water(tilt):
    """A tank at rest rotated by 15°, 30°, 45°, walls along its true sides, water to a level surface: no
    particle inside a wall at any output over 1 s. (The water is not at rest: the axis-aligned lattice meets the
    tilted walls at irregular distances and the start is out of equilibrium; quiet tilted tanks need a relaxed
    start, not done yet.)"""
    device.use("cpu", 2)
    run = load_scene("tank_at_rest_2d").build(
        tilt=tilt, width=0.5, depth=0.4, dx=0.025, t_end=1.0, frames=False, vtk=False)
    summary = run.run(None, progress=False)
    assert summary["status"] == "ok" and outputs_audited(run) == 21


def test_rotated_3d_tank_holds_its_water():
    """A box tank rotated about a tilted axis, walls from its true faces, water to a level surface: no particle
    inside a wall at any output over 0.5 s."""
    device.use("cpu", 2)
    dx, g = 0.04, 9.81
    tank = trimesh.creation.box(extents=(0.6, 0.4, 0.5))
    tank.apply_transform(trimesh.transformations.rotation_matrix(np.radians(20.0), (1.0, 0.5, 0.0)))
    tank.apply_translation(-tank.bounds[0])
    fluid = fill_mesh(tank, dx, origin=(0, 0, 0), clearance=0.5 * dx)
    level = 0.25
    fluid = fluid[fluid[:, 2] < level]
    c0 = 10.0 * np.sqrt(2.0 * g * level)
    lo, hi = tank.bounds
    params = FluidParams(dim=3, dx=dx, c0=c0, alpha=0.1, delta=0.1, gravity=(0.0, 0.0, -g), cfl=0.2,
                         lj_d=2 * g * level, lj_r0=0.75 * dx, container_lo=tuple(lo), container_hi=tuple(hi))
    model = WCSPHModel(fluid, surface_layers(tank, dx, 3, "outside"), params, containers=[tank])
    solver = WCSPHSolver(model, density=hydrostatic_density(fluid[:, 2], level, 1000.0, c0, g))
    run = TimeLoop(solver, t_end=0.5, output_interval=0.05, output=OutputOptions(vtk=False, frames=False))
    summary = run.run(None, progress=False)
    assert summary["status"] == "ok" and outputs_audited(run) == 11
