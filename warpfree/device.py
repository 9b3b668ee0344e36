"""Device choice and the threaded CPU launcher.

Warp runs one CPU launch on one thread. :class:`Launcher` splits a launch of ``n`` items into
contiguous chunks, the calling thread running one and a thread pool the others (``wp.launch`` releases
the GIL on the CPU), each kernel computing ``i = first + wp.tid()``. On CUDA the same kernel runs as a
single launch with ``first = 0``.

Every chunked kernel must be race-free (gather form: each thread writes only its own outputs), which
makes results bitwise identical for any thread count and any split. Whether a launch splits is chosen
by measured launch time (whole against split, see :class:`Launcher`); the boundaries of k chunks depend
only on ``n`` and k.
"""

from __future__ import annotations

import importlib
import os
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import warp as wp

from .errors import ParameterError, require_integer
from .progress import announce

_initialised = False
#: what Warp's native library said about CUDA while it initialised (e.g. no driver found), kept for a run that asks
#: for a GPU: a CPU run prints none of it
_cuda_notes: list[str] = []


def init_warp() -> None:
    """Initialise Warp once, configured as :mod:`warpfree.kernels` configures it (quiet, no gradient kernels).

    Warp's native library looks for the CUDA driver as it initialises and, on a machine without one, writes
    ``Warp CUDA warning: Could not find or load the NVIDIA CUDA driver ...`` straight to file descriptor 2 (no Warp
    setting silences it: ``wp.config.log_level`` governs only Warp's Python messages). Those ``Warp CUDA`` lines are
    caught here and kept: a CPU run never needs CUDA, and :func:`resolve_device` puts them into the error of a run
    that asks for ``cuda`` (or prints them when a GPU was found all the same). Anything else Warp writes there
    passes through."""
    global _initialised
    if not _initialised:
        importlib.import_module("warpfree.kernels")  # Warp's configuration
        said = _captured_stderr(wp.init)
        _initialised = True
        notes = [line for line in said.splitlines() if line.startswith("Warp CUDA")]
        _cuda_notes[:] = notes
        rest = "".join(line + "\n" for line in said.splitlines() if line and line not in notes)
        if rest:
            sys.stderr.write(rest)
            sys.stderr.flush()


def _captured_stderr(function) -> str:
    """Call ``function()`` with file descriptor 2 sent to a temporary file (native code writes there, past
    ``sys.stderr``); return what was written. The descriptor is restored whatever happens."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with tempfile.TemporaryFile(mode="w+b") as sink:
            os.dup2(sink.fileno(), 2)
            try:
                function()
            finally:
                sys.stderr.flush()
                os.dup2(saved, 2)
            sink.seek(0)
            return sink.read().decode("utf-8", errors="replace")
    finally:
        os.close(saved)


def resolve_device(name: str | None = None) -> str:
    """Return a Warp device name: ``"cpu"`` by default, ``"cuda"``/``"cuda:N"`` when asked and present."""
    init_warp()
    if name is None or name == "" or name == "cpu":
        return "cpu"
    if not str(name).startswith("cuda"):
        raise ParameterError("device", f"must be 'cpu', 'cuda' or 'cuda:N', got {name!r}")
    if not wp.is_cuda_available():
        why = f" (Warp: {'; '.join(_without_prefix(n) for n in _cuda_notes)})" if _cuda_notes else ""
        raise ParameterError("device", f"{name!r} was asked for but no CUDA device is present{why}; use 'cpu'")
    for note in _cuda_notes:  # a GPU run is told what Warp said about its driver
        print(note, file=sys.stderr)
    _cuda_notes.clear()
    try:
        return str(wp.get_device(name))
    except Exception as exc:  # unknown ordinal
        raise ParameterError("device", f"{name!r} is not a CUDA device here ({exc})") from None


def _without_prefix(note: str) -> str:
    """A Warp CUDA line without its ``Warp CUDA warning:`` / ``Warp CUDA error:`` label."""
    head, sep, tail = note.partition(": ")
    text = tail if sep and head.startswith("Warp CUDA") else note
    return text.strip().rstrip(".")


def gpu_count() -> int:
    """CUDA devices this process sees (0 without a driver)."""
    init_warp()
    return wp.get_cuda_device_count() if wp.is_cuda_available() else 0


def default_threads() -> int:
    """All cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


class Launcher:
    """Launch gather kernels over ``n`` items, chunked across ``threads`` on the CPU.

    Every kernel launched through here takes ``first: int`` as its first argument and computes
    ``i = first + wp.tid()``. The calling thread runs the first chunk itself while pool threads run the
    others (one wake-up fewer than handing every chunk to the pool).

    Whether a launch is split is decided from measured time (``min_items_per_thread=None``, the default):
    per launch site (kernel, item-count size class and argument arrays, :meth:`site`) the launcher keeps the wall
    time per item of its launches run whole and run split
    (from handing the chunks over to the last one done: the pool thread's wake-up included), and runs the
    next launch the faster way. A first launch runs whole; a split is tried once the whole launch takes more
    than twice the pool's hand-over (measured when the pool starts, 20–60 µs on a VM), and both ways are timed
    again every ``RETRY`` launches, as the work of a kernel changes during a run (neighbour counts grow as a
    dam break develops). A way is (re)timed over a burst of ``TRIAL`` consecutive launches whose first is
    discarded (a kernel's first launch, and the first split after a run of whole ones, are cold). A launch
    longer than ``ALWAYS_SPLIT`` hand-overs is always split: on this VM the second core reaches full speed
    only after about 0.1 s of continuous work (the SPEM waveguide split on 2 threads: 2.6 ms a step for its
    first ~50 steps, then 1.4 ms; 2.4 ms on 1 thread), so trial splits between whole launches, with that
    core idle, ran as slowly as the whole launch; the measurement chose whole and the step stayed at 1.0x. On
    the default 2D dam break the rates kernel (3 ms a step) runs split, a drift over the same particles (50 µs)
    whole. Since every chunked kernel is a gather, the split never changes a
    result: they are bitwise the same for any thread count and any split (tested). ``min_items_per_thread``
    = m instead splits every launch with at least m items per chunk (tests use 1 to exercise the chunking on
    small sets).
    """

    #: launches of a kernel between two re-measurements of the way not taken
    RETRY = 64
    #: launch sites timed at most (a kernel given new arrays at every launch makes a new site each time)
    MAX_SITES = 4096
    #: a split is tried once a whole launch takes this many times the pool's hand-over
    TRY_SPLIT = 2.0
    #: consecutive launches a way is timed over when it is tried (the first, cold, is not counted)
    TRIAL = 4
    #: a launch this many times the pool's hand-over is always split: it can lose at most one hand-over
    #: (5 % of it) where the memory bus is already saturated, and gains up to the thread count where it is not
    ALWAYS_SPLIT = 20.0
    #: recorded commands kept per kernel (the chunks of its last few launch sizes; a command holds its arguments,
    #: so with no bound a count that keeps changing would keep every array it was ever given alive)
    RECORDED_PER_KERNEL = 16

    def __init__(self, device: str | None = None, threads: int | None = None, min_items_per_thread: int | None = None):
        self.device = resolve_device(device)
        if threads is None:
            threads = default_threads()
        threads = require_integer("threads", threads, minimum=1)
        self.threads = threads if self.is_cpu else 1
        self.min_items_per_thread = (None if min_items_per_thread is None else
                                     require_integer("min_items_per_thread", min_items_per_thread, minimum=1))
        self._pool = ThreadPoolExecutor(self.threads - 1) if self.threads > 1 else None
        self._loaded: set = set()
        self._timings: dict = {}  # launch site -> _Timing: measured wall of whole and split launches
        # kernel -> {(first, count): (recorded command, the arguments it holds)}, oldest first, at most
        # RECORDED_PER_KERNEL a kernel
        self._recorded: dict = {}
        self._recording = threading.Lock()  # the chunks of one launch record on several threads
        # (kernel, first, count) -> the identities of the last plain launch's arguments (no reference held)
        self._seen: dict = {}
        self._capture = None  # the Warp capture under way (:meth:`capturing`)
        self.handover_s = self._measure_handover() if self._pool is not None else 0.0

    def _measure_handover(self) -> float:
        """Median seconds to hand a no-op to a pool thread and get it back (wake-up and hand-back)."""
        times = []
        for _ in range(15):
            t0 = time.perf_counter()
            self._pool.submit(_no_op).result()
            times.append(time.perf_counter() - t0)
        return sorted(times)[len(times) // 2]

    @property
    def is_cpu(self) -> bool:
        """True when this launcher's device is the CPU."""
        return self.device == "cpu"

    def chunks(self, n: int, count: int | None = None) -> list[tuple[int, int]]:
        """``count`` contiguous ``(first, items)`` chunks of ``n`` items (default: the fixed rule of
        ``min_items_per_thread``, else one per thread); boundaries depend only on ``n`` and ``count``."""
        if n <= 0:
            return []
        if count is None:
            per_thread = self.min_items_per_thread or 1
            count = min(self.threads, n // per_thread)
        k = max(1, min(int(count), n))
        return [((n * c) // k, (n * (c + 1)) // k - (n * c) // k) for c in range(k)]

    @staticmethod
    def site(kernel, n: int, args=()) -> tuple:
        """The key a launch is timed under: kernel, the item count's size class (its power of two: an open
        system's count changes every step, and a site keyed by the exact count was never launched twice, so it
        never split — PIC diode above the space-charge limit, 34 k particles: 1.12x on 2 threads, 1.79x with
        the count steady) and the arrays it is given (one launch site; the same kernel filling a long and a
        short table over the same points is timed twice). Times are kept per item, so counts within a class
        compare."""
        return (kernel, int(n).bit_length(), *(id(a) for a in args if type(a) not in _SCALARS))

    def split_count(self, kernel, n: int, args=()) -> int:
        """How many chunks the next launch of ``kernel`` over ``n`` items with the arrays of ``args`` gets (see
        the class docstring)."""
        if self._pool is None or n < 2:
            return 1
        if self.min_items_per_thread is not None:
            return max(1, min(self.threads, n // self.min_items_per_thread))
        return self._measured_split(self._timings.get(self.site(kernel, n, args)), n)

    def _measured_split(self, t: "_Timing | None", n: int) -> int:
        """:meth:`split_count` from a launch site's timing ``t`` (None: never launched)."""
        if t is None or t.whole is None:
            return 1
        whole = t.whole * n  # the launch's expected time run whole
        if whole > self.ALWAYS_SPLIT * self.handover_s:
            return self.threads
        if t.trial_left == 0:
            if t.split is None:
                if whole > self.TRY_SPLIT * self.handover_s:
                    t.start_trial(split=True, launches=self.TRIAL)
            elif t.launches % self.RETRY == 0:  # time the way not taken again
                t.start_trial(split=t.split > t.whole, launches=self.TRIAL)
        if t.trial_left > 0:
            return self.threads if t.trial_split else 1
        if t.split is None:
            return 1
        return self.threads if t.split < t.whole else 1

    def launch(self, kernel, n: int, inputs: list, once: bool = False) -> None:
        """Run ``kernel(first, *inputs)`` over ``n`` items. ``once``: a launch made once (a static solve's
        set-up and assembly, over arrays it never sees again): split over every thread from the start, untimed,
        since there is no later launch a measurement could serve (measured-split would run every such launch
        whole: the EFG assembly of 36 864 Gauss points ran at 1.05x on 2 threads)."""
        n = int(n)
        if n <= 0:
            return
        if kernel not in self._loaded:
            # Compile/load before threads race to do it (they would each compile the module, and a module that has
            # grown a kernel since it was loaded, made by a factory, is loaded again: keyed by kernel, not module).
            with announce(f"Warp module {kernel.module.name} compiled (first launch)"):
                wp.load_module(kernel.module, device=self.device)
            self._loaded.add(kernel)
        if self._capture is not None:  # recorded whole, on this thread, with plain launches (:meth:`capturing`)
            wp.launch(kernel, dim=n, inputs=[0, *inputs], device=self.device)
            return
        if self._pool is None or n == 1:  # one item (a clock's or a report's single thread): nothing to split or time
            self._run(kernel, 0, n, inputs)
            return
        timed = self.min_items_per_thread is None and not once
        if timed:  # the launch site's timing, looked up once (its key walks the arguments)
            site = self.site(kernel, n, inputs)
            timing = self._timings.get(site)
            count = self._measured_split(timing, n)
        else:
            count = self.threads if once else self.split_count(kernel, n, inputs)
        t0 = time.perf_counter()
        if count == 1:  # whole, on this thread
            self._run(kernel, 0, n, inputs)
        else:
            chunks = self.chunks(n, count)
            futures = [self._pool.submit(self._run, kernel, first, cnt, inputs) for first, cnt in chunks[1:]]
            first, cnt = chunks[0]
            try:
                self._run(kernel, first, cnt, inputs)
            finally:
                for f in futures:
                    f.result()  # wait for every chunk; re-raise any error from a worker
        if timed:
            if timing is None:
                if len(self._timings) > self.MAX_SITES:  # sites with fresh arrays each launch: start over
                    self._timings.clear()
                timing = self._timings[site] = _Timing(self.TRIAL)
            timing.add((time.perf_counter() - t0) / n, count > 1)

    def _run(self, kernel, first: int, count: int, inputs: list) -> None:
        """One launch of ``count`` items from ``first``, replayed from a recorded command when it can be.

        ``wp.launch`` packs every argument in Python (15-20 µs a launch, a few % of a small step); a recorded
        command (``record_cmd=True``) is replayed with only the changed scalars re-packed. A command is recorded at
        the second launch with the same arrays (a set-up launch, made once, would otherwise keep its arrays alive in
        the command), and at most ``RECORDED_PER_KERNEL`` are kept a kernel. Reuse is safe: an
        argument that is the same object as at recording is passed as it is now (arrays do not move; a Warp
        struct is packed as its own ctypes object, so assigning a field after recording is seen); any other
        change (a new array, a new struct) records the command again.
        """
        if not self.is_cpu:
            wp.launch(kernel, dim=count, inputs=[first, *inputs], device=self.device)
            return
        args = list(inputs)
        key = (first, count)
        recorded = self._recorded.get(kernel, {}).get(key)
        if recorded is not None:
            command, previous = recorded
            if len(previous) == len(args) and all(
                    a is b or (type(a) in _SCALARS and type(a) is type(b)) for a, b in zip(args, previous)):
                for i, (a, b) in enumerate(zip(args, previous)):
                    if a is not b and a != b:
                        command.set_param_at_index(i + 1, a)
                previous[:] = args
                command.launch()
                return
        identity = tuple(type(a) if type(a) in _SCALARS else id(a) for a in args)
        if self._seen.get((kernel, key)) != identity:
            # first launched with these arrays (a set-up launch is never repeated): run plainly, recording nothing that
            # would hold them; remembered by identity only, so the second such launch records
            if len(self._seen) > self.MAX_SITES:
                self._seen.clear()
            self._seen[(kernel, key)] = identity
            wp.launch(kernel, dim=count, inputs=[first, *inputs], device=self.device)
            return
        command = wp.launch(kernel, dim=count, inputs=[first, *inputs], device=self.device, record_cmd=True)
        with self._recording:
            kept = self._recorded.setdefault(kernel, {})
            kept.pop(key, None)
            kept[key] = (command, args)
            while len(kept) > self.RECORDED_PER_KERNEL:  # the oldest go, and the arrays only they held
                del kept[next(iter(kept))]
        command.launch()

    @contextmanager
    def capturing(self):
        """Record the launches made inside as a Warp graph (``wp.ScopedCapture``; nothing runs until it is replayed
        with ``wp.capture_launch(graph)``). Launches are recorded whole, on the calling thread: a graph replays them in
        order, and gather kernels give bitwise the same results whole or split. Yields the capture (its ``graph``)."""
        if self._capture is not None:
            raise RuntimeError("a capture is already under way on this launcher")
        with wp.ScopedCapture(device=self.device) as capture:
            self._capture = capture
            try:
                yield capture
            finally:
                self._capture = None

    def synchronize(self) -> None:
        """Wait until the device has finished every launch (nothing to wait for on the CPU)."""
        if not self.is_cpu:
            wp.synchronize_device(self.device)

    def close(self) -> None:
        """Stop the thread pool of a CPU launcher (idempotent)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __repr__(self) -> str:
        return f"Launcher(device={self.device!r}, threads={self.threads})"


#: argument types passed by value: a launch site is not keyed by them, and a recorded command re-packs them when
#: they change (Warp's own scalars among them: a fresh ``wp.float64(dt)`` each step made every PIC push a new site,
#: so it never split)
_SCALARS = (int, float, bool, wp.int8, wp.int16, wp.int32, wp.int64, wp.uint8, wp.uint16, wp.uint32, wp.uint64,
            wp.float16, wp.float32, wp.float64)


class _Timing:
    """A kernel's launch wall time per item (s) run whole and run split (each the median of its last ``KEEP`` warm
    samples: one launch slowed by the machine does not flip the choice for ``RETRY`` launches), its launch
    count, and the trial under way (``trial_left`` launches of the way ``trial_split``, the first not counted;
    a new kernel starts with a trial of ``trial`` whole launches)."""

    KEEP = 5
    __slots__ = ("whole", "split", "launches", "trial_left", "trial_split", "_cold", "_samples")

    def __init__(self, trial: int = 1):
        self.whole = self.split = None
        self.launches = 0
        self._samples = {False: [], True: []}
        self.start_trial(split=False, launches=trial)  # the first launch of a kernel is cold too

    def start_trial(self, split: bool, launches: int) -> None:
        self.trial_left, self.trial_split, self._cold = launches, split, True

    def add(self, seconds: float, split: bool) -> None:
        self.launches += 1
        if self.trial_left > 0 and split == self.trial_split:
            self.trial_left -= 1
            if self._cold:  # the first launch of a trial: the pool thread woke, the other core's cache was cold
                self._cold = False
                if self.trial_left > 0:
                    return
        samples = self._samples[split]
        samples.append(seconds)
        del samples[:-self.KEEP]
        value = float(sorted(samples)[len(samples) // 2])
        if split:
            self.split = value
        else:
            self.whole = value


def _no_op() -> None:
    return None


_current: Launcher | None = None


def use(device: str | None = None, threads: int | None = None, min_items_per_thread: int | None = None) -> Launcher:
    """Set the launcher that solvers use when none is passed (the CLI calls this once per run)."""
    global _current
    if _current is not None:
        _current.close()
    _current = Launcher(device, threads, min_items_per_thread)
    return _current


def current_launcher() -> Launcher:
    """The launcher set by :func:`use`, or a CPU launcher on all cores."""
    global _current
    if _current is None:
        _current = Launcher()
    return _current
