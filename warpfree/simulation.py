"""The simulation loop shared by every solver: time, outputs, probes, progress, checkpoints, resume.

A solver provides ``step(dt)``, ``stable_dt()``, ``state_arrays()``, ``after_load()``,
``output_sets()``, ``diagnostics()``, ``describe()``, ``work_items``, ``timings`` and ``problem``
(None, or a message when the last step left the state bad). The loop owns everything else.

Time step: the solver's stable step, shortened only to land exactly on output times; or a fixed
``dt`` that must stay within the stable step (else the run stops naming ``dt``).

Checkpoints (``checkpoints/step_XXXXXXXX.npz``) hold every state array, the time, the step and the
loop's own state (probe series, next output), so ``resume`` continues a run and reproduces the
uninterrupted one bitwise. A run that goes bad raises :class:`~warpfree.errors.RunError` naming the
step; the last good checkpoint stays on disk (without periodic checkpoints, the state at the last
output is written as one).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import ParameterError, RunError, require_positive

#: probe: name -> function(solver, time) -> float
Probe = Callable[[object, float], float]
#: analysis: function(simulation, out_dir) -> dict merged into summary["analysis"]
Analysis = Callable[["Simulation", str], dict]


@dataclass
class OutputOptions:
    """What a run writes besides ``summary.json``."""

    vtk: bool = True
    frames: bool = True
    frame_field: str = "speed"
    frame_set: str = "fluid"
    frame_bounds: tuple | None = None
    surface: bool = False            # free-surface meshes (3D), needs a solver with ``surface_mesh()``


class Simulation:
    """Runs a solver from t = 0 to ``t_end``, writing outputs every ``output_interval`` seconds."""

    def __init__(self, solver, t_end: float, output_interval: float, name: str = "run",
                 params: dict | None = None, probes: dict[str, Probe] | None = None,
                 analyses: list[Analysis] | None = None, dt: float | None = None,
                 checkpoint_every: int = 0, output: OutputOptions | None = None, max_steps: int | None = None):
        self.solver = solver
        self.t_end = require_positive("t_end", t_end)
        self.output_interval = require_positive("output_interval", output_interval)
        self.dt_fixed = None if dt is None else require_positive("dt", dt)
        if int(checkpoint_every) != checkpoint_every or checkpoint_every < 0:
            raise ParameterError("checkpoint_every", f"must be an integer >= 0, got {checkpoint_every!r}")
        self.checkpoint_every = int(checkpoint_every)
        self.name = name
        self.params = dict(params or {})
        self.probes = dict(probes or {})
        self.analyses = list(analyses or [])
        self.output = output or OutputOptions()
        self.max_steps = max_steps
        self.time = 0.0
        self.step_count = 0
        self.series: dict[str, list] = {"time": []}
        self.diag_series: dict[str, list] = {}
        self.n_outputs = 0
        self._next_output = 0.0
        self.wall = {"step": 0.0, "output": 0.0, "checkpoint": 0.0}
        if self.dt_fixed is not None:
            limit = solver.stable_dt()
            if self.dt_fixed > limit:
                raise ParameterError("dt", f"{self.dt_fixed:.4g} s exceeds the stable (CFL) limit {limit:.4g} s")

    # -- outputs -------------------------------------------------------------------------------
    def _record(self, out_dir: str | None) -> None:
        """Probes, diagnostics, VTU and frame at the current time."""
        t0 = time.perf_counter()
        self.series["time"].append(self.time)
        for name, probe in self.probes.items():
            self.series.setdefault(name, []).append(float(probe(self.solver, self.time)))
        for k, v in self.solver.diagnostics().items():
            self.diag_series.setdefault(k, []).append(v)
        if out_dir is not None:
            self._write_fields(out_dir)
        self.n_outputs += 1
        self._next_output = self.n_outputs * self.output_interval
        if out_dir is not None:
            self._snapshot = self._state_snapshot()  # the last good state, written if the run goes wrong
        self.wall["output"] += time.perf_counter() - t0

    def _write_fields(self, out_dir: str) -> None:
        sets = self.solver.output_sets()
        if self.output.vtk:
            for set_name, fields in sets.items():
                series = self._vtk.setdefault(set_name, self._make_series(out_dir, set_name))
                pts = fields["points"]
                series.write(self.step_count, self.time, pts, {k: v for k, v in fields.items() if k != "points"})
        if self.output.frames:
            from .io.frames import render_frame

            fs = sets[self.output.frame_set]
            others = [f["points"] for k, f in sets.items() if k != self.output.frame_set]
            bpts = np.vstack(others) if others else None
            os.makedirs(os.path.join(out_dir, "frames"), exist_ok=True)
            render_frame(os.path.join(out_dir, "frames", f"frame_{self.n_outputs:05d}.png"), fs["points"],
                         fs[self.output.frame_field], self.solver.params.dim, self.output.frame_field,
                         bounds=self.output.frame_bounds, boundary_points=bpts,
                         title=f"{self.name}  t = {self.time:.4f} s")
        if self.output.surface and hasattr(self.solver, "surface_mesh"):
            from .io.surface import write_surface

            os.makedirs(os.path.join(out_dir, "surface"), exist_ok=True)
            write_surface(os.path.join(out_dir, "surface", f"surface_{self.n_outputs:05d}.ply"),
                          self.solver.surface_mesh())

    def _make_series(self, out_dir: str, set_name: str):
        from .io.vtk import VtuSeries

        if self._resumed_time is not None:
            return VtuSeries(out_dir, set_name, resume_after_time=self._resumed_time)
        return VtuSeries(out_dir, set_name)

    # -- checkpoints -----------------------------------------------------------------------------
    def _loop_state(self) -> dict:
        return {"time": self.time, "step": self.step_count, "n_outputs": self.n_outputs,
                "series": self.series, "diag_series": self.diag_series}

    def _state_snapshot(self) -> tuple[dict, dict]:
        """(loop state, copies of every state array): what a checkpoint holds."""
        return (json.loads(json.dumps(self._loop_state())),
                {k: v.numpy().copy() for k, v in self.solver.state_arrays().items()})

    def save_checkpoint(self, out_dir: str, snapshot: tuple[dict, dict] | None = None) -> str:
        """Write every state array and the loop state (now, or a kept snapshot); keep the two newest."""
        t0 = time.perf_counter()
        loop, arrays = snapshot if snapshot is not None else self._state_snapshot()
        cdir = os.path.join(out_dir, "checkpoints")
        os.makedirs(cdir, exist_ok=True)
        path = os.path.join(cdir, f"step_{loop['step']:08d}.npz")
        tmp = path + ".tmp.npz"
        np.savez(tmp, loop=np.array(json.dumps(loop)), **{f"state_{k}": v for k, v in arrays.items()})
        os.replace(tmp, path)
        for old in sorted(f for f in os.listdir(cdir) if f.startswith("step_") and f.endswith(".npz"))[:-2]:
            os.remove(os.path.join(cdir, old))
        self.last_checkpoint = path
        self._checkpoint_step = loop["step"]
        self.wall["checkpoint"] += time.perf_counter() - t0
        return path

    def load_checkpoint(self, path: str) -> None:
        data = np.load(path)
        loop = json.loads(str(data["loop"]))
        arrays = self.solver.state_arrays()
        for k, arr in arrays.items():
            key = f"state_{k}"
            if key not in data or data[key].shape != arr.numpy().shape:
                raise ParameterError("resume", f"checkpoint {path} does not match this scene (array {k!r})")
            arr.assign(data[key])
        self.solver.after_load()
        self.time = float(loop["time"])
        self.step_count = int(loop["step"])
        self.n_outputs = int(loop["n_outputs"])
        self._next_output = self.n_outputs * self.output_interval
        self.series = {k: list(v) for k, v in loop["series"].items()}
        self.diag_series = {k: list(v) for k, v in loop["diag_series"].items()}
        self.last_checkpoint = path
        self._checkpoint_step = self.step_count

    @staticmethod
    def latest_checkpoint(out_dir: str) -> str | None:
        cdir = os.path.join(out_dir, "checkpoints")
        if not os.path.isdir(cdir):
            return None
        files = sorted(f for f in os.listdir(cdir) if f.startswith("step_") and f.endswith(".npz"))
        return os.path.join(cdir, files[-1]) if files else None

    # -- the loop --------------------------------------------------------------------------------
    def next_dt(self) -> float:
        limit = self.solver.stable_dt()
        if not math.isfinite(limit) or limit <= 0:
            raise RunError(f"non-finite or broken state: the stable time step is {limit}", self.step_count)
        if self.dt_fixed is not None:
            if self.dt_fixed > limit * (1 + 1e-6):
                raise RunError(f"dt = {self.dt_fixed:.4g} s exceeds the stable (CFL) limit {limit:.4g} s",
                               self.step_count)
            dt = self.dt_fixed
        else:
            dt = limit
        # land exactly on the next output time (or the end)
        target = min(self._next_output, self.t_end)
        remaining = target - self.time
        if remaining <= dt * (1 + 1e-9):
            dt = remaining
        elif remaining < 2 * dt:
            dt = 0.5 * remaining  # avoid a sliver step before the output time
        return dt

    def run(self, out_dir: str | None = None, resume: bool = False, progress: bool = True) -> dict:
        """Run to ``t_end``; write outputs under ``out_dir`` (None: run in memory). Returns the summary."""
        self._vtk: dict = {}
        self._resumed_time = None
        self.last_checkpoint = None
        self._checkpoint_step = -1
        self._snapshot = None
        wall0 = time.perf_counter()
        if out_dir is not None:
            os.makedirs(out_dir, exist_ok=True)
        if resume:
            if out_dir is None:
                raise ParameterError("resume", "needs the run directory")
            path = self.latest_checkpoint(out_dir)
            if path is None:
                raise ParameterError("resume", f"no checkpoint in {out_dir}/checkpoints")
            self.load_checkpoint(path)
            self._resumed_time = self.time
        else:
            self._record(out_dir)
            if out_dir is not None and self.checkpoint_every:
                self.save_checkpoint(out_dir)
        bar = _progress(self.t_end, self.time, progress, self.name)
        steps0 = self.step_count
        try:
            while self.time < self.t_end * (1 - 1e-12):
                if self.max_steps is not None and self.step_count - steps0 >= self.max_steps:
                    break
                dt = self.next_dt()
                t0 = time.perf_counter()
                self.solver.step(dt)
                self.wall["step"] += time.perf_counter() - t0
                self.step_count += 1
                self.time = self._next_output if abs(self.time + dt - self._next_output) <= 1e-12 * max(1.0, self.time) \
                    else self.time + dt
                if self.solver.problem:
                    raise RunError(self.solver.problem, self.step_count)
                if self.time >= self._next_output * (1 - 1e-12) or self.time >= self.t_end * (1 - 1e-12):
                    self._record(out_dir)
                if out_dir is not None and self.checkpoint_every and self.step_count % self.checkpoint_every == 0:
                    self.save_checkpoint(out_dir)
                if bar is not None:
                    bar.update(self.time - bar.n)
        except RunError as err:
            if out_dir is not None and self._snapshot is not None and \
                    self._snapshot[0]["step"] > self._checkpoint_step:
                self.save_checkpoint(out_dir, self._snapshot)  # the state at the last output
            if self.last_checkpoint and not err.last_good:
                err = RunError(err.message, err.step, self.last_checkpoint)
            summary = self.summary(time.perf_counter() - wall0, self.step_count - steps0, error=str(err))
            if out_dir is not None:
                _write_json(os.path.join(out_dir, "summary.json"), summary)
            raise err from None
        finally:
            if bar is not None:
                bar.close()
        steps = self.step_count - steps0
        summary = self.summary(time.perf_counter() - wall0, steps)
        if out_dir is not None:
            analysis = {}
            for fn in self.analyses:
                analysis.update(fn(self, out_dir) or {})
            summary["analysis"] = analysis
            _write_json(os.path.join(out_dir, "summary.json"), summary)
        self.last_summary = summary
        return summary

    def summary(self, wall_s: float, steps: int, error: str | None = None) -> dict:
        """Parameters, counts, steps, wall time per phase, throughput, diagnostics and probes."""
        s = self.solver
        step_wall = self.wall["step"]
        out = {
            "scene": self.name,
            "solver": getattr(s, "name", type(s).__name__),
            "params": self.params,
            "model": s.describe(),
            "device": s.launcher.device,
            "threads": s.launcher.threads,
            "time": self.time,
            "t_end": self.t_end,
            "steps": self.step_count,
            "steps_this_run": steps,
            "wall_s": wall_s,
            "wall_s_per_phase": {**self.wall, **dict(s.timings)},
            "particle_steps_per_s": (s.work_items * steps / step_wall) if step_wall > 0 else None,
            "diagnostics": s.diagnostics(),
            "probes": self.series,
            "diagnostic_series": self.diag_series,
            "status": "error" if error else "ok",
        }
        if error:
            out["error"] = error
            out["last_good_checkpoint"] = getattr(self, "last_checkpoint", None)
        return out


def _progress(total: float, start: float, enabled: bool, name: str):
    if not enabled:
        return None
    from tqdm import tqdm

    bar = tqdm(total=total, initial=start, desc=name, unit="s(sim)", mininterval=0.5 if sys.stderr.isatty() else 10.0,
               bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.4f}/{total:.4f} s [{elapsed}<{remaining}]"))
    return bar


def _write_json(path: str, data: dict) -> None:
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
