"""Device choice and the threaded CPU launcher.

Warp runs one CPU launch on one thread. :class:`Launcher` splits a launch of ``n`` items into
contiguous chunks, the calling thread running one and a thread pool the others (``wp.launch`` releases
the GIL on the CPU), each kernel computing ``i = first + wp.tid()``. On CUDA the same kernel runs as a
single launch with ``first = 0``.

Every chunked kernel must be race-free (gather form: each thread writes only its own outputs), which
makes results bitwise identical for any thread count and any split. The number of chunks is chosen
from measured cost (a kernel's time per item against the pool's hand-over time); the boundaries of k
chunks depend only on ``n`` and k.
"""

from __future__ import annotations

import math
import numbers
import os
import time
from concurrent.futures import ThreadPoolExecutor

import warp as wp

from .errors import ParameterError

_initialised = False


def init_warp() -> None:
    """Initialise Warp once (quiet unless WARPFREE_VERBOSE=1, see ``warpfree/__init__.py``)."""
    global _initialised
    if not _initialised:
        if os.environ.get("WARPFREE_VERBOSE", "0") in ("", "0"):
            wp.config.log_level = wp.LOG_WARNING
        wp.init()
        _initialised = True


def resolve_device(name: str | None = None) -> str:
    """Return a Warp device name: ``"cpu"`` by default, ``"cuda"``/``"cuda:N"`` when asked and present."""
    init_warp()
    if name is None or name == "" or name == "cpu":
        return "cpu"
    if not str(name).startswith("cuda"):
        raise ParameterError("device", f"must be 'cpu', 'cuda' or 'cuda:N', got {name!r}")
    if not wp.is_cuda_available():
        raise ParameterError("device", f"{name!r} was asked for but no CUDA device is present; use 'cpu'")
    try:
        return str(wp.get_device(name))
    except Exception as exc:  # unknown ordinal
        raise ParameterError("device", f"{name!r} is not a CUDA device here ({exc})") from None


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

    How many chunks a launch gets is chosen from measured cost (``min_items_per_thread=None``, the default):
    the launcher keeps, per kernel and item count, the seconds per item of its past launches, and the cost
    of handing a chunk to a pool thread and waiting for it (measured when the pool starts, typically
    20–60 µs on a VM). A launch is split into k chunks only when the time it saves, T (1 - 1/k), exceeds that
    hand-over cost (while the pool thread wakes, the calling thread already runs its own chunk): on the
    default 2D dam break the rates kernel (3 ms a step) splits, a drift over the same particles (50 µs) does
    not. A first launch runs whole and is timed. Since every chunked kernel
    is a gather, the chunking never changes a result: they are bitwise the same for any thread count and any
    split (tested). ``min_items_per_thread`` = m instead splits every launch with at least m items per chunk
    (tests use 1 to exercise the chunking on small sets).
    """

    #: a split must save this many times the measured hand-over cost (measured on the default 2D dam break
    #: at 2 threads, alternating: 0.5, 1 and 2 within the VM's noise of each other, never splitting 20 % slower)
    SPLIT_MARGIN = 1.0

    def __init__(self, device: str | None = None, threads: int | None = None, min_items_per_thread: int | None = None):
        self.device = resolve_device(device)
        if threads is None:
            threads = default_threads()
        if (isinstance(threads, bool) or not isinstance(threads, numbers.Real) or not math.isfinite(threads)
                or int(threads) != threads or threads < 1):
            raise ParameterError("threads", f"must be an integer >= 1, got {threads!r}")
        self.threads = int(threads) if self.is_cpu else 1
        self.min_items_per_thread = None if min_items_per_thread is None else max(1, int(min_items_per_thread))
        self._pool = ThreadPoolExecutor(self.threads - 1) if self.threads > 1 else None
        self._loaded: set = set()
        self._seconds_per_item: dict = {}  # (kernel, n) -> measured seconds per item (running average)
        self._recorded: dict = {}  # (kernel, first, count) -> (recorded command, the arguments it holds)
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

    def split_count(self, kernel, n: int) -> int:
        """How many chunks a launch of ``kernel`` over ``n`` items gets (see the class docstring)."""
        if self._pool is None or n < 2:
            return 1
        if self.min_items_per_thread is not None:
            return max(1, min(self.threads, n // self.min_items_per_thread))
        per_item = self._seconds_per_item.get((kernel, n))
        if per_item is None:
            return 1
        whole = per_item * n
        best, best_k = whole, 1
        for k in range(2, self.threads + 1):
            # hand-over: one wake-up, plus a share of it for every further thread woken
            estimate = whole / k + self.SPLIT_MARGIN * self.handover_s * (1.0 + 0.25 * (k - 2))
            if estimate < best:
                best, best_k = estimate, k
        return best_k

    def _observe(self, kernel, n: int, seconds: float, items: int) -> None:
        key = (kernel, n)
        per_item = seconds / items
        old = self._seconds_per_item.get(key)
        self._seconds_per_item[key] = per_item if old is None else 0.7 * old + 0.3 * per_item

    def launch(self, kernel, n: int, inputs: list, outputs: list | None = None) -> None:
        """Run ``kernel(first, *inputs, *outputs)`` over ``n`` items."""
        n = int(n)
        if n <= 0:
            return
        outputs = outputs or []
        if kernel.module not in self._loaded:
            # Compile/load once before threads race to do it (they would each compile the module).
            wp.load_module(kernel.module, device=self.device)
            self._loaded.add(kernel.module)
        if self._pool is None:
            self._run(kernel, 0, n, inputs, outputs)
            return
        chunks = self.chunks(n, self.split_count(kernel, n))
        futures = [self._pool.submit(self._run, kernel, first, cnt, inputs, outputs) for first, cnt in chunks[1:]]
        first, cnt = chunks[0]
        t0 = time.perf_counter()
        try:
            self._run(kernel, first, cnt, inputs, outputs)
        finally:
            for f in futures:
                f.result()  # wait for every chunk; re-raise any error from a worker
        self._observe(kernel, n, time.perf_counter() - t0, n if not futures else cnt)

    def _run(self, kernel, first: int, count: int, inputs: list, outputs: list) -> None:
        """One launch of ``count`` items from ``first``, replayed from a recorded command when it can be.

        ``wp.launch`` packs every argument in Python (15-20 µs a launch, a few % of a small step); a recorded
        command (``record_cmd=True``) is replayed with only the changed scalars re-packed. Reuse is safe: an
        argument that is the same object as at recording is passed as it is now (arrays do not move; a Warp
        struct is packed as its own ctypes object, so assigning a field after recording is seen); any other
        change (a new array, a new struct) records the command again.
        """
        if not self.is_cpu:
            wp.launch(kernel, dim=count, inputs=[first, *inputs], outputs=outputs, device=self.device)
            return
        args = [*inputs, *outputs]
        key = (kernel, first, count)
        recorded = self._recorded.get(key)
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
        command = wp.launch(kernel, dim=count, inputs=[first, *inputs], outputs=outputs, device=self.device,
                            record_cmd=True)
        self._recorded[key] = (command, args)
        command.launch()

    def synchronize(self) -> None:
        if not self.is_cpu:
            wp.synchronize_device(self.device)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __repr__(self) -> str:
        return f"Launcher(device={self.device!r}, threads={self.threads})"


_SCALARS = (int, float, bool)


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
