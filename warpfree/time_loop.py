"""The time loop: steps, probes, the output schedule and checkpoints of a time-dependent solver.

Time step, as the solver's :class:`~warpfree.solver.StepRule` says: ``variable``, the solver's stable step
(``stable_dt()``; ``math.inf`` means no limit, and then a fixed ``dt`` is required) or a fixed ``dt`` the run asks for
that must stay within it (else the run stops naming ``dt``), shortened only to land exactly on output times and the
end; ``constant``, one step for the whole run, the solver's limit (or the run's ``dt``, within it), never shortened:
each output falls at the first step at or after its time (as Meep's ``at_every``), which the output records, and the
run ends at the first step at or after ``t_end``, so output intervals never constrain the step; ``fixed``, the
solver's own step, the output interval and end time whole multiples of it. :attr:`TimeLoop.step_size` is the constant
or fixed step.

After every step the loop samples the sensors that are due (``warpfree.sensors``: each on its own interval, never
shortening a step). At every output time it records the probes and the solver's diagnostics, hands the output sets
to the writer and keeps a copy of the state (the last good state, written as a checkpoint if the run
goes wrong later). Every ``checkpoint_every`` steps it writes a checkpoint (``warpfree.io.checkpoint``);
``run(..., resume=True)`` continues from the newest one and reproduces the uninterrupted run bitwise.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable
from typing import ClassVar

import numpy as np

from .errors import ParameterError, RunError, RunInterrupted, require_integer, require_positive
from .io import checkpoint
from .run import Analysis, OutputOptions, Run, RunDirectory
from .sensors import Sensor, append_csv, due_time, write_csv
from .solver import StepKind, TimeDependentSolver

__all__ = ["TimeLoop", "Probe"]

#: probe: name -> function(solver, time) -> float, recorded at every output time
Probe = Callable[[TimeDependentSolver, float], float]


class TimeLoop(Run):
    """Runs a time-dependent solver from t = 0 to ``t_end``, with outputs every ``output_interval`` seconds.

    Parameters (besides those of :class:`~warpfree.run.Run`)
    ----------
    t_end, output_interval: seconds (> 0).
    probes: name -> ``f(solver, t)``, recorded at every output time into ``series`` and the summary.
    sensors: :class:`~warpfree.sensors.Sensor` s, each sampled on its own interval (:meth:`add_sensor`).
    dt: a fixed step (s) instead of the stable one (variable and constant rules); refused if above the stable limit;
        a solver with a fixed step of its own takes none.
    checkpoint_every: write a checkpoint every K steps (0: none; the two newest are kept).
    max_steps: stop after this many steps of this call to :meth:`run` (an interrupted run, for tests).
    """

    kind: ClassVar[str] = "time-dependent"
    stoppable: ClassVar[bool] = True

    def __init__(self, solver: TimeDependentSolver, t_end: float, output_interval: float, name: str = "run",
                 params: dict | None = None, probes: dict[str, Probe] | None = None,
                 analyses: list[Analysis] | None = None, dt: float | None = None, checkpoint_every: int = 0,
                 output: OutputOptions | None = None, max_steps: int | None = None,
                 reported_as: dict[str, str] | None = None, sensors: list[Sensor] | None = None):
        if not isinstance(solver, TimeDependentSolver):
            raise ParameterError("solver", f"a TimeLoop needs a TimeDependentSolver, got {type(solver).__name__}")
        super().__init__(solver, name, params, analyses, output, reported_as)
        self.t_end = require_positive("t_end", t_end)
        self.output_interval = require_positive("output_interval", output_interval)
        self.checkpoint_every = checkpoint_every
        self.probes = dict(probes or {})
        self.max_steps = max_steps
        self.time = 0.0
        self.step_count = 0
        self.steps_this_run = 0
        self.n_outputs = 0
        self.series: dict[str, list[float]] = {"time": [], **{k: [] for k in self.probes}}
        self.diag_series: dict[str, list[float]] = {}
        self.sensors: dict[str, Sensor] = {}
        #: each sensor's rows: (time, value per column), float64
        self.sensor_rows: dict[str, list[np.ndarray]] = {}
        self._sensor_columns: dict[str, list[tuple[str, str]]] = {}
        self._sensor_written: dict[str, int] = {}  # rows of each sensor's file this process has written
        self.step_s = 0.0
        self.last_checkpoint: str | None = None
        self._good = None                  # (loop scalars, state copies, series lengths) at the last output
        self._checkpoint_step = -1
        self.skipped_checkpoints: list[str] = []  # damaged checkpoints a resume passed over
        self.rule = solver.step_rule()
        self.dt_fixed = self._chosen_step(None if dt is None else require_positive("dt", dt))
        if self.dt_fixed is not None:
            solver.use_step(self.dt_fixed)
        for sensor in sensors or ():
            self.add_sensor(sensor)

    def add_sensor(self, sensor: Sensor) -> None:
        """Sample ``sensor`` on its interval from the start (or from a resumed run's time: its rows so far come back
        with the checkpoint); the solver is checked against it now. A name taken: ParameterError naming ``sensor``."""
        if not isinstance(sensor, Sensor):
            raise ParameterError("sensor", f"a warpfree.sensors.Sensor, got {type(sensor).__name__}")
        if sensor.name in self.sensors:
            raise ParameterError("sensor", f"two sensors are named {sensor.name!r}")
        sensor.check(self.solver)
        self.sensors[sensor.name] = sensor
        self.sensor_rows[sensor.name] = []
        self._sensor_columns[sensor.name] = [("time", self.solver.time_unit)] + sensor.columns(self.solver)

    def _sample_sensors(self) -> None:
        """A row for every sensor whose next sample time the loop has reached (every rank: sampling is collective)."""
        for name, sensor in self.sensors.items():
            rows = self.sensor_rows[name]
            if self.time >= due_time(sensor.interval, rows[-1][0] if rows else None) * (1 - 1e-12):
                with self.phases("sensors"):
                    rows.append(np.concatenate([[self.time], sensor.sample(self.solver)]).astype(np.float64))

    def write_sensors(self, directory: RunDirectory | None) -> None:
        """Every sensor's rows so far as ``sensors/<name>.csv`` (the first rank)."""
        if directory is None or not self.world.is_root or not self.sensors:
            return
        with self.phases("output"):
            for name in self.sensors:
                path, rows = self._sensor_file(directory, name), self.sensor_rows[name]
                written = self._sensor_written.get(name)
                if written is None or written > len(rows):  # this process's first write: the whole file
                    write_csv(path, self._sensor_columns[name], self._sensor_table(name))
                elif len(rows) > written:
                    append_csv(path, np.vstack(rows[written:]))
                self._sensor_written[name] = len(rows)

    @staticmethod
    def _sensor_file(directory: RunDirectory, name: str) -> str:
        return os.path.join(directory.root, "sensors", f"{name}.csv")

    def _sensor_table(self, name: str, length: int | None = None) -> np.ndarray:
        rows = self.sensor_rows[name][:length]
        width = len(self._sensor_columns[name])
        return np.vstack(rows) if rows else np.zeros((0, width))

    @property
    def step_size(self) -> float | None:
        """The run's step when it has one for the whole run (a constant or fixed rule, or a fixed ``dt``); None when
        the solver's stable step is taken anew every step."""
        return self.dt_fixed

    def _chosen_step(self, dt: float | None) -> float | None:
        """The step of the whole run from the solver's rule and the run's ``dt`` (None: a new stable step each step)."""
        unit, rule = self.solver.time_unit, self.rule
        if rule.kind is StepKind.FIXED:
            if dt is not None and dt != rule.value:
                raise ParameterError("dt", f"this solver steps by its own Δt = {rule.value:.6g} {unit}, set where the "
                                           f"solver is made; a run cannot take another ({dt:.6g} {unit})")
            for name, span in (("output_interval", self.output_interval), ("t_end", self.t_end)):
                steps = span / rule.value
                if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
                    raise ParameterError(name, f"{span:.6g} {unit} is not a whole number of the solver's steps "
                                               f"Δt = {rule.value:.6g} {unit} ({steps:.6g})")
            return rule.value
        limit = self.solver.stable_dt() if rule.kind is StepKind.VARIABLE else rule.value
        if dt is None:
            if not math.isfinite(limit):
                raise ParameterError("dt", "this solver has no stable-step limit: give a fixed dt")
            if rule.kind is StepKind.CONSTANT:  # the limit itself: outputs fall at the first step at or after their time
                return limit
            return None
        if dt > limit:
            raise ParameterError("dt", f"{dt:.4g} {unit} exceeds the stable (CFL) limit {limit:.4g} {unit}")
        return dt

    @property
    def checkpoint_every(self) -> int:
        return self._checkpoint_every

    @checkpoint_every.setter
    def checkpoint_every(self, value) -> None:
        self._checkpoint_every = require_integer("checkpoint_every", value, minimum=0)

    # -- time step -------------------------------------------------------------------------------
    def _next_output_time(self) -> float:
        """The output times are 0, Δ, 2Δ, ...: the next is the first after the last output's time (a step landed on
        it, or, with a constant step, the first step at or after it: a step longer than Δ passes some by)."""
        times = self.series["time"]
        if not times:
            return 0.0
        return (math.floor(times[-1] / self.output_interval + 1e-9) + 1) * self.output_interval

    @property
    def _lands(self) -> bool:
        """Whether steps are shortened to land on output times and the end (not with a constant step, which a
        staggered leapfrog needs unbroken)."""
        return self.rule.kind is not StepKind.CONSTANT

    # -- outputs and the last good state ------------------------------------------------------------
    def _record(self, directory: RunDirectory | None) -> None:
        """Audit, probes, diagnostics and outputs at the current time; keep the state as the last good one."""
        with self.phases("audit"):
            problem = self.solver.audit()
        if problem:
            raise RunError(problem, self.step_count)
        index = self.n_outputs
        self.n_outputs += 1
        with self.phases("output"):
            self.series["time"].append(self.time)
            for name, probe in self.probes.items():
                self.series[name].append(float(probe(self.solver, self.time)))
            for k, v in self.solver.diagnostics().items():
                self.diag_series.setdefault(k, []).append(float(v))
        if directory is not None:
            self.write_sensors(directory)
            with self.phases("output"):
                state, lengths = self.solver.state.numpy(), self._series_lengths()
            try:
                self.write_outputs(directory, index, self.step_count, self.time, self.frame_title())
            finally:  # the loop's scalars once the frames have fixed their scales (a write that failed: all the same)
                self._good = (self._loop_scalars(), state, lengths)

    def frame_title(self) -> str:
        """The title of the frames written now: the scene and the time in the solver's time unit, with the SI prefix
        the progress bar shows it in (an EM run's ns: ``t = 0.82 ns``)."""
        from .progress import time_scale

        factor, unit = time_scale(self.t_end, self.solver.time_unit)
        return f"{self.name}  t = {self.time / factor:.4g} {unit}"

    def _loop_scalars(self) -> dict:
        """The loop's own state a checkpoint keeps (JSON): time, step, outputs written, and what the frames fixed
        from the first ones (their extent, each series' colour range and disc size), so that a resumed run draws its
        frames as the uninterrupted one does."""
        frames = {"bounds": self._bounds, "scales": self._frame_scales}
        return {"time": self.time, "step": self.step_count, "n_outputs": self.n_outputs,
                "frames": json.loads(json.dumps(frames))}

    def _series_lengths(self) -> dict[str, int]:
        return {**{f"probe:{k}": len(v) for k, v in self.series.items()},
                **{f"diagnostic:{k}": len(v) for k, v in self.diag_series.items()},
                **{f"sensor:{k}": len(v) for k, v in self.sensor_rows.items()}}

    def _series_arrays(self, lengths: dict[str, int] | None = None) -> dict[str, np.ndarray]:
        """The series as float64 arrays (cut to ``lengths``: the series are append-only, so a kept
        state needs only their lengths, never a copy)."""
        out = {}
        for prefix, series in (("probe:", self.series), ("diagnostic:", self.diag_series)):
            for k, v in series.items():
                n = len(v) if lengths is None else lengths.get(prefix + k, 0)
                out[prefix + k] = np.asarray(v[:n], dtype=np.float64)
        for k in self.sensor_rows:
            out["sensor:" + k] = self._sensor_table(k, None if lengths is None else lengths.get("sensor:" + k, 0))
        return out

    def save_checkpoint(self, directory: RunDirectory) -> str:
        """Write the current state, loop scalars and series as a checkpoint, once every output handed to the writer
        so far is on disk: a resume takes every output up to its checkpoint as written, so a kill right after the
        checkpoint must find them there."""
        with self.phases("output"):
            self._writer.finish()
        with self.phases("checkpoint"):
            self.last_checkpoint = checkpoint.save(directory.checkpoints, self.step_count, self._loop_scalars(),
                                                   self._series_arrays(), self.solver.state.numpy(),
                                                   piece=self._piece)
            self._checkpoint_step = self.step_count
        return self.last_checkpoint

    @property
    def _piece(self) -> str | None:
        """This rank's checkpoint suffix in a distributed run (None in one process)."""
        w = self.world
        return checkpoint.piece_name(w.rank, w.size) if w.distributed else None

    def _keep_last_step(self, directory: RunDirectory | None) -> str | None:
        """A run stopped on request: its current state (the last completed step) as a checkpoint, unless one of
        this step exists; the checkpoint's path (None for a run in memory)."""
        if directory is None:
            return None
        if self._checkpoint_step != self.step_count:
            self.save_checkpoint(directory)
        return self.last_checkpoint

    def _keep_last_good(self, directory: RunDirectory | None, err: RunError) -> RunError:
        """Write the state of the last output as a checkpoint when none newer exists; name it in the error."""
        if directory is not None and self._good is not None and self._good[0]["step"] > self._checkpoint_step:
            loop, state, lengths = self._good
            with self.phases("checkpoint"):
                self.last_checkpoint = checkpoint.save(directory.checkpoints, loop["step"], loop,
                                                       self._series_arrays(lengths), state, piece=self._piece)
        if self.last_checkpoint and not err.last_good:
            err = RunError(err.message, err.step, self.last_checkpoint)
        return err

    def load_checkpoint(self, path: str) -> None:
        loop, series, state = checkpoint.load(path)
        self.solver.load_state(state, f"checkpoint {path}")
        self._take_loop(loop, series, path)

    def _take_loop(self, loop: dict, series: dict, path: str) -> None:
        """The loop's scalars and series from a checkpoint."""
        self.time = float(loop["time"])
        self.step_count = int(loop["step"])
        self.n_outputs = int(loop["n_outputs"])
        frames = loop.get("frames", {})
        bounds = frames.get("bounds")
        self._bounds = tuple(tuple(axis) for axis in bounds) if bounds else None
        self._frame_scales = {name: {k: tuple(v) if isinstance(v, list) else v for k, v in scale.items()}
                              for name, scale in frames.get("scales", {}).items()}
        self.series = {k[len("probe:"):]: v.tolist() for k, v in series.items() if k.startswith("probe:")}
        for k in self.probes:
            self.series.setdefault(k, [])
        self.diag_series = {k[len("diagnostic:"):]: v.tolist() for k, v in series.items()
                            if k.startswith("diagnostic:")}
        self._sensor_written = {}  # the files are written whole again
        for k in self.sensors:  # a sensor the checkpointed run had not starts now
            kept = series.get("sensor:" + k)
            width = len(self._sensor_columns[k])
            ok = kept is not None and kept.ndim == 2 and kept.shape[1] == width
            self.sensor_rows[k] = [np.array(row, dtype=np.float64) for row in kept] if ok else []
        self.last_checkpoint = path
        self._checkpoint_step = self.step_count

    def _resume(self, directory: RunDirectory) -> None:
        """Load the newest checkpoint that reads back and fits this scene; a damaged newer one (a write cut
        short by a crash, a foreign file) is skipped, with a line on stderr and in the summary. In a distributed run
        every rank loads its own piece of the newest step all ranks can load; a checkpoint of another number of
        processes is spread anew (:meth:`_resume_spread`)."""
        skipped = []
        paths = checkpoint.newest_first(directory.checkpoints, self._piece)
        if (not paths or self.world.distributed) and self._resume_spread(directory):
            return  # written by another number of processes, or by moving particles whose layout the pieces carry
        if self.world.distributed:
            every = self.world.comm.allgather([checkpoint.step_of(q) for q in paths])
            common = set(every[0]).intersection(*map(set, every[1:]))
            paths = [q for q in paths if checkpoint.step_of(q) in common]
        for path in paths:
            try:
                self.load_checkpoint(path)
                problem = None
            except ParameterError as exc:
                problem = f"{os.path.basename(path)} ({str(exc).removeprefix('resume: ')})"
            problem = self.world.first_message(problem)
            if problem:
                skipped.append(problem)
                continue
            if skipped and self.world.is_root:
                print(f"warpfree: resuming from {os.path.basename(path)}; skipped the newer {'; '.join(skipped)}",
                      file=sys.stderr)
            self.skipped_checkpoints = skipped
            return
        if not skipped:
            raise ParameterError("resume", f"no checkpoint in {directory.checkpoints}")
        raise ParameterError("resume", f"no usable checkpoint in {directory.checkpoints}: {'; '.join(skipped)}")

    def _resume_spread(self, directory: RunDirectory) -> bool:
        """Resume from the newest complete checkpoint of another rank count (or of one process): every rank reads
        every piece and the solver takes the whole state from them (``restore_pieces``). False when there is none."""
        sets = checkpoint.piece_sets(directory.checkpoints)
        candidates = [(step, paths) for steps in sets.values() for step, paths in steps.items()]
        serial = checkpoint.newest_first(directory.checkpoints) if self.world.distributed else []
        candidates += [(checkpoint.step_of(q), [q]) for q in serial]
        if not candidates:
            return False
        step, paths = max(candidates, key=lambda c: c[0])
        pieces = [checkpoint.load(q) for q in paths]
        loop, series, _ = pieces[0]
        self.solver.restore_pieces([state for _, _, state in pieces])
        self.solver.clock.invalidate()
        self._take_loop(loop, series, paths[0])
        if self.world.is_root:
            print(f"warpfree: resuming from step {step} written by {len(paths)} process(es), on {self.world.size}",
                  file=sys.stderr)
        return True

    # -- the loop ----------------------------------------------------------------------------------
    def _execute(self, directory: RunDirectory | None, resume: bool, progress: bool) -> None:
        self._good = None
        self._sensor_written = {}
        self._checkpoint_step = -1
        self.last_checkpoint = None
        self._resumed_time = None
        if resume:
            self._resume(directory)
            self._resumed_time = self.time
        else:
            self._sample_sensors()
            self._record(directory)
            if directory is not None and self.checkpoint_every:
                self.save_checkpoint(directory)
        clock = self.solver.clock
        self._start_clock(clock)
        host_limit = self.rule.kind is StepKind.VARIABLE and not self.solver.limit_on_device
        bar = _progress(self.t_end, self.time, progress and self.world.is_root, self.name, self.solver.time_unit)
        steps0 = self.step_count
        try:
            while self.time < self.t_end * (1 - 1e-12):
                if self.max_steps is not None and self.step_count - steps0 >= self.max_steps:
                    break
                if host_limit:  # a variable step whose limit the solver computes on the host
                    limit = self.solver.stable_dt()
                    if clock.limit != limit:
                        clock.set(limit=limit)
                refused = clock.problem(self.solver.time_unit)  # the step the clock chose (the last report's)
                if refused:
                    raise RunError(refused, self.step_count)
                t0 = time.perf_counter()
                self.solver.advance()  # the step the clock chose, taken; its report is the step's one read-back
                problem = self.solver.problem()
                self.step_s += time.perf_counter() - t0
                self.step_count += 1
                self.steps_this_run = self.step_count - steps0
                target = self._next_output_time()
                self.time = clock.time
                if problem:
                    raise RunError(problem, self.step_count)
                self._sample_sensors()
                if self.time >= target * (1 - 1e-12) or self.time >= self.t_end * (1 - 1e-12):
                    self._record(directory)
                    if self._lands:
                        clock.set(next_output=self._next_output_time())
                if directory is not None and self.checkpoint_every and self.step_count % self.checkpoint_every == 0:
                    self.save_checkpoint(directory)
                if bar is not None:
                    bar.update(self.time)
                self._stop_if_asked()
            self._stop_if_asked()  # asked during the last step: the analyses wait for the resume
        finally:
            if bar is not None:
                bar.close()

    def _stop_if_asked(self) -> None:
        """After a step: stop, every rank alike, when Ctrl-C or SIGTERM asked to (:mod:`warpfree.stop`)."""
        signum = self._stop.agreed() if self._stop is not None else None
        if signum:
            raise RunInterrupted(signum, self.step_count, self.time)

    def _start_clock(self, clock) -> None:
        """Set up the solver's clock (``warpfree.clock``): the time, the next output time, the end, the run's fixed step
        and, for a constant or fixed rule, the limit it is checked against (a variable rule's limit is the solver's,
        every step: computed on the device, or given by its ``advance``)."""
        landing = dict(next_output=self._next_output_time(), end=self.t_end) if self._lands else \
            dict(next_output=math.inf, end=math.inf)
        slots = dict(time=self.time, fixed=self.dt_fixed or 0.0, **landing)
        if self.rule.kind is not StepKind.VARIABLE:
            slots["limit"] = self.rule.value
        clock.set(**slots)

    def _current_step(self) -> int | None:
        return self.step_count

    @property
    def complete(self) -> bool:
        return self.time >= self.t_end * (1 - 1e-12)

    # -- summary -------------------------------------------------------------------------------------
    def _throughput(self) -> dict:
        n = self.solver.work_items
        rate = n * self.steps_this_run / self.step_s if self.step_s > 0 else None
        return {"unit": f"{self.solver.work_unit}/s", "value": rate, "work_items": n}

    def _summary_fields(self, error: str | None) -> dict:
        out = {"time": self.time, "time_unit": self.solver.time_unit, "t_end": self.t_end, "steps": self.step_count,
               "steps_this_run": self.steps_this_run, "probes": self.series, "diagnostic_series": self.diag_series}
        if not self._lands:  # the step of a constant rule: the run ends at the first step at or after t_end
            out["constant_step"] = self.step_size
        if self.last_checkpoint:
            out["last_good_checkpoint" if error else "last_checkpoint"] = self.last_checkpoint
        if self.skipped_checkpoints:
            out["skipped_checkpoints"] = self.skipped_checkpoints
        if self.sensors:
            out["sensors"] = {name: {**sensor.describe(), "file": f"sensors/{name}.csv",
                                     "columns": [f"{c} [{u}]" if u else c for c, u in self._sensor_columns[name]],
                                     "samples": len(self.sensor_rows[name])}
                              for name, sensor in self.sensors.items()}
        return out

    def _write_summary(self, directory: RunDirectory | None, summary: dict) -> None:
        """The sensors' files, then the summary (whatever ended the run)."""
        self.write_sensors(directory)
        super()._write_summary(directory, summary)

    def _phases(self) -> dict[str, float]:
        return {"step": self.step_s, **super()._phases()}


def _progress(total: float, start: float, enabled: bool, name: str, time_unit: str = "s") -> "_Bar | None":
    """The progress bar in simulated time, in the solver's time unit (seconds with an SI prefix: an EM run of
    4.75e-9 s reads ns; PIC: /ω_pe)."""
    return _Bar(total, start, name, time_unit) if enabled else None


class _Bar:
    """A tqdm bar over simulated time ``t`` in ``[0, t_end]``, shown as ``t=<t>/<t_end> <unit>`` with the wall time
    elapsed and left. The bar is set to the loop's time (clamped to the end), never advanced by differences: sums of
    steps rounded past ``t_end`` made tqdm clamp its fraction (``TqdmWarning``) and show a negative time left."""

    def __init__(self, t_end: float, start: float, name: str, time_unit: str):
        from tqdm import tqdm

        from .progress import time_scale

        self.scale, unit = time_scale(t_end, time_unit)
        self.total = t_end / self.scale
        self.bar = tqdm(total=self.total, initial=self._shown(start), desc=name, unit=f"{unit}(sim)", miniters=0,
                        mininterval=0.5 if sys.stderr.isatty() else 10.0,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| t={n:.4g}/{total:.4g} " + unit
                        + " [{elapsed}<{remaining}]")

    def _shown(self, t: float) -> float:
        return min(max(t / self.scale, 0.0), self.total)

    def update(self, t: float) -> None:
        """Show simulated time ``t`` (tqdm redraws at most every ``mininterval`` seconds)."""
        self.bar.n = self._shown(t)
        self.bar.update(0)

    def close(self) -> None:
        self.bar.close()
