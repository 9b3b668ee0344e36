"""A WCSPH fluid spread over the ranks of a run: what each rank holds, and what moves between them.

A run of one process is a one-rank partition: it holds the whole fluid and every wall, in global order, with no
ghost; its refreshes and reductions do nothing and nothing moves at a rebuild.

The fluid and the wall particles are two item sets on one :class:`~warpfree.parallel.Decomposition` (cut over the
neighbour grid's cells, a cell being the kernel support). A rank holds the fluid and walls its box owns and, as
ghosts, those within one support plus the tables' skin of it (``depth``), each set in global-id order; its arrays are
laid out as the one process's, [held fluid | held walls]. With openings, a rank also holds the fluid whose mirror image
across an opening's plane lies within ``depth`` of its box (:func:`opening_mirrors`): its own buffer particles take
their values from the fluid about their mirror points, as far in front of the plane as they are behind it. A step then needs, besides the one reduction of its report
(the stable step, the rebuild decision and the status: a max), two refreshes of the ghosts:

- the walls' pressure, density and no-slip velocity after the wall-pressure pass (a ghost wall's fluid neighbours
  are not all held);
- the fluid's state after the kick (:data:`STEP_FIELDS`: what the next drift reads), so that a ghost drifts exactly
  as its owner does. It travels while the step's report is reduced (over the owned rows: the ghosts' rows of the
  report are set to zero first, neutral in its max) and the reduction's one Allreduce runs.

At a neighbour rebuild the fluid moves to the boxes that now hold it (:meth:`FluidSpread.redistribute`, carrying
:data:`MOVING_FIELDS`); when the ranks' work (the neighbour pairs they own) has drifted apart by more than
``rebalance`` (max/mean), the decomposition is cut anew from the current positions first, and the walls follow it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from warpfree.parallel import CutMethod, Mirrors, Partition, World
from warpfree.parallel.moving import MovingSpread

__all__ = ["FluidSpread", "MOVING_FIELDS", "STEP_FIELDS", "opening_mirrors"]

#: the fluid arrays a ghost gets from its owner after every kick (held fluid rows)
STEP_FIELDS = ("position", "velocity", "density", "acceleration", "density_rate")
#: the fluid arrays that move with a particle at a rebuild (after the drift: the predicted values included)
MOVING_FIELDS = ("position", "velocity", "density", "pressure", "acceleration", "density_rate", "velocity_eval",
                 "density_eval")
#: the cost of a wall particle against a fluid one, before any neighbour count is known
WALL_COST = 0.5

#: cut anew at a rebuild when the ranks' measured work since the last one has max/mean above this. A cut costs about a
#: fifth of a rebuild (an allgather of the positions and the recursive bisection: 4 ms beside 20 ms for the 2D dam
#: break at dx 0.01 on 2 ranks); the measured time between rebuilds (about 9 steps there) varies by a few % on a
#: shared machine, and at 1.05 that alone cut anew at 89 of 342 rebuilds (19 at 1.1), for no gain
REBALANCE = 1.1
#: the solver's phases whose time is its items' work (the kernels over held particles, no message): what a rank's
#: measured work since the last rebuild adds up
WORK_PHASES = ("rates", "boundary", "surfaces")


def opening_mirrors(model) -> Mirrors | None:
    """The openings' planes as :class:`~warpfree.parallel.Mirrors` (None without openings). A buffer particle is at
    most T + dx/2 behind its plane at a rebuild (farther, it is taken out) and moves at most skin/2 before the next;
    its mirror point reads the fluid within the support of it, which has moved at most skin/2 since the rebuild: the
    fluid up to T + dx/2 + support + skin in front of the plane (and, having just crossed it, skin behind it) is
    reflected. By the triangle inequality its image at the rebuild then lies within support + skin (``depth``) of
    the box that owned the buffer particle."""
    o = model.openings
    if o is None:
        return None
    P = model.params
    reach = o.thickness + o.margin + P.support + model.skin
    return Mirrors(o.point.astype(np.float64), o.normal.astype(np.float64), reach, np.full(o.count, model.skin))


class FluidSpread(MovingSpread):
    """The decomposition of a :class:`~warpfree.solvers.wcsph.model.WCSPHModel` over ``world``'s ranks: the fluid is
    the moving set (:attr:`fluid`), the walls the fixed one (:attr:`walls`, cut anew with the fluid).

    Parameters
    ----------
    world, model: the ranks and the (whole) model, which every rank builds.
    method: CutMethod.RCB or CutMethod.SLABS (:class:`~warpfree.parallel.Decomposition`).
    rebalance: cut anew at a rebuild when the ranks' work has max/mean above this (>= 1; ``inf``: never).
    """

    def __init__(self, world: World, model, method: CutMethod = CutMethod.RCB, rebalance: float = REBALANCE):
        P = model.params
        self.model = model
        x = model.position_np.astype(np.float64)
        self.fluid_start = x[: model.nf]
        self.wall_points = x[model.nf:]
        self.walls: Partition | None = None
        self._walls_moved = False  # walls moved (rigid bodies) since their part was made
        super().__init__(world, self.fluid_start, cell=P.support, depth=P.support + model.skin, dim=P.dim,
                         lower=P.container_lo, upper=P.container_hi, periodic=P.periodic, method=method,
                         rebalance=rebalance, mirrors=opening_mirrors(model))

    @property
    def fluid(self) -> Partition:
        """This rank's part of the fluid (the moving set)."""
        return self.moving

    def fixed_items(self) -> tuple[np.ndarray, np.ndarray]:
        """The wall particles, each :data:`WALL_COST` of a fluid particle before neighbour counts are known."""
        return self.wall_points, np.full(len(self.wall_points), WALL_COST)

    def move_walls(self, points: np.ndarray) -> None:
        """Every wall's position now ((nb, 3), the same on every rank: rigid bodies move some): the next cut weighs
        them there and the walls' part is made anew from them at the next :meth:`redistribute` (or cut)."""
        self.wall_points = np.asarray(points, dtype=np.float64)
        self._walls_moved = True

    def follow_cut(self) -> None:
        """The walls' part on the current cut."""
        if self.walls is not None:
            self.walls.release()
        self.walls = Partition.of_all(self.world, self.decomposition, self.depth, self.wall_points)
        self._walls_moved = False

    # -- the held arrays ------------------------------------------------------------------------------------
    def n_container_walls(self) -> int:
        """Held walls of the containers (the walls' global order: containers first, then obstacles)."""
        return int(np.count_nonzero(self.walls.ids < self.model.n_container_walls))

    def held_fluid(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The held rows of fluid arrays over the whole fluid (by name)."""
        return {k: self.fluid.take(v) for k, v in values.items()}

    def held_walls(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The held rows of wall arrays over all walls (by name)."""
        return {k: self.walls.take(v) for k, v in values.items()}

    def grid_sizes(self, launcher) -> dict[str, int] | None:
        """The grid points the one process's hash tables are sized for (fluid at its start, walls), which every rank
        sizes its tables for (its neighbours then come in the one process's order); None in one process (each grid
        sizes itself for its first build: the whole set)."""
        if self.whole:
            return None
        import warp as wp

        from warpfree.neighbours import NeighbourGrid

        model = self.model
        grid = NeighbourGrid(launcher, self.depth, model.space)
        sizes = {"moving": grid.grid_points(wp.array(self.fluid_start.astype(np.float32), dtype=wp.vec3,
                                                     device=launcher.device))}
        if model.nb:
            sizes["walls"] = grid.grid_points(wp.array(self.wall_points.astype(np.float32), dtype=wp.vec3,
                                                       device=launcher.device))
        return sizes

    # -- a rebuild --------------------------------------------------------------------------------------------
    def redistribute(self, held_fluid: Callable[[], dict[str, np.ndarray]],
                     work: Callable[[], tuple[np.ndarray, np.ndarray]],
                     lay_out: Callable[[dict[str, np.ndarray], dict[str, np.ndarray]], None],
                     busy: float | None = None) -> None:
        """Move the fluid to the boxes that hold it now and lay the arrays out anew: ``held_fluid()`` gives its held
        rows (:data:`MOVING_FIELDS` and mass, NumPy), ``work()`` the work per held fluid and wall row (e.g.
        neighbour counts: the decomposition is cut anew first when it is out of balance; ``busy``: the seconds this
        rank spent on that work since the last rebuild, which weighs it, :meth:`MovingSpread.migrate`),
        ``lay_out(fluid, walls)`` takes the new held rows. In one process nothing moves: none of them is called."""
        if self.whole:
            return

        def own_work():
            fluid_cost, wall_cost = work()
            own = self.walls.owned_index
            return fluid_cost, self.wall_points[self.walls.ids[own]], np.asarray(wall_cost, np.float64)[own]

        held = self.migrate(held_fluid(), work=own_work, busy=busy)
        if self._walls_moved:  # the walls' part where they are now (the work above was the held walls' before)
            self.follow_cut()
        lay_out(held, self.held_walls(self.model.wall_values()))

    def redistribute_changed(self, values: dict[str, np.ndarray], ids: np.ndarray, owned: np.ndarray, issued: int,
                             work: Callable[[], tuple[np.ndarray, np.ndarray]],
                             lay_out: Callable[[dict[str, np.ndarray], dict[str, np.ndarray]], None],
                             busy: float | None = None) -> None:
        """:meth:`redistribute` for a fluid that particles joined and left at this rebuild (openings): ``values``, the
        rows this rank now has (NumPy, by name), with their global ``ids`` and which of them it owns (the new ones: the
        rank that made them); ``issued``: the ids issued so far; ``work()``: the cost of each of those rows and of each
        held wall. In one process the part is the rows as given; ``lay_out`` takes them."""
        if self.whole:
            self.moving.release()
            self.moving = Partition(self.world, self.decomposition, self.depth, np.asarray(ids, np.int64),
                                    np.ones(len(ids), dtype=bool), {}, {}, issued, self.mirrors)
            lay_out(values, self.held_walls(self.model.wall_values()))
            return

        def own_work():
            fluid_cost, wall_cost = work()
            own = self.walls.owned_index
            return fluid_cost, self.wall_points[self.walls.ids[own]], np.asarray(wall_cost, np.float64)[own]

        before = self.moving
        before.count = int(issued)
        held = self.migrate(dict(values, fluid_id=np.asarray(ids, np.int64)), owned=np.asarray(owned, bool),
                            ids="fluid_id", work=own_work, busy=busy)
        before.release()
        held.pop("fluid_id")
        if self._walls_moved:
            self.follow_cut()
        lay_out(held, self.held_walls(self.model.wall_values()))

    def counts(self) -> dict[str, int]:
        """Fluid and wall particles owned and ghost on this rank."""
        return {"fluid_owned": self.fluid.n_owned, "fluid_ghosts": self.fluid.n_ghosts,
                "walls_owned": self.walls.n_owned, "walls_ghosts": self.walls.n_ghosts}
