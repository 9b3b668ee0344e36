"""Device choice and the threaded CPU launcher.

Warp runs one CPU launch on one thread. :class:`Launcher` splits a launch of ``n`` items into
contiguous chunks run from a thread pool (``wp.launch`` releases the GIL on the CPU), each kernel
computing ``i = first + wp.tid()``. On CUDA the same kernel runs as a single launch with ``first = 0``.

Every chunked kernel must be race-free (gather form: each thread writes only its own outputs), which
makes results bitwise identical for any thread count. Chunk boundaries depend only on ``n`` and the
thread count, never on timing.
"""

from __future__ import annotations

import math
import numbers
import os
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
    ``i = first + wp.tid()``. Launches of fewer than ``min_items_per_thread`` items per thread use
    fewer threads.
    """

    def __init__(self, device: str | None = None, threads: int | None = None, min_items_per_thread: int = 2048):
        self.device = resolve_device(device)
        if threads is None:
            threads = default_threads()
        if (isinstance(threads, bool) or not isinstance(threads, numbers.Real) or not math.isfinite(threads)
                or int(threads) != threads or threads < 1):
            raise ParameterError("threads", f"must be an integer >= 1, got {threads!r}")
        self.threads = int(threads) if self.is_cpu else 1
        # below this many items per thread a launch runs on one thread (waking a pool thread costs
        # 0.1-1 ms on a VM, the work of ~1000 particles of a neighbour loop);
        # the result is bitwise the same either way, tests set 1 to exercise the chunking on small sets
        self.min_items_per_thread = max(1, int(min_items_per_thread))
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        self._loaded: set = set()

    @property
    def is_cpu(self) -> bool:
        return self.device == "cpu"

    def chunks(self, n: int, light: bool = False) -> list[tuple[int, int]]:
        """Contiguous ``(first, count)`` chunks: deterministic in ``n`` and the thread count.

        ``light`` kernels (a few flops per item, no neighbour loop) need 8x more items per thread
        before a split pays for waking a pool thread.
        """
        per_thread = self.min_items_per_thread * (8 if light else 1)
        k = min(self.threads, n // per_thread) if n > 0 else 0
        k = max(k, 1) if n > 0 else 0
        out = []
        for c in range(k):
            a = (n * c) // k
            b = (n * (c + 1)) // k
            if b > a:
                out.append((a, b - a))
        return out

    def launch(self, kernel, n: int, inputs: list, outputs: list | None = None, light: bool = False) -> None:
        """Run ``kernel(first, *inputs, *outputs)`` over ``n`` items (``light``: see :meth:`chunks`)."""
        n = int(n)
        if n <= 0:
            return
        outputs = outputs or []
        if kernel.module not in self._loaded:
            # Compile/load once before threads race to do it (they would each compile the module).
            wp.load_module(kernel.module, device=self.device)
            self._loaded.add(kernel.module)
        chunks = self.chunks(n, light) if self._pool is not None else [(0, n)]
        if len(chunks) == 1:
            wp.launch(kernel, dim=n, inputs=[0, *inputs], outputs=outputs, device=self.device)
            return
        futures = [
            self._pool.submit(
                wp.launch, kernel, dim=cnt, inputs=[first, *inputs], outputs=outputs, device=self.device
            )
            for first, cnt in chunks
        ]
        for f in futures:
            f.result()  # re-raise any error from a worker

    def synchronize(self) -> None:
        if not self.is_cpu:
            wp.synchronize_device(self.device)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __repr__(self) -> str:
        return f"Launcher(device={self.device!r}, threads={self.threads})"


_current: Launcher | None = None


def use(device: str | None = None, threads: int | None = None, min_items_per_thread: int = 2048) -> Launcher:
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
