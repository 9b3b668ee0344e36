"""The PIC solver (Marques 2008, ch. 4-5): electrostatic particle-in-cell whose field solve is EFG.

One step (``kernels/pic.py``; the order of Marques 2008, §5.2), each part in its module:

    push:        leapfrog (eqs 2.21 / 4.7), positions wrapped into the box, reflected or absorbed at walls
    history:     the step's diagnostics row (:mod:`.history`)
    inject:      wall sources add their particles (:mod:`.injection`, :mod:`.particles`)
    sort:        particles re-sorted by cell; absorbed ones move past the live ones and leave the count
    neighbours, fits, deposit, solve, gather: the field at the new positions (:mod:`.coupling`)

Open boundaries (walls along y): particles that cross an absorbing wall leave (their charge is added to the wall's
tally), sources inject new ones (:mod:`.particles`). ``deposited_charge`` = initial + injected - absorbed charge to
round-off.

The state holds x^n, v^{n-1/2}; the first step is preceded by the half-step start v^{-1/2} = v^0 - (q/m) E^0 Δt/2
(Marques 2008, §2.2.3), done at construction. The solver holds the EFG model and its factorised Poisson matrix (the
discretisation does not change in time: assembled and factorised once, Marques 2008, §5.5).

Checks (the two causes of numerical heating PIC users hit most): ω_pe Δt ≥ 2 (the leapfrog's stability limit) is
refused; ω_pe Δt > 0.2 (Marques 2008, §2.2.3, printed "Δt = 0.2 ω_pe") and a node spacing above 2 λ_D warn, saying by
how much. Diagnostics each step (:attr:`PICSolver.history`): kinetic, field and total energy, momentum, deposited
charge, field energy in chosen Fourier modes. Normalised units: see :mod:`.species`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError, require_finite, require_positive
from warpfree.galerkin.mls import MLSModel
from warpfree.graph import StepGraph
from warpfree.kernels import pic as pk
from warpfree.parallel import world as ranks_of_run
from warpfree.parallel.halo import whole_from_pieces
from warpfree.parameters import Choice
from warpfree.progress import announced
from warpfree.solver import HostTable, OutputSet, StepRule, TimeDependentSolver

from .boundary import ParticleBoundary, Wall
from .emission import SurfaceEmitter, SurfaceSource
from .coupling import FieldSolve, Gather, NodeCoupling
from .electrodes import ElectrodeField
from .field import PlasmaPoisson
from .history import REPORT, Diagnostics, history_columns, report_slots
from .spread import PlasmaSpread
from .injection import Injection
from .particles import WALLS, Particles, PICState
from .species import ParticleLoad, Species

__all__ = ["PICSolver", "PICState", "ParticleWall", "HEATING_DT", "HEATING_SPACING", "default_field_solve"]

#: ω_pe Δt above which the leapfrog's phase error heats the plasma noticeably (Marques 2008, §2.2.3: Δt = 0.2/ω_pe)
HEATING_DT = 0.2
#: node spacing / λ_D above which finite-grid (aliasing) heating sets in for a warm plasma
HEATING_SPACING = 2.0


class ParticleWall(Choice):
    """What a wall (along y) does with a particle that reaches it."""

    REFLECT = "reflect", "reflects it (its normal velocity reversed)"
    ABSORB = "absorb", "absorbs it (its charge added to the wall's tally)"

#: the units of the output sets' quantities, normalised (:mod:`.species`: ω_pe = λ_D = 1, charge in e, mass in m_e,
#: density in n_ref): velocities in λ_D ω_pe, the field in m_e λ_D ω_pe²/e, the potential in m_e λ_D² ω_pe²/e, a node's
#: deposited charge in e n_ref λ_D² (per unit depth); the species index and the particle id are numbers
UNITS = {"position": "λ_D", "velocity": "λ_D ω_pe", "speed": "λ_D ω_pe", "e_field": "m_e λ_D ω_pe²/e",
         "species": "1", "particle_id": "1", "potential": "m_e λ_D² ω_pe²/e", "charge": "e n_ref λ_D²"}


def default_field_solve(on_cpu: bool, in_region: bool) -> FieldSolve:
    """Where the field is solved when a scene does not say: the host's SuperLU on a CPU (its fastest) and for a
    region's field (its electrodes' multipliers are read there each step); the device on a GPU for a box."""
    return FieldSolve.HOST if on_cpu or in_region else FieldSolve.DEVICE


class PICSolver(TimeDependentSolver):
    """Electrostatic PIC on an EFG field solve, in a periodic box or between walls along y (reflecting particles).

    Parameters
    ----------
    field: :class:`~.field.PlasmaPoisson` (a box; holds the :class:`~warpfree.galerkin.mls.MLSModel`) or
    :class:`~.electrodes.ElectrodeField` (a region of any shape between electrodes: the particles absorbed by the
    electrodes they reach, their charge on it, and by the ``walls`` that absorb; the energy gather, the host's solve).
    loads: the species and their macro-particles (:func:`~.species.load_species`).
    dt: the time step (ω_pe⁻¹ units); ω_pe Δt must be < 2.
    background_density: uniform immobile charge density (e n_ref); default: the one that makes the plasma neutral.
    modes: Fourier modes (mx, my) whose field energy each step records (default (1, 0) in a box, none in a region).
    gather: a :class:`~.coupling.Gather`: "momentum" (nodal fields interpolated with φ_I: no self-force, momentum kept
    on node lattices) or "energy" (eq 4.5, -Σ u_I ∇φ_I: energy kept, a self-force of the order of a neighbour's); see
    :mod:`.field`.
    magnetic_field: a static uniform B_z (normalised: ω_ce = |B_z| for electrons), pushed by Boris's rotation.
    particle_walls: what the walls along y (y not periodic) do with a particle that reaches them: a
    :class:`ParticleWall` ("reflect" or "absorb"), one for both or (lower, upper).
    injections: wall sources (:class:`~.injection.Injection`); loads may then be empty (a vacuum diode).
    average_from: time from which the nodal potential is averaged over the steps (:meth:`mean_potential`: the
    steady profile of a noisy run); None: not averaged.
    field_solve: where the field is solved each step (a :class:`~.device_solve.FieldSolve`, :mod:`.coupling`): "host"
    (SuperLU, the CPU's fastest: the default on the CPU), "device" (on the device, no host copy: the default on a GPU;
    :mod:`.device_solve`), or the device's "cg" or "dense".
    walls: with a region's field, the :class:`~.boundary.Wall` pieces (insulating; absorbing or reflecting particles;
    the region's pieces in no electrode and no wall reflect them).
    surface_sources: with a region's field, its :class:`~.emission.SurfaceSource` list (a beam or space-charge-limited
    emission from tagged pieces); loads may then be empty.
    """

    name = "pic"
    distributes = True
    work_unit = "particle pushes"
    time_unit = "/ω_pe"

    @announced("PIC solver made: particles loaded and coupled to the nodes")
    def __init__(self, field: PlasmaPoisson | ElectrodeField, loads: list[ParticleLoad], dt: float,
                 background_density: float | None = None, modes=None, gather: Gather = Gather.MOMENTUM,
                 magnetic_field: float = 0.0, particle_walls=ParticleWall.REFLECT, injections: list[Injection] = (),
                 average_from: float | None = None, field_solve: FieldSolve | None = None,
                 launcher: Launcher | None = None, walls: list[Wall] = (), surface_sources: list[SurfaceSource] = ()):
        model: MLSModel = field.model
        in_region = isinstance(field, ElectrodeField)
        modes = (() if in_region else ((1, 0),)) if modes is None else modes
        modes = [tuple(int(v) for v in m) for m in modes]
        if in_region:
            self._check_region(modes, gather, injections, field_solve)
        elif walls or surface_sources:
            raise ParameterError("walls" if walls else "surface_sources",
                                 "a box's field has its walls along y (particle_walls=, injections=): a region's walls "
                                 "and surface sources go with its field (ElectrodeField)")
        # the step report (``history.py``) in the clock's report slots: one read a step brings both
        super().__init__(model, launcher or model.launcher, report_slots=report_slots(modes))
        self.field = field
        self.loads = list(loads)
        self.injections = list(injections)
        self.surface_sources = list(surface_sources)
        if not self.loads and not self.injections and not self.surface_sources:
            raise ParameterError("loads", "need at least one species (loaded, or injected from a wall)")
        self.gather = gather = Gather.of("gather", gather)
        field_solve = None if field_solve is None else FieldSolve.of("field_solve", field_solve)
        self.magnetic_field = wp.float64(require_finite("magnetic_field", magnetic_field))
        self.dt = require_positive("dt", dt)
        space = field.space if in_region else model.space
        self.particle_walls = self._wall_modes(particle_walls, space) if not in_region else (ParticleWall.ABSORB,) * 2
        #: a region's boundary as the particles meet it (None in a box): its electrodes, then its walls
        self.boundary = (ParticleBoundary(field.region, field.electrodes, list(walls), self.launcher, WALLS + 1)
                         if in_region else None)
        if self.injections and space.periodic[1]:
            raise ParameterError("injections", "a source sits on a wall: the box is periodic along y (give walls)")
        self.species_list: list[Species] = ([ld.species for ld in self.loads] + [j.species for j in self.injections]
                                            + [src.species for src in self.surface_sources])
        first = len(self.loads) + len(self.injections)
        #: a region's surface sources, as emitted (:mod:`.emission`)
        self.emitters = [SurfaceEmitter(src, first + k, field, self.dt, self.launcher)
                         for k, src in enumerate(self.surface_sources)]
        self.plasma_frequency = math.sqrt(sum(s.plasma_frequency ** 2 for s in self.species_list))
        self._check_step()
        self._check_spacing()
        self.background_density = (-sum(ld.species.charge * ld.species.density for ld in self.loads)
                                   if background_density is None else float(background_density))
        dev = self.launcher.device
        weights = ([ld.weight for ld in self.loads] + [j.weight(space.length[0], self.dt) for j in self.injections]
                   + [e.weight for e in self.emitters])
        self.macro_charge_np = np.array([sp_.charge * w for sp_, w in zip(self.species_list, weights)])
        self.macro_mass_np = np.array([sp_.mass * w for sp_, w in zip(self.species_list, weights)])
        self.species_table = pk.SpeciesTable()
        self.species_table.charge_over_mass = wp.array([sp_.charge / sp_.mass for sp_ in self.species_list],
                                                       dtype=wp.float64, device=dev)
        self.species_table.macro_mass = wp.array(self.macro_mass_np, dtype=wp.float64, device=dev)
        box = space.box2d
        self.push = pk.PushParams()
        self.push.box = box
        self.push.magnetic_field = self.magnetic_field
        self.push.dt = wp.float64(self.dt)
        # a region's particles meet its boundary before the box's walls, which absorb any that got past (none should)
        self.push.absorb = wp.array([int(in_region)] * 2 + [int(m is ParticleWall.ABSORB) for m in self.particle_walls],
                                    dtype=wp.int32, device=dev)
        open_boundaries = bool(self.injections or self.emitters) or ParticleWall.ABSORB in self.particle_walls
        position = np.concatenate([ld.position for ld in self.loads]) if self.loads else np.zeros((0, 2))
        velocity = np.concatenate([ld.velocity for ld in self.loads]) if self.loads else np.zeros((0, 2))
        index = (np.concatenate([np.full(ld.count, k, np.int32) for k, ld in enumerate(self.loads)]) if self.loads
                 else np.zeros(0, np.int32))
        self.initial_particle_charge = float(sum(ld.count * q for ld, q in zip(self.loads, self.macro_charge_np)))
        headroom = int(math.ceil(4 * sum(j.particles_per_step for j in self.injections + self.surface_sources)))
        self.world = ranks_of_run()
        #: how the particles are spread over the ranks (one process: a one-rank partition, every particle)
        self.spread = PlasmaSpread(self.world, model, position, space=space)
        held = self.spread.particles
        loaded = index.size   # every rank's: the ids 0..loaded-1; injected particles take the next
        ids = held.take(np.arange(loaded, dtype=np.int32))
        position, velocity, index = held.take(position), held.take(velocity), held.take(index)
        self.state = PICState(position, velocity, index,
                              max(1, index.size + self.spread.room(index.size, headroom)),
                              len(self.injections) + len(self.emitters), dev,
                              history_columns(modes, open_boundaries, self._region_columns()), len(self.species_list),
                              WALLS + (len(self.boundary.names) if self.boundary else 0))
        self.state.particle_id[:index.size].assign(ids)
        self.average_from = None if average_from is None else require_finite("average_from", average_from)
        if self.average_from is not None:
            self.state.potential_sum = np.zeros(model.node_count)
            self.state.potential_samples = 0
        sources = [Particles.wall_source(len(self.loads) + k, j) for k, j in enumerate(self.injections)]
        self.particles = Particles(self.launcher, self.state, space, box, model.reach, self.macro_charge_np,
                                   self.injections, sources, loaded, self.dt, open_boundaries, self.spread,
                                   self.emitters)
        self.particles.sync_position32()
        if field_solve is None:
            field_solve = default_field_solve(self.launcher.is_cpu, in_region)
        self.coupling = NodeCoupling(field, self.particles,
                                     wp.array(self.macro_charge_np, dtype=wp.float64, device=dev),
                                     self.background_density, gather, self.phases, field_solve)
        self.particles.on_resize = self.coupling.allocate
        self.diagnostics_record = Diagnostics(field, self.coupling, self.particles, modes, self.phases,
                                              self.clock.report_values, self.clock.read_report)
        self.diagnostics_record.region_groups = self.boundary.names if self.boundary is not None else None
        # a rank deposits on its own nodes; the charges of all, and the step's sums
        self.coupling.whole_charge = self.spread.charge_exchange
        self.diagnostics_record.combine = self._combine_report
        self.particles.sort(self.count)
        self._find_owned()
        self._charge_electrodes()
        self.coupling.fields_at_particles()
        bad = self.coupling.bad_particle()
        if bad:
            raise ParameterError("support", bad)
        # half-step start: v^{-1/2} = v^0 - (q/m) E^0 Δt/2 (Marques 2008, §2.2.3)
        self.launcher.launch(pk.kick, self.count, [self.species_table, self.particles.arrays, self.particles.e_field,
                                                   self.magnetic_field, wp.float64(-0.5 * self.dt)])
        self.diagnostics_record.after_solve()
        self._accumulate_potential()

    # -- the parts' quantities, under the names scenes and analyses read ------------------------------------------
    @property
    def count(self) -> int:
        """The live particles (slots [0, count) of the per-particle arrays)."""
        return self.state.particle_count

    @property
    def n(self) -> int:
        """The live particles (of every rank: its own, added, in a distributed run)."""
        return int(self.world.allreduce(np.array([int(self._owned.sum())]), "sum")[0])

    @property
    def history(self) -> dict[str, list[float]]:
        """The per-step diagnostics, column -> values (:mod:`.history`)."""
        return self.state.history.as_dict()

    @property
    def potential(self) -> np.ndarray:
        """The nodal potential u_I at x^n."""
        return self.coupling.potential

    @property
    def charge(self) -> wp.array:
        """The deposited nodal charges Q_I at x^n."""
        return self.coupling.charge

    @property
    def nodal_field(self) -> wp.array:
        """The nodal fields E_I of the momentum gather."""
        return self.coupling.nodal_field

    @property
    def e_field(self) -> wp.array:
        """E at each particle slot."""
        return self.particles.e_field

    @staticmethod
    def _wall_modes(particle_walls, space) -> tuple[ParticleWall, ParticleWall]:
        modes = (particle_walls, particle_walls) if isinstance(particle_walls, str) else tuple(particle_walls)
        if len(modes) != 2:
            raise ParameterError("particle_walls", f"one of {ParticleWall.texts()}, or two of them (lower, upper); "
                                                   f"got {particle_walls!r}")
        modes = tuple(ParticleWall.of("particle_walls", m) for m in modes)
        if space.periodic[1] and any(m is not ParticleWall.REFLECT for m in modes):
            raise ParameterError("particle_walls", "the box is periodic along y: it has no walls to absorb particles")
        return modes

    @staticmethod
    def _check_region(modes, gather, injections, field_solve) -> None:
        """What a region's field does not take (yet): Fourier modes (a box's), the momentum gather (its projection is
        corrected at a box's walls only), a box wall's sources, a field solve off the host."""
        if modes:
            raise ParameterError("modes", f"Fourier modes are a periodic box's; a region's field has none (got {modes})")
        if Gather.of("gather", gather) is not Gather.ENERGY:
            raise ParameterError("gather", "a region's field takes the energy gather (gather='energy'): the momentum "
                                           "gather's projection is corrected at a box's walls only")
        if injections:
            raise ParameterError("injections", "a box wall's sources: a region has no such walls")
        if field_solve is not None and FieldSolve.of("field_solve", field_solve) is not FieldSolve.HOST:
            raise ParameterError("field_solve", "a region's field is solved on the host (field_solve='host')")

    def _region_columns(self) -> list[str]:
        """A region's history columns: the charge each boundary group absorbed, then each electrode's charge and
        each floating one's potential."""
        if self.boundary is None:
            return []
        return ([f"absorbed_charge_{name}" for name in self.boundary.names]
                + [f"charge_{e.name}" for e in self.field.electrodes]
                + [f"potential_{e.name}" for e in self.field.electrodes if e.floating])

    def _charge_electrodes(self) -> None:
        """A region's electrodes take the charge of the particles they absorbed (a floating one's potential follows
        from it at the next solve)."""
        if self.boundary is not None:
            first = WALLS
            self.field.absorbed_charge[:] = self.particles.wall_charge[first:first + len(self.field.electrodes)]

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

    def advance(self) -> None:
        """One leapfrog step of the solver's own Δt (the clock's): push (gather, Boris), then deposit, field solve and
        the step's report, the clock moved on; another Δt is refused (it would break the staggering)."""
        dt = self.clock.step
        if abs(dt - self.dt) > 1e-9 * self.dt:
            raise ParameterError("dt", f"the leapfrog keeps v at half steps of its own Δt = {self.dt:.6g}; a step of "
                                       f"{dt:.6g} would break the staggering (make output times multiples of Δt)")
        self._launch_push()
        self._between()
        self._launch_fields()
        self.clock.launch_advance_and_choose()
        self._after()

    # the step's parts: launches only (a graph can record them) and the host's work between them
    def _launch_push(self) -> None:
        """The push to x^{n+1}, v^{n+1/2} and time n's row of diagnostics on the device."""
        pa = self.particles
        with self.phases("push"):
            self.launcher.launch(pk.leapfrog_push, self.count, [self.push, self.species_table, pa.arrays, pa.e_field,
                                                                pa.kinetic, pa.momentum])
            if self.boundary is not None:
                self.launcher.launch(pk.cross_boundary, self.count, [self.boundary.struct, wp.float64(self.dt),
                                                                      pa.arrays])
        self.spread.count_once((pa.kinetic, pa.momentum), self._owned, self.count)  # each particle on its owner
        self.diagnostics_record.launch_record()

    def _between(self) -> None:
        """Time n's row on the host, the step count, injection, the sort and the particles' grid."""
        pa = self.particles
        self.diagnostics_record.begin_row(self.t)
        self.state.steps += 1
        with self.phases("exchange"):
            self.spread.redistribute(self._moving_slots, self._owned, self._refill)
        with self.phases("sort"):
            total = pa.inject() if self.injections or self.emitters else self.count
            pa.sort(total)
        self._find_owned()
        self._charge_electrodes()
        self.coupling.build_grid()

    def _launch_fields(self) -> None:
        """Fits, deposit, solve, gather, the fits' flags and the field terms at x^{n+1}."""
        record = self.diagnostics_record
        self.coupling.fields_from_grid()
        record.flag(self.coupling.launch_flags(), self.count)
        record.launch_field_terms()

    def _after(self) -> None:
        """The step's one read (its report: time n's row and the fits' flag) and the host's tallies."""
        record = self.diagnostics_record
        record.keep_tallies()
        with self.phases("diagnostics"):
            record.read()
        self._accumulate_potential()

    # -- a distributed run -----------------------------------------------------------------------------------
    def _find_owned(self) -> None:
        """Which held slots this rank owns (its box holds them): after every sort; with open boundaries the live and
        absorbed particles counted over the ranks (:meth:`_count_open`)."""
        self._owned = self.spread.owned(self.state.position, 0, self.count)
        if self.particles.open_boundaries:
            self._count_open()

    def _count_open(self) -> None:
        """With sources or absorbing walls, after a sort: the live particles and the step's absorbed ones of every
        rank (``Particles.count_over_ranks``), and the particles' partition made of the slots now held."""
        self.particles.count_over_ranks(self._owned)
        self.spread.hold(self.state.particle_id, self._owned)

    def particle_slots(self) -> dict[str, np.ndarray]:
        """Position, velocity, species and id of the live slots (host copies, slot order)."""
        st, n = self.state, self.count
        return {"position": st.position.numpy()[:n], "velocity": st.velocity.numpy()[:n],
                "species": st.species.numpy()[:n], "particle_id": st.particle_id.numpy()[:n]}

    def _moving_slots(self) -> dict[str, np.ndarray]:
        """What a particle takes to the ranks that hold it next: :meth:`particle_slots` and its ``exit_wall`` (the
        push's mark of an absorbed particle, which the next sort drops)."""
        return {**self.particle_slots(), "exit_wall": self.particles.exit_wall.numpy()[:self.count]}

    def _refill(self, new: dict[str, np.ndarray]) -> None:
        """The slots refilled with the held particles after a redistribution (in id order, sorted next)."""
        st, pa = self.state, self.particles
        count = new["position"].shape[0]
        pa.ensure_capacity(count)
        if count:
            for name in ("position", "velocity", "species", "particle_id"):
                getattr(st, name)[:count].assign(new[name])
            pa.exit_wall[:count].assign(new["exit_wall"])
        st.particle_count = count
        pa.sync_position32()

    def _combine_report(self, values: np.ndarray) -> np.ndarray:
        """The step report over every rank: its own particles' sums added (rank order), the bad-particle flag's
        largest; the field terms are every rank's alike (the field is replicated)."""
        out = values.copy()
        sums = [REPORT.index(k) for k in ("kinetic_energy", "momentum_x", "momentum_y")]
        out[sums] = self.world.allreduce(values[sums], "sum")
        bad = REPORT.index("bad_particle")
        out[bad] = self.world.allreduce(values[bad:bad + 1], "max")[0]
        return out

    def particle_values(self) -> dict[str, np.ndarray]:
        """Position, velocity, species and id of every live particle (host copies): in slot order in one process, in
        id order over every rank's own in a distributed run."""
        return self.spread.gather_particles(self.particle_slots(), self._owned)

    def record_step(self) -> StepGraph | None:
        """:meth:`step` as two Warp graphs (the push; the fields) around the host's sort and grid build, and the
        report's read after them. None when a step cannot be recorded: with open boundaries (the live count changes
        the launches) or a field solve with host work (SuperLU, or Warp's CG on a CPU, which checks its residual
        there)."""
        solve = self.coupling.device_solve
        if (self.particles.open_boundaries or solve is None or (solve.method is FieldSolve.CG and self.launcher.is_cpu)):
            return None
        with self.launcher.capturing() as push:
            self._launch_push()
        with self.launcher.capturing() as fields:
            self._launch_fields()
            self.clock.launch_advance_and_choose()
        return StepGraph([push.graph, self._between, fields.graph, self.clock.invalidate, self._after])

    def _accumulate_potential(self) -> None:
        if self.average_from is not None and self.t >= self.average_from - 1e-9 * self.dt:
            st = self.state
            st.potential_sum = st.potential_sum + self.potential
            st.potential_samples += 1

    def mean_potential(self) -> np.ndarray:
        """The nodal potential u_I averaged over the steps from ``average_from`` (u^h is linear in u_I: evaluate it
        with the model's shape functions)."""
        if self.average_from is None:
            raise ParameterError("average_from", "the solver was built without it: the potential is not averaged")
        samples = self.state.potential_samples
        if samples == 0:
            raise ParameterError("average_from", f"no step reached t = {self.average_from} yet (t = {self.t:.4g})")
        return self.state.potential_sum / samples

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
        """2: the PIC solver works in the plane."""
        return 2

    @property
    def work_items(self) -> int:
        """Live particles (the unit of the throughput: particle pushes)."""
        return self.n

    def problem(self) -> str | None:
        """The first bad particle of the last step's fits (from the step's report: no read unless one is flagged)."""
        if not self.diagnostics_record.bad_flag:
            return None
        flagged = bool(np.any(self.coupling._flags[:self.count].numpy()[self._owned]))
        return self.world.first_message(self.coupling.describe_bad() if flagged else None)

    @property
    def t(self) -> float:
        """The time of x^n (ω_pe⁻¹): the clock's."""
        return self.clock.time

    #: the per-particle arrays a checkpoint piece carries (its first ``particle_count`` slots)
    RESTORED = ("position", "velocity", "species", "particle_id")

    def restore_pieces(self, pieces: list[dict]) -> None:
        """The whole plasma from every process's checkpoint: each piece's live particles, one copy of each by id (a
        ghost is its owner's copy: the pieces agree on every particle they share; ids are sparse once particles were
        injected or absorbed), spread over this run's ranks as at a step's redistribution; the host values (step
        count, history, tallies: every rank's alike) from the first piece. Then as :meth:`after_load`: the run
        continues bitwise as the uninterrupted one."""
        whole = whole_from_pieces(pieces, self.RESTORED, "particle_id", None, rows="particle_count")
        issued = self.particles.loaded_count + int(pieces[0]["injected"])
        if whole["particle_id"].size and whole["particle_id"][-1] >= issued:
            raise ParameterError("resume", "the checkpoint's particle ids do not match this scene")
        rows = self.spread.respread(whole["position"], whole["particle_id"], issued)
        held = {k: whole[k][rows] for k in self.RESTORED}
        st = self.state
        for k, v in st.host_values().items():
            if k == "particle_count":
                continue
            saved = pieces[0][k]
            if isinstance(v, HostTable):
                v.restore(np.asarray(saved))
            else:
                setattr(st, k, np.array(saved, copy=True) if isinstance(v, np.ndarray) else type(v)(saved))
        count = held["position"].shape[0]
        if count > st.capacity:
            st.resize(count + max(16, count // 4))
        for k in self.RESTORED:
            if count:
                getattr(st, k)[:count].assign(held[k])
        st.particle_count = count
        self.after_load()

    def after_load(self) -> None:
        """After a checkpoint is restored: the per-particle buffers sized to it, the float32 positions and the particle
        order rebuilt."""
        pa = self.particles
        pa.allocate(self.state.capacity)
        self.coupling.allocate(self.state.capacity)
        pa.sync_position32()
        pa.exit_wall.zero_()   # a checkpoint holds live particles only
        self.spread.issued(pa.loaded_count + self.state.injected)
        pa.sort(self.count)
        self._find_owned()
        self._charge_electrodes()
        self.coupling.fields_at_particles()
        self.diagnostics_record.after_solve()

    def diagnostics(self) -> dict[str, float]:
        """The last row of the history: energies, charge, momentum, mode amplitudes (normalised units)."""
        if not len(self.state.history):
            return {}
        return {k: v[-1] for k, v in self.history.items() if k != "time"}

    def output_sets(self) -> list[OutputSet]:
        """The particles (slot order) and the nodes; in a distributed run a rank's own particles (``ids``: their
        particle ids) and, from rank 0, the nodes (every rank holds them all)."""
        n = self.count
        rows = np.flatnonzero(self._owned)
        p = self.state.position.numpy()[:n][rows]
        v = self.state.velocity.numpy()[:n][rows]
        e = self.particles.e_field.numpy()[:n][rows]
        pts = np.zeros((rows.size, 3))
        pts[:, :2] = p
        s = self.state.species.numpy()[:n][rows]
        ids = self.state.particle_id.numpy()[:n][rows]
        node_rows = np.arange(self.model.node_count) if self.world.is_root else np.zeros(0, int)
        nodes = np.zeros((node_rows.size, 3))
        nodes[:, :2] = self.model.nodes_np[node_rows]
        return [OutputSet("particles", pts, {"velocity": v, "e_field": e, "species": s.astype(np.float64),
                                             "particle_id": ids.astype(np.float64),
                                             "speed": np.linalg.norm(v, axis=1)}, frame_field="speed",
                          ids=ids, units=UNITS),
                OutputSet("nodes", nodes, {"potential": self.potential.copy()[node_rows],
                                           "charge": self.charge.numpy().copy()[node_rows]},
                          ids=node_rows, units=UNITS, backdrop=False)]

    def describe(self) -> dict:
        """The run for ``summary.json``: species, injections, field solve, step and the distributed layout."""
        species = [{"name": ld.species.name, "count": ld.count, "weight": ld.weight, "charge": ld.species.charge,
                    "mass": ld.species.mass, "density": ld.species.density, "temperature": ld.species.temperature}
                   for ld in self.loads]
        for k, j in enumerate(self.injections):
            sp_ = j.species
            species.append({"name": sp_.name, "injected_from": j.wall, "particles_per_step": j.particles_per_step,
                            "weight": self.macro_mass_np[len(self.loads) + k] / sp_.mass, "charge": sp_.charge,
                            "mass": sp_.mass, "density": sp_.density, "temperature": sp_.temperature,
                            "drift": list(sp_.drift), "flux": j.flux})
        species += [{"name": e.source.species.name, "charge": e.source.species.charge, "mass": e.source.species.mass,
                     "density": e.source.species.density, "temperature": e.source.species.temperature,
                     "emitted_from": e.describe()} for e in self.emitters]
        walls = self.boundary.describe() if self.boundary is not None else list(self.particle_walls)
        return {**self.spread.describe(), "particles": self.n, "species": species, "particle_walls": walls,
                "dt": self.dt, "gather": self.gather, "field_solve": self.coupling.field_solve,
                "magnetic_field": float(self.magnetic_field), "plasma_frequency": self.plasma_frequency,
                "omega_dt": self.plasma_frequency * self.dt,
                "debye_length": self.debye_length(), "background_density": self.background_density,
                "model": self.model.describe(), "field": self.field.describe()}
