"""A test scene: a box of density 500 kg/m³ released 2 cm above its floating draft in a tank 2 m wide, free in x, y and
rotation, moved by the fluid's load and its weight: its state must be the same on every rank of a distributed run."""

import numpy as np

from warpfree.geometry import lattice_box
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import FluidParams, RigidBody, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.sensors import BodySensor
from warpfree.time_loop import TimeLoop

SMALLEST = {}


#: the box and its tank: tank width, water depth, box height and breadth (m), density (kg/m³), how high above its
#: draft it is released (m)
WIDTH, DEPTH, HEIGHT, BREADTH, DENSITY, DROP = 2.0, 0.4, 0.2, 0.4, 500.0, 0.02
G = 9.81


def floating_box_solver(dx: float) -> WCSPHSolver:
    """The tank of water at rest (hydrostatic density) and the box released ``DROP`` above Archimedes' draft, free
    in x, y and rotation, at spacing ``dx``."""
    c0 = 10.0 * np.sqrt(G * DEPTH)
    x0, y0 = 0.5 * (WIDTH - BREADTH), DEPTH - (DENSITY / 1000.0 * HEIGHT - DROP)
    fluid = lattice_box((0.0, 0.0), (WIDTH, DEPTH), dx)
    fluid = fluid[~((fluid[:, 0] > x0) & (fluid[:, 0] < x0 + BREADTH) & (fluid[:, 1] > y0))]
    w = 3 * dx
    walls = np.vstack([lattice_box((-w, -w), (WIDTH + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, DEPTH + 0.3), dx),
                       lattice_box((WIDTH, 0.0), (WIDTH + w, DEPTH + 0.3), dx)])
    surface = np.array([(x0, y0), (x0 + BREADTH, y0), (x0 + BREADTH, y0 + HEIGHT), (x0, y0 + HEIGHT)])
    box = RigidBody(lattice_box((x0, y0), (x0 + BREADTH, y0 + HEIGHT), dx), None, surface=surface, density=DENSITY)
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=1e-3, delta=0.1, cfl=0.25, lj_d=G * DEPTH, lj_r0=0.75 * dx,
                         container_lo=(-w, -w, -1.0), container_hi=(WIDTH + w, 2.0, 1.0))
    water = 1000.0 * (1.0 + 7.0 * G * (DEPTH - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    model = WCSPHModel(fluid, walls, params, bodies=[box],
                       containers=[np.array([(0.0, 0.0), (WIDTH, 0.0), (WIDTH, 2.0), (0.0, 2.0)])])
    return WCSPHSolver(model, density=water)


def build(dx: float = 0.04, t_end: float = 0.6, output_interval: float = 0.2, frames: bool = False,
          vtk: bool = True, checkpoint_every: int = 0) -> TimeLoop:
    run = TimeLoop(floating_box_solver(dx), t_end=t_end, output_interval=output_interval, name="floating_box",
                   checkpoint_every=checkpoint_every, output=OutputOptions(vtk=vtk, frames=frames))
    run.add_sensor(BodySensor("box", 0, 0.05))
    return run
