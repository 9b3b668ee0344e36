"""The solver contract: the only thing the run shell and the time loop know about a solver.

A solver is a static **model** (parameters, materials, neighbour structures, factorised matrices: an
object another solver may hold), a **state** (the arrays that change; by construction exactly what a
checkpoint saves), and the launches that advance or solve them. Two kinds:

- :class:`TimeDependentSolver`: ``advance()`` (one step of the Δt its clock holds, the clock moved on),
  ``stable_dt()`` (``math.inf``: no limit) and ``step_rule()``, how the time loop may choose the step
  (:class:`StepRule`: a new stable step every step, one constant step below a limit, or the solver's own fixed step),
  run by :class:`warpfree.time_loop.TimeLoop`; the clock (:class:`warpfree.clock.DeviceClock`) is the base class's.
- :class:`StaticSolver`: ``solve()``, run once by :class:`warpfree.run.StaticRun`, with the same run
  directory, summary, outputs and errors and no time loop.

Both declare what to write (:meth:`Solver.output_sets`, :meth:`Solver.output_meshes`), what to report
(:meth:`Solver.diagnostics`, :meth:`Solver.describe`), their dimension and their work: ``work_items``
counted in ``work_unit`` (particle-steps, Gauss points, particle pushes), from which the summary
gives a throughput. Timed phases go to :attr:`Solver.phases`.
"""

from __future__ import annotations

import math
import os
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import warp as wp

from .clock import DeviceClock
from .device import Launcher
from .errors import ParameterError
from .parallel.world import world
from .parameters import Choice

__all__ = ["State", "HostTable", "OutputSet", "PhaseTimes", "Solver", "StepRule", "StepKind", "TimeDependentSolver", "StaticSolver"]


class HostTable:
    """An append-only table of host numbers a state keeps (a solver's per-step history): named ``columns``, one row
    per :meth:`append`; checkpointed as a (rows, columns) float64 array and restored from one."""

    def __init__(self, columns: list[str] | tuple[str, ...]):
        self.columns = list(columns)
        self._data = {k: [] for k in self.columns}

    def append(self, row: dict[str, float]) -> None:
        """Add one row (every column's value, ``row``'s keys being :attr:`columns`)."""
        if set(row) != set(self.columns):
            raise ValueError(f"a row of this table has the columns {self.columns}, got {sorted(row)}")
        for k in self.columns:
            self._data[k].append(row[k])

    def column(self, name: str) -> list[float]:
        return self._data[name]

    def as_dict(self) -> dict[str, list[float]]:
        """Column name -> its values (the lists themselves: append-only, never to be changed by the caller)."""
        return self._data

    def __len__(self) -> int:
        return len(self._data[self.columns[0]]) if self.columns else 0

    def to_array(self) -> np.ndarray:
        if not len(self):
            return np.zeros((0, len(self.columns)))
        return np.array([self._data[k] for k in self.columns], dtype=np.float64).T.copy()

    def restore(self, table: np.ndarray) -> None:
        self._data = {k: table[:, j].tolist() for j, k in enumerate(self.columns)}


#: host values a :class:`State` checkpoints besides its arrays
_HOST_SCALARS = (int, float, np.integer, np.floating)


class State:
    """What a solver changes in time: exactly what a checkpoint saves and restores.

    Set attributes on it (in ``__init__`` of a subclass, or on an instance): ``wp.array`` s (the device state) and
    host values (Python or NumPy numbers, NumPy arrays, :class:`HostTable` s: a step count, a running sum, a per-step
    history); :meth:`arrays` and :meth:`host_values` walk them in the order they were set. Attributes whose names
    start with ``_`` and values of other types are not state. Name them as the outputs do (``position``,
    ``velocity``, ``density``): one name per quantity in the API, the kernels, the checkpoints and the VTU files.
    """

    def arrays(self) -> dict[str, wp.array]:
        return {k: v for k, v in vars(self).items() if isinstance(v, wp.array) and not k.startswith("_")}

    def host_values(self) -> dict:
        return {k: v for k, v in vars(self).items() if not k.startswith("_") and not isinstance(v, bool)
                and isinstance(v, (*_HOST_SCALARS, np.ndarray, HostTable))}

    def numpy(self) -> dict[str, np.ndarray]:
        """Copies of every array and host value (a checkpoint's content)."""
        out = {k: v.numpy().copy() for k, v in self.arrays().items()}
        for k, v in self.host_values().items():
            out[k] = v.to_array() if isinstance(v, HostTable) else np.array(v, copy=True)
        return out

    def assign(self, values: dict[str, np.ndarray], source: str = "checkpoint") -> None:
        """Overwrite every array and host value from ``values``; names, shapes and dtypes must match (else
        ParameterError naming ``resume``: the checkpoint is of another scene or resolution)."""
        arrays, host = self.arrays(), self.host_values()
        missing = sorted((set(arrays) | set(host)) - set(values))
        if missing:
            raise ParameterError("resume", f"{source} does not match this scene: it lacks {missing}")
        current = {k: a.numpy() for k, a in arrays.items()}
        current.update({k: (v.to_array() if isinstance(v, HostTable) else np.asarray(v)) for k, v in host.items()})
        for k, ref in current.items():
            v = np.asarray(values[k])
            table = isinstance(host.get(k), HostTable)
            same = (v.ndim == 2 and v.shape[1] == ref.shape[1]) if table else v.shape == ref.shape
            if not same or v.dtype != ref.dtype:
                raise ParameterError("resume", f"{source} does not match this scene: {k!r} has shape {v.shape} "
                                               f"{v.dtype}, this scene needs {ref.shape} {ref.dtype}")
        for k, arr in arrays.items():
            arr.assign(np.asarray(values[k]))
        for k, old in host.items():
            v = np.asarray(values[k])
            if isinstance(old, HostTable):
                old.restore(v)
            elif isinstance(old, np.ndarray):
                setattr(self, k, v.copy())
            else:
                setattr(self, k, type(old)(v[()]))


@dataclass
class OutputSet:
    """One particle (or node) set to write: (N, 3) ``points`` and per-point ``fields`` (NumPy copies).

    ``frame_field`` names the field frames colour this set by; ``None`` draws it as context in the frames of another
    set: faint grey (container walls), or, with ``solid``, opaque in a colour of its own and hiding what is behind it
    (an obstacle); ``backdrop=False`` leaves it out of other sets' frames (a field solve's nodes). The first set with a
    ``frame_field`` is the one frames show by default. ``ids``: in a distributed run, the rows are this rank's own part
    of the set and ``ids`` their indices in the whole set (None: the whole set, in order).

    ``units``: the unit of each quantity, by name: ``"position"`` (the points) and each field (``"Pa"``, ``"m/s"``;
    ``"1"`` for a dimensionless one; a normalised unit such as ``"λ_D"``): frames label their axes and colour bars with
    them, VTU files and ``summary.json`` record them. A quantity without an entry is written without a unit.
    """

    name: str
    points: np.ndarray
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    frame_field: str | None = None
    solid: bool = False
    ids: np.ndarray | None = None
    units: dict[str, str] = field(default_factory=dict)
    backdrop: bool = True


class PhaseTimes:
    """Wall seconds per named phase, accumulated: ``with solver.phases("assembly"): ...``.

    On the CPU, launches are synchronous and a phase's time is its work. On a GPU, launches only
    enqueue; set ``WARPFREE_PROFILE=1`` to synchronise at the end of every phase (slower, but each
    phase then holds its own kernel time) — otherwise the step's one read-back absorbs the GPU time.
    """

    def __init__(self, launcher: Launcher | None = None):
        profile = os.environ.get("WARPFREE_PROFILE", "0") not in ("", "0")
        self._sync: Callable[[], None] | None = (launcher.synchronize if launcher is not None and profile
                                                 and not launcher.is_cpu else None)
        self.seconds: dict[str, float] = {}

    @contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            if self._sync is not None:
                self._sync()
            self.add(name, time.perf_counter() - t0)

    def add(self, name: str, seconds: float) -> None:
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds

    def as_dict(self) -> dict[str, float]:
        return dict(self.seconds)


@dataclass(frozen=True)
class StepRule:
    """How the time loop chooses a solver's time step; the solver declares it (:meth:`TimeDependentSolver.step_rule`).

    - ``variable``: a new step every step, the solver's :meth:`~TimeDependentSolver.stable_dt` at the current state
      (WCSPH's CFL step); a run may ask for a fixed step instead, checked against the stable one every step.
    - ``constant`` (``value``: the largest stable step): that step for the whole run, never shortened (a staggered
      leapfrog keeps its order only with a constant step: SPEM); outputs fall at the first step at or after their
      times.
    - ``fixed`` (``value``: the step): exactly the solver's own step, set on the solver (PIC: the velocities live at
      half steps of its Δt, and ω_p Δt is physics the scene chooses); output interval and end time must be whole
      multiples of it.
    """

    kind: "StepKind"
    value: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "kind", StepKind.of("StepRule.kind", self.kind))

    @classmethod
    def variable(cls) -> "StepRule":
        return cls(StepKind.VARIABLE)

    @classmethod
    def constant(cls, limit: float) -> "StepRule":
        return cls(StepKind.CONSTANT, float(limit))

    @classmethod
    def fixed(cls, step: float) -> "StepRule":
        return cls(StepKind.FIXED, float(step))


class StepKind(Choice):
    """How a solver's time step is chosen (:class:`StepRule`)."""

    VARIABLE = "variable", "the solver's stable step at the current state, anew every step"
    CONSTANT = "constant", "one step for the whole run, the largest stable one; outputs at the first step at or after"
    FIXED = "fixed", "the solver's own step, set where the solver is made"


class Solver(ABC):
    """What every solver provides. Subclass :class:`TimeDependentSolver` or :class:`StaticSolver`.

    Class attributes: ``name`` (the method family, e.g. "wcsph"), ``work_unit`` (what
    :attr:`work_items` counts, e.g. "particle-steps" for a time-dependent solver, "Gauss points" for a
    static one) and ``distributes`` (whether it splits its work over the ranks of an ``mpiexec`` run: its
    partitions, ghost refreshes and global reductions; a run of a solver that does not is refused on several ranks). Instance attributes set by :meth:`__init__`: ``model``, ``launcher``, ``phases``.
    """

    name: ClassVar[str] = "solver"
    work_unit: ClassVar[str] = "items"
    distributes: ClassVar[bool] = False

    def __init__(self, model, launcher: Launcher):
        self.model = model
        self.launcher = launcher
        self.phases = PhaseTimes(launcher)

    @property
    @abstractmethod
    def dim(self) -> int:
        """Spatial dimension (1, 2 or 3)."""

    @property
    @abstractmethod
    def work_items(self) -> int:
        """Work per step (time-dependent) or per solve (static), in :attr:`work_unit`."""

    @abstractmethod
    def output_sets(self) -> list[OutputSet]:
        """The sets to write now (VTU files, frames), as NumPy copies."""

    def output_fields(self) -> dict[str, list[str]]:
        """Set name -> field names (for checking a scene's output options before the run)."""
        return {s.name: list(s.fields) for s in self.output_sets()}

    def output_meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Name -> (vertices (V, 3), triangles (F, 3)) to write as PLY (e.g. a free surface). None by default."""
        return {}

    def output_tables(self) -> dict[str, tuple[list[tuple[str, str]], np.ndarray]]:
        """Path (in the run directory, without ``.csv``) -> (columns as (name, unit), rows): tables written whole at
        every output, e.g. monitors' running transforms. Called on every rank (collective); the first writes. None by
        default."""
        return {}

    def diagnostics(self) -> dict[str, float]:
        """Scalars recorded at every output (energies, mass, extremes)."""
        return {}

    @abstractmethod
    def describe(self) -> dict:
        """Parameters and counts of the model, for ``summary.json``."""


class TimeDependentSolver(Solver):
    """A solver advanced in time by :class:`warpfree.time_loop.TimeLoop`.

    ``state`` (a :class:`State`) holds every array that changes; a checkpoint saves it and
    :meth:`after_load` rebuilds whatever derives from it, so that a resumed run continues bitwise.
    """

    work_unit: ClassVar[str] = "particle-steps"
    #: the unit of the solver's time, as frames, messages and the CLI print it (SI seconds unless the solver works in
    #: normalised units, e.g. PIC's 1/ω_pe)
    time_unit: ClassVar[str] = "s"
    state: State
    #: slots after the clock's own that the solver's step report fills (:class:`warpfree.clock.DeviceClock`)
    report_slots: ClassVar[int] = 0
    #: True when the solver computes its stable step on the device and writes it to the clock (its step's last
    #: launch: WCSPH's ``finish_step``); False: a variable rule's limit is :meth:`stable_dt`, which the time loop gives
    #: the clock when it changes
    limit_on_device: ClassVar[bool] = False

    def __init__(self, model, launcher: Launcher, report_slots: int | None = None):
        super().__init__(model, launcher)
        #: the run's time (:class:`warpfree.clock.DeviceClock`, with ``report_slots`` of the solver's own, default
        #: :attr:`report_slots`): t, Δt and the landing times, on the device. The time loop sets its landing times and
        #: reads its report once per step; a solver whose step must continue bitwise from a checkpoint's clock keeps
        #: ``clock.values`` in its state.
        self.clock = DeviceClock(launcher, self.report_slots if report_slots is None else report_slots)

    @abstractmethod
    def advance(self) -> None:
        """One step of the Δt the :attr:`clock` holds (``clock.step``, read on the host or by the kernels on the
        device), ending with the time moved on and the next step chosen (``clock.launch_advance_and_choose()``, or a
        kernel of the solver's own that does both): what the time loop calls."""

    def step(self, dt: float) -> None:
        """One step of ``dt`` (scripts, tests, settling): Δt written to the clock (no landing time), then
        :meth:`advance`."""
        self.clock.set_step(dt)
        self.advance()

    def record_step(self):
        """A :class:`warpfree.graph.StepGraph` that replays :meth:`advance` as recorded Warp graphs. None: the
        solver's step cannot be recorded. Called through :meth:`step_graph`, which records no step of several ranks."""
        return None

    def step_graph(self):
        """:meth:`record_step`'s graphs, or None in a run of several ranks: there a step's ghosts and migrations go
        through MPI on the host between its launches, which a recorded graph cannot replay."""
        return None if world().distributed else self.record_step()

    @abstractmethod
    def stable_dt(self) -> float:
        """The largest stable step at the current state (s); ``math.inf`` when nothing limits it."""

    def step_rule(self) -> StepRule:
        """How the time loop chooses the step (:class:`StepRule`); by default a new stable step every step."""
        return StepRule.variable()

    def use_step(self, dt: float) -> None:
        """The step the run takes throughout (a constant or fixed rule, or a fixed ``dt``), told by the time loop once
        before its first record; for diagnostics that depend on it (a leapfrog's invariant). Default: unused."""

    def problem(self) -> str | None:
        """Checked after every step: a message when the last step left the state bad, else None."""
        return None

    def audit(self) -> str | None:
        """A costlier check run at every output time (e.g. particles inside a solid, measured against the true
        surfaces): a message stops the run, which keeps its last good state; None when all is well."""
        return None

    def after_load(self) -> None:
        """Rebuild derived structures (neighbour tables, reductions) after the state was loaded."""

    def load_state(self, values: dict, source: str) -> None:
        """Take the state of a checkpoint of this run's own layout (``values``: its arrays and host values;
        ``source``: what to name in a refusal), then :meth:`after_load`."""
        self.state.assign(values, source)
        self.clock.invalidate()  # its array may have been loaded with the state: read it anew
        self.after_load()

    def restore_pieces(self, pieces: list[dict]) -> None:
        """Take the state from a checkpoint written by any number of processes: ``pieces``, each process's state
        (rank order; one piece from one process), into this process's part (then as :meth:`after_load`). A solver that
        ``distributes`` implements it: its distributed runs resume through it on any rank count, their own included,
        as each rank's checkpoint holds the layout of the step it was written at."""
        raise ParameterError("resume", f"a {self.name} run resumes only on the number of processes that wrote its "
                                       "checkpoint")


class StaticSolver(Solver):
    """A one-off solve (EFG, NEM) run by :class:`warpfree.run.StaticRun`."""

    work_unit: ClassVar[str] = "items"

    @abstractmethod
    def solve(self) -> None:
        """Assemble and solve, timing each phase in :attr:`phases` (e.g. "assembly", "factorisation", "solve")."""
