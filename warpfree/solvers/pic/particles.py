"""The PIC particles: the state that changes (:class:`PICState`) and the per-particle work around it (:class:`Particles`):
capacity grown on demand, the sort by cell that also takes absorbed particles out, and wall injection.

Open boundaries (walls along y): particles that cross an absorbing wall leave (their charge is added to the wall's
tally), sources inject new ones; the particle arrays have spare capacity, grown (doubled) when a step needs more, and
every launch runs over the live count: slots [0, ``state.particle_count``) hold the live particles. float64 positions
and velocities; float32 copies of the positions serve the ``wp.HashGrid`` queries. On several ranks a rank's slots
hold its part of the particles (:class:`~.spread.PlasmaSpread`): it keeps the injected particles its part holds and
counts the absorbed ones it owns; the counts are summed over the ranks (integers: exact).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import RunError
from warpfree.kernels import pic as pk
from warpfree.solver import HostTable, State

from .injection import Injection
from .spread import PlasmaSpread

__all__ = ["PICState", "Particles", "PARTICLE_ARRAYS", "WALLS"]

#: the state's per-particle arrays (they share one capacity: slots [0, particle_count) hold the live particles)
PARTICLE_ARRAYS = ("position", "velocity", "species", "particle_id")
#: the box's walls a particle can leave through (w = 2 axis + side; ``exit_wall`` w + 1); a region's boundary groups
#: follow (w = WALLS + g, ``warpfree.solvers.pic.boundary``), then the code of an injected particle another rank's part
#: holds, not this one's (:attr:`Particles.elsewhere`: the sort drops it uncounted)
WALLS = 4


class PICState(State):
    """The checkpoint of a PIC run.

    Device arrays, one capacity for all: ``position`` x^n (vec2d), ``velocity`` v^{n-1/2} (vec2d), ``species`` (index
    into the solver's species: loads, then sources), ``particle_id`` (the particle's index at load time, or its count
    at injection: ids are never reused, and the arrays are re-sorted by cell every step). Host values: ``steps`` (the
    step count n: t = n Δt survives a resume), ``particle_count`` (the live particles this process holds),
    ``injected`` (particles injected so far: ids and random streams), ``injection_carry`` (each source's fraction of a
    particle owed: the box's sources', then each surface source's), ``absorbed`` (int64 (walls, species): the particles each wall absorbed, index 2·axis + side for
    the box's four, then the region's boundary groups, of each species, over every rank; the wall's charge is :attr:`Particles.wall_charge`), ``injected_charge``, ``history`` (the
    per-step diagnostics,
    :class:`~warpfree.solvers.pic.history.Diagnostics`: a resumed run's ``history.csv`` covers the whole run) and,
    when the potential is averaged, ``potential_sum`` and ``potential_samples``.
    """

    def __init__(self, position: np.ndarray, velocity: np.ndarray, species: np.ndarray, capacity: int, sources: int,
                 device: str, history_columns: list[str], kinds: int = 1, walls: int = WALLS):
        n = len(species)

        def padded(a: np.ndarray) -> np.ndarray:
            out = np.zeros((capacity,) + a.shape[1:], dtype=a.dtype)
            out[:n] = a
            return out

        self.position = wp.array(padded(position), dtype=wp.vec2d, device=device)
        self.velocity = wp.array(padded(velocity), dtype=wp.vec2d, device=device)
        self.species = wp.array(padded(species), dtype=wp.int32, device=device)
        self.particle_id = wp.array(padded(np.arange(n, dtype=np.int32)), dtype=wp.int32, device=device)
        self.steps = 0
        self.particle_count = n
        self.injected = 0
        self.injection_carry = np.zeros(max(sources, 1))
        self.absorbed = np.zeros((walls, max(kinds, 1)), dtype=np.int64)
        self.injected_charge = 0.0
        self.history = HostTable(history_columns)

    @property
    def capacity(self) -> int:
        """The particle slots allocated (the live count is at most this)."""
        return self.position.shape[0]

    def resize(self, capacity: int) -> None:
        """Per-particle arrays of ``capacity`` slots, keeping the first min(old, new) (growth, or a checkpoint's)."""
        for name in PARTICLE_ARRAYS:
            old = getattr(self, name)
            new = wp.zeros(capacity, dtype=old.dtype, device=old.device)
            wp.copy(new, old, count=min(capacity, old.shape[0]))
            setattr(self, name, new)

    def assign(self, values: dict[str, np.ndarray], source: str = "checkpoint") -> None:
        """As :meth:`State.assign`, after taking the checkpoint's capacity (particles injected before it was written
        may have grown the arrays)."""
        saved = values.get("position")
        if saved is not None and np.ndim(saved) == 2 and saved.shape[0] != self.capacity:
            self.resize(int(saved.shape[0]))
        super().assign(values, source)


class Particles:
    """The work arrays of the particles beside the state, sized to its capacity, and what changes their slots.

    state: the :class:`PICState`; box: the space's ``Box2d``; sort_cell: the side of a sort cell (the supports'
    reach); macro_charge: each species' macro-particle charge (host); injections and their kernel bundles
    (``sources``, ``pk.WallSource``); open_boundaries: absorbing walls or sources (the sort then drops absorbed
    particles); emitters: a region's surface sources (:mod:`.emission`); spread: the particles' spread over the ranks (which injected particles this rank keeps and which
    absorbed ones it counts); on_resize: called with the new capacity after the arrays grew (the other parts' work
    arrays).
    """

    def __init__(self, launcher: Launcher, state: PICState, space, box, sort_cell: float, macro_charge: np.ndarray,
                 injections: list[Injection], sources: list, loaded_count: int, dt: float, open_boundaries: bool,
                 spread: PlasmaSpread, emitters: list = ()):
        self.launcher = launcher
        self.state = state
        self.spread = spread
        #: the particles this rank's last sort found absorbed and owns, per wall and species (summed over the ranks
        #: into the state's ``absorbed`` by :meth:`count_over_ranks`)
        self.absorbed_here = np.zeros_like(state.absorbed)
        #: the walls particles are counted against (the box's, then a region's boundary groups) and the ``exit_wall``
        #: code of a particle another rank holds (past them all)
        self.walls = state.absorbed.shape[0]
        self.elsewhere = self.walls + 1
        #: the live particles of every rank (:meth:`count_over_ranks`)
        self.live_total = state.particle_count
        self.box = box
        self.macro_charge_np = macro_charge
        self.injections = injections
        self.sources = sources
        #: a region's surface sources (:class:`~.emission.SurfaceEmitter`), after the box's; their carried fractions
        #: follow the box sources' in the state's ``injection_carry``
        self.emitters = list(emitters)
        self.loaded_count = loaded_count
        self.dt = dt
        self.open_boundaries = open_boundaries
        #: re-sort the particles by cell every step (off: for measuring what sorting buys; 1.1x at 65 k particles;
        #: with absorbing walls the sort also removes the absorbed particles, so it runs regardless)
        self.sort_particles = True
        self.sort_cell = sort_cell
        self.sort_cells_x = int(math.ceil(space.length[0] / sort_cell)) + 1
        self.dead_key = self.sort_cells_x * (int(math.ceil(space.length[1] / sort_cell)) + 1)
        self._live = wp.zeros(1, dtype=wp.int32, device=launcher.device)
        self.on_resize = None
        self.arrays = pk.ParticleArrays()
        self.scratch = pk.ParticleArrays()
        self.allocate(state.capacity)

    @property
    def count(self) -> int:
        """The live particles (the per-step launches run over them)."""
        return self.state.particle_count

    def allocate(self, capacity: int) -> None:
        """The per-particle work arrays for ``capacity`` slots (their contents are rebuilt every step, except the
        exit flags and float32 positions, which are kept)."""
        dev = self.launcher.device
        old32 = getattr(self, "position32", None)
        old_exit = getattr(self, "exit_wall", None)
        self.position32 = wp.zeros(capacity, dtype=wp.vec3, device=dev)
        self.exit_wall = wp.zeros(capacity, dtype=wp.int32, device=dev)
        for new, old in ((self.position32, old32), (self.exit_wall, old_exit)):
            if old is not None:
                wp.copy(new, old, count=min(capacity, old.shape[0]))
        self.sort_keys = wp.zeros(2 * capacity, dtype=wp.int64, device=dev)
        self.sort_order = wp.zeros(2 * capacity, dtype=wp.int32, device=dev)
        self._scratch = {name: wp.zeros(capacity, dtype=getattr(self.state, name).dtype, device=dev)
                         for name in PARTICLE_ARRAYS}
        self.e_field = wp.zeros(capacity, dtype=wp.vec2d, device=dev)
        self.kinetic = wp.zeros(capacity, dtype=wp.float64, device=dev)
        self.momentum = wp.zeros(capacity, dtype=wp.vec2d, device=dev)
        self.bind()

    def bind(self) -> None:
        """Point the kernels' bundles at the current arrays (after a growth or a checkpoint's resize)."""
        for bundle, source in ((self.arrays, vars(self.state)), (self.scratch, self._scratch)):
            for name in PARTICLE_ARRAYS:
                setattr(bundle, name, source[name])
            bundle.position32 = self.position32
            bundle.exit_wall = self.exit_wall

    def ensure_capacity(self, needed: int) -> None:
        """Double the per-particle arrays until ``needed`` slots fit (injection)."""
        capacity = self.state.capacity
        if needed <= capacity:
            return
        while capacity < needed:
            capacity *= 2
        self.state.resize(capacity)
        self.allocate(capacity)
        if self.on_resize is not None:
            self.on_resize(capacity)

    def sync_position32(self) -> None:
        """Copy the float64 positions into the float32 vec3 array the hash grid is built over."""
        p = self.state.position.numpy()
        p32 = np.zeros((p.shape[0], 3), dtype=np.float32)
        p32[:, :2] = p
        self.position32.assign(p32)

    def sort(self, total: int) -> None:
        """Reorder slots [0, ``total``) by cell (row-major, cells of the support reach), then particle id: the deposit
        gathers each node's particles from contiguous memory. Every step, so the order depends on the positions and ids
        only (a resumed run sorts as the uninterrupted one did, a distributed run's rank as the one process does).
        Absorbed particles sort past every cell, grouped by wall (then those another rank holds, :attr:`elsewhere`):
        the live count drops to the particles before them, and the absorbed ones this rank owns are counted in
        :attr:`absorbed_here`."""
        L, st = self.launcher, self.state
        if self.sort_particles or self.open_boundaries:
            L.launch(pk.cell_keys, total, [self.box, wp.float64(1.0 / self.sort_cell), self.sort_cells_x,
                                           self.dead_key, self.exit_wall, st.position, st.particle_id,
                                           self.sort_keys, self.sort_order])
            if total > 1:
                wp.utils.radix_sort_pairs(self.sort_keys, self.sort_order, total)
            L.launch(pk.permute_particles, total, [self.sort_order, self.arrays, self.scratch])
            for name in PARTICLE_ARRAYS:
                wp.copy(getattr(st, name), self._scratch[name], count=total)
        live = total
        if self.open_boundaries and total:
            self._live.zero_()
            L.launch(pk.count_live, total, [total, self.dead_key, self.sort_keys, self._live])
            live = int(self._live.numpy()[0])
            if live < total:
                self.count_absorbed(live, total)
        st.particle_count = live

    def count_absorbed(self, first: int, last: int) -> None:
        """Add the absorbed particles in the sorted dead slots [``first``, ``last``) that this rank owns to
        :attr:`absorbed_here`, per wall and species (those of :attr:`elsewhere` are another rank's)."""
        walls = self.sort_keys[first:last].numpy() // 2 ** 31 - self.dead_key
        species = self.state.species[first:last].numpy()
        counted = (walls < self.walls) & self.spread.owned(self.state.position, first, last)
        np.add.at(self.absorbed_here, (walls[counted], species[counted]), 1)

    def count_over_ranks(self, owned: np.ndarray) -> None:
        """After a sort, with open boundaries: the live particles (this rank's ``owned`` slots) and the absorbed ones
        (:attr:`absorbed_here`) added over the ranks, into :attr:`live_total` and the state's ``absorbed``."""
        st = self.state
        counts = np.concatenate([[int(np.count_nonzero(owned))], self.absorbed_here.ravel()])
        totals = self.spread.sum_over_ranks(counts)
        self.live_total = int(totals[0])
        st.absorbed = st.absorbed + totals[1:].reshape(st.absorbed.shape)
        self.absorbed_here[:] = 0

    @property
    def wall_charge(self) -> np.ndarray:
        """The charge each wall absorbed (index 2·axis + side, then a region's boundary groups): its count of each
        species × the species'
        macro-charge, summed over the species (the same bits on every rank count)."""
        return (self.state.absorbed * self.macro_charge_np).sum(axis=1)

    def inject(self) -> int:
        """Each source's particles for this step into the slots after the live ones (:mod:`.injection`, and a
        region's surface sources, :mod:`.emission`);
        returns the slots now filled (live + new). Every rank makes every new particle (the same ids, positions and
        velocities as the one process); those its part does not hold are marked :attr:`elsewhere` for the sort to
        drop."""
        st = self.state
        carry = st.injection_carry
        injected = st.injected
        new_counts = []
        for k, source in enumerate(self.injections):
            owed = carry[k] + source.particles_per_step
            new_counts.append(int(math.floor(owed)))
            carry[k] = owed - new_counts[-1]
        first = len(self.injections)
        for k, emitter in enumerate(self.emitters):
            new_counts.append(emitter.count(carry[first + k:first + k + 1]))
        if self.loaded_count + injected + sum(new_counts) >= 2 ** 31:
            raise RunError(f"{self.loaded_count + injected} particles loaded and injected so far: the next step's "
                           "would take particle ids past the int32 range", st.steps)
        self.ensure_capacity(self.count + sum(new_counts))
        slot = self.count
        charge = 0.0
        for source, new in zip(self.sources, new_counts):
            self.launcher.launch(pk.inject_particles, new, [self.box, source, slot, self.loaded_count + injected,
                                                            wp.float64(self.dt), self.arrays])
            slot += new
            injected += new
            charge += new * self.macro_charge_np[source.species]
        for emitter, new in zip(self.emitters, new_counts[len(self.sources):]):
            self.launcher.launch(pk.emit_from_surface, new, [emitter.bundle, slot, self.loaded_count + injected,
                                                             wp.float64(self.dt), self.arrays])
            slot += new
            injected += new
            charge += new * self.macro_charge_np[emitter.bundle.species]
        self.spread.issued(self.loaded_count + injected)
        self._drop_elsewhere(self.count, slot)
        st.injected = injected
        st.injected_charge = st.injected_charge + charge
        return slot

    def _drop_elsewhere(self, first: int, last: int) -> None:
        """Mark the new particles in slots [``first``, ``last``) that this rank's part does not hold
        :attr:`elsewhere` (no read in one process: it holds them all)."""
        drop = self.spread.injected_elsewhere(self.state.position, first, last)
        if drop.size:
            codes = self.exit_wall[first:last].numpy().copy()
            codes[drop - first] = self.elsewhere
            self.exit_wall[first:last].assign(codes)

    @staticmethod
    def wall_source(index: int, injection: Injection) -> pk.WallSource:
        """The kernel's bundle for one source (built once: the same object every step)."""
        src = pk.WallSource()
        src.species = index
        src.seed = int(injection.seed)
        src.inward = wp.float64(injection.inward)
        src.normal_speed = wp.float64(injection.normal_speed)
        src.thermal_speed = wp.float64(injection.species.thermal_speed if injection.warm else 0.0)
        src.drift_x = wp.float64(injection.species.drift[0])
        return src
