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
from warpfree.parallel import CutMethod, MovingSpread, Partition, World, points3
from warpfree.parallel.halo import host_view

__all__ = ["PlasmaSpread"]


class PlasmaSpread(MovingSpread):
    """The decomposition of a plasma over ``world``'s ranks: the particles are the moving set (:attr:`particles`;
    global ids: the particles' ids), the nodes each rank's box owns deposit there."""

    def __init__(self, world: World, model, positions: np.ndarray, injections=(), particle_walls=(),
                 method: CutMethod = CutMethod.RCB):
        if world.distributed:
            self.refuse_open_boundaries(injections, particle_walls)
        space = model.space
        self.nodes = points3(model.nodes_np)
        super().__init__(world, positions, cell=float(model.reach), depth=float(model.reach) * (1.0 + 1e-9), dim=2,
                         lower=space.lower, upper=space.upper, periodic=space.periodic, method=method)
        self.follow_cut()

    @property
    def particles(self) -> Partition:
        """This rank's part of the particles (the moving set)."""
        return self.moving

    def follow_cut(self) -> None:
        """The nodes this rank deposits on (its box's), every node's owner, and the nodes in rank order."""
        owner = self.decomposition.owner(self.nodes)
        self.my_nodes = np.flatnonzero(owner == self.world.rank)
        self.node_owner = owner
        self._node_order = np.concatenate([np.flatnonzero(owner == r) for r in range(self.world.size)])

    def room(self, held: int, injected: int) -> int:
        """Slots to keep free beyond the ``held`` particles: ``injected`` (what sources add between two sorts) in one
        process; on several ranks room for the particles that arrive, before the arrays must grow."""
        return injected if self.whole else max(16, held // 4)

    def owned(self, positions, count: int) -> np.ndarray:
        """Which of the first ``count`` held particles (``positions``: their Warp array, (n, 2)) this rank owns (its
        box holds them): all of them in one process, without a read."""
        if self.whole:
            return np.ones(count, dtype=bool)
        return self.decomposition.owner(points3(positions.numpy()[:count])) == self.world.rank

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
        if not self.whole:
            lay_out(self.migrate(held(), owned=owned, ids="particle_id"))

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

    def counts(self) -> dict[str, int]:
        """Particles owned and ghost, and nodes, on this rank."""
        return {"particles_owned": self.particles.n_owned, "particles_ghosts": self.particles.n_ghosts,
                "nodes_owned": int(self.my_nodes.size)}
