"""The PIDC solver (seed 002 ch. 4-5): electrostatic particle-in-cell whose field solve is EFG.

One step (``kernels/pic.py``; the order of seed 002 §5.2):

    neighbours:  rebuild the HashGrid over the particles (and their periodic images)
    fits:        the MLS fit of every particle over the nodes (γ, ∂γ: φ_I and ∇φ_I, stored once per step)
    deposit:     Q_I = Σ_p q_p φ_I(x_p), a node gather (eq 4.4)
    solve:       K u = Q + ρ_bg m on the kept factorisation (:class:`~.field.PlasmaPoisson`)
    gather:      E_p = -Σ_I u_I ∇φ_I(x_p) (eq 4.5)
    push:        leapfrog (eqs 2.21 / 4.7), positions wrapped into the box, reflected or absorbed at walls
    inject:      wall sources add their particles (:mod:`.injection`)
    sort:        particles re-sorted by cell; absorbed ones move past the live ones and leave the count

Open boundaries (walls along y): particles that cross an absorbing wall leave (their charge is added to the wall's
tally), sources inject new ones; the particle arrays have spare capacity, grown (doubled) when a step needs more,
and every launch runs over the live count. ``deposited_charge`` = initial + injected - absorbed charge to round-off.

The state holds x^n, v^{n-1/2}; the first step is preceded by the half-step start v^{-1/2} = v^0 - (q/m) E^0 Δt/2
(seed 002 §2.2.3), done at construction. The solver holds the EFG model and its factorised Poisson matrix (the
discretisation does not change in time: assembled and factorised once, seed 002 §5.5).

Checks (the two causes of numerical heating PIC users hit most): ω_pe Δt ≥ 2 (the leapfrog's stability limit) is
refused; ω_pe Δt > 0.2 (seed 002 §2.2.3, printed "Δt = 0.2 ω_pe") and a node spacing above 2 λ_D warn, saying by
how much. Diagnostics each step (:attr:`PICSolver.history`): kinetic, field and total energy, momentum, deposited
charge, field energy in chosen Fourier modes. Normalised units: see :mod:`.species`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError, RunError, require_finite, require_positive
from warpfree.kernels import mls as mk
from warpfree.kernels import pic as pk
from warpfree.neighbours import NeighbourGrid
from warpfree.reduce import Reduction
from warpfree.solver import OutputSet, State, StepRule, TimeDependentSolver
from warpfree.galerkin.mls import RCOND_LIMIT, MLSModel

from .field import PlasmaPoisson
from .injection import Injection
from .species import ParticleLoad, Species

__all__ = ["PICSolver", "PICState", "HEATING_DT", "HEATING_SPACING"]

#: ω_pe Δt above which the leapfrog's phase error heats the plasma noticeably (seed 002 §2.2.3: Δt = 0.2/ω_pe)
HEATING_DT = 0.2
#: node spacing / λ_D above which finite-grid (aliasing) heating sets in for a warm plasma
HEATING_SPACING = 2.0
#: the field gathers (``warpfree.solvers.pic.field``)
GATHERS = ("momentum", "energy")
#: what a wall does with a particle that reaches it
PARTICLE_WALLS = ("reflect", "absorb")
#: the state's per-particle arrays (they share one capacity: slots [0, particle_count) hold the live particles)
PARTICLE_ARRAYS = ("position", "velocity", "species", "particle_id")


class PICState(State):
    """position x^n (vec2d), velocity v^{n-1/2} (vec2d), species (index into the solver's species: loads, then
    sources), particle_id (the particle's index at load time, or count at injection: the arrays are re-sorted by cell
    every step), steps (the step count n, one int64: t = n Δt survives a resume), particle_count (the live particles:
    slots [0, particle_count) of the per-particle arrays, whose length is the capacity), injected (particles injected
    so far: ids and random streams), injection_carry (each source's fraction of a particle owed), wall_charge (charge
    absorbed by each wall: index 2·axis + side), injected_charge. Its checkpoint also holds the solver's per-step
    history (``history``: steps × columns), so a resumed run's ``history.csv`` covers the whole run."""

    def __init__(self, position: np.ndarray, velocity: np.ndarray, species: np.ndarray, capacity: int, sources: int,
                 device: str):
        n = len(species)

        def padded(a: np.ndarray) -> np.ndarray:
            out = np.zeros((capacity,) + a.shape[1:], dtype=a.dtype)
            out[:n] = a
            return out

        self.position = wp.array(padded(position), dtype=wp.vec2d, device=device)
        self.velocity = wp.array(padded(velocity), dtype=wp.vec2d, device=device)
        self.species = wp.array(padded(species), dtype=wp.int32, device=device)
        self.particle_id = wp.array(padded(np.arange(n, dtype=np.int32)), dtype=wp.int32, device=device)
        self.steps = wp.zeros(1, dtype=wp.int64, device=device)
        self.particle_count = wp.array([n], dtype=wp.int64, device=device)
        self.injected = wp.zeros(1, dtype=wp.int64, device=device)
        self.injection_carry = wp.zeros(max(sources, 1), dtype=wp.float64, device=device)
        self.wall_charge = wp.zeros(4, dtype=wp.float64, device=device)
        self.injected_charge = wp.zeros(1, dtype=wp.float64, device=device)
        #: the solver's per-step history as a table and its restorer (set by :class:`PICSolver`)
        self.history_table = None
        self.restore_history = None

    def numpy(self) -> dict[str, np.ndarray]:
        out = super().numpy()
        if self.history_table is not None:
            out["history"] = self.history_table()
        return out

    @property
    def capacity(self) -> int:
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
        if self.restore_history is not None and "history" in values:
            self.restore_history(np.asarray(values["history"]), source)


class PICSolver(TimeDependentSolver):
    """Electrostatic PIC on an EFG field solve, in a periodic box or between walls along y (reflecting particles).

    Parameters
    ----------
    field: :class:`~.field.PlasmaPoisson` (holds the :class:`~warpfree.galerkin.mls.MLSModel`).
    loads: the species and their macro-particles (:func:`~.species.load_species`).
    dt: the time step (ω_pe⁻¹ units); ω_pe Δt must be < 2.
    background_density: uniform immobile charge density (e n_ref); default: the one that makes the plasma neutral.
    modes: Fourier modes (mx, my) whose field energy each step records.
    gather: "momentum" (nodal fields interpolated with φ_I: no self-force, momentum kept on node lattices) or
    "energy" (eq 4.5, -Σ u_I ∇φ_I: energy kept, a self-force of the order of a neighbour's); see :mod:`.field`.
    magnetic_field: a static uniform B_z (normalised: ω_ce = |B_z| for electrons), pushed by Boris's rotation.
    particle_walls: what the walls along y (y not periodic) do with a particle that reaches them: "reflect" or
    "absorb", one for both or (lower, upper).
    injections: wall sources (:class:`~.injection.Injection`); loads may then be empty (a vacuum diode).
    average_from: time from which the nodal potential is averaged over the steps (:meth:`mean_potential`: the
    steady profile of a noisy run); None: not averaged.
    """

    name = "pic"
    work_unit = "particle pushes"
    time_unit = "/ω_pe"

    def __init__(self, field: PlasmaPoisson, loads: list[ParticleLoad], dt: float,
                 background_density: float | None = None, modes=((1, 0),), gather: str = "momentum",
                 magnetic_field: float = 0.0, particle_walls="reflect", injections: list[Injection] = (),
                 average_from: float | None = None, launcher: Launcher | None = None):
        model: MLSModel = field.model
        super().__init__(model, launcher or model.launcher)
        self.field = field
        self.loads = list(loads)
        self.injections = list(injections)
        if not self.loads and not self.injections:
            raise ParameterError("loads", "need at least one species (loaded, or injected from a wall)")
        if gather not in GATHERS:
            raise ParameterError("gather", f"must be one of {list(GATHERS)}, got {gather!r}")
        self.gather = gather
        self.magnetic_field = wp.float64(require_finite("magnetic_field", magnetic_field))
        self.dt = require_positive("dt", dt)
        space = model.space
        self.particle_walls = self._wall_modes(particle_walls, space)
        if self.injections and space.periodic[1]:
            raise ParameterError("injections", "a source sits on a wall: the box is periodic along y (give walls)")
        self.species_list: list[Species] = [ld.species for ld in self.loads] + [j.species for j in self.injections]
        self.plasma_frequency = math.sqrt(sum(s.plasma_frequency ** 2 for s in self.species_list))
        self._check_step()
        self._check_spacing()
        self.background_density = (-sum(ld.species.charge * ld.species.density for ld in self.loads)
                                   if background_density is None else float(background_density))
        dev = self.launcher.device
        weights = [ld.weight for ld in self.loads] + [j.weight(space.length[0], self.dt) for j in self.injections]
        self.macro_charge_np = np.array([sp_.charge * w for sp_, w in zip(self.species_list, weights)])
        self.macro_mass_np = np.array([sp_.mass * w for sp_, w in zip(self.species_list, weights)])
        self.macro_charge = wp.array(self.macro_charge_np, dtype=wp.float64, device=dev)
        self.macro_mass = wp.array(self.macro_mass_np, dtype=wp.float64, device=dev)
        self.charge_over_mass = wp.array([sp_.charge / sp_.mass for sp_ in self.species_list], dtype=wp.float64,
                                         device=dev)
        self._sources = [self._wall_source(len(self.loads) + k, j) for k, j in enumerate(self.injections)]
        self._absorb = wp.array([0, 0] + [int(m == "absorb") for m in self.particle_walls], dtype=wp.int32,
                                device=dev)
        self.open_boundaries = bool(self.injections) or "absorb" in self.particle_walls
        position = np.concatenate([ld.position for ld in self.loads]) if self.loads else np.zeros((0, 2))
        velocity = np.concatenate([ld.velocity for ld in self.loads]) if self.loads else np.zeros((0, 2))
        index = (np.concatenate([np.full(ld.count, k, np.int32) for k, ld in enumerate(self.loads)]) if self.loads
                 else np.zeros(0, np.int32))
        self.loaded_count = index.size
        #: the live particles (slots [0, count) of the per-particle arrays)
        self.count = index.size
        self.initial_particle_charge = float(sum(ld.count * q for ld, q in zip(self.loads, self.macro_charge_np)))
        headroom = int(math.ceil(4 * sum(j.particles_per_step for j in self.injections)))
        self.state = PICState(position, velocity, index, max(1, self.count + headroom), len(self.injections), dev)
        self.average_from = None if average_from is None else require_finite("average_from", average_from)
        if self.average_from is not None:
            self.state.potential_sum = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
            self.state.potential_samples = wp.zeros(1, dtype=wp.int64, device=dev)
        self.kernels = pk.mls_kernels(model.settings.terms)
        self.node_set = model.node_set()
        self._sort_cell = model.reach
        #: re-sort the particles by cell every step (off: for measuring what sorting buys; 1.1x at 65 k particles;
        #: with absorbing walls the sort also removes the absorbed particles, so it runs regardless)
        self.sort_particles = True
        self._sort_cells_x = int(math.ceil(space.length[0] / self._sort_cell)) + 1
        self._dead_key = self._sort_cells_x * (int(math.ceil(space.length[1] / self._sort_cell)) + 1)
        self._live = wp.zeros(1, dtype=wp.int32, device=dev)
        self.particle_grid = NeighbourGrid(self.launcher, model.reach, space)
        self._allocate_work(self.state.capacity)
        self._sync_position32()
        self.inv_scale = wp.float64(1.0 / float(np.mean(model.support_np[:, 0])))
        self._flag_max = Reduction(self.launcher, wp.int32, "max")
        self.charge = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
        self.potential = np.zeros(model.node_count)
        self.potential_wp = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
        self.nodal_field = wp.zeros(model.node_count, dtype=wp.vec2d, device=dev)
        self.modes = [tuple(int(v) for v in m) for m in modes]
        self.mode_matrix = field.mode_coefficients(self.modes) if self.modes else np.zeros((0, model.node_count))
        self.mode_k2 = np.sum(field.wavevectors(self.modes) ** 2, axis=1) if self.modes else np.zeros(0)
        #: per-step diagnostics since this solver was built (a resumed run's start at the resume: the time loop's
        #: output-time series, which checkpoints keep, hold the whole run)
        self.history: dict[str, list[float]] = {}
        self.state.history_table = self._history_table
        self.state.restore_history = self._restore_history
        self._steps = 0
        self._sort(self.count)
        self._fields_at_current_positions()
        bad = self._bad_fit()
        if bad:
            raise ParameterError("support", bad)
        # half-step start: v^{-1/2} = v^0 - (q/m) E^0 Δt/2 (seed 002 §2.2.3)
        self.launcher.launch(pk.kick, self.count, [self.state.species, self.charge_over_mass, self.e_field,
                                                   self.magnetic_field, wp.float64(-0.5 * self.dt),
                                                   self.state.velocity])
        self._pending_field = self._field_terms()
        self._accumulate_potential()

    @staticmethod
    def _wall_modes(particle_walls, space) -> tuple[str, str]:
        modes = (particle_walls, particle_walls) if isinstance(particle_walls, str) else tuple(particle_walls)
        if len(modes) != 2 or any(m not in PARTICLE_WALLS for m in modes):
            raise ParameterError("particle_walls", f"one of {list(PARTICLE_WALLS)}, or two of them (lower, upper); "
                                                   f"got {particle_walls!r}")
        if space.periodic[1] and modes != ("reflect", "reflect"):
            raise ParameterError("particle_walls", "the box is periodic along y: it has no walls to absorb particles")
        return modes

    @staticmethod
    def _wall_source(index: int, injection: Injection) -> pk.WallSource:
        """The kernel's bundle for one source (built once: the same object every step)."""
        src = pk.WallSource()
        src.species = index
        src.seed = int(injection.seed)
        src.inward = wp.float64(injection.inward)
        src.normal_speed = wp.float64(injection.normal_speed)
        src.thermal_speed = wp.float64(injection.species.thermal_speed if injection.warm else 0.0)
        src.drift_x = wp.float64(injection.species.drift[0])
        return src

    def _allocate_work(self, capacity: int) -> None:
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
        self._sort_keys = wp.zeros(2 * capacity, dtype=wp.int32, device=dev)
        self._sort_order = wp.zeros(2 * capacity, dtype=wp.int32, device=dev)
        self._scratch = {name: wp.zeros(capacity, dtype=getattr(self.state, name).dtype, device=dev)
                         for name in PARTICLE_ARRAYS}
        self.fit = wp.zeros(capacity, dtype=mk.MLSFit, device=dev)
        self.node_count_of = wp.zeros(capacity, dtype=wp.int32, device=dev)
        self._flags = wp.zeros(capacity, dtype=wp.int32, device=dev)
        self.e_field = wp.zeros(capacity, dtype=wp.vec2d, device=dev)
        self.kinetic = wp.zeros(capacity, dtype=wp.float64, device=dev)
        self.momentum = wp.zeros(capacity, dtype=wp.vec2d, device=dev)

    def _ensure_capacity(self, needed: int) -> None:
        """Double the per-particle arrays until ``needed`` slots fit (injection)."""
        capacity = self.state.capacity
        if needed <= capacity:
            return
        while capacity < needed:
            capacity *= 2
        self.state.resize(capacity)
        self._allocate_work(capacity)

    @property
    def n(self) -> int:
        """The live particles (the per-step launches run over them)."""
        return self.count

    # -- checks ----------------------------------------------------------------------------------------------
    def _check_step(self) -> None:
        """Refuse ω_p Δt >= 2 (ω_p of all species together: the leapfrog's limit); warn above ω_pe Δt = 0.2 (ω_pe:
        the fastest species' own plasma frequency, the electrons')."""
        wdt = self.plasma_frequency * self.dt
        if wdt >= 2.0:
            raise ParameterError("dt", f"ω_p Δt = {wdt:.4g} >= 2: the leapfrog is unstable; take Δt < "
                                       f"{2.0 / self.plasma_frequency:.4g} (and <= "
                                       f"{HEATING_DT / self.plasma_frequency:.4g} to keep numerical heating small)")
        fastest = max(sp_.plasma_frequency for sp_ in self.species_list) * self.dt
        if fastest > HEATING_DT * (1.0 + 1e-12):
            warnings.warn(f"dt: ω_pe Δt = {fastest:.3g} is {fastest / HEATING_DT:.3g}x the {HEATING_DT} that keeps "
                          "the leapfrog's phase error and numerical heating small", stacklevel=3)

    def debye_length(self) -> float:
        """λ_De = v_th / ω_p of the fastest species (the electrons: the Debye length PIC resolution rules refer to);
        inf when it is cold."""
        fastest = max(self.species_list, key=lambda sp_: sp_.plasma_frequency)
        return fastest.thermal_speed / fastest.plasma_frequency if fastest.temperature > 0 else math.inf

    def _check_spacing(self) -> None:
        lam = self.debye_length()
        spacing = float(np.median(self.model.spacing))
        if math.isfinite(lam) and spacing > HEATING_SPACING * lam:
            warnings.warn(f"nodes: the node spacing {spacing:.3g} is {spacing / lam:.2g} Debye lengths (λ_D = "
                          f"{lam:.3g}); above {HEATING_SPACING} λ_D finite-grid heating sets in: add nodes",
                          stacklevel=3)

    # -- the step ------------------------------------------------------------------------------------------------
    def _sync_position32(self) -> None:
        p = self.state.position.numpy()
        p32 = np.zeros((p.shape[0], 3), dtype=np.float32)
        p32[:, :2] = p
        self.position32.assign(p32)

    def _sort(self, total: int) -> None:
        """Reorder slots [0, ``total``) by cell (row-major, cells of the support reach): the deposit gathers each
        node's particles from contiguous memory. Every step, so the order depends on the positions only (a resumed
        run sorts as the uninterrupted one did). Absorbed particles sort past every cell, grouped by wall: their
        charge goes to the wall's tally and the live count drops to the particles before them."""
        L, st, sc = self.launcher, self.state, self._scratch
        if self.sort_particles or self.open_boundaries:
            L.launch(pk.cell_keys, total, [self.model.box, wp.float64(1.0 / self._sort_cell), self._sort_cells_x,
                                           self._dead_key, self.exit_wall, st.position, self._sort_keys,
                                           self._sort_order])
            if total > 1:
                wp.utils.radix_sort_pairs(self._sort_keys, self._sort_order, total)
            L.launch(pk.permute_particles, total, [self._sort_order, st.position, st.velocity, st.species,
                                                   st.particle_id, sc["position"], sc["velocity"], sc["species"],
                                                   sc["particle_id"], self.position32])
            for name in PARTICLE_ARRAYS:
                wp.copy(getattr(st, name), sc[name], count=total)
        live = total
        if self.open_boundaries and total:
            self._live.zero_()
            L.launch(pk.count_live, total, [total, self._dead_key, self._sort_keys, self._live])
            live = int(self._live.numpy()[0])
            if live < total:  # the absorbed: their charge to their walls' tallies
                walls = self._sort_keys[live:total].numpy() - self._dead_key
                species = st.species[live:total].numpy()
                tally = st.wall_charge.numpy()
                np.add.at(tally, walls, self.macro_charge_np[species])
                st.wall_charge.assign(tally)
        self.count = live
        st.particle_count.assign(np.array([live], dtype=np.int64))

    def _inject(self) -> int:
        """Each source's particles for this step into the slots after the live ones (:mod:`.injection`); returns the
        slots now filled (live + new)."""
        st = self.state
        carry = st.injection_carry.numpy()
        injected = int(st.injected.numpy()[0])
        new_counts = []
        for k, source in enumerate(self.injections):
            owed = carry[k] + source.particles_per_step
            new_counts.append(int(math.floor(owed)))
            carry[k] = owed - new_counts[-1]
        if self.loaded_count + injected + sum(new_counts) >= 2 ** 31:
            raise RunError(f"{self.loaded_count + injected} particles loaded and injected so far: the next step's "
                           "would take particle ids past the int32 range", self._steps)
        self._ensure_capacity(self.count + sum(new_counts))
        slot = self.count
        charge = 0.0
        for source, new in zip(self._sources, new_counts):
            self.launcher.launch(pk.inject_particles, new, [
                self.model.box, source, slot, self.loaded_count + injected, wp.float64(self.dt), st.position,
                st.velocity, st.species, st.particle_id, self.position32, self.exit_wall])
            slot += new
            injected += new
            charge += new * self.macro_charge_np[source.species]
        st.injection_carry.assign(carry)
        st.injected.assign(np.array([injected], dtype=np.int64))
        st.injected_charge.assign(st.injected_charge.numpy() + charge)
        return slot

    def _fields_at_current_positions(self) -> None:
        """Neighbours, fits, deposit, solve and gather at x^n (E into ``e_field``) for the live particles."""
        m, L, n = self.model, self.launcher, self.count
        with self.phases("neighbours"):
            if n:
                self.particle_grid.build(self.position32[:n])
        with self.phases("fits"):
            L.launch(self.kernels.particle_fits, n, [self.node_set, self.position32, self.state.position,
                                                      self.inv_scale, self.fit, self.node_count_of])
        with self.phases("deposit"):
            g = self.particle_grid
            if n:
                # the particle grid's image arrays are new at every build, so no launch timing could serve the
                # next step: split over every thread (``once``)
                L.launch(self.kernels.deposit, m.node_count,
                         [self.node_set, g.id, g.points, g.source_id, self.state.position, self.state.species,
                          self.macro_charge, self.inv_scale, self.fit, self.charge], once=True)
            else:
                self.charge.zero_()
        with self.phases("solve"):
            charge = self.charge.numpy()
            self.potential = self.field.solve(charge, self.background_density)
            self.potential_wp.assign(self.potential)
            if self.gather == "momentum":
                self.nodal_field.assign(self.field.nodal_field(self.potential, charge))
        with self.phases("gather"):
            L.launch(self.kernels.particle_field, n, [self.node_set, self.position32, self.state.position,
                                                       self.inv_scale, self.fit, self.potential_wp,
                                                       self.nodal_field, int(self.gather == "momentum"),
                                                       self.e_field])

    def step(self, dt: float) -> None:
        if abs(dt - self.dt) > 1e-9 * self.dt:
            raise ParameterError("dt", f"the leapfrog keeps v at half steps of its own Δt = {self.dt:.6g}; a step of "
                                       f"{dt:.6g} would break the staggering (make output times multiples of Δt)")
        with self.phases("push"):
            self.launcher.launch(pk.leapfrog_push, self.count, [
                self.model.box, self.state.species, self.charge_over_mass, self.macro_mass, self.e_field,
                self.magnetic_field, wp.float64(self.dt), self._absorb, self.state.position, self.state.velocity,
                self.position32, self.kinetic, self.momentum, self.exit_wall])
        self._record()
        self._steps += 1
        self.state.steps.assign(np.array([self._steps], dtype=np.int64))
        with self.phases("sort"):
            total = self._inject() if self.injections else self.count
            self._sort(total)
        self._fields_at_current_positions()
        self._pending_field = self._field_terms()
        self._accumulate_potential()

    def _accumulate_potential(self) -> None:
        if self.average_from is not None and self.t >= self.average_from - 1e-9 * self.dt:
            st = self.state
            st.potential_sum.assign(st.potential_sum.numpy() + self.potential)
            st.potential_samples.assign(st.potential_samples.numpy() + 1)

    def mean_potential(self) -> np.ndarray:
        """The nodal potential u_I averaged over the steps from ``average_from`` (u^h is linear in u_I: evaluate it
        with the model's shape functions)."""
        if self.average_from is None:
            raise ParameterError("average_from", "the solver was built without it: the potential is not averaged")
        samples = int(self.state.potential_samples.numpy()[0])
        if samples == 0:
            raise ParameterError("average_from", f"no step reached t = {self.average_from} yet (t = {self.t:.4g})")
        return self.state.potential_sum.numpy() / samples

    # -- diagnostics -------------------------------------------------------------------------------------------
    def _field_terms(self) -> dict[str, float]:
        u = self.potential
        out = {"field_energy": self.field.field_energy(u),
               "deposited_charge": float(self.charge.numpy().sum()),
               "net_charge_density": self.field.net_charge_density}
        if self.open_boundaries:
            wall = self.state.wall_charge.numpy()
            out.update(particles=float(self.count), injected_charge=float(self.state.injected_charge.numpy()[0]),
                       wall_charge_lower=float(wall[2]), wall_charge_upper=float(wall[3]))
        if self.modes:
            coeff = self.mode_matrix @ u
            energy = self.field.area * self.mode_k2 * np.abs(coeff) ** 2   # A |k|² |u_k|² (modes ±k together)
            for (mx, my), e in zip(self.modes, energy):
                out[f"mode_{mx}_{my}_energy"] = float(e)
            for (mx, my), c in zip(self.modes, coeff):
                out[f"mode_{mx}_{my}_potential_re"] = float(c.real)
        return out

    def _record(self) -> None:
        """Append time n's diagnostics: the field terms at x^n (computed last step) and the time-centred kinetic
        energy and momentum the push just wrote."""
        with self.phases("diagnostics"):
            row = {"time": self.t, **self._pending_field}
            n = self.count
            kin = float(self.kinetic[:n].numpy().sum()) if n else 0.0
            # column by column: NumPy's sum over axis 0 of an (n, 2) array took 2.4 ms at 131 k particles, 0.13 ms so
            mom = self.momentum[:n].numpy() if n else np.zeros((1, 2))
            mom = (mom[:, 0].sum(), mom[:, 1].sum())
            row.update(kinetic_energy=kin, total_energy=kin + row["field_energy"], momentum_x=float(mom[0]),
                       momentum_y=float(mom[1]))
            for k, v in row.items():
                self.history.setdefault(k, []).append(v)

    def _history_keys(self) -> list[str]:
        return ["time", *self._pending_field, "kinetic_energy", "total_energy", "momentum_x", "momentum_y"]

    def _history_table(self) -> np.ndarray:
        """The per-step history as a (steps, columns) float64 table, columns in :meth:`_history_keys` order."""
        keys = self._history_keys()
        if not self.history:
            return np.zeros((0, len(keys)))
        return np.array([self.history[k] for k in keys], dtype=np.float64).T.copy()

    def _restore_history(self, table: np.ndarray, source: str) -> None:
        keys = self._history_keys()
        if table.ndim != 2 or table.shape[1] != len(keys):
            raise ParameterError("resume", f"{source} does not match this scene: its history has shape {table.shape}, "
                                           f"this scene records {len(keys)} columns")
        self.history = {k: table[:, j].tolist() for j, k in enumerate(keys)}

    # -- the contract ----------------------------------------------------------------------------------------
    def stable_dt(self) -> float:
        """The solver's own Δt (checked against the leapfrog's limit 2/ω_p at construction): the staggered
        velocities belong to it, so it is the only step :meth:`step` takes."""
        return self.dt

    def step_rule(self) -> StepRule:
        """Exactly the solver's own Δt: output times and the end are whole multiples of it."""
        return StepRule.fixed(self.dt)

    @property
    def dim(self) -> int:
        return 2

    @property
    def work_items(self) -> int:
        return self.count

    def _bad_fit(self) -> str | None:
        """A message naming the first particle whose MLS fit is ill-posed (too few nodes in reach, or a singular
        moment matrix) or whose velocity is not finite, else None. Flags and their maximum on the device: one read
        per step; the arrays come to the host only when something is wrong."""
        terms = self.model.settings.terms
        if not self.count:
            return None
        self.launcher.launch(pk.flag_bad_particles, self.count, [terms, wp.float64(RCOND_LIMIT), self.node_count_of,
                                                                 self.fit, self.state.velocity, self._flags])
        self._flag_max.launch(self._flags, self.count)
        if not self._flag_max.value():
            return None
        bad = np.flatnonzero(self._flags[:self.count].numpy())
        i = int(bad[0])
        x = self.state.position.numpy()[i]
        v = self.state.velocity.numpy()[i]
        if not np.all(np.isfinite(v)):
            return f"particle {i} at ({x[0]:.6g}, {x[1]:.6g}) has a non-finite velocity {v.tolist()}"
        count = int(self.node_count_of.numpy()[i])
        rcond = float(self.fit.numpy()["rcond"][i])
        return (f"particle {i} at ({x[0]:.6g}, {x[1]:.6g}) lies in the support of {count} node(s) (scaled pivot "
                f"{rcond:.1e}); the {self.model.settings.basis} basis needs {terms} nodes around it: raise d_max "
                f"(now {self.model.settings.d_max}) or add nodes ({bad.size} such particles)")

    def problem(self) -> str | None:
        return self._bad_fit()

    @property
    def t(self) -> float:
        """The time of x^n, n Δt (ω_pe⁻¹)."""
        return self._steps * self.dt

    def after_load(self) -> None:
        self._steps = int(self.state.steps.numpy()[0])
        self.count = int(self.state.particle_count.numpy()[0])
        self._allocate_work(self.state.capacity)
        self._sync_position32()
        self._sort(self.count)
        self._fields_at_current_positions()
        self._pending_field = self._field_terms()

    def diagnostics(self) -> dict[str, float]:
        return {k: v[-1] for k, v in self.history.items() if k != "time"} if self.history else {}

    def output_sets(self) -> list[OutputSet]:
        n = self.count
        p = self.state.position.numpy()[:n]
        v = self.state.velocity.numpy()[:n]
        e = self.e_field.numpy()[:n]
        pts = np.zeros((n, 3))
        pts[:, :2] = p
        s = self.state.species.numpy()[:n]
        nodes = np.zeros((self.model.node_count, 3))
        nodes[:, :2] = self.model.nodes_np
        return [OutputSet("particles", pts, {"velocity": v, "e_field": e, "species": s.astype(np.float64),
                                             "particle_id": self.state.particle_id.numpy()[:n].astype(np.float64),
                                             "speed": np.linalg.norm(v, axis=1)}, frame_field="species"),
                OutputSet("nodes", nodes, {"potential": self.potential.copy(), "charge": self.charge.numpy().copy()})]

    def describe(self) -> dict:
        species = [{"name": ld.species.name, "count": ld.count, "weight": ld.weight, "charge": ld.species.charge,
                    "mass": ld.species.mass, "density": ld.species.density, "temperature": ld.species.temperature}
                   for ld in self.loads]
        for k, j in enumerate(self.injections):
            sp_ = j.species
            species.append({"name": sp_.name, "injected_from": j.wall, "particles_per_step": j.particles_per_step,
                            "weight": self.macro_mass_np[len(self.loads) + k] / sp_.mass, "charge": sp_.charge,
                            "mass": sp_.mass, "density": sp_.density, "temperature": sp_.temperature,
                            "drift": list(sp_.drift), "flux": j.flux})
        return {"particles": self.count, "species": species, "particle_walls": list(self.particle_walls),
                "dt": self.dt, "gather": self.gather,
                "magnetic_field": float(self.magnetic_field), "plasma_frequency": self.plasma_frequency,
                "omega_dt": self.plasma_frequency * self.dt,
                "debye_length": self.debye_length(), "background_density": self.background_density,
                "model": self.model.describe(), "field": self.field.describe()}
