"""Reductions on the device: max, min and sum of an array into one value, read back once.

A solver reduces what its step produced (largest displacement, speed, a status flag) on the device
and reads one small value per step; on a GPU that read is the step's only synchronisation.
:class:`Reduction` keeps its buffers between launches; :func:`reduce` is the one-off form.
A tree of passes over fixed blocks of :data:`BLOCK` items (n, n/32, n/1024, ... down to one value): every pass runs
n/32 threads at least, so a GPU has work for all its cores (one pass over blocks of 1 024 ran 256 threads at 262 k
items, and its second pass one thread over 256 partials), and the CPU's passes split over its threads. The blocks
depend only on n, never on the thread count: sums are bitwise the same for any thread count (``warpfree.kernels.reduce``).
"""

from __future__ import annotations

import warp as wp

from .device import Launcher
from .errors import ParameterError
from warpfree.kernels.reduce import OPERATIONS, block_reduce_kernel

__all__ = ["Reduction", "reduce"]

#: items per block of every pass (fixed, so that sums do not depend on the thread count)
BLOCK = 32

_SUM_ACCUMULATOR = {wp.float32: wp.float64, wp.float16: wp.float64}


class Reduction:
    """``op`` ("max", "min", "sum") over arrays of ``dtype`` on ``launcher``'s device.

    :meth:`launch` enqueues its passes and leaves the result in :attr:`result` (a one-element
    device array); :meth:`value` reads it back once per launch (NumPy scalar or small vector).
    Sums of float32 accumulate in float64. A reduction over zero items gives the type's zero.
    """

    def __init__(self, launcher: Launcher, dtype, op: str, block: int = BLOCK):
        if op not in OPERATIONS:
            raise ParameterError("op", f"must be one of {OPERATIONS}, got {op!r}")
        self.launcher = launcher
        self.op = op
        self.dtype = dtype
        self.acc_dtype = _SUM_ACCUMULATOR.get(dtype, dtype) if op == "sum" else dtype
        self.block = int(block)
        self._first = block_reduce_kernel(dtype, self.acc_dtype, op)
        self._second = block_reduce_kernel(self.acc_dtype, self.acc_dtype, op)
        self._levels: list[wp.array] = []   # the partials of every pass but the last, for up to ``_levels_for`` items
        self._levels_for = -1
        # the accumulator type's zero (written for a block without items)
        self._zero = self.acc_dtype() if wp.types.type_is_vector(self.acc_dtype) else self.acc_dtype(0)
        self.result = wp.zeros(1, dtype=self.acc_dtype, device=launcher.device)
        self._value = None

    def _passes(self, n: int) -> list[int]:
        """The block counts of the passes for n items: ceil(n/B), ceil(n/B²), ..., 1."""
        counts = [max(1, -(-n // self.block))]
        while counts[-1] > 1:
            counts.append(-(-counts[-1] // self.block))
        return counts

    def reserve(self, n: int) -> None:
        """Buffers for up to ``n`` items, kept (a recorded graph reads the same ones every replay); a count that grows
        (particles injected) grows them by 1.5x at least, not at every step. :meth:`launch` reserves what it needs;
        an owner that knows its count before its first launch reserves it then, outside a step."""
        if n > self._levels_for:
            room = n if self._levels_for < 0 else max(n, self._levels_for * 3 // 2)
            self._levels = [wp.zeros(b, dtype=self.acc_dtype, device=self.launcher.device)
                            for b in self._passes(room)[:-1]]
            self._levels_for = room

    def launch(self, values: wp.array, n: int | None = None) -> wp.array:
        """Reduce the first ``n`` items of ``values`` (all by default) into :attr:`result`."""
        if values.dtype != self.dtype:
            raise ParameterError("values", f"this reduction takes {self.dtype.__name__}, got {values.dtype.__name__}")
        n = values.shape[0] if n is None else int(n)
        passes = self._passes(n)
        self.reserve(n)
        outputs = self._levels[: len(passes) - 1] + [self.result]
        L, source, items = self.launcher, values, n
        for k, (blocks, out) in enumerate(zip(passes, outputs)):
            L.launch(self._first if k == 0 else self._second, blocks, [source, items, self.block, self._zero, out])
            source, items = out, blocks
        self._value = None
        return self.result

    def value(self):
        """The last launch's result on the host (one read per launch, cached)."""
        if self._value is None:
            self._value = self.result.numpy()[0]
        return self._value


def reduce(launcher: Launcher, values: wp.array, op: str, n: int | None = None):
    """One-off ``op`` over ``values`` (first ``n`` items), returned on the host."""
    r = Reduction(launcher, values.dtype, op)
    r.launch(values, n)
    return r.value()
