"""A PIC plasma spread over the ranks of a distributed run.

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

import numpy as np

from warpfree.errors import ParameterError
from warpfree.parallel import CutMethod, Decomposition, Partition, World

__all__ = ["PlasmaSpread"]


def _points3(xy: np.ndarray) -> np.ndarray:
    out = np.zeros((len(xy), 3))
    out[:, :2] = xy
    return out


class PlasmaSpread:
    """The decomposition of a plasma over ``world``'s ranks: the particles' :class:`~warpfree.parallel.Partition`
    (global ids: the particles' ids) and the nodes each rank's box owns."""

    def __init__(self, world: World, model, positions: np.ndarray, method: CutMethod = CutMethod.RCB):
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

    def owned(self, positions: np.ndarray) -> np.ndarray:
        """Which of the held particles at ``positions`` (n, 2) this rank owns (its box holds them)."""
        return self.decomposition.owner(_points3(positions)) == self.world.rank

    def redistribute(self, held: dict[str, np.ndarray], owned: np.ndarray) -> dict[str, np.ndarray]:
        """Every rank's own particles (``held`` rows where ``owned``: position, velocity, species, particle_id) to the
        ranks that now need them; returns the new held rows in id order."""
        ids = held["particle_id"].astype(np.int64)
        part = Partition(self.world, self.decomposition, self.depth, ids, owned, {}, {}, self.particles.count)
        self.particles, out = part.redistribute(self.decomposition, _points3(held["position"]), held)
        return out

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
        """The distributed layout for ``summary.json``: particles owned and ghost, and nodes, per rank; imbalance."""
        counts = np.concatenate(self.world.allgather(np.array(
            [self.particles.n_owned, self.particles.n_ghosts, self.my_nodes.size], dtype=np.int64)))
        counts = counts.reshape(self.world.size, 3)
        held = counts[:, 0] + counts[:, 1]
        return {"ranks": self.world.size, "depth": self.depth, "particles_owned": counts[:, 0].tolist(),
                "particles_ghosts": counts[:, 1].tolist(), "nodes_owned": counts[:, 2].tolist(),
                "ghost_fraction": float(counts[:, 1].sum() / max(held.sum(), 1)),
                "decomposition": self.decomposition.describe()}
