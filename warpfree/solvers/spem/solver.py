"""The SPEM solver: leapfrog of Ez (half steps) and H (whole steps) on the model's static sets.

One step Δt (Algorithm 3.1): E phase Ez^{n-1/2} → Ez^{n+1/2} from H^n, sources at t^{n+1/2}, then H phase
H^n → H^{n+1} from Ez^{n+1/2}; the launch boundary is the thesis's barrier. The state is Ez, its x part
Ezx (split field, 3.17), Hx, Hy and the time t^n of H (s). Sources:

- hard: Ez = A_p f(t) on the source particles (they are not updated by the E phase);
- soft: Ez += A_p f(t) after the E phase (an additive, transparent source);
- a :class:`~.plane_wave.PlaneWave`: a plane wave injected into a total-field box (TF/SF, E and H both).

f(t) is a :class:`Waveform` (a sine sin(2π f t + φ), optionally switched on over ``ramp`` periods with a smooth
sin² envelope) or a :class:`GaussianPulse`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.distribution import Distribution, launch_order
from warpfree.errors import ParameterError, require_finite, require_positive
from warpfree.kernels import spem as K
from warpfree.kernels import spem_dispersive as KD
from warpfree.kernels import spem_monitors as KM
from warpfree.graph import StepGraph
from warpfree.parallel import world as ranks_of_run
from warpfree.parallel.halo import whole_from_pieces
from warpfree.parameters import Choice
from warpfree.progress import announced
from warpfree.solver import OutputSet, State, StepRule, TimeDependentSolver

from .layouts import HX, HY
from .kronecker import NodalValues
from .model import Scheme, SPEMModel
from .monitors import (FIELD_UNITS, DFTMonitor, FluxMonitor, field_particles, interpolation_rows, window_amplitude,
                       window_weights)
from .plane_wave import DevicePlaneWave, PlaneWave

__all__ = ["Waveform", "GaussianPulse", "Source", "SourceKind", "SPEMState", "SPEMSolver"]

#: the units of the output sets' quantities (SI): E_z on the E particles, H_x, H_y on the H particles
UNITS = {"position": "m", "ez": "V/m", "hx": "A/m", "hy": "A/m"}


@dataclass
class Waveform:
    """sin(2π f t + phase), times a sin² ramp over the first ``ramp`` periods (0: none); ``t`` (s) a number or
    an array."""

    frequency: float
    phase: float = 0.0
    ramp: float = 0.0

    def __call__(self, t):
        w = 2.0 * math.pi * self.frequency
        envelope = 1.0
        if self.ramp > 0:
            s = np.minimum(1.0, np.asarray(t) * self.frequency / self.ramp)
            envelope = np.sin(0.5 * math.pi * s) ** 2
        return envelope * np.sin(w * np.asarray(t) + self.phase)


@dataclass
class GaussianPulse:
    """sin(2π f (t - delay)) exp(-((t - delay)/width)²): a modulated pulse (s, Hz); ``delay`` >= 4 widths starts it
    from (numerically) zero."""

    frequency: float
    width: float
    delay: float

    def __call__(self, t):
        u = (np.asarray(t) - self.delay) / self.width
        return np.exp(-u * u) * np.sin(2.0 * math.pi * self.frequency * (np.asarray(t) - self.delay))


class SourceKind(Choice):
    """How a source drives its E particles."""

    HARD = "hard", "Ez = A f(t) imposed (the particles are not updated by the E phase)"
    SOFT = "soft", "Ez += A f(t) after the E phase (additive, transparent)"


@dataclass
class Source:
    """E particles ``particles`` (indices) driven by ``waveform`` with per-particle ``amplitude`` (V/m),
    ``kind`` a :class:`SourceKind` (hard or soft)."""

    particles: np.ndarray
    waveform: Waveform
    amplitude: np.ndarray | float = 1.0
    kind: SourceKind = SourceKind.HARD

    def __post_init__(self):
        self.kind = SourceKind.of("source.kind", self.kind)


class SPEMState(State):
    """Ez and its x part Ezx on the E set (V/m), Hx and Hy on the H set (A/m), and ``clock``, the device clock's array
    (``warpfree.clock``: t of H in s, Δt, ...)."""

    def __init__(self, ez, ezx, hx, hy, clock):
        self.ez, self.ezx, self.hx, self.hy, self.clock = ez, ezx, hx, hy, clock


class _DeviceSource:
    """A :class:`Source` on the device: ``index`` its E particles (global indices), ``particles`` those this process
    updates (held indices of its own ones in a distributed run; ``local`` maps global to held indices and owned)."""

    def __init__(self, source: Source, model: SPEMModel, device: str, local=None):
        idx = np.asarray(source.particles, dtype=np.int64).ravel()
        if idx.size == 0 or idx.min() < 0 or idx.max() >= model.layout.n_e or np.unique(idx).size != idx.size:
            raise ParameterError("source.particles", f"must be distinct indices of E particles (0..{model.layout.n_e - 1})")
        require_positive("source.frequency", source.waveform.frequency)
        amp = np.broadcast_to(np.asarray(source.amplitude, dtype=np.float64), idx.shape)
        if not np.all(np.isfinite(amp)):
            raise ParameterError("source.amplitude", "must be finite")
        self.source = source
        self.index = idx
        mine = np.arange(idx.size)
        here = idx
        if local is not None:
            here, mine = local(idx)
        self.count = int(mine.size)
        self.particles = wp.array(here.astype(np.int32) if mine.size else np.zeros(1, np.int32), dtype=wp.int32,
                                  device=device)
        self.amplitude = wp.array(amp[mine].astype(np.float32) if mine.size else np.zeros(1, np.float32), dtype=float,
                                  device=device)
        self.additive = int(source.kind is SourceKind.SOFT)
        self.signal = source_signal(source.waveform)


class _DeviceTransform:
    """One field of a :class:`~.monitors.DFTMonitor` on the device: the particles its points read (``ids``: their
    indices in the whole set, those this process owns), their transforms' sums (``real``, ``imag``: (particles,
    frequencies), float64) and the interpolation from the particles to the points (``weights``: points × ``stencil``,
    the global indices of every particle read)."""

    def __init__(self, monitor: DFTMonitor, field: str, model: SPEMModel, spread, frequencies: wp.array, device: str):
        lay = model.layout
        carriers = field_particles(lay, field)
        positions = lay.e_position if field == "ez" else lay.h_position
        weights = interpolation_rows(positions[carriers], monitor.points, lay.dim, lay.spacing).tocsc()
        used = np.flatnonzero(np.diff(weights.indptr) > 0)
        self.field, self.monitor = field, monitor
        self.weights = weights[:, used].tocsr()
        self.stencil = carriers[used].astype(np.int64)
        part = spread.electric if field == "ez" else spread.magnetic
        here, mine = spread.owned(part, self.stencil)
        self.ids = self.stencil[mine]
        self.count = int(mine.size)
        n, nf = max(self.count, 1), frequencies.shape[0]
        self.particles = wp.array(here.astype(np.int32) if self.count else np.zeros(1, np.int32), dtype=wp.int32,
                                  device=device)
        self.real = wp.zeros((n, nf), dtype=wp.float64, device=device)
        self.imag = wp.zeros((n, nf), dtype=wp.float64, device=device)
        self.frequencies = frequencies
        self.offset = 0.5 if field == "ez" else 1.0  # the field's time in the step: Ez at t + Δt/2, H at t + Δt
        self.key = f"dft_{monitor.name}_{field}"


def source_signal(waveform) -> K.SourceSignal:
    """The device form (``kernels/spem.py: SourceSignal``) of a :class:`Waveform` or :class:`GaussianPulse`."""
    signal = K.SourceSignal()
    signal.kind = 1 if isinstance(waveform, GaussianPulse) else 0
    signal.frequency = wp.float64(waveform.frequency)
    signal.phase = wp.float64(getattr(waveform, "phase", 0.0))
    signal.ramp = wp.float64(getattr(waveform, "ramp", 0.0))
    signal.width = wp.float64(getattr(waveform, "width", 1.0))
    signal.delay = wp.float64(getattr(waveform, "delay", 0.0))
    return signal


class SPEMSolver(TimeDependentSolver):
    """Leapfrog SPEM on ``model``; ``ez``/``hx``/``hy``: initial fields (arrays or f(points) -> values), zero
    by default; ``sources``: a list of :class:`Source` and :class:`~.plane_wave.PlaneWave`.

    ``kronecker``: the initial fields are field values, converted once to the nodal values whose SPH interpolant
    takes them at the particles (Mendes 2010, §3.1.5, :mod:`.kronecker`; for the "sph" and "cspm" schemes, whose values
    are read through that interpolant; FPM's values already are point values). PEC particles keep 0.
    ``monitors``: :class:`~.monitors.DFTMonitor` s, running DFTs of fields at points accumulated every step (their sums
    are state: a checkpoint holds them), written at every output as ``monitors/<name>.csv`` (:meth:`output_tables`).
    ``distribution``: which particles each thread updates (``warpfree/distribution.py``: "blocks",
    "alternating", "random", "neighbours"); the results are bitwise the same for all.

    Time step: constant over a run (the staggered leapfrog keeps its second order only so), at most ``courant`` × the
    stable limit (:meth:`stable_dt`, eq. 3.21), whatever the output interval: outputs fall at the first step at or
    after their times (:class:`~warpfree.solver.StepRule`)."""

    name = "spem"
    distributes = True
    work_unit = "particle-steps"

    @announced("EM solver made")
    def __init__(self, model: SPEMModel, sources: list[Source] | None = None, ez=None, hx=None, hy=None,
                 launcher: Launcher | None = None, kronecker: bool = False,
                 distribution: Distribution = Distribution.BLOCKS,
                 courant: float = 0.95, monitors: list[DFTMonitor] | None = None):
        super().__init__(model, launcher or model.launcher or current_launcher())
        if not 0.0 < require_finite("courant", courant) <= 1.0:
            raise ParameterError("courant", f"must be in (0, 1] (a fraction of the stable step), got {courant}")
        self.courant = float(courant)
        distribution = Distribution.of("distribution", distribution)
        e, h, dev = model.electric, model.magnetic, self.launcher.device

        def initial(name, value, s):
            if value is None:
                return np.zeros(s.n)
            v = value(s.numpy("position")) if callable(value) else value
            v = np.broadcast_to(np.asarray(v, dtype=np.float64), (s.n,)).copy()
            if not np.all(np.isfinite(v)):
                raise ParameterError(name, "must be finite")
            return v

        ez0 = initial("ez", ez, e)
        ez0[model.held] = 0.0
        hx0, hy0 = initial("hx", hx, h), initial("hy", hy, h)
        carries = model.layout.h_carries
        if carries is not None:  # Yee's staggering: each H particle holds one component, the other is not there
            hx0[carries != HX] = 0.0
            hy0[carries != HY] = 0.0
        if kronecker:
            ez0, hx0, hy0 = self._nodal_values(model, ez0, hx0, hy0)
        sources = list(sources or [])
        for s in sources:
            if not isinstance(s, Source | PlaneWave):
                raise ParameterError("sources", f"each source is a Source or a PlaneWave, got {type(s).__name__}")
        held = model.held.copy()
        for s in sources:
            if isinstance(s, Source) and s.kind is SourceKind.HARD:
                held[np.asarray(s.particles, dtype=np.int64).ravel()] = True
        self._held_whole = held
        self._dt_max = model.stable_dt()
        self._run_step: float | None = None   # the run's constant step (use_step)
        self._curl = None
        self.distribution = distribution
        self.world = ranks_of_run()
        from .spread import FieldSpread

        #: the E and H sets over the ranks (one process: a one-rank partition of the model's sets)
        spread = self.spread = FieldSpread(self.world, model)
        ep, hp = spread.electric, spread.magnetic
        #: the E and H sets this process steps: a rank's part (its own particles and their ghosts; ``numpy`` gathers
        #: the whole set), over the model's own arrays in one process
        electric_state = {"ez": ez0.astype(np.float32), "ezx": (0.5 * ez0).astype(np.float32),
                          "held": held.astype(np.int32)}
        if model.drude is not None:  # the Drude current J (A/m², at H's times), and its medium
            at, weight, rate = model.drude
            for name, values in (("current", np.zeros(e.n)), ("drude_weight", np.zeros(e.n)),
                                 ("collision_rate", np.zeros(e.n))):
                electric_state[name] = values.astype(np.float32)
            electric_state["drude_weight"][at] = weight
            electric_state["collision_rate"][at] = rate
        self.electric = spread.held_set("electric", e, ep, electric_state, dev)
        self.magnetic = spread.held_set("magnetic", h, hp, {"hx": hx0.astype(np.float32),
                                                            "hy": hy0.astype(np.float32)}, dev)
        self.state = SPEMState(self.electric["ez"], self.electric["ezx"], self.magnetic["hx"], self.magnetic["hy"],
                               self.clock.values)
        #: the fields a checkpoint holds per set (the Drude current with E where there is one)
        self.restored = {"electric": ("ez", "ezx") + (("current",) if model.drude is not None else ()),
                         "magnetic": ("hx", "hy")}
        self.drude = None
        if model.drude is not None:
            self.state.current = self.electric["current"]
            here, _ = spread.owned(ep, model.drude[0].astype(np.int64))
            self.drude = wp.array(here.astype(np.int32) if here.size else np.zeros(1, np.int32), dtype=wp.int32,
                                  device=dev)
            self._drude_count = int(here.size)
        for name, part in (("electric", ep), ("magnetic", hp)):  # which particles a checkpoint piece holds
            setattr(self.state, f"{name}_id", part.ids.astype(np.int64))
            setattr(self.state, f"{name}_owned", part.owned.astype(np.int8))
        self.held = self.electric["held"]
        self.e_rows, self.e_coefficient = spread.rows(model.e_rows.rows, model.e_coefficient, ep, hp)
        self.h_rows, self.h_coefficient = spread.rows(model.h_rows.rows, model.h_coefficient, hp, ep)
        self.sources = [_DeviceSource(s, model, dev, local=spread.owned_electric)
                        for s in sources if isinstance(s, Source)]
        waves = [DevicePlaneWave(s, model, dev) for s in sources if isinstance(s, PlaneWave)]
        if model.drude is not None:
            for w in waves:
                if np.intersect1d(w.e_targets.numpy()[:w.n_e], model.drude[0]).size:
                    raise ParameterError("plane_wave.lower", "the total-field box's boundary crosses a dispersive "
                                                             "object: the incident wave is vacuum's there")
        self.plane_waves = [spread.plane_wave(w) for w in waves]
        self.monitors = self._monitors(monitors, model, dev)
        self._field_rows: dict = {}  # field_at's interpolation per set of points
        # each thread's particles (``distribution``) among this rank's own; a held particle returns at once
        e_cost = np.where(held, 0, model.e_rows.rows.count.numpy()[:e.n])
        h_cost = model.h_rows.rows.count.numpy()[:h.n]
        self.e_order, self.h_order = (
            wp.array(part.owned_index[launch_order(distribution, part.n_owned, self.launcher.threads,
                                                   cost=cost[part.ids[part.owned_index]])].astype(np.int32),
                     dtype=wp.int32, device=dev) for part, cost in ((ep, e_cost), (hp, h_cost)))

    def _monitors(self, monitors, model: SPEMModel, device: str) -> dict[str, list[_DeviceTransform]]:
        """Each monitor checked and its fields' transforms on the device, their sums and owned ids in the state."""
        out: dict[str, list[_DeviceTransform]] = {}
        slowest = float(np.sqrt(np.max(model.eps_r)) * np.sqrt(np.max(model.mu_r)))
        for m in monitors or []:
            if not isinstance(m, DFTMonitor):
                raise ParameterError("monitor", f"each monitor is a DFTMonitor, got {type(m).__name__}")
            m = m.checked(model.layout, slowest)
            if m.name in out:
                raise ParameterError("monitor", f"two monitors are named {m.name!r}")
            frequencies = wp.array(np.asarray(m.frequencies, np.float64), dtype=wp.float64, device=device)
            out[m.name] = [_DeviceTransform(m, f, model, self.spread, frequencies, device) for f in m.fields]
            for t in out[m.name]:
                setattr(self.state, f"{t.key}_real", t.real)
                setattr(self.state, f"{t.key}_imag", t.imag)
                setattr(self.state, f"{t.key}_id", t.ids)
        return out

    @staticmethod
    def _nodal_values(model: SPEMModel, ez0, hx0, hy0):
        """The nodal values of the initial fields (the ``kronecker`` option): E with its PEC particles at 0."""
        if model.scheme is Scheme.FPM:
            raise ParameterError("kronecker", "FPM's particle values are point values already (its derivative is "
                                              "exact on them); the option is for the 'sph' and 'cspm' schemes")
        free = np.flatnonzero(~model.held)
        e = NodalValues.from_set(model.electric, model.dim, subset=free if model.held.any() else None)
        ez = e.nodal(ez0) if e.subset is None else e.nodal_for(ez0[free], np.zeros(model.layout.n_e))
        h = NodalValues.from_set(model.magnetic, model.dim)
        hxy = h.nodal(np.stack([hx0, hy0], axis=1))
        return ez, hxy[:, 0].copy(), hxy[:, 1].copy()

    # -- stepping --------------------------------------------------------------------------------
    def advance(self) -> None:
        """Ez to t + Δt/2, sources there, then H to t + Δt (3.13-3.15), with the Δt the clock holds (the run's
        constant step, shortened to land on an output), then the time moved on and the next step picked."""
        self._launch_step()
        self.clock.launch_advance_and_choose()

    def record_step(self) -> StepGraph:
        """:meth:`advance` recorded as one Warp graph."""
        with self.launcher.capturing() as capture:
            self.advance()
        return StepGraph([capture.graph], after=self.clock.invalidate)

    def _launch_step(self) -> None:
        """The step's launches; t and Δt from the clock (``kernels/clock.py``). In a distributed run each phase ends
        by giving the ghosts their owners' new values (Ez for the H phase, H for the next E phase)."""
        L, st, clock = self.launcher, self.state, self.clock.values
        e, h = self.electric, self.magnetic
        with self.phases("electric"):
            L.launch(K.update_electric, self.e_order.shape[0], [self.e_order, clock, self.e_rows, self.e_coefficient,
                                                                st.hx, st.hy, e["inv_permittivity"], e["loss"],
                                                                self.held, st.ez, st.ezx])
            for w in self.plane_waves:  # TF/SF: the incident H^n across the box's boundary
                L.launch(K.plane_wave_electric, w.n_e, [clock, w.struct, w.e_targets, w.e_rows, w.e_coefficient,
                                                        h.position, e["inv_permittivity"], e["loss"], self.held,
                                                        st.ez, st.ezx])
        if self.drude is not None and self._drude_count:
            with self.phases("electric"):
                L.launch(KD.drude_electric, self._drude_count, [self.drude, clock, e["inv_permittivity"], st.current,
                                                                st.ez, st.ezx])
                L.launch(KD.drude_current, self._drude_count, [self.drude, clock, e["drude_weight"],
                                                               e["collision_rate"], st.ez, st.current])
        with self.phases("sources"):
            for s in self.sources:
                L.launch(K.set_source, s.count, [s.particles, s.amplitude, s.signal, clock, s.additive, st.ez,
                                                 st.ezx])
            self._launch_transforms(("ez",))
        with self.phases("exchange"):
            self.spread.electric.refresh(st.ez)
        with self.phases("magnetic"):
            L.launch(K.update_magnetic, self.h_order.shape[0], [self.h_order, clock, self.h_rows, self.h_coefficient,
                                                                st.ez, h["inv_permeability"], h["loss"], st.hx, st.hy])
            for w in self.plane_waves:  # TF/SF: the incident Ez^{n+1/2}
                L.launch(K.plane_wave_magnetic, w.n_h, [clock, w.struct, w.h_targets, w.h_rows, w.h_coefficient,
                                                        e.position, h["inv_permeability"], h["loss"], st.hx, st.hy])
            self._launch_transforms(("hx", "hy"))
        with self.phases("exchange"):
            self.spread.magnetic.refresh(st.hx, st.hy)

    def _launch_transforms(self, fields: tuple[str, ...]) -> None:
        """The monitors' running DFTs of ``fields`` at the time those fields have reached in the step."""
        for transforms in self.monitors.values():
            for t in transforms:
                if t.field in fields and t.count:
                    values = getattr(self.state, t.field)
                    self.launcher.launch(KM.accumulate_dft, t.count * t.frequencies.shape[0],
                                         [t.particles, values, self.clock.values, wp.float64(t.offset),
                                          wp.float64(t.monitor.start), wp.float64(t.monitor.stop), t.frequencies,
                                          t.real, t.imag])

    def field_at(self, points) -> dict[str, np.ndarray]:
        """Ez (V/m), Hx and Hy (A/m; Hy alone in 1D) at ``points`` ((m, dim) or (m, 3), m): each the quadratic
        least-squares fit of the 12 nearest particles of its set (``monitors.interpolation_rows``; exact on a particle),
        NaN outside the domain (in a conductor). What a :class:`warpfree.sensors.FieldSensor` records. The same values
        on every rank (collective: each particle's value comes from the rank that owns it)."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] not in (self.dim, 3) or not np.all(np.isfinite(pts)):
            raise ParameterError("points", f"must be finite (m, {self.dim}) or (m, 3) coordinates, got shape "
                                           f"{pts.shape}")
        key = pts.tobytes()
        if key not in self._field_rows:  # set-up once per set of points: the rows and the particles they read
            lay = self.model.layout
            full = np.zeros((pts.shape[0], 3))
            full[:, :pts.shape[1]] = pts
            outside = ~lay.inside(full) if lay.inside is not None else np.zeros(pts.shape[0], bool)
            rows = {}
            inside = np.flatnonzero(~outside)
            place = sp.csr_matrix((np.ones(inside.size), (inside, np.arange(inside.size))),
                                  shape=(pts.shape[0], inside.size))  # the inside points' rows among all
            for field in ("ez", "hy") if self.dim == 1 else ("ez", "hx", "hy"):
                carriers = field_particles(lay, field)
                positions = lay.e_position if field == "ez" else lay.h_position
                weights = (place @ interpolation_rows(positions[carriers], full[inside], lay.dim, lay.spacing)).tocsc()
                used = np.flatnonzero(np.diff(weights.indptr) > 0)
                stencil = carriers[used].astype(np.int64)
                part = self.spread.electric if field == "ez" else self.spread.magnetic
                here, mine = self.spread.owned(part, stencil)
                rows[field] = (weights[:, used].tocsr(), stencil, here, mine)
            self._field_rows[key] = (rows, outside)
        rows, outside = self._field_rows[key]
        out = {}
        for field, (weights, stencil, here, mine) in rows.items():
            s = self.electric if field == "ez" else self.magnetic
            local = np.column_stack([stencil[mine].astype(np.float64), s[field].numpy()[here].astype(np.float64)])
            every = np.vstack(self.world.allgather(local)) if self.world.distributed else local
            values = np.zeros(stencil.size)
            values[np.searchsorted(stencil, every[:, 0].astype(np.int64))] = every[:, 1]
            out[field] = np.where(outside, np.nan, weights @ values)
        return out

    def dft(self, name: str) -> dict[str, np.ndarray]:
        """Monitor ``name``'s transforms at its points: field -> complex (points, frequencies), V·s/m or A·s/m (every
        rank gets them: a collective call in a distributed run)."""
        if name not in self.monitors:
            raise ParameterError("monitor", f"no monitor is named {name!r} (there are {sorted(self.monitors)})")
        out = {}
        for t in self.monitors[name]:
            n = t.count
            rows = np.column_stack([t.ids.astype(np.float64), t.real.numpy()[:n], t.imag.numpy()[:n]])
            every = np.vstack(self.world.allgather(rows)) if self.world.distributed else rows
            nf = t.frequencies.shape[0]
            value = np.zeros((t.stencil.size, nf), complex)
            at = np.searchsorted(t.stencil, every[:, 0].astype(np.int64))
            value[at] = every[:, 1:1 + nf] + 1j * every[:, 1 + nf:]
            out[t.field] = t.weights @ value
        return out

    def flux(self, name: str) -> dict[str, np.ndarray]:
        """Flux monitor ``name``'s ``spectrum`` (W s²/m in 2D) and ``power`` (W/m) per frequency
        (:class:`~.monitors.FluxMonitor`; collective in a distributed run)."""
        monitor = self.monitors[name][0].monitor if name in self.monitors else None
        if not isinstance(monitor, FluxMonitor):
            raise ParameterError("monitor", f"no flux monitor is named {name!r}")
        return monitor.flux(self.dft(name), {f: self.dft_window(name, f) for f in monitor.fields})

    def dft_window(self, name: str, field: str) -> float:
        """The time (s) monitor ``name``'s transform of ``field`` has summed: the parts of its samples' steps
        [t - Δt/2, t + Δt/2] inside its window (:func:`~.monitors.window_weights`, the kernel's rule)."""
        t = next(t for t in self.monitors[name] if t.field == field)
        dt = self.run_step
        if dt <= 0:
            return 0.0
        steps = int(round(self.t / dt))
        times = (np.arange(steps) + t.offset) * dt
        return float(window_weights(times, dt, t.monitor.start, t.monitor.stop).sum())

    def output_tables(self) -> dict[str, tuple[list[tuple[str, str]], np.ndarray]]:
        """Each monitor's table: a row per point and frequency (point index, position, frequency) with, per field, the
        transform's real and imaginary parts and the amplitude and phase of the steady sine over the window summed
        (:func:`~.monitors.window_amplitude`)."""
        tables = {}
        for name, transforms in self.monitors.items():
            m = transforms[0].monitor
            if isinstance(m, FluxMonitor):  # the flux per frequency
                flux = self.flux(name)
                tables[f"monitors/{name}"] = ([("frequency", "Hz"), ("spectrum", "W s2/m" if self.dim == 2 else "W s2/m2"),
                                               ("power", "W/m" if self.dim == 2 else "W/m2")],
                                              np.column_stack([np.asarray(m.frequencies), flux["spectrum"],
                                                               flux["power"]]))
                continue
            values = self.dft(name)
            npts, nf = m.points.shape[0], len(m.frequencies)
            point = np.repeat(np.arange(npts), nf)
            columns = [np.asarray(point, float)] + [np.repeat(m.points[:, a], nf) for a in range(self.dim)]
            columns.append(np.tile(np.asarray(m.frequencies), npts))
            header = [("point", ""), *[("xyz"[a], "m") for a in range(self.dim)], ("frequency", "Hz")]
            for t in transforms:
                unit, transform_unit = FIELD_UNITS[t.field]
                f = values[t.field].ravel()
                amplitude, phase = window_amplitude(f, self.dft_window(name, t.field))
                columns += [f.real, f.imag, amplitude, phase]
                header += [(f"{t.field}_real", transform_unit), (f"{t.field}_imag", transform_unit),
                           (f"{t.field}_amplitude", unit), (f"{t.field}_phase", "rad")]
            tables[f"monitors/{name}"] = (header, np.column_stack(columns))
        return tables

    def stable_dt(self) -> float:
        """The stable step of the operators' spectral radius, fixed at set-up (s)."""
        return self._dt_max

    def step_rule(self) -> StepRule:
        """One constant step for the run, at most ``courant`` × the stable limit."""
        return StepRule.constant(self.courant * self._dt_max)

    @property
    def t(self) -> float:
        """The time of H (s), the clock's (read once after a step)."""
        return self.clock.time

    @property
    def run_step(self) -> float:
        """The run's constant Δt (s): the one the time loop announced (:meth:`use_step`), else the last step taken."""
        return self._run_step if self._run_step is not None else self.clock.last_step

    @property
    def electric_time(self) -> float:
        """The time of Ez (s): half the run's step behind H's, t - Δt/2 (the staggered leapfrog: Ez^{n+1/2} and H^{n+1}
        after a step to t = (n + 1) Δt)."""
        return self.t - 0.5 * self.run_step

    def problem(self) -> str | None:
        """None: a SPEM step has nothing to refuse (the step is fixed below its limit at set-up)."""
        return None

    def audit(self) -> str | None:
        """At every output: a field that is no longer a finite number stops the run (its last good state kept), with
        where and since when it went wrong; None when all are finite. Every rank checks its own particles."""
        for name, fields in (("electric", ("ez",)), ("magnetic", ("hx", "hy"))):
            s = getattr(self, name)
            part = getattr(self.spread, name)
            for field in fields:
                values = part.owned_values(s[field])
                bad = ~np.isfinite(values)
                if np.any(bad):
                    k = int(np.flatnonzero(bad)[0])
                    where = part.owned_values(s.position)[k]
                    return (f"{field} is not finite at {int(bad.sum())} particle(s), e.g. at "
                            f"{np.round(np.asarray(where)[:self.dim], 6).tolist()} m: the run grew without bound (a "
                            f"step above the limit of a material the model was not told of?)")
        return None

    # -- outputs ---------------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """The dimension of the layout (1 or 2)."""
        return self.model.dim

    @property
    def work_items(self) -> int:
        """E and H particles (the unit of the throughput)."""
        return self.model.layout.n_e + self.model.layout.n_h

    def restore_pieces(self, pieces: list[dict]) -> None:
        """The whole fields from every process's checkpoint (each its own particles, by ``electric_id`` and
        ``magnetic_id``; one process's piece holds every particle), then this rank's held rows of them: the sets are
        static, so the run continues bitwise as the uninterrupted one."""
        counts = {"electric": self.model.layout.n_e, "magnetic": self.model.layout.n_h}
        for name, keys in self.restored.items():
            whole = whole_from_pieces(pieces, keys, f"{name}_id", counts[name], owned=f"{name}_owned")
            part = getattr(self.spread, name)
            for k in keys:
                getattr(self.state, k).assign(part.take(whole[k]))
        for transforms in self.monitors.values():
            for t in transforms:
                names = (f"{t.key}_real", f"{t.key}_imag")
                whole = whole_from_pieces(pieces, names, f"{t.key}_id", None)
                at = np.searchsorted(whole[f"{t.key}_id"], t.ids)
                for k, arr in zip(names, (t.real, t.imag)):
                    values = np.zeros(arr.shape)
                    values[:t.count] = whole[k][at]
                    arr.assign(values)
        self.clock.values.assign(pieces[0]["clock"])
        self.clock.invalidate()
        self.after_load()

    def output_sets(self) -> list[OutputSet]:
        """Ez on the E set, H on the H set: every particle in one process; a rank's own in a distributed run
        (``OutputSet.ids``: their indices in the whole set)."""
        e, h = self.electric, self.magnetic
        ep, hp = self.spread.electric, self.spread.magnetic
        return [OutputSet("electric", ep.owned_values(e.position), {"ez": ep.owned_values(e["ez"])},
                          frame_field="ez", ids=ep.ids[ep.owned_index], units=UNITS),
                OutputSet("magnetic", hp.owned_values(h.position), {"hx": hp.owned_values(h["hx"]),
                                                                    "hy": hp.owned_values(h["hy"])},
                          ids=hp.ids[hp.owned_index], units=UNITS)]

    def use_step(self, dt: float) -> None:
        """The run's constant step (told by the time loop before its first record): the step :meth:`energy`'s
        leapfrog invariant is taken with."""
        self._run_step = float(dt)

    def energy(self, dt: float | None = None) -> dict[str, float]:
        """The energy the leapfrog conserves (J, per metre of depth in 2D, per m² in 1D), with Ez^{n-1/2} and H^n the
        state at t = nΔt:

            W^n = ½ Σ_i ε_i V_i Ez_i^{n-1/2} Ez_i^{n+1/2} + ½ Σ_k μ_k V_k |H_k^n|²,

        Ez^{n+1/2} = Ez^{n-1/2} + Δt ε⁻¹ (D_x Hy^n - D_y Hx^n) the lossless update (held particles keep their value),
        V the quadrature volumes of the pair. For the energy-conserving pair (V_E D_E = D_Hᵀ V_H) W^{n+1} = W^n
        exactly in a closed lossless region without sources, over
        steps of one size (a run's last step shortened to land on its end time breaks the sequence); the plain ½ Σ ε V Ez² + ½ Σ μ V H² of the staggered
        values is not conserved (it swings with the field's spectrum: down to 0.6 of its start for white noise).
        ``electric_energy`` is the first sum, ``magnetic_energy`` the second. ``dt``: the step of the run (default:
        the one the time loop announced, else the last one taken; before any step, 0: the plain sum). Host,
        float64, from the float32 state."""
        e, h, m = self.model.electric, self.model.magnetic, self.model
        if dt is None:
            dt = self.run_step
        ez = self.electric.numpy("ez").astype(np.float64)
        hx, hy = self.magnetic.numpy("hx").astype(np.float64), self.magnetic.numpy("hy").astype(np.float64)
        if self._curl is None:  # the E rows as host CSR matrices (set-up, once)
            self._curl = m.electric_operator()
        curl = self._curl[0] @ hy - (self._curl[1] @ hx if m.dim > 1 else 0.0)
        ez_next = np.where(self._held_whole, ez, ez + dt * e.numpy("inv_permittivity").astype(np.float64) * curl)
        we = 0.5 * np.sum(e.numpy("permittivity") * ez * ez_next * e.numpy("cell_volume"))
        wm = 0.5 * np.sum(h.numpy("permeability") * (hx ** 2 + hy ** 2) * h.numpy("cell_volume"))
        return {"electric_energy": float(we), "magnetic_energy": float(wm)}

    def diagnostics(self) -> dict[str, float]:
        """The field energy's parts (J/m in 2D) and the largest |Ez| (V/m)."""
        d = self.energy()
        d["ez_max"] = float(np.abs(self.electric.numpy("ez")).max())
        return d

    def describe(self) -> dict:
        """The run for ``summary.json``: the model, the largest stable step, the sources and the distributed layout."""
        d = self.model.describe()
        d.update(dt_max=self._dt_max, distribution=self.distribution, sources=[{"particles": int(s.index.size), "kind": s.source.kind,
                                                "frequency": s.source.waveform.frequency} for s in self.sources])
        d.update(self.spread.describe())
        return d
