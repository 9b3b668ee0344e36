"""Moving items over the ranks: the cut of space they follow, this rank's part of them, their migration and the
rebalancing of the cut.

Particles that move (a fluid's, a plasma's) are one item set on a :class:`~warpfree.parallel.Decomposition`: a rank
holds those its box owns and, as ghosts, those within ``depth`` of it (:class:`~warpfree.parallel.Partition`). When
they have moved, :meth:`MovingSpread.migrate` sends each rank's own items to the ranks that now hold them; when the
ranks' work (a cost per item: neighbour pairs, or 1) has drifted apart by more than ``rebalance`` (max/mean over the
ranks; or their measured time), space is cut anew from the current positions first. A family's spread subclasses it and keeps beside it what
does not move (a fluid's walls, a field's nodes): :meth:`MovingSpread.fixed_items` gives their positions and cost for
a cut, :meth:`MovingSpread.follow_cut` lays them out on a new one.

A run of one process is a one-rank partition: the part is the whole set in global order, no ghost, and nothing moves
(:meth:`migrate` does nothing and returns None).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from warpfree.errors import ParameterError

from .decomposition import CutMethod, Decomposition, Mirrors, imbalance
from .halo import Partition
from .world import World

__all__ = ["MovingSpread", "points3"]


def points3(positions) -> np.ndarray:
    """Positions of any dimension (n, 1..3) as (n, 3) float64 points (zeros beyond the dimension)."""
    p = np.asarray(positions, dtype=np.float64)
    p = p.reshape(p.shape[0], int(np.prod(p.shape[1:]))) if p.ndim > 1 else p.reshape(-1, 1)
    out = np.zeros((p.shape[0], 3))
    out[:, :min(p.shape[1], 3)] = p[:, :3]
    return out


class MovingSpread:
    """A moving item set over ``world``'s ranks.

    Parameters
    ----------
    world: the ranks.
    positions: every moving item's position at set-up ((n, dim), global order; every rank knows them all).
    cell: the cut's cell (m; the neighbour grid's cell: boxes are whole cells).
    depth: how far from its box a rank holds ghosts (m).
    dim: the space's dimension; lower, upper: the domain's bounds (finite where known); periodic: per axis.
    method: how space is cut (:class:`~warpfree.parallel.CutMethod`).
    rebalance: cut anew at a migration when the ranks' work has max/mean above this (>= 1; ``inf``: never).
    mirrors: planes across which a rank also holds the moving items whose mirror image is near its box
        (:class:`~warpfree.parallel.decomposition.Mirrors`), or None.
    """

    def __init__(self, world: World, positions, *, cell: float, depth: float, dim: int, lower, upper, periodic,
                 method: CutMethod = CutMethod.RCB, rebalance: float = math.inf, mirrors: Mirrors | None = None):
        if not rebalance >= 1.0:
            raise ParameterError("rebalance", f"must be >= 1 (max/mean of the ranks' work), got {rebalance!r}")
        self.world = world
        self.cell, self.depth, self.dim, self.method = float(cell), float(depth), int(dim), method
        self.periodic = tuple(bool(p) for p in periodic)
        self.lower, self.upper = points3([lower])[0], points3([upper])[0]
        self.rebalance_above = float(rebalance)
        self.mirrors = mirrors
        self.rebalances = 0
        self.last_imbalance: float | None = None
        moving = points3(positions)
        fixed, fixed_cost = self.fixed_items()
        self.decomposition = self.cut(np.vstack([moving, fixed]), np.concatenate([np.ones(len(moving)), fixed_cost]))
        #: this rank's part of the moving items
        self.moving = Partition.of_all(world, self.decomposition, self.depth, moving, mirrors)
        self.follow_cut()

    @property
    def whole(self) -> bool:
        """True in one process: every item is this rank's, in global order."""
        return self.moving.whole

    # -- what a family adds -----------------------------------------------------------------------------------
    def fixed_items(self) -> tuple[np.ndarray, np.ndarray]:
        """The items that do not move but weigh in a cut: their points ((m, 3)) and cost ((m,)). None by default."""
        return np.zeros((0, 3)), np.zeros(0)

    def follow_cut(self) -> None:
        """Lay the fixed items out on the current :attr:`decomposition` (at set-up, after a rebalance or a
        respread)."""

    # -- the cut ----------------------------------------------------------------------------------------------
    def cut(self, points: np.ndarray, cost: np.ndarray) -> Decomposition:
        """Boxes of whole cells for ``points`` (n, 3) balancing ``cost`` (n,), counted from the domain's lower
        corner where it is finite (else the items'); weightless items (a cost of 0 in all) balance their count. A
        periodic side too thin for a ghost layer on each side of a cut: ParameterError naming ``ranks``."""
        if not np.sum(cost) > 0:
            cost = np.ones(len(points))
        finite = np.isfinite(self.lower) & (np.abs(self.lower) < 1e20)
        origin = np.where(finite, self.lower, points.min(axis=0) if len(points) else 0.0)
        dec = Decomposition.build(self.world.size, points, cost, self.cell, self.dim, self.method, origin,
                                  self.upper, self.periodic)
        for a in range(self.dim):
            if (self.periodic[a] and self.world.size > 1 and dec.period[a] < 2.0 * self.depth * 1.0000001
                    and np.unique(dec.lower[:, a]).size > 1):
                raise ParameterError("ranks", f"the periodic side {dec.period[a]:.4g} m along {'xyz'[a]} is too "
                                              f"thin to cut: a ghost layer is {self.depth:.4g} m deep")
        return dec

    # -- moving -----------------------------------------------------------------------------------------------
    def migrate(self, values: dict[str, np.ndarray], owned: np.ndarray | None = None,
                work: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
                ids: str = "", busy: float | None = None) -> dict[str, np.ndarray] | None:
        """Send each own item, with its ``values`` (held rows, NumPy; one of them ``position``), to the ranks that
        now hold it; returns the new held rows, in global-id order. The held rows are the part's (``owned`` None), or
        rows in another order whose global ids are ``values[ids]`` and own ones ``owned`` (a set re-sorted since).
        ``work()`` gives each held item's cost, and the own fixed items' points and cost: when the ranks' work has
        max/mean above ``rebalance``, space is cut anew first. ``busy`` (given on every rank or on none): the seconds
        this rank worked on its items since the last migration; the ranks' work is then their measured time, and each
        item's cost is weighted by its rank's seconds per unit of cost (as LAMMPS' ``balance weight time``: a cost
        model misses per-item overheads and slower cores; the results do not depend on the cut). In one process
        nothing moves: returns None, calls nothing."""
        if self.whole:
            return None
        part = self.moving
        if owned is not None:
            part = Partition(self.world, self.decomposition, self.depth, np.asarray(values[ids], np.int64), owned,
                             {}, {}, self.moving.count, self.mirrors)
        positions = points3(values["position"])
        if work is not None:
            self._rebalance(positions[part.owned_index], *work(), part.owned_index, busy)
        self.moving, held = part.redistribute(self.decomposition, positions, values)
        return held

    def _rebalance(self, own_positions, moving_cost, fixed_points, fixed_cost, own, busy=None) -> None:
        world = self.world
        own_cost = np.asarray(moving_cost, np.float64)[own]
        fixed_cost = np.asarray(fixed_cost, np.float64)
        modelled = own_cost.sum() + fixed_cost.sum()
        if busy is not None and busy > 0.0 and modelled > 0.0:  # cost in this rank's measured seconds
            own_cost, fixed_cost = own_cost * (busy / modelled), fixed_cost * (busy / modelled)
        per_rank = np.concatenate(world.allgather(np.array([own_cost.sum() + fixed_cost.sum()])))
        self.last_imbalance = imbalance(per_rank)
        if self.last_imbalance <= self.rebalance_above:
            return
        points = np.vstack(world.allgather(own_positions) + world.allgather(points3(fixed_points)))
        cost = np.concatenate(world.allgather(own_cost) + world.allgather(fixed_cost))
        self.decomposition = self.cut(points, cost)
        self.rebalances += 1
        self.follow_cut()

    def respread(self, positions, ids: np.ndarray | None = None, count: int | None = None) -> np.ndarray:
        """Cut anew for the moving items at ``positions`` (a checkpoint read on any number of ranks: every item, in
        the order of their ascending global ``ids``, default 0..n-1; ``count``: the ids issued, default n) and the
        fixed items, and hold the part of that cut; returns the rows of ``positions`` held (every row in one
        process)."""
        moving = points3(positions)
        ids = np.arange(len(moving), dtype=np.int64) if ids is None else np.asarray(ids, np.int64)
        fixed, fixed_cost = self.fixed_items()
        self.decomposition = self.cut(np.vstack([moving, fixed]), np.concatenate([np.ones(len(moving)), fixed_cost]))
        rows = np.flatnonzero(self.decomposition.held_by(moving, self.world.rank, self.depth, self.mirrors))
        self.moving.release()
        self.moving = Partition.of_items(self.world, self.decomposition, self.depth, ids[rows], moving[rows],
                                         len(moving) if count is None else int(count), self.mirrors)
        self.follow_cut()
        return rows

    # -- the layout in summary.json ---------------------------------------------------------------------------
    def counts(self) -> dict[str, int]:
        """This rank's item counts by name, for :meth:`describe`."""
        return {"owned": self.moving.n_owned, "ghosts": self.moving.n_ghosts}

    def describe(self) -> dict:
        """The distributed layout for ``summary.json`` (``{"distributed": ...}``; nothing in one process): the
        :meth:`counts` per rank, the moving items' ghost fraction and imbalance, the rebalances and the cut."""
        if self.whole:
            return {}
        mine = self.counts()
        table = np.concatenate(self.world.allgather(np.array(list(mine.values()), dtype=np.int64)))
        table = table.reshape(self.world.size, len(mine))
        out = {"ranks": self.world.size, "method": self.method, "depth": self.depth}
        out.update({name: table[:, k].tolist() for k, name in enumerate(mine)})
        owned = np.concatenate(self.world.allgather(np.array([self.moving.n_owned])))
        ghosts = np.concatenate(self.world.allgather(np.array([self.moving.n_ghosts])))
        out.update({"ghost_fraction": float(ghosts.sum() / max(owned.sum() + ghosts.sum(), 1)),
                    "imbalance_owned": imbalance(owned), "last_work_imbalance": self.last_imbalance,
                    "rebalances": self.rebalances, "decomposition": self.decomposition.describe()})
        return {"distributed": out}
