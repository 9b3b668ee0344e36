"""Reductions on the device (max, min, sum) in two passes over fixed blocks.

Pass 1: thread b combines items [b·B, min((b+1)·B, n)) of the input into ``partial[b]``; pass 2 runs
the same kernel with one thread over the partials. No atomics: every thread writes only its own
slot, so a reduction may be chunked over CPU threads. The block layout depends only on n and B,
never on the thread count, so sums are bitwise the same for any thread count (and max/min are exact
anyway). Sums accumulate in the accumulator type (float64 for float32 input).

Kernels are made per (input type, accumulator type, operation) by :func:`block_reduce_kernel` and
cached; each lives in its own Warp module.
"""

import warp as wp

_kernels: dict = {}

OPERATIONS = ("max", "min", "sum")


def block_reduce_kernel(dtype, acc_dtype, op: str):
    """``kernel(first, values: array(dtype), n, block, empty: acc_dtype, partial: array(acc_dtype))``.

    ``op``: "max", "min" (component-wise for vectors) or "sum". A block without items (n = 0)
    writes ``empty`` (the caller passes the type's zero).
    """
    if op not in OPERATIONS:
        raise ValueError(f"op: must be one of {OPERATIONS}, got {op!r}")
    key = (dtype, acc_dtype, op)
    if key in _kernels:
        return _kernels[key]

    @wp.func
    def combine(a: acc_dtype, b: acc_dtype) -> acc_dtype:
        if wp.static(op == "max"):
            return wp.max(a, b)
        elif wp.static(op == "min"):
            return wp.min(a, b)
        else:
            return a + b

    @wp.kernel(module="unique")
    def block_reduce(first: int, values: wp.array(dtype=dtype), n: int, block: int, empty: acc_dtype,
                     partial: wp.array(dtype=acc_dtype)):
        b = first + wp.tid()
        lo = b * block
        hi = wp.min(lo + block, n)
        acc = empty
        if lo < hi:
            acc = acc_dtype(values[lo])
            for k in range(lo + 1, hi):
                acc = combine(acc, acc_dtype(values[k]))
        partial[b] = acc

    _kernels[key] = block_reduce
    return block_reduce
