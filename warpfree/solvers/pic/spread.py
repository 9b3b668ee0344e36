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

Open boundaries (sources and absorbing walls: :meth:`PlasmaSpread.injected_elsewhere`,
:meth:`PlasmaSpread.owned`, :meth:`PlasmaSpread.sum_over_ranks`, :meth:`PlasmaSpread.issued`):

- a wall source's particles are counter-based random numbers of their ids (``kernels/pic.py: inject_particles``), and
  every rank issues the same ids (the sources' counts are every rank's alike): every rank makes every injected
  particle, as the one process does, and keeps those its box owns or holds as ghosts, so an injected particle has the
  one process's id, position and velocity wherever it lands;
- an absorbed particle is taken out by every rank that holds it (a ghost is pushed as its owner pushes it, so the
  wall test gives every holder the same answer) and counted once, by the rank whose box holds where it landed (its
  owner after the step's redistribution); the counts of absorbed particles per wall and species are integers, summed
  over the ranks every step (:meth:`sum_over_ranks`), so the walls' charge (count × macro-charge) is bitwise the one
  process's, and so is the live count;
- the ids are then sparse: an id is issued once (loaded particles 0..N-1, each injected one the next) and never
  reused; the particles' :class:`~warpfree.parallel.Partition` counts the ids issued (``count``), and a checkpoint's
  pieces are joined by id (:meth:`respread`).
A plasma with no loaded particle (a diode filled by its source) is cut over its nodes (:meth:`fixed_items`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from warpfree.parallel import CutMethod, MovingSpread, Partition, World, points3
from warpfree.parallel.halo import host_view

__all__ = ["PlasmaSpread"]


class PlasmaSpread(MovingSpread):
    """The decomposition of a plasma over ``world``'s ranks: the particles are the moving set (:attr:`particles`;
    global ids: the particles' ids), the nodes each rank's box owns deposit there. ``space``: the particles' box (default
    the model's; a region's field gives the box enclosing it)."""

    def __init__(self, world: World, model, positions: np.ndarray, method: CutMethod = CutMethod.RCB, space=None):
        space = space or model.space
        self.nodes = points3(model.nodes_np)
        super().__init__(world, positions, cell=float(model.reach), depth=float(model.reach) * (1.0 + 1e-9), dim=2,
                         lower=space.lower, upper=space.upper, periodic=space.periodic, method=method)

    @property
    def particles(self) -> Partition:
        """This rank's part of the particles (the moving set)."""
        return self.moving

    def fixed_items(self) -> tuple[np.ndarray, np.ndarray]:
        """The nodes, weightless: the cut balances the particles, or the nodes when there is no particle yet (a box
        that wall sources fill: the cut cannot follow particles that are not there)."""
        return self.nodes, np.zeros(len(self.nodes))

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

    def owned(self, positions, first: int, last: int) -> np.ndarray:
        """Which held slots [``first``, ``last``) this rank owns (``positions``: the slots' Warp array, (n, 2)): the
        box that holds a slot's position, inside the box or beyond a wall (an absorbed particle, where it landed);
        all of them in one process, without a read."""
        if self.whole:
            return np.ones(last - first, dtype=bool)
        return self.decomposition.owner(points3(positions[first:last].numpy())) == self.world.rank

    # -- open boundaries: sources and absorbing walls --------------------------------------------------------
    def injected_elsewhere(self, positions, first: int, last: int) -> np.ndarray:
        """Of the injected particles in slots [``first``, ``last``) (every rank makes every one), those this rank
        neither owns nor holds as ghosts (their slots, ascending: the caller drops them); none in one process, without
        a read."""
        if self.whole or last <= first:
            return np.zeros(0, dtype=np.int64)
        held = self.decomposition.held_by(points3(positions[first:last].numpy()), self.world.rank, self.depth)
        return first + np.flatnonzero(~held)

    def issued(self, count: int) -> None:
        """The particle ids issued so far (loaded and injected: ``count``): the id space of the particles'
        partition."""
        self.moving.count = int(count)

    def hold(self, particle_id, owned: np.ndarray) -> None:
        """The particles' partition made of the held slots after a sort (``particle_id``: their Warp array; ``owned``:
        which of the first ``owned.size`` this rank owns), for :meth:`describe`: sources and walls change the held
        set after the redistribution. Nothing in one process (its part is every particle)."""
        if self.whole:
            return
        ids = particle_id[:owned.size].numpy().astype(np.int64)
        order = np.argsort(ids, kind="stable")
        part = Partition(self.world, self.decomposition, self.depth, ids[order], owned[order], {}, {},
                         self.particles.count)
        self.moving.release()
        self.moving = part

    def sum_over_ranks(self, counts: np.ndarray) -> np.ndarray:
        """Every rank's integer ``counts`` added (exact in any order: the one process's totals); a copy in one
        process."""
        return self.world.allreduce(np.asarray(counts, dtype=np.int64), "sum")

    def counts(self) -> dict[str, int]:
        """Particles owned and ghost, and nodes, on this rank."""
        return {"particles_owned": self.particles.n_owned, "particles_ghosts": self.particles.n_ghosts,
                "nodes_owned": int(self.my_nodes.size)}
