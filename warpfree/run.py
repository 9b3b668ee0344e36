"""The run shell: what every run does, whatever advances its solver.

A scene's ``build(**params)`` returns a :class:`Run`: a :class:`~warpfree.time_loop.TimeLoop` for a
time-dependent solver or a :class:`StaticRun` for a one-off solve. The shell owns

- the run directory (:class:`RunDirectory`: every path in one place);
- ``summary.json``: parameters, model, device and threads, wall time per phase, throughput in the
  solver's unit, diagnostics, analyses, status and error;
- the outputs (VTU + PVD, PNG frames, PLY meshes), written beside the run by
  :class:`~warpfree.io.writer.OutputWriter` from NumPy copies;
- analyses (scene functions run at the end, e.g. an error against a reference), and errors: a run
  that goes wrong raises :class:`~warpfree.errors.RunError` after keeping its last good state, and
  ``summary.json`` says so.

The CLI maps :class:`~warpfree.errors.ParameterError` to exit code 2 and RunError to 3.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .errors import ParameterError, RunError, RunInterrupted, reported_as
from .io.frames import DIMENSIONLESS
from .io.writer import OutputError, OutputWriter
from .memory import solver_memory
from .parallel import world
from .solver import OutputSet, PhaseTimes, Solver, StaticSolver
from .stop import StopSignals
from .validation import validation_block

__all__ = ["OutputOptions", "RunDirectory", "Run", "StaticRun", "build_scene"]

#: analysis: function(run, out_dir) -> dict merged into summary["analysis"]; out_dir is None for a run in memory
#: (compute, draw nothing); a result's "checks" (validation.tolerance_check records) make summary["validation"]
Analysis = Callable[["Run", "str | None"], dict]


@dataclass
class OutputOptions:
    """What a run writes besides ``summary.json``.

    frame_set / frame_field: the set and field frames colour (default: the first output set with a
    ``frame_field``, and that field); a field is a scalar field of the set or a component of a vector field,
    ``<field>_x``, ``_y`` or ``_z`` (``velocity_x``); frame_bounds: the plotted extent, ``((xmin, xmax), (ymin,
    ymax)[, (zmin, zmax)])`` (default: the bounding box of the first output, 5% margin); frame_range: the colour
    range (1D: the y range) of each field frames colour by, ``{field: (vmin, vmax)}`` in the field's unit, from the
    scene's physical scale (ρ0 g H for a hydrostatic pressure, a source's amplitude): one range for the whole series;
    a field without one takes its range from the first frame whose values spread (:func:`warpfree.io.frames.
    colour_range`); meshes: write the solver's ``output_meshes()`` (e.g. free surfaces) as PLY; background: write in a
    worker process beside the run; plots: the scene's analyses draw plots through :meth:`Run.plot` (the writer loads
    Matplotlib while the run steps, as it does for frames); extra_frames: more frame series, each a (set, field)
    pair drawn alone into ``frames/<set>_<field>_NNNNN.png`` (a PIC scene's potential on its nodes beside its
    particles); units: the unit of each quantity by name (``{"position": "consistent units", ...}``), over the
    solver's (``OutputSet.units``), for a scene whose inputs are not in the solver's units.
    """

    vtk: bool = True
    frames: bool = True
    frame_set: str | None = None
    frame_field: str | None = None
    frame_bounds: tuple | None = None
    frame_range: dict | None = None
    meshes: bool = False
    background: bool = True
    plots: bool = False
    extra_frames: tuple = ()
    units: dict | None = None


class RunDirectory:
    """The layout of a run directory, in one place.

    ``summary.json``, ``run.json`` (how the CLI ran it: scene, overrides), ``<set>.pvd`` + ``vtk/``,
    ``frames/frame_NNNNN.png`` (and ``frames/<set>_<field>_NNNNN.png`` for extra series),
    ``<mesh>/<mesh>_NNNNN.ply``, ``checkpoints/``, and the scene's own plots.
    """

    def __init__(self, root: str):
        self.root = str(root)
        os.makedirs(self.root, exist_ok=True)

    @property
    def summary(self) -> str:
        return os.path.join(self.root, "summary.json")

    @property
    def checkpoints(self) -> str:
        return os.path.join(self.root, "checkpoints")

    def frame(self, index: int, series: str = "frame") -> str:
        return os.path.join(self.root, "frames", f"{series}_{index:05d}.png")

    def mesh(self, name: str, index: int) -> str:
        return os.path.join(self.root, name, f"{name}_{index:05d}.ply")

    def path(self, name: str) -> str:
        """A file of the scene's own (a plot, a table) at the top of the run directory."""
        return os.path.join(self.root, name)


class Run(ABC):
    """The shell around a solver: run directory, outputs, summary, analyses, errors.

    Parameters
    ----------
    solver: a :class:`~warpfree.solver.Solver`.
    name: the scene's name (summary, frame titles, progress bar).
    params: the scene's parameters, recorded in the summary.
    analyses: functions ``(run, out_dir) -> dict`` run at the end, merged into ``summary["analysis"]`` (``out_dir`` None:
        a run in memory, nothing drawn); their ``checks`` make ``summary["validation"]``.
    output: :class:`OutputOptions`.
    reported_as: internal name -> the scene's parameter(s) (:func:`~warpfree.errors.reported_as`), for bad input found
        only when the run starts (e.g. an MLS support too small for its basis, met when a static solve evaluates its
        shape functions): the error names what the user set.
    """

    kind: ClassVar[str] = "run"
    #: Ctrl-C and SIGTERM stop the run at the end of a step, keeping it (:mod:`warpfree.stop`); a run without steps
    #: (a static solve) is ended at once, with nothing to keep
    stoppable: ClassVar[bool] = False

    def __init__(self, solver: Solver, name: str = "run", params: dict | None = None,
                 analyses: list[Analysis] | None = None, output: OutputOptions | None = None,
                 reported_as: dict[str, str] | None = None):
        self.solver = solver
        self.reported_as = dict(reported_as or {})
        self.name = name
        self.params = dict(params or {})
        self.analyses = list(analyses or [])
        self.output = output or OutputOptions()
        self.phases = PhaseTimes()           # the shell's own: setup, output, checkpoint, analysis
        self.last_summary: dict | None = None
        self._frame_set, self._frame_field = self._frame_choice()
        self._writer: OutputWriter | None = None
        self._series: dict = {}
        self._bounds = None
        self._frame_scales: dict[str, dict] = {}  # per frame series: its fixed colour range and disc spacing
        self._resumed_time: float | None = None
        self._directory: RunDirectory | None = None
        self._stop = None  # the run's StopSignals (warpfree.stop) while it runs
        #: the ranks of the run (one process, or ``mpiexec``'s): rank 0 writes the summary, the indices, the frames
        #: and the plots; every rank its own piece of each snapshot and its checkpoints
        self.world = world()
        if self.world.distributed and not self.solver.distributes:
            raise ParameterError("ranks", f"the {self.solver.name} solver runs in one process only: start it without "
                                          f"mpiexec (this run has {self.world.size} ranks)")

    # -- outputs --------------------------------------------------------------------------------
    def _frame_choice(self) -> tuple[str | None, str | None]:
        """The set and field frames show; bad names, ranges and units are refused before the run starts."""
        ranges = _checked_frame_range(self.output.frame_range)
        _checked_units(self.output.units)
        if not self.output.frames:
            return None, None
        sets = {s.name: s for s in self.solver.output_sets()}
        name = self.output.frame_set
        if name is None:
            name = next((s.name for s in sets.values() if s.frame_field), None)
            if name is None:
                raise ParameterError("frame_set", "the solver marks no set to draw; name one or switch frames off")
        if name not in sets:
            raise ParameterError("frame_set", f"must be one of {sorted(sets)}, got {name!r}")
        field = self.output.frame_field
        if field is None:
            field = sets[name].frame_field
        if field not in drawable_fields(sets[name]):
            raise ParameterError("frame_field", f"must be one of {drawable_fields(sets[name])} for the set {name!r}, "
                                                f"got {field!r}")
        drawable = {k: drawable_fields(s) for k, s in sets.items()}
        for extra in self.output.extra_frames:
            if len(extra) != 2 or extra[0] not in sets or extra[1] not in drawable[extra[0]]:
                raise ParameterError("extra_frames", f"each must be a (set, field) pair of {drawable}, got {extra!r}")
        every = sorted({f for names in drawable.values() for f in names})
        for key in ranges:
            if key not in every:
                raise ParameterError("frame_range", f"names a field frames can colour by, one of {every}; got {key!r}")
        return name, field

    def write_outputs(self, directory: RunDirectory, index: int, step: int, time_s: float, title: str) -> None:
        """Hand the solver's output sets (and meshes) at this moment to the writer, as one batch."""
        with self.phases("output"):
            sets = self.solver.output_sets()
            batch: list[tuple[str, dict]] = []
            if self.output.vtk:
                batch += self._vtu_jobs(directory, sets, step, time_s)
            if self.output.frames:
                whole = gather_sets(self.world, sets)  # frames show every rank's particles, drawn on rank 0
                if whole is not None:
                    batch.append(self._frame_job(directory, whole, index, title))
                    for set_name, field in self.output.extra_frames:
                        batch.append(self._frame_job(directory, whole, index, title, set_name, field))
            for table, (header, rows) in self.solver.output_tables().items():
                if self.world.is_root:
                    batch.append(("call", {"function": "warpfree.sensors:write_csv",
                                           "kwargs": {"path": os.path.join(directory.root, f"{table}.csv"),
                                                      "header": header, "rows": rows}}))
            if self.output.meshes:
                for mesh_name, (vertices, faces) in self.solver.output_meshes().items():
                    if self.world.is_root:
                        batch.append(("mesh", {"path": directory.mesh(mesh_name, index), "vertices": vertices,
                                               "faces": faces}))
            self._writer.submit(batch)

    def _vtu_jobs(self, directory: RunDirectory, sets: list[OutputSet], step: int, time_s: float) -> list:
        from .io.vtk import VtuSeries

        if self.world.distributed:
            return self._piece_jobs(directory, sets, step, time_s)
        jobs = []
        for s in sets:
            if not len(s.points):  # nothing to write: a VTU without points is not readable
                continue
            if s.name not in self._series:
                self._series[s.name] = VtuSeries(directory.root, s.name, resume_after_time=self._resumed_time)
            series = self._series[s.name]
            path, entries = series.record(step, time_s)
            jobs.append(("vtu", {"path": str(path), "points": s.points, "fields": s.fields, "units": self.units(s)}))
            jobs.append(("pvd", {"path": str(series.pvd_path), "entries": entries}))
        return jobs

    def _piece_jobs(self, directory: RunDirectory, sets: list[OutputSet], step: int, time_s: float) -> list:
        """A distributed run's snapshot: each rank writes its own part of every set as a VTU piece (with the
        particles' ``global_id``); rank 0 writes the ``.pvtu`` that joins the pieces and the PVD that lists those,
        so that ParaView opens the run as one dataset. Empty pieces are not written (a VTU without points is not
        readable)."""
        from .io.vtk import VtuSeries

        jobs = []
        rank = self.world.rank
        for s in sets:
            counts = np.concatenate(self.world.allgather(np.array([len(s.points)], dtype=np.int64)))
            if not counts.sum():  # no point on any rank: no piece, no index (a series starts at its first point)
                continue
            if s.name not in self._series:  # only rank 0 writes the index, so only its series resumes one
                self._series[s.name] = VtuSeries(directory.root, s.name, extension="pvtu",
                                                 resume_after_time=self._resumed_time if self.world.is_root else None)
            series = self._series[s.name]
            fields = dict(s.fields)
            fields["global_id"] = np.asarray(s.ids, dtype=np.int64)
            units = {**self.units(s), "global_id": DIMENSIONLESS}
            if counts[rank]:
                jobs.append(("vtu", {"path": str(series.piece_for(step, rank)), "points": s.points, "fields": fields,
                                     "units": units}))
            if self.world.is_root:
                path, entries = series.record(step, time_s)
                pieces = [series.piece_for(step, r).name for r in range(self.world.size) if counts[r]]
                jobs.append(("pvtu", {"path": str(path), "pieces": pieces, "points": s.points[:0],
                                      "fields": {k: np.asarray(v)[:0] for k, v in fields.items()}, "units": units}))
                jobs.append(("pvd", {"path": str(series.pvd_path), "entries": entries}))
        return jobs

    def _frame_job(self, directory: RunDirectory, sets: list[OutputSet], index: int, title: str,
                   set_name: str | None = None, field: str | None = None):
        """The main frame (the chosen set, the others as context unless they are no ``backdrop``), or with
        ``set_name`` and ``field`` an extra series' frame (that set alone); in its series' colour range and disc
        size (:meth:`_series_scale`), labelled with the units."""
        extra = set_name is not None
        set_name, field = (set_name, field) if extra else (self._frame_set, self._frame_field)
        shown = next(s for s in sets if s.name == set_name)
        context = [] if extra else [s for s in sets if s.name != set_name and s.backdrop and len(s.points)]
        others = [s.points for s in context if not s.solid]
        solids = [s.points for s in context if s.solid]
        dim = self.solver.dim
        if self._bounds is None:
            self._bounds = self.output.frame_bounds or _bounding_box(sets, dim)
        series = f"{set_name}_{field}" if extra else "frame"
        path = directory.frame(index, series)
        values = field_values(shown, field)
        vmin, vmax, spacing = self._series_scale(series, field, shown.points[:, :dim], values)
        units = self.units(shown)
        return ("frame", {"path": path, "points": shown.points, "values": values, "dim": dim, "field_name": field,
                          "field_unit": field_unit(shown, field, units),
                          "length_unit": units.get("position"), "vmin": vmin, "vmax": vmax, "spacing": spacing,
                          "bounds": self._bounds, "boundary_points": np.vstack(others) if others else None,
                          "solid_points": np.vstack(solids) if solids else None, "title": title})

    def _series_scale(self, series: str, field: str, points: np.ndarray, values: np.ndarray
                      ) -> tuple[float, float, float | None]:
        """(vmin, vmax, disc spacing) of a frame of ``series``: the colour range the scene's ``frame_range`` gives the
        field, else the one its first frame with a spread fixes (:func:`~warpfree.io.frames.colour_range`; a frame at
        rest before it is drawn about its value), and the particle spacing the first frame with two particles or more
        fixes (its median nearest-neighbour distance; None before: the frame estimates its own)."""
        from .io.frames import colour_range, estimate_spacing

        scale = self._frame_scales.setdefault(series, {})
        if "range" in scale:
            vmin, vmax = scale["range"]
        else:
            (vmin, vmax), fixed = colour_range(values, (self.output.frame_range or {}).get(field))
            if fixed:
                scale["range"] = (vmin, vmax)
        if "spacing" not in scale and len(points) >= 2 and points.shape[1] > 1:
            spacing = estimate_spacing(points)
            if np.isfinite(spacing) and spacing > 0:
                scale["spacing"] = spacing
        return vmin, vmax, scale.get("spacing")

    def units(self, output_set: OutputSet) -> dict[str, str]:
        """The unit of each quantity of ``output_set`` (its points, ``position``, and its fields): the solver's, with
        the scene's ``OutputOptions.units`` over them."""
        units = {**output_set.units, **(self.output.units or {})}
        return {k: v for k, v in units.items() if k == "position" or k in output_set.fields}

    # -- the run --------------------------------------------------------------------------------
    def run(self, out_dir: str | None = None, resume: bool = False, progress: bool = True) -> dict:
        """Run, writing outputs under ``out_dir`` (None: in memory, nothing written). Returns the summary."""
        if resume and out_dir is None:
            raise ParameterError("resume", "needs the run directory")
        directory = RunDirectory(out_dir) if out_dir is not None else None
        self._directory = directory
        self._writer = OutputWriter(background=self.output.background and directory is not None,
                                    plots=directory is not None and (self.output.frames or self.output.plots))
        if self._writer.plots:
            self._writer.start()
        self._series, self._bounds, self._frame_scales = {}, None, {}
        wall0 = time.perf_counter()
        try:
            try:
                try:
                    with reported_as(**self.reported_as), StopSignals(self.world, self.stoppable) as self._stop:
                        self._execute(directory, resume, progress)
                    with self.phases("output"):
                        self._writer.finish()
                except OutputError as exc:
                    raise RunError(str(exc).splitlines()[0], self._current_step()) from None
            except RunInterrupted as stop:
                try:
                    self._writer.finish()  # the outputs of every completed step, then the step itself
                except OutputError as exc:
                    raise RunError(str(exc).splitlines()[0], self._current_step()) from None
                kept = self._keep_last_step(directory)
                summary = self.summary(time.perf_counter() - wall0, interrupted=stop.signum)
                self._write_summary(directory, summary)
                raise RunInterrupted(stop.signum, stop.step, stop.time, kept) from None
            except KeyboardInterrupt as stop:  # a second Ctrl-C or SIGTERM, mid-step: the last checkpoint stands
                summary = self.summary(time.perf_counter() - wall0, interrupted=getattr(stop, "signum", signal.SIGINT))
                self._write_summary(directory, summary)
                raise
            except RunError as err:
                try:
                    self._writer.finish()  # what was handed over before the failure is still written
                except OutputError:
                    pass
                err = self._keep_last_good(directory, err)
                summary = self.summary(time.perf_counter() - wall0, error=str(err))
                self._write_summary(directory, summary)
                raise err from None
            summary = self.summary(time.perf_counter() - wall0)
            analysis = {}
            with self.phases("analysis"):
                for fn in (self.analyses if self.complete else ()):  # an interrupted run is analysed when resumed
                    analysis.update(fn(self, directory.root if directory is not None else None) or {})
                try:
                    self._writer.finish()  # the plots the analyses handed over (:meth:`plot`)
                except OutputError as exc:
                    raise RunError(str(exc).splitlines()[0], self._current_step()) from None
            summary["analysis"] = analysis
            validation = validation_block(analysis)
            if validation is not None:
                summary["validation"] = validation
            summary["phases_s"] = self._phases()
            summary["total_s"] += self.phases.seconds.get("analysis", 0.0)
        finally:
            self._writer.close()
        self._write_summary(directory, summary)
        return summary

    def plot(self, function: str, **kwargs) -> None:
        """Have the output writer call ``function`` ("warpfree.<module>:<name>", e.g. a validation plot) with
        ``kwargs`` (NumPy arrays, numbers, strings), beside the run: its process has loaded Matplotlib while the
        run stepped (``OutputOptions.plots``). For a scene's analysis; the run waits for it before it ends. In a
        distributed run rank 0 draws it; a run in memory (no directory) draws nothing."""
        if self.world.is_root and self._directory is not None:
            self._writer.submit([("call", {"function": function, "kwargs": kwargs})])

    @abstractmethod
    def _execute(self, directory: RunDirectory | None, resume: bool, progress: bool) -> None:
        """Advance or solve, writing outputs through :meth:`write_outputs`."""

    def _current_step(self) -> int | None:
        return None

    @property
    def complete(self) -> bool:
        """The run has done all it was asked to (a time loop: reached its end; not stopped by ``max_steps``)."""
        return True

    def _keep_last_good(self, directory: RunDirectory | None, err: RunError) -> RunError:
        """Keep the last good state on disk (time loops: a checkpoint); returns the error to raise."""
        return err

    def _keep_last_step(self, directory: RunDirectory | None) -> str | None:
        """A run stopped on request: keep the state of its last completed step (time loops: a checkpoint); the
        path kept, or None when nothing can be kept."""
        return None

    # -- summary ----------------------------------------------------------------------------------
    def _phases(self) -> dict[str, float]:
        return {**self.phases.as_dict(), **self.solver.phases.as_dict()}

    def summary(self, wall_s: float, error: str | None = None, interrupted: int | None = None) -> dict:
        """Parameters, model, device, wall time per phase, throughput, diagnostics, status (``ok``, ``error``, or
        ``interrupted`` by the signal ``interrupted``)."""
        s = self.solver
        out = {
            "scene": self.name,
            "kind": self.kind,
            "solver": s.name,
            "params": self.params,
            "model": s.describe(),
            "device": s.launcher.device,
            "threads": s.launcher.threads,
            "wall_s": wall_s,
            "total_s": self.phases.seconds.get("setup", 0.0) + wall_s,  # set-up + run; + analysis when it is done
            "phases_s": self._phases(),
            "throughput": self._throughput(),
            "memory": solver_memory(s),
            "diagnostics": s.diagnostics(),
            "units": self._units_summary(),
            "status": "error" if error else "interrupted" if interrupted else "ok",
        }
        if interrupted:
            out["interrupted_by"] = signal.Signals(interrupted).name
        out.update(self._summary_fields(error))
        if self.world.distributed:
            out["ranks"] = self._ranks_summary(out["phases_s"])
            # every rank's bytes, and the whole run's per item (the work items count the whole set)
            out["memory"]["bytes_per_rank"] = self.world.comm.allgather(out["memory"]["bytes"])
            items = out["throughput"].get("work_items")
            total = sum(out["memory"]["bytes_per_rank"])
            out["memory"]["per_item"] = total / items if items else None
        if error:
            out["error"] = error
        self.last_summary = out
        return out

    def _units_summary(self) -> dict:
        """``summary["units"]``: the unit of the run's time (time-dependent runs) and, per output set, of each quantity
        its VTU files hold (``position``: the points)."""
        units = {"outputs": {s.name: self.units(s) for s in self.solver.output_sets()}}
        time_unit = getattr(self.solver, "time_unit", None)
        return {"time": time_unit, **units} if time_unit is not None else units

    def _ranks_summary(self, phases: dict[str, float]) -> dict:
        """A distributed run: the ranks' count and each rank's phase times (rank order), and their imbalance in the
        step (max / mean)."""
        every = self.world.comm.allgather(phases)
        step = [p.get("step", 0.0) for p in every]
        mean = sum(step) / len(step)
        return {"size": self.world.size, "phases_s": every,
                "step_imbalance": (max(step) / mean) if mean > 0 else None}

    def _summary_fields(self, error: str | None) -> dict:
        return {}

    @abstractmethod
    def _throughput(self) -> dict:
        """``{"unit": "<work unit>/s", "value": ..., "work_items": ...}``."""

    def _write_summary(self, directory: RunDirectory | None, summary: dict) -> None:
        if directory is not None and self.world.is_root:
            write_json(directory.summary, summary)

    # -- results in Python ------------------------------------------------------------------------
    def fields(self) -> dict[str, OutputSet]:
        """The solver's output sets at this moment, by name (after :meth:`run`: the final state): each set's
        ``points`` (N, 3) and ``fields`` (name -> array), NumPy copies of what a VTU snapshot holds. In a distributed
        run, this rank's own part of each set (``ids``: the rows' indices in the whole set)."""
        return {s.name: s for s in self.solver.output_sets()}


class StaticRun(Run):
    """A one-off solve through the shell: the solver's ``solve()`` (its phases timed), then one output."""

    kind: ClassVar[str] = "static"

    def __init__(self, solver: StaticSolver, name: str = "run", params: dict | None = None,
                 analyses: list[Analysis] | None = None, output: OutputOptions | None = None,
                 reported_as: dict[str, str] | None = None):
        if not isinstance(solver, StaticSolver):
            raise ParameterError("solver", f"a StaticRun needs a StaticSolver, got {type(solver).__name__}")
        super().__init__(solver, name, params, analyses, output, reported_as)
        self.solve_s = 0.0

    def _execute(self, directory: RunDirectory | None, resume: bool, progress: bool) -> None:
        if resume:
            raise ParameterError("resume", "a static solve has nothing to resume: run it again")
        t0 = time.perf_counter()
        self.solver.solve()
        self.solve_s = time.perf_counter() - t0
        if directory is not None:
            self.write_outputs(directory, 0, 0, 0.0, self.name)

    def _throughput(self) -> dict:
        n = self.solver.work_items
        return {"unit": f"{self.solver.work_unit}/s", "value": n / self.solve_s if self.solve_s > 0 else None,
                "work_items": n}


def build_scene(module, params: dict, started: float | None = None) -> Run:
    """Call a scene's ``build(**params)``, timing it as the run's ``setup`` phase: from ``started`` (a
    ``time.perf_counter()`` reading: the command line passes its own start, so that loading the scene and starting
    Warp count as set-up) or from the call. With progress on (:mod:`warpfree.progress`) the set-up's end is
    announced with its time, whatever it is."""
    from .progress import report, stage

    t0 = time.perf_counter() if started is None else started
    stage("set-up")
    run = module.build(**params)
    if not isinstance(run, Run):
        raise ParameterError("scene", f"build() must return a warpfree Run (TimeLoop or StaticRun), "
                                      f"got {type(run).__name__}")
    seconds = time.perf_counter() - t0
    run.phases.add("setup", seconds)
    report(f"done, {run.name} ready", seconds)
    stage("run")
    return run


def gather_sets(world_, sets: list[OutputSet]) -> list[OutputSet] | None:
    """The whole output sets from every rank's own parts (rows in global order), on rank 0 (None on the others);
    the sets themselves in one process."""
    if not world_.distributed:
        return sets
    parts = world_.comm.gather([(s.ids, s.points, s.fields) for s in sets], root=0)
    if not world_.is_root:
        return None
    whole = []
    for j, s in enumerate(sets):
        ids = np.concatenate([p[j][0] for p in parts])
        order = np.argsort(ids, kind="stable")
        points = np.concatenate([p[j][1] for p in parts])[order]
        fields = {k: np.concatenate([p[j][2][k] for p in parts])[order] for k in s.fields}
        whole.append(dataclasses.replace(s, points=points, fields=fields, ids=None))
    return whole


#: the components a frame may colour by, by suffix: ``velocity_x`` is column 0 of the vector field ``velocity``
_COMPONENTS = ("_x", "_y", "_z")


def _component(output_set: OutputSet, name: str) -> tuple[str, int] | None:
    """(vector field, column) that ``name`` (``<field>_x``, ``_y`` or ``_z``) names in ``output_set``, or None."""
    base, suffix = name[:-2], name[-2:]
    if name in output_set.fields or suffix not in _COMPONENTS or base not in output_set.fields:
        return None
    values = np.asarray(output_set.fields[base])
    column = _COMPONENTS.index(suffix)
    return (base, column) if values.ndim == 2 and column < values.shape[1] else None


def drawable_fields(output_set: OutputSet) -> list[str]:
    """The names a frame of ``output_set`` may colour by: its scalar fields and its vector fields' components
    (``velocity_x``, ``velocity_y``)."""
    names = []
    for name, values in output_set.fields.items():
        shape = np.shape(values)
        if len(shape) == 1:
            names.append(name)
        elif len(shape) == 2 and shape[1] <= 3:
            names += [name + suffix for suffix in _COMPONENTS[:shape[1]] if name + suffix not in output_set.fields]
    return sorted(names)


def field_values(output_set: OutputSet, name: str) -> np.ndarray:
    """The (N,) values frames colour ``output_set`` by for ``name`` (a scalar field or a vector's component)."""
    component = _component(output_set, name)
    if component is not None:
        return np.asarray(output_set.fields[component[0]])[:, component[1]]
    return np.asarray(output_set.fields[name])


def field_unit(output_set: OutputSet, name: str, units: dict[str, str]) -> str | None:
    """The unit of the field or component ``name`` of ``output_set`` (a component has its vector's)."""
    component = _component(output_set, name)
    return units.get(name, units.get(component[0]) if component is not None else None)


def _checked_frame_range(frame_range) -> dict[str, tuple[float, float]]:
    """``OutputOptions.frame_range`` as {field: (vmin, vmax)}, each pair finite with vmax > vmin (else ParameterError
    naming ``frame_range``)."""
    if frame_range is None:
        return {}
    if not isinstance(frame_range, dict):
        raise ParameterError("frame_range", f"must be a dict {{field: (vmin, vmax)}}, got {frame_range!r}")
    checked = {}
    for key, pair in frame_range.items():
        try:
            vmin, vmax = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise ParameterError("frame_range", f"{key!r}: must be a pair (vmin, vmax) of numbers, got {pair!r}") \
                from None
        if not (np.isfinite(vmin) and np.isfinite(vmax)) or vmax <= vmin:
            raise ParameterError("frame_range", f"{key!r}: must be finite with vmax > vmin, got ({vmin!r}, {vmax!r})")
        checked[str(key)] = (vmin, vmax)
    return checked


def _checked_units(units) -> None:
    """``OutputOptions.units``: None or {quantity: unit}, both strings (else ParameterError naming ``units``)."""
    if units is None:
        return
    if not isinstance(units, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in units.items()):
        raise ParameterError("units", f"must be a dict {{quantity: unit}} of strings, got {units!r}")


def _bounding_box(sets: list[OutputSet], dim: int) -> tuple:
    pts = np.vstack([s.points[:, :dim] for s in sets if len(s.points)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * np.maximum(hi - lo, 1e-12)
    return tuple((float(a), float(b)) for a, b in zip(lo - pad, hi + pad))


def write_json(path: str, data: dict) -> None:
    """Write JSON atomically (NumPy scalars and arrays as numbers and lists)."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(data, f, indent=2, default=_json_default)
    os.replace(tmp, path)


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, tuple):
        return list(o)
    return str(o)
