"""The PIDC solver (seed 002 ch. 4-5): electrostatic particle-in-cell whose field solve is EFG.

One step (``kernels/pic.py``; the order of seed 002 §5.2):

    neighbours:  rebuild the HashGrid over the particles (and their periodic images)
    fits:        the MLS fit of every particle over the nodes (γ, ∂γ: φ_I and ∇φ_I, stored once per step)
    deposit:     Q_I = Σ_p q_p φ_I(x_p), a node gather (eq 4.4)
    solve:       K u = Q + ρ_bg m on the kept factorisation (:class:`~.field.PlasmaPoisson`)
    gather:      E_p = -Σ_I u_I ∇φ_I(x_p) (eq 4.5)
    push:        leapfrog (eqs 2.21 / 4.7), positions wrapped into the box

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
from warpfree.errors import ParameterError, require_finite, require_positive
from warpfree.kernels import efg as ek
from warpfree.kernels import pic as pk
from warpfree.neighbours import NeighbourGrid
from warpfree.reduce import Reduction
from warpfree.solver import OutputSet, State, TimeDependentSolver
from warpfree.solvers.efg.model import RCOND_LIMIT, EFGModel

from .field import PlasmaPoisson
from .species import ParticleLoad

__all__ = ["PICSolver", "PICState", "HEATING_DT", "HEATING_SPACING"]

#: ω_pe Δt above which the leapfrog's phase error heats the plasma noticeably (seed 002 §2.2.3: Δt = 0.2/ω_pe)
HEATING_DT = 0.2
#: node spacing / λ_D above which finite-grid (aliasing) heating sets in for a warm plasma
HEATING_SPACING = 2.0
#: the field gathers (``warpfree.solvers.pic.field``)
GATHERS = ("momentum", "energy")


class PICState(State):
    """position x^n (vec2d), velocity v^{n-1/2} (vec2d), species (index into the solver's loads), particle_id (the
    particle's index at load time: the arrays are re-sorted by cell every step), steps (the step count n, one int64:
    t = n Δt survives a resume)."""

    def __init__(self, position: np.ndarray, velocity: np.ndarray, species: np.ndarray, device: str):
        self.position = wp.array(position, dtype=wp.vec2d, device=device)
        self.velocity = wp.array(velocity, dtype=wp.vec2d, device=device)
        self.species = wp.array(species, dtype=wp.int32, device=device)
        self.particle_id = wp.array(np.arange(len(species), dtype=np.int32), dtype=wp.int32, device=device)
        self.steps = wp.zeros(1, dtype=wp.int64, device=device)


class PICSolver(TimeDependentSolver):
    """Electrostatic PIC on an EFG field solve, in a periodic box or between walls along y (reflecting particles).

    Parameters
    ----------
    field: :class:`~.field.PlasmaPoisson` (holds the :class:`~warpfree.solvers.efg.EFGModel`).
    loads: the species and their macro-particles (:func:`~.species.load_species`).
    dt: the time step (ω_pe⁻¹ units); ω_pe Δt must be < 2.
    background_density: uniform immobile charge density (e n_ref); default: the one that makes the plasma neutral.
    modes: Fourier modes (mx, my) whose field energy each step records.
    gather: "momentum" (nodal fields interpolated with φ_I: no self-force, momentum kept on node lattices) or
    "energy" (eq 4.5, -Σ u_I ∇φ_I: energy kept, a self-force of the order of a neighbour's); see :mod:`.field`.
    magnetic_field: a static uniform B_z (normalised: ω_ce = |B_z| for electrons), pushed by Boris's rotation.
    """

    name = "pic"
    work_unit = "particle pushes"
    time_unit = "/ω_pe"

    def __init__(self, field: PlasmaPoisson, loads: list[ParticleLoad], dt: float,
                 background_density: float | None = None, modes=((1, 0),), gather: str = "momentum",
                 magnetic_field: float = 0.0, launcher: Launcher | None = None):
        model: EFGModel = field.model
        super().__init__(model, launcher or model.launcher)
        self.field = field
        if not loads:
            raise ParameterError("loads", "need at least one species")
        self.loads = list(loads)
        if gather not in GATHERS:
            raise ParameterError("gather", f"must be one of {list(GATHERS)}, got {gather!r}")
        self.gather = gather
        self.magnetic_field = wp.float64(require_finite("magnetic_field", magnetic_field))
        self.dt = require_positive("dt", dt)
        species = [ld.species for ld in self.loads]
        self.plasma_frequency = math.sqrt(sum(s.plasma_frequency ** 2 for s in species))
        self._check_step()
        self._check_spacing()
        self.background_density = (-sum(s.charge * s.density for s in species) if background_density is None
                                   else float(background_density))
        dev = self.launcher.device
        space = model.space
        position = np.concatenate([ld.position for ld in self.loads])
        velocity = np.concatenate([ld.velocity for ld in self.loads])
        self.n = position.shape[0]
        index = np.concatenate([np.full(ld.count, k, np.int32) for k, ld in enumerate(self.loads)])
        self.macro_charge_np = np.array([ld.species.charge * ld.weight for ld in self.loads])
        self.macro_mass_np = np.array([ld.species.mass * ld.weight for ld in self.loads])
        self.macro_charge = wp.array(self.macro_charge_np, dtype=wp.float64, device=dev)
        self.macro_mass = wp.array(self.macro_mass_np, dtype=wp.float64, device=dev)
        self.charge_over_mass = wp.array([ld.species.charge / ld.species.mass for ld in self.loads],
                                         dtype=wp.float64, device=dev)
        self.total_particle_charge = float(sum(ld.count * q for ld, q in zip(self.loads, self.macro_charge_np)))
        self.state = PICState(position, velocity, index, dev)
        self.position32 = wp.zeros(self.n, dtype=wp.vec3, device=dev)
        self._sort_keys = wp.zeros(2 * self.n, dtype=wp.int32, device=dev)
        self._sort_order = wp.zeros(2 * self.n, dtype=wp.int32, device=dev)
        self._scratch = PICState(position, velocity, index, dev)
        self.kernels = pk.mls_kernels(model.settings.terms)
        self.node_set = model.node_set()
        self._sort_cell = model.reach
        #: re-sort the particles by cell every step (off: for measuring what sorting buys; 1.1x at 65 k particles)
        self.sort_particles = True
        self._sort_cells_x = int(math.ceil(space.length[0] / self._sort_cell)) + 1
        self._sync_position32()
        self.particle_grid = NeighbourGrid(self.launcher, model.reach, space)
        self.fit = wp.zeros(self.n, dtype=ek.MLSFit, device=dev)
        self.inv_scale = wp.float64(1.0 / float(np.mean(model.support_np[:, 0])))
        self.node_count_of = wp.zeros(self.n, dtype=wp.int32, device=dev)
        self._flags = wp.zeros(self.n, dtype=wp.int32, device=dev)
        self._flag_max = Reduction(self.launcher, wp.int32, "max")
        self.charge = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
        self.e_field = wp.zeros(self.n, dtype=wp.vec2d, device=dev)
        self.kinetic = wp.zeros(self.n, dtype=wp.float64, device=dev)
        self.momentum = wp.zeros(self.n, dtype=wp.vec2d, device=dev)
        self.potential = np.zeros(model.node_count)
        self.potential_wp = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
        self.nodal_field = wp.zeros(model.node_count, dtype=wp.vec2d, device=dev)
        self.modes = [tuple(int(v) for v in m) for m in modes]
        self.mode_matrix = field.mode_coefficients(self.modes) if self.modes else np.zeros((0, model.node_count))
        self.mode_k2 = np.sum(field.wavevectors(self.modes) ** 2, axis=1) if self.modes else np.zeros(0)
        #: per-step diagnostics since this solver was built (a resumed run's start at the resume: the time loop's
        #: output-time series, which checkpoints keep, hold the whole run)
        self.history: dict[str, list[float]] = {}
        self._steps = 0
        self._fields_at_current_positions()
        bad = self._bad_fit()
        if bad:
            raise ParameterError("support", bad)
        # half-step start: v^{-1/2} = v^0 - (q/m) E^0 Δt/2 (seed 002 §2.2.3)
        self.launcher.launch(pk.kick, self.n, [self.state.species, self.charge_over_mass, self.e_field,
                                               self.magnetic_field, wp.float64(-0.5 * self.dt), self.state.velocity])
        self._pending_field = self._field_terms()

    # -- checks ----------------------------------------------------------------------------------------------
    def _check_step(self) -> None:
        """Refuse ω_p Δt >= 2 (ω_p of all species together: the leapfrog's limit); warn above ω_pe Δt = 0.2 (ω_pe:
        the fastest species' own plasma frequency, the electrons')."""
        wdt = self.plasma_frequency * self.dt
        if wdt >= 2.0:
            raise ParameterError("dt", f"ω_p Δt = {wdt:.4g} >= 2: the leapfrog is unstable; take Δt < "
                                       f"{2.0 / self.plasma_frequency:.4g} (and <= "
                                       f"{HEATING_DT / self.plasma_frequency:.4g} to keep numerical heating small)")
        fastest = max(ld.species.plasma_frequency for ld in self.loads) * self.dt
        if fastest > HEATING_DT * (1.0 + 1e-12):
            warnings.warn(f"dt: ω_pe Δt = {fastest:.3g} is {fastest / HEATING_DT:.3g}x the {HEATING_DT} that keeps "
                          "the leapfrog's phase error and numerical heating small", stacklevel=3)

    def debye_length(self) -> float:
        """λ_De = v_th / ω_p of the fastest species (the electrons: the Debye length PIC resolution rules refer to);
        inf when it is cold."""
        fastest = max((ld.species for ld in self.loads), key=lambda sp_: sp_.plasma_frequency)
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
        p32 = np.zeros((self.n, 3), dtype=np.float32)
        p32[:, :2] = p
        self.position32.assign(p32)

    def _sort(self) -> None:
        """Reorder the particles by cell (row-major, cells of the support reach): the deposit gathers each node's
        particles from contiguous memory. Every step, so the order depends on the positions only (a resumed run
        sorts as the uninterrupted one did)."""
        L, st, sc = self.launcher, self.state, self._scratch
        L.launch(pk.cell_keys, self.n, [self.model.box, wp.float64(1.0 / self._sort_cell), self._sort_cells_x,
                                        st.position, self._sort_keys, self._sort_order])
        wp.utils.radix_sort_pairs(self._sort_keys, self._sort_order, self.n)
        L.launch(pk.permute_particles, self.n, [self._sort_order, st.position, st.velocity, st.species,
                                                st.particle_id, sc.position, sc.velocity, sc.species, sc.particle_id,
                                                self.position32])
        for name in ("position", "velocity", "species", "particle_id"):
            wp.copy(getattr(st, name), getattr(sc, name))

    def _fields_at_current_positions(self) -> None:
        """Sort, neighbours, fits, deposit, solve and gather at x^n (E into ``e_field``)."""
        m, L = self.model, self.launcher
        with self.phases("sort"):
            if self.sort_particles:
                self._sort()
        with self.phases("neighbours"):
            self.particle_grid.build(self.position32)
        with self.phases("fits"):
            L.launch(self.kernels.particle_fits, self.n, [self.node_set, self.position32, self.state.position,
                                                           self.inv_scale, self.fit, self.node_count_of])
        with self.phases("deposit"):
            g = self.particle_grid
            # the particle grid's image arrays are new at every build, so no launch timing could serve the next
            # step: split over every thread (``once``)
            L.launch(self.kernels.deposit, m.node_count,
                     [self.node_set, g.id, g.points, g.source_id, self.state.position, self.state.species,
                      self.macro_charge, self.inv_scale, self.fit, self.charge], once=True)
        with self.phases("solve"):
            self.potential = self.field.solve(self.charge.numpy(), self.background_density)
            self.potential_wp.assign(self.potential)
            if self.gather == "momentum":
                self.nodal_field.assign(self.field.nodal_field(self.potential))
        with self.phases("gather"):
            L.launch(self.kernels.particle_field, self.n, [self.node_set, self.position32, self.state.position,
                                                            self.inv_scale, self.fit, self.potential_wp,
                                                            self.nodal_field, int(self.gather == "momentum"),
                                                            self.e_field])

    def step(self, dt: float) -> None:
        if abs(dt - self.dt) > 1e-9 * self.dt:
            raise ParameterError("dt", f"the leapfrog keeps v at half steps of its own Δt = {self.dt:.6g}; a step of "
                                       f"{dt:.6g} would break the staggering (make output times multiples of Δt)")
        with self.phases("push"):
            self.launcher.launch(pk.leapfrog_push, self.n, [self.model.box, self.state.species, self.charge_over_mass,
                                                            self.macro_mass, self.e_field, self.magnetic_field,
                                                            wp.float64(self.dt),
                                                            self.state.position, self.state.velocity, self.position32,
                                                            self.kinetic, self.momentum])
        self._record()
        self._steps += 1
        self.state.steps.assign(np.array([self._steps], dtype=np.int64))
        self._fields_at_current_positions()
        self._pending_field = self._field_terms()

    # -- diagnostics -------------------------------------------------------------------------------------------
    def _field_terms(self) -> dict[str, float]:
        u = self.potential
        out = {"field_energy": self.field.field_energy(u),
               "deposited_charge": float(self.charge.numpy().sum()),
               "net_charge_density": self.field.net_charge_density}
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
            kin = float(self.kinetic.numpy().sum())
            mom = self.momentum.numpy().sum(axis=0)
            row.update(kinetic_energy=kin, total_energy=kin + row["field_energy"], momentum_x=float(mom[0]),
                       momentum_y=float(mom[1]))
            for k, v in row.items():
                self.history.setdefault(k, []).append(v)

    # -- the contract ----------------------------------------------------------------------------------------
    def stable_dt(self) -> float:
        """The solver's own Δt (checked against the leapfrog's limit 2/ω_p at construction): the staggered
        velocities belong to it, so it is the only step :meth:`step` takes."""
        return self.dt

    @property
    def dim(self) -> int:
        return 2

    @property
    def work_items(self) -> int:
        return self.n

    def _bad_fit(self) -> str | None:
        """A message naming the first particle whose MLS fit is ill-posed (too few nodes in reach, or a singular
        moment matrix) or whose velocity is not finite, else None. Flags and their maximum on the device: one read
        per step; the arrays come to the host only when something is wrong."""
        terms = self.model.settings.terms
        self.launcher.launch(pk.flag_bad_particles, self.n, [terms, wp.float64(RCOND_LIMIT), self.node_count_of,
                                                             self.fit, self.state.velocity, self._flags])
        self._flag_max.launch(self._flags)
        if not self._flag_max.value():
            return None
        bad = np.flatnonzero(self._flags.numpy())
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
        self._sync_position32()
        self._fields_at_current_positions()
        self._pending_field = self._field_terms()

    def diagnostics(self) -> dict[str, float]:
        return {k: v[-1] for k, v in self.history.items() if k != "time"} if self.history else {}

    def output_sets(self) -> list[OutputSet]:
        p = self.state.position.numpy()
        v = self.state.velocity.numpy()
        e = self.e_field.numpy()
        pts = np.zeros((self.n, 3))
        pts[:, :2] = p
        s = self.state.species.numpy()
        nodes = np.zeros((self.model.node_count, 3))
        nodes[:, :2] = self.model.nodes_np
        return [OutputSet("particles", pts, {"velocity": v, "e_field": e, "species": s.astype(np.float64),
                                             "particle_id": self.state.particle_id.numpy().astype(np.float64),
                                             "speed": np.linalg.norm(v, axis=1)}, frame_field="species"),
                OutputSet("nodes", nodes, {"potential": self.potential.copy(), "charge": self.charge.numpy().copy()})]

    def describe(self) -> dict:
        return {"particles": self.n, "species": [{"name": ld.species.name, "count": ld.count, "weight": ld.weight,
                                                  "charge": ld.species.charge, "mass": ld.species.mass,
                                                  "density": ld.species.density,
                                                  "temperature": ld.species.temperature} for ld in self.loads],
                "dt": self.dt, "gather": self.gather,
                "magnetic_field": float(self.magnetic_field), "plasma_frequency": self.plasma_frequency,
                "omega_dt": self.plasma_frequency * self.dt,
                "debye_length": self.debye_length(), "background_density": self.background_density,
                "model": self.model.describe(), "field": self.field.describe()}
