"""A WCSPH fluid spread over the ranks of a run: what each rank holds, and what moves between them.

A run of one process is a one-rank partition: it holds the whole fluid and every wall, in global order, with no
ghost; its refreshes and reductions do nothing and nothing moves at a rebuild.

The fluid and the wall particles are two item sets on one :class:`~warpfree.parallel.Decomposition` (cut over the
neighbour grid's cells, a cell being the kernel support). A rank holds the fluid and walls its box owns and, as
ghosts, those within one support plus the tables' skin of it (``depth``), each set in global-id order; its arrays are
laid out as the one process's, [held fluid | held walls]. A step then needs, besides the one reduction of its report
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

from warpfree.errors import ParameterError
from warpfree.parallel import CutMethod, Decomposition, Partition, World, imbalance

__all__ = ["FluidSpread", "MOVING_FIELDS", "STEP_FIELDS"]

#: the fluid arrays a ghost gets from its owner after every kick (held fluid rows)
STEP_FIELDS = ("position", "velocity", "density", "acceleration", "density_rate")
#: the fluid arrays that move with a particle at a rebuild (after the drift: the predicted values included)
MOVING_FIELDS = ("position", "velocity", "density", "pressure", "acceleration", "density_rate", "velocity_eval",
                 "density_eval")
#: the cost of a wall particle against a fluid one, before any neighbour count is known
WALL_COST = 0.5


class FluidSpread:
    """The decomposition of a :class:`~warpfree.solvers.wcsph.model.WCSPHModel` over ``world``'s ranks, and the
    fluid's and walls' :class:`~warpfree.parallel.Partition` on it.

    Parameters
    ----------
    world, model: the ranks and the (whole) model, which every rank builds.
    method: CutMethod.RCB or CutMethod.SLABS (:class:`~warpfree.parallel.Decomposition`).
    rebalance: cut anew at a rebuild when the ranks' work has max/mean above this (>= 1; ``inf``: never).
    """

    def __init__(self, world: World, model, method: CutMethod = CutMethod.RCB, rebalance: float = 1.2):
        if not rebalance >= 1.0:
            raise ParameterError("rebalance", f"must be >= 1 (max/mean of the ranks' work), got {rebalance!r}")
        P = model.params
        self.world = world
        self.model = model
        self.method = method
        self.rebalance_above = float(rebalance)
        self.depth = P.support + model.skin
        self.cell = P.support
        self.rebalances = 0
        x = model.position_np.astype(np.float64)
        self.fluid_start = x[: model.nf]
        self.wall_points = x[model.nf:]
        cost = np.concatenate([np.ones(model.nf), np.full(model.nb, WALL_COST)])
        self.decomposition = self._cut(x, cost)
        self.fluid = Partition.of_all(world, self.decomposition, self.depth, self.fluid_start)
        self.walls = Partition.of_all(world, self.decomposition, self.depth, self.wall_points)
        self.last_imbalance = None

    def _cut(self, points: np.ndarray, cost: np.ndarray) -> Decomposition:
        P = self.model.params
        periodic = tuple(bool(p) for p in P.periodic)
        lo = np.asarray(P.container_lo, float)
        finite = np.isfinite(lo) & (np.abs(lo) < 1e20)
        origin = np.where(finite, lo, points.min(axis=0) if len(points) else 0.0)
        dec = Decomposition.build(self.world.size, points, cost, self.cell, P.dim, self.method, origin,
                                  P.container_hi, periodic)
        for a in range(P.dim):
            if periodic[a] and dec.period[a] < 2.0 * self.depth * 1.0000001 and self.world.size > 1:
                cut = np.unique(dec.lower[:, a]).size > 1
                if cut:
                    raise ParameterError("ranks", f"the periodic side {dec.period[a]:.4g} m along {'xyz'[a]} is too "
                                                  f"thin to cut: a ghost layer is {self.depth:.4g} m deep")
        return dec

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
        if self.fluid.whole:
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
                     lay_out: Callable[[dict[str, np.ndarray], dict[str, np.ndarray]], None]) -> None:
        """Move the fluid to the boxes that hold it now and lay the arrays out anew: ``held_fluid()`` gives its held
        rows (:data:`MOVING_FIELDS` and mass, NumPy), ``work()`` the owned work per held fluid and wall row (e.g.
        neighbour counts: the decomposition is cut anew first when it is out of balance), ``lay_out(fluid, walls)``
        takes the new held rows. In one process nothing moves: none of them is called."""
        if self.fluid.whole:
            return
        fluid_fields = held_fluid()
        fluid_cost, wall_cost = work()
        work_here = float(np.sum(fluid_cost[self.fluid.owned_index]) + np.sum(wall_cost[self.walls.owned_index]))
        per_rank = np.concatenate(self.world.allgather(np.array([work_here])))
        self.last_imbalance = imbalance(per_rank)
        if self.last_imbalance > self.rebalance_above:
            points = np.vstack(self.world.allgather(np.asarray(fluid_fields["position"], np.float64)
                                                     [self.fluid.owned_index])
                               + self.world.allgather(self.wall_points[self.walls.ids[self.walls.owned_index]]))
            cost = np.concatenate(self.world.allgather(fluid_cost[self.fluid.owned_index].astype(np.float64))
                                  + self.world.allgather(wall_cost[self.walls.owned_index].astype(np.float64)))
            self.decomposition = self._cut(points, cost)
            self.walls.release()
            self.walls = Partition.of_all(self.world, self.decomposition, self.depth, self.wall_points)
            self.rebalances += 1
        self.fluid, held = self.fluid.redistribute(self.decomposition, fluid_fields["position"], fluid_fields)
        lay_out(held, self.held_walls({"position": self.wall_points.astype(np.float32),
                                       "mass": self.model.mass.numpy()[self.model.nf:]}))

    def respread(self, fluid_at_build: np.ndarray) -> None:
        """Cut anew for the whole fluid at its build positions (a checkpoint read on another number of ranks) and
        hold the parts of that cut."""
        cost = np.concatenate([np.ones(len(fluid_at_build)), np.full(len(self.wall_points), WALL_COST)])
        self.decomposition = self._cut(np.vstack([fluid_at_build, self.wall_points]), cost)
        self.fluid.release()
        self.walls.release()
        self.fluid = Partition.of_all(self.world, self.decomposition, self.depth, fluid_at_build)
        self.walls = Partition.of_all(self.world, self.decomposition, self.depth, self.wall_points)

    def describe(self) -> dict:
        """The distributed layout for ``summary.json`` (``{"distributed": ...}``; nothing in one process): fluid and
        wall particles owned and ghost per rank, imbalance."""
        if self.fluid.whole:
            return {}
        counts = np.concatenate(self.world.allgather(np.array(
            [self.fluid.n_owned, self.fluid.n_ghosts, self.walls.n_owned, self.walls.n_ghosts], dtype=np.int64)))
        counts = counts.reshape(self.world.size, 4)
        held = counts[:, 0] + counts[:, 1]
        return {"distributed": {"ranks": self.world.size, "method": self.method, "depth": self.depth,
                "fluid_owned": counts[:, 0].tolist(), "fluid_ghosts": counts[:, 1].tolist(),
                "walls_owned": counts[:, 2].tolist(), "walls_ghosts": counts[:, 3].tolist(),
                "ghost_fraction": float(counts[:, 1].sum() / max(held.sum(), 1)),
                "imbalance_owned_fluid": imbalance(counts[:, 0]), "last_work_imbalance": self.last_imbalance,
                "rebalances": self.rebalances, "decomposition": self.decomposition.describe()}}
