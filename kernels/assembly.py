"""Per-slot writers for race-free sparse assembly (float64).

An assembly kernel gives every work item (a Gauss point, a particle) its own contiguous range of
slots, ``slot = first_slot(item) + k``, and writes one matrix triplet ``(row, col, value)`` or one load
entry ``(row, value)`` per slot. No two items share a slot, so the kernel is a gather in the sense of
``warpfree.device.Launcher``: it can be chunked over threads and gives bitwise identical slots for any
thread count. Duplicates are summed afterwards, on the host, in slot order (``warpfree.sparse``).

A slot left with ``row = -1`` is unused and dropped on conversion (e.g. a Gauss point with fewer
neighbours than its slot budget).

float64: MLS moment matrices and EFG stiffness entries are ill-conditioned in float32.
"""

import warp as wp

UNUSED_ROW = wp.constant(-1)


@wp.struct
class Triplets:
    """Matrix entries ``K[rows[s], cols[s]] += values[s]``, one per slot ``s``."""

    rows: wp.array(dtype=wp.int32)
    cols: wp.array(dtype=wp.int32)
    values: wp.array(dtype=wp.float64)


@wp.struct
class Loads:
    """Right-hand-side entries ``b[rows[s]] += values[s]``, one per slot ``s``."""

    rows: wp.array(dtype=wp.int32)
    values: wp.array(dtype=wp.float64)


@wp.func
def write_triplet(t: Triplets, slot: int, row: int, col: int, value: wp.float64):
    """Write ``K[row, col] += value`` into ``slot`` (the slot must belong to the calling item)."""
    t.rows[slot] = wp.int32(row)
    t.cols[slot] = wp.int32(col)
    t.values[slot] = value


@wp.func
def write_load(b: Loads, slot: int, row: int, value: wp.float64):
    """Write ``b[row] += value`` into ``slot`` (the slot must belong to the calling item)."""
    b.rows[slot] = wp.int32(row)
    b.values[slot] = value
