"""A PIC plasma spread over the ranks of a run.

A run of one process is a one-rank partition: it holds every particle and deposits on every node; nothing moves
between ranks and the charges and sums need no exchange.

The field side is replicated: every rank holds every node, the factorised Poisson matrix and the whole potential.
The particles are spread: a rank holds those its box owns and, as ghosts, those within the nodes' support reach of
its box. A ghost is pushed as its owner pushes it (its field comes from the replicated nodal fields and its own fit),
so a step needs no refresh; after each push the particles move to the boxes that now hold them
(:meth:`PlasmaSpread.redistribute`), then each rank sorts what it holds by cell and id, as the one process sorts all
of them (``Particles.sort``): its particles sit in the order they have among all, and each node's deposit sums the one
process's terms in its order. A rank deposits on the nodes its box owns; one gather of those charges gives every rank
the whole charge vector (:meth:`PlasmaSpread.whole_charge`), bitwise the one process's, and so the same potential.
The step's particle sums (kinetic energy, momentum) are each rank's own particles', added in rank order: these, unlike
the state, agree with the one process to round-off only (its reduction adds the particles in another order).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from warpfree.errors import ParameterError
from warpfree.parallel import CutMethod, Decomposition, Partition, World
from warpfree.parallel.halo import host_view

__all__ = ["PlasmaSpread"]


def _points3(xy: np.ndarray) -> np.ndarray:
    out = np.zeros((len(xy), 3))
    out[:, :2] = xy
    return out


class PlasmaSpread:
    """The decomposition of a plasma over ``world``'s ranks: the particles' :class:`~warpfree.parallel.Partition`
    (global ids: the particles' ids) and the nodes each rank's box owns."""

    def __init__(self, world: World, model, positions: np.ndarray, injections=(), particle_walls=(),
                 method: CutMethod = CutMethod.RCB):
        if world.distributed:
            self.refuse_open_boundaries(injections, particle_walls)
        self.world = world
        space = model.space
        self.depth = float(model.reach) * (1.0 + 1e-9)
        self.decomposition = Decomposition.build(world.size, _points3(positions), None, float(model.reach), 2, method,
                                                 space.lower, space.upper, space.periodic)
        self.particles = Partition.of_all(world, self.decomposition, self.depth, _points3(positions))
        owner = self.decomposition.owner(_points3(model.nodes_np))
        #: the nodes this rank deposits on (its box's), and every node's owner
        self.my_nodes = np.flatnonzero(owner == world.rank)
        self.node_owner = owner
        self._node_order = np.concatenate([np.flatnonzero(owner == r) for r in range(world.size)])

    @property
    def whole(self) -> bool:
        """True in one process: every particle and node is this rank's."""
        return self.particles.whole

    def room(self, held: int, injected: int) -> int:
        """Slots to keep free beyond the ``held`` particles: ``injected`` (what sources add between two sorts) in one
        process; on several ranks room for the particles that arrive, before the arrays must grow."""
        return injected if self.whole else max(16, held // 4)

    def owned(self, positions, count: int) -> np.ndarray:
        """Which of the first ``count`` held particles (``positions``: their Warp array, (n, 2)) this rank owns (its
        box holds them): all of them in one process, without a read."""
        if self.whole:
            return np.ones(count, dtype=bool)
        return self.decomposition.owner(_points3(positions.numpy()[:count])) == self.world.rank

    def gather_particles(self, values: dict[str, np.ndarray], owned: np.ndarray) -> dict[str, np.ndarray]:
        """Every rank's own particles' ``values`` (held rows, one of them ``particle_id``), in id order, on every
        rank; in one process ``values`` themselves (slot order)."""
        if self.whole:
            return values
        ids = self.world.allgather(values["particle_id"][owned].astype(np.int64))
        order = np.argsort(np.concatenate(ids), kind="stable")
        return {k: np.concatenate(self.world.allgather(np.ascontiguousarray(v[owned])))[order]
                for k, v in values.items()}

    def count_once(self, arrays, owned: np.ndarray, count: int) -> None:
        """Zero the per-particle ``arrays`` (their first ``count`` slots) where a particle is a ghost, so that a sum
        over every rank counts each particle once, on its owner: nothing to do in one process."""
        if self.whole:
            return
        for values in arrays:
            held, write_back = host_view(values)
            held[:count][~owned] = 0.0
            if write_back is not None:
                write_back()

    def redistribute(self, held: Callable[[], dict[str, np.ndarray]], owned: np.ndarray,
                     lay_out: Callable[[dict[str, np.ndarray]], None]) -> None:
        """Every rank's own particles (``held()`` rows where ``owned``: position, velocity, species, particle_id) to
        the ranks that now need them; ``lay_out`` takes the new held rows, in id order. Nothing moves in one process:
        neither is called."""
        if self.whole:
            return
        values = held()
        ids = values["particle_id"].astype(np.int64)
        part = Partition(self.world, self.decomposition, self.depth, ids, owned, {}, {}, self.particles.count)
        self.particles, out = part.redistribute(self.decomposition, _points3(values["position"]), values)
        lay_out(out)

    def respread(self, positions: np.ndarray) -> None:
        """Hold the parts of every particle at ``positions`` (all N, by id: a checkpoint read on another number of
        processes)."""
        part = Partition.of_all(self.world, self.decomposition, self.depth, _points3(positions))
        self.particles.release()
        self.particles = part

    @property
    def charge_exchange(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """:meth:`whole_charge` on several ranks; None in one process (its deposit is the whole charge already)."""
        return None if self.whole else self.whole_charge

    def whole_charge(self, charge: np.ndarray) -> np.ndarray:
        """The nodal charges of every rank's own nodes (each deposited by its owner, over its own and ghost particles),
        as one vector on every rank."""
        parts = self.world.allgather(np.ascontiguousarray(charge[self.my_nodes]))
        out = np.empty_like(charge)
        out[self._node_order] = np.concatenate(parts)
        return out

    @staticmethod
    def refuse_open_boundaries(injections, particle_walls) -> None:
        """Sources and absorbing walls change the particles' count on one rank and their ids: not distributed yet."""
        if injections:
            raise ParameterError("injections", "a distributed run cannot inject particles yet (wall sources): run "
                                               "this scene in one process")
        if "absorb" in particle_walls:
            raise ParameterError("particle_walls", "a distributed run cannot absorb particles at the walls yet: run "
                                                   "this scene in one process, or with reflecting walls")

    def describe(self) -> dict:
        """The distributed layout for ``summary.json`` (``{"distributed": ...}``; nothing in one process): particles
        owned and ghost, and nodes, per rank; imbalance."""
        if self.whole:
            return {}
        counts = np.concatenate(self.world.allgather(np.array(
            [self.particles.n_owned, self.particles.n_ghosts, self.my_nodes.size], dtype=np.int64)))
        counts = counts.reshape(self.world.size, 3)
        held = counts[:, 0] + counts[:, 1]
        return {"distributed": {"ranks": self.world.size, "depth": self.depth,
                                "particles_owned": counts[:, 0].tolist(), "particles_ghosts": counts[:, 1].tolist(),
                                "nodes_owned": counts[:, 2].tolist(),
                                "ghost_fraction": float(counts[:, 1].sum() / max(held.sum(), 1)),
                                "decomposition": self.decomposition.describe()}}
