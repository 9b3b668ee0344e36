"""Output files written beside the stepping: VTU snapshots, PVD indices, PNG frames, PLY meshes.

The run takes NumPy copies of what it writes at an output time and hands them over as one *batch* of
jobs; a worker process writes them, batch after batch, in the order given, while the run steps on.
The worker is a separate Python process (``python -m warpfree.io.writer``): rendering a frame holds
Python's lock for most of its time, so a thread would stall the stepping thread between its kernel
launches; the process runs on another core (at lower priority). At most ``max_pending`` batches
wait; a run that outputs faster than they are written waits for the oldest. A job that fails
raises :class:`OutputError` in the run at its next submission or at :meth:`OutputWriter.finish`, and
the run stops cleanly, keeping its last good state.

The files are the same, in the same order and byte for byte, as when written inline
(``background=False``: the same job functions run in the calling thread).

Protocol on the worker's stdin/stdout: pickled ``("batch", id, [(job, kwargs), ...])`` or
``("stop",)`` in; ``(id, None)`` or ``(id, "error text")`` out.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import traceback

__all__ = ["OutputWriter", "OutputError", "JOBS"]


class OutputError(RuntimeError):
    """Writing an output file failed (in the worker or inline)."""


# -- the jobs (run in the worker, or inline) ---------------------------------------------------------

def _job_vtu(path, points, fields, units=None):
    from .vtk import write_vtu

    write_vtu(path, points, fields, units)


def _job_pvtu(path, pieces, points, fields, units=None):
    from .vtk import write_pvtu

    write_pvtu(path, pieces, points, fields, units)


def _job_pvd(path, entries):
    from .vtk import write_pvd

    write_pvd(path, entries)


def _job_frame(path, **kwargs):
    from .frames import render_frame

    render_frame(path, **kwargs)


def _job_mesh(path, vertices, faces):
    from .meshes import write_mesh

    write_mesh(path, vertices, faces)


def _job_call(function, kwargs):
    """``function`` ("warpfree.module:name", a plot of a scene's analysis) called with ``kwargs``."""
    import importlib

    module, _, name = function.partition(":")
    if not module.startswith("warpfree.") or not name:
        raise ValueError(f"a call job takes 'warpfree.<module>:<function>', got {function!r}")
    getattr(importlib.import_module(module), name)(**kwargs)


JOBS = {"vtu": _job_vtu, "pvtu": _job_pvtu, "pvd": _job_pvd, "frame": _job_frame, "mesh": _job_mesh, "call": _job_call}

#: what the worker imports while it waits, when told that plots or frames will come (Matplotlib: 0.4-0.6 s)
PLOT_MODULES = ("matplotlib.figure", "matplotlib.backends.backend_agg", "PIL.ImageDraw", "PIL.ImageFont")


def run_batch(batch: list[tuple[str, dict]]) -> str | None:
    """Run the jobs of a batch in order; stop at the first failure and return its description."""
    for job, kwargs in batch:
        try:
            JOBS[job](**kwargs)
        except Exception as exc:  # reported to the run, which stops cleanly
            where = kwargs.get("path", "")
            return (f"writing {job} {where} failed: {type(exc).__name__}: {exc}\n"
                    + "".join(traceback.format_exception(exc)[-3:]))
    return None


# -- the run's side ----------------------------------------------------------------------------------

class OutputWriter:
    """Hands batches of jobs to a worker process (``background=True``) or runs them inline."""

    def __init__(self, background: bool = True, max_pending: int = 2, plots: bool = False):
        self.background = bool(background)
        self.max_pending = max(1, int(max_pending))
        self.plots = bool(plots)  # frames or plots will come: the worker loads Matplotlib while it waits
        self._proc: subprocess.Popen | None = None
        self._pending: list[int] = []
        self._next_id = 0
        self.batches = 0

    def submit(self, batch: list[tuple[str, dict]]) -> None:
        """Write a batch (after every batch submitted before it). Raises OutputError for an earlier failure."""
        if not batch:
            return
        self.batches += 1
        if not self.background:
            error = run_batch(batch)
            if error:
                raise OutputError(error)
            return
        proc = self._worker()
        batch_id = self._next_id
        self._next_id += 1
        try:
            pickle.dump(("batch", batch_id, batch), proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            proc.stdin.flush()
        except (BrokenPipeError, OSError):
            raise OutputError(self._died()) from None
        self._pending.append(batch_id)
        while len(self._pending) > self.max_pending:
            self._receive()

    def start(self) -> None:
        """Start the worker now (it is otherwise started by the first batch), so that it loads what it
        will need (``plots``) while the run sets up and steps."""
        if self.background:
            self._worker()

    def finish(self) -> None:
        """Wait until every submitted batch is written; raises OutputError if one failed."""
        while self._pending:
            self._receive()

    def close(self) -> None:
        """Stop the worker (after the batches already handed over); idempotent, never raises."""
        proc, self._proc = self._proc, None
        self._pending = []
        if proc is None:
            return
        try:
            pickle.dump(("stop",), proc.stdin)
            proc.stdin.close()
            proc.wait(timeout=60)
        except Exception:
            proc.kill()
            proc.wait()

    def _worker(self) -> subprocess.Popen:
        if self._proc is None:
            import warpfree

            env = dict(os.environ)
            root = os.path.dirname(os.path.dirname(os.path.abspath(warpfree.__file__)))
            env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
            args = ["--preload-plots"] if self.plots else []
            self._proc = subprocess.Popen([sys.executable, "-m", "warpfree.io.writer", *args], stdin=subprocess.PIPE,
                                          stdout=subprocess.PIPE, env=env)
        return self._proc

    def _receive(self) -> None:
        try:
            batch_id, error = pickle.load(self._proc.stdout)
        except (EOFError, pickle.UnpicklingError, OSError):
            raise OutputError(self._died()) from None
        self._pending.remove(batch_id)
        if error:
            raise OutputError(error)

    def _died(self) -> str:
        code = self._proc.poll() if self._proc is not None else None
        return f"the output writer process ended unexpectedly (exit code {code})"

    def __del__(self):
        self.close()


# -- the worker's side -------------------------------------------------------------------------------

def _preload(modules) -> None:
    """Import ``modules`` before the first batch is read. In the worker's main thread: a second thread importing
    Matplotlib while the main one unpickles NumPy arrays (or imports the frame module) made the two imports race
    and the worker die on a partially initialised ``numpy._core`` (seen once in ~10 suite runs). The worker is a
    process of its own, so the run steps meanwhile all the same; the first batch waits in the pipe."""
    import importlib

    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError:  # the job that needs it reports the error
            return


def _serve(preload_plots: bool = False) -> None:
    """Worker loop: read batches from stdin, write their files, answer on stdout.

    The run decides when writing ends: Ctrl-C and SIGTERM sent to the whole process group are ignored here (the run
    stops at the end of a step and finishes the batches it handed over), and a run that has gone (killed) leaves
    its batches to be written all the same, unanswered, until the pipe is empty."""
    import signal

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
    requests = sys.stdin.buffer
    answers = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    sys.stdout = sys.stderr  # anything a library prints must not reach the answer channel
    try:
        os.nice(10)  # the stepping comes first
    except (AttributeError, OSError):
        pass
    if preload_plots:
        _preload(PLOT_MODULES)
    while True:
        try:
            message = pickle.load(requests)
        except EOFError:  # the run ended (or died): nothing more to write
            return
        if message[0] == "stop":
            return
        _, batch_id, batch = message
        error = run_batch(batch)
        if answers is None:
            continue
        try:
            pickle.dump((batch_id, error), answers)
            answers.flush()
        except (BrokenPipeError, OSError):  # the run has gone: write what it handed over, answer no more
            try:
                answers.close()
            except OSError:
                pass
            answers = None


if __name__ == "__main__":
    _serve(preload_plots="--preload-plots" in sys.argv[1:])
