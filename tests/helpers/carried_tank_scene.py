"""A test scene: a tank of water carried 1 m along x from rest to rest in 1.5 s (a rigid body with a prescribed motion
and its true surface), far across the cut of a distributed run: its walls and its water change ranks as it goes."""

import numpy as np

from warpfree.geometry import lattice_box
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import FluidParams, PrescribedMotion, RigidBody, WCSPHModel, WCSPHSolver
from warpfree.time_loop import TimeLoop

SMALLEST = {}


def build(dx: float = 0.02, t_end: float = 1.6, output_interval: float = 0.4, frames: bool = False,
          vtk: bool = True, checkpoint_every: int = 0) -> TimeLoop:
    width, depth, w, c0, g = 0.4, 0.2, 3 * dx, 20.0, 9.81

    def x(t):
        s = min(max(t / 1.5, 0.0), 1.0)
        return (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, 0.0)

    fluid = lattice_box((0.0, 0.0), (width, depth), dx)
    walls = np.vstack([lattice_box((-w, -w), (width + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, depth + 0.4), dx),
                       lattice_box((width, 0.0), (width + w, depth + 0.4), dx)])
    surface = np.array([(0.0, 0.0), (width, 0.0), (width, 1.0), (0.0, 1.0)])
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=1e-3, delta=0.1, delta_gradient=True,
                         container_lo=(-0.5, -0.5, -1.0), container_hi=(2.0, 1.0, 1.0))
    density = 1000.0 * (1.0 + 7.0 * g * (depth - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    tank = RigidBody(walls, PrescribedMotion(np.linspace(0.0, 1.5, 151), displacement=x), surface=surface,
                     holds_fluid=True, name="tank")
    solver = WCSPHSolver(WCSPHModel(fluid, np.zeros((0, 2)), params, bodies=[tank]), density=density)
    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="carried_tank",
                    checkpoint_every=checkpoint_every, output=OutputOptions(vtk=vtk, frames=frames))
