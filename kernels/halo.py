"""Packing and unpacking the ghost rows of a halo exchange on the device (``warpfree.parallel.halo``).

A rank sends each neighbour rank the rows of the items it owns that the neighbour holds as ghosts, and receives the
rows of its own ghosts. Per refreshed array, one launch packs every outgoing row into the send buffer and one
unpacks every incoming row into its ghost row, over all neighbours at once:

    pack:    block[slots[k]] = values[rows[k]]      k over the rows sent (all neighbours in turn)
    unpack:  values[rows[k]] = block[slots[k]]      k over the rows received

``rows``: held rows (int32); ``slots``: each row's element in ``block``, the message buffer seen as an array of the
values' type (each field's block in a message starts on a multiple of its item size). Both are copies: no
arithmetic, so a ghost holds its owner's value bit for bit. ``fill_rows`` sets chosen rows to one value. Race-free: a packed slot, and an unpacked ghost row
(each ghost has one owner), is written once. Generic over the values' type; the types the solvers refresh (float32,
vec3, vec4) and float64, int32 are declared here, so the module compiles them all at its first load.
"""

from typing import Any

import warp as wp

#: the value types a refresh packs (each an overload of both kernels)
TYPES = (wp.float32, wp.float64, wp.int32, wp.vec3, wp.vec4)


@wp.kernel
def pack_rows(first: int, values: wp.array(dtype=Any), rows: wp.array(dtype=wp.int32),
              slots: wp.array(dtype=wp.int32), block: wp.array(dtype=Any)):
    """Outgoing row k: ``block[slots[k]] = values[rows[k]]``."""
    k = first + wp.tid()
    block[slots[k]] = values[rows[k]]


@wp.kernel
def unpack_rows(first: int, block: wp.array(dtype=Any), slots: wp.array(dtype=wp.int32),
                rows: wp.array(dtype=wp.int32), values: wp.array(dtype=Any)):
    """Incoming row k: ``values[rows[k]] = block[slots[k]]``."""
    k = first + wp.tid()
    values[rows[k]] = block[slots[k]]


@wp.kernel
def fill_rows(first: int, rows: wp.array(dtype=wp.int32), value: Any, values: wp.array(dtype=Any)):
    """Row k of ``rows``: ``values[rows[k]] = value`` (e.g. the ghost rows of an array reduced over owned rows)."""
    k = first + wp.tid()
    values[rows[k]] = value


for _t in TYPES:
    wp.overload(pack_rows, {"values": wp.array(dtype=_t), "block": wp.array(dtype=_t)})
    wp.overload(unpack_rows, {"block": wp.array(dtype=_t), "values": wp.array(dtype=_t)})
    wp.overload(fill_rows, {"value": _t, "values": wp.array(dtype=_t)})
