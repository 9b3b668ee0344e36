"""Neighbour kernels over ``wp.HashGrid``: periodic image points and neighbour rows.

Rows. Every neighbour structure, static CSR lists and fixed-capacity tables of moving sets alike,
is a :class:`NeighbourRows`: row ``i`` holds ``count[i]`` source indices at
``index[start[i] : start[i] + count[i]]``. A solver kernel loops over a row the same way whatever
built it, and tests the true distance (rows of moving sets hold candidates within radius + skin).

Periodic boxes. The grid is built over the source points plus their images: a point closer than the
query radius to a periodic face gets a copy shifted by ±L across it (up to 3 in 2D, 7 in 3D, one
per combination of faces it is close to). ``source_id`` maps every grid point to its original; rows
store original indices, and solver kernels take the minimum-image displacement
(``warpfree.kernels.space``). HashGrid's own wrap-around is never used (Warp issue #283).

A HashGrid query returns candidates from nearby and aliased cells: every loop here tests the
distance. Positions are float32 ``vec3`` (z = 0 in 2D, y = z = 0 in 1D). Gather form: thread ``i``
writes only its own row or its own image slots, so any thread count gives the same rows in the same
order.

Fixed points gathering from moving ones (:class:`GatherCopies`): the moving points' grid holds no images; a fixed
point queries it at each of its own static periodic copies instead (:func:`copy_takes`).
"""

import warp as wp

from .space import Box, displacement, image_displacement


@wp.struct
class NeighbourRows:
    """Row i: ``index[start[i] : start[i] + count[i]]`` (source indices)."""

    start: wp.array(dtype=wp.int32)
    count: wp.array(dtype=wp.int32)
    index: wp.array(dtype=wp.int32)


@wp.func
def image_side(box: Box, x: wp.vec3, margin: float, axis: int) -> int:
    """+1 if x is within ``margin`` of the lower periodic face of ``axis`` (its image goes to +L),
    -1 if within ``margin`` of the upper face (image at -L), 0 otherwise or if the axis is free."""
    side = int(0)
    if box.periodic[axis] != 0.0:
        if x[axis] - box.lower[axis] < margin:
            side = 1
        elif box.lower[axis] + box.length[axis] - x[axis] < margin:
            side = -1
    return side


@wp.kernel
def count_images(
    first: int,
    points: wp.array(dtype=wp.vec3),
    box: Box,
    margin: float,
    counts: wp.array(dtype=wp.int32),
):
    """counts[i] = number of images of point i: (1+|s_x|)(1+|s_y|)(1+|s_z|) - 1, s from image_side."""
    i = first + wp.tid()
    x = points[i]
    n = int(1)
    for a in range(3):
        if image_side(box, x, margin, a) != 0:
            n = n * 2
    counts[i] = n - 1


@wp.kernel
def place_images(
    first: int,
    points: wp.array(dtype=wp.vec3),
    box: Box,
    margin: float,
    offsets: wp.array(dtype=wp.int32),
    n_points: int,
    extended: wp.array(dtype=wp.vec3),
    source_id: wp.array(dtype=wp.int32),
):
    """Copy point i to ``extended[i]`` and its images to ``extended[n_points + offsets[i] + k]``.

    Image k of the combinations (mask 1..7 over the axes with a non-zero side) is shifted by
    side_a · L_a along every axis a in the mask. ``source_id`` maps each slot back to i.
    """
    i = first + wp.tid()
    x = points[i]
    extended[i] = x
    source_id[i] = i
    sx = image_side(box, x, margin, 0)
    sy = image_side(box, x, margin, 1)
    sz = image_side(box, x, margin, 2)
    k = n_points + offsets[i]
    for mask in range(1, 8):
        use_x = (mask & 1) != 0
        use_y = (mask & 2) != 0
        use_z = (mask & 4) != 0
        if (use_x and sx == 0) or (use_y and sy == 0) or (use_z and sz == 0):
            continue
        shift = wp.vec3(0.0, 0.0, 0.0)
        if use_x:
            shift = shift + wp.vec3(float(sx) * box.length[0], 0.0, 0.0)
        if use_y:
            shift = shift + wp.vec3(0.0, float(sy) * box.length[1], 0.0)
        if use_z:
            shift = shift + wp.vec3(0.0, 0.0, float(sz) * box.length[2])
        extended[k] = x + shift
        source_id[k] = i
        k += 1


@wp.kernel
def fill_rows(
    first: int,
    grid: wp.uint64,
    query_points: wp.array(dtype=wp.vec3),
    grid_points: wp.array(dtype=wp.vec3),
    source_id: wp.array(dtype=wp.int32),
    radius: float,
    exclude_self: int,
    capacity: int,
    room: wp.array(dtype=wp.int32),
    start: wp.array(dtype=wp.int32),
    count: wp.array(dtype=wp.int32),
    index: wp.array(dtype=wp.int32),
):
    """Row i: the sources within ``radius`` of query i (strictly closer), in HashGrid order.

    Writes the first ``capacity`` of them (``room[i]`` when ``room`` is not empty: a compact table's rows) at
    ``index[start[i]:]`` and the true number to ``count[i]`` (capacity 0: count only, the first pass of a CSR build;
    a count above the room tells a table to lay its rows out again). ``exclude_self`` drops source i from row i
    (query set = source set).
    """
    i = first + wp.tid()
    x = query_points[i]
    r2 = radius * radius
    base = start[i]
    if room.shape[0] > 0:  # a compact table's row: its room, and never past the index's end
        capacity = wp.max(wp.min(room[i], index.shape[0] - base), 0)
    n = int(0)
    for k in wp.hash_grid_query(grid, x, radius):
        j = source_id[k]
        if exclude_self != 0 and j == i:
            continue
        d = image_displacement(x, grid_points[k])
        if wp.dot(d, d) < r2:
            if n < capacity:
                index[base + n] = j
            n += 1
    count[i] = n


@wp.struct
class PairGrid:
    """A moving set's pairs read straight from its grid, with no rows stored (``warpfree.neighbours.NeighbourGrid``):
    the HashGrid ``grid`` over ``points`` (the set's positions at the last build, then their periodic images),
    ``source_id`` from grid point to particle, and ``reach`` (radius + skin, the grid's radius). A query at particle
    i's position at build, kept to the copies within ``reach`` (:func:`pair_in_reach`), visits the candidates a
    table's row i holds, in the same order."""

    grid: wp.uint64
    points: wp.array(dtype=wp.vec3)
    source_id: wp.array(dtype=wp.int32)
    reach: float


@wp.func
def pair_in_reach(pairs: PairGrid, at: wp.vec3, k: int) -> bool:
    """Does grid point k lie strictly within ``pairs.reach`` of ``at`` (a particle's position at build)? The test a
    table's fill makes (:func:`fill_rows`): with periodic sides >= 2 reach, one copy of a particle at most passes."""
    d = image_displacement(at, pairs.points[k])
    return wp.dot(d, d) < pairs.reach * pairs.reach


@wp.struct
class GatherCopies:
    """A grid over moving points that fixed points gather from at their periodic copies, as kernels read it
    (``warpfree.neighbours.GatherGrid``): the HashGrid ``grid`` over the moving points (no images; cell = ``radius``,
    the query radius) and fixed point i's copies, float32 offsets ``shift[start[i] : start[i + 1]]`` from the point
    (its own first, zero); ``periodic`` 1 when the box has a periodic axis."""

    grid: wp.uint64
    start: wp.array(dtype=wp.int32)
    shift: wp.array(dtype=wp.vec3)
    radius: float
    periodic: int


@wp.func
def copy_takes(copies: GatherCopies, at: wp.vec3, x: wp.vec3) -> bool:
    """Does the fixed point's copy at ``at`` take the moving point at ``x`` its query returned? In a periodic box only
    the copy within ``radius`` of it (a side >= 2 radius leaves one such copy: no moving point is found twice);
    otherwise the point has one copy, which takes every candidate (the caller tests its own distance or support)."""
    if copies.periodic != 0:
        r = at - x
        if wp.dot(r, r) >= copies.radius * copies.radius:
            return False
    return True


@wp.kernel
def fill_gather_rows(
    first: int,
    copies: GatherCopies,
    fixed_points: wp.array(dtype=wp.vec3),
    moving_points: wp.array(dtype=wp.vec3),
    capacity: int,
    room: wp.array(dtype=wp.int32),
    start: wp.array(dtype=wp.int32),
    count: wp.array(dtype=wp.int32),
    index: wp.array(dtype=wp.int32),
):
    """Row i: the moving points strictly within ``copies.radius`` of fixed point i (of one of its periodic copies), in
    copy then HashGrid order; ``capacity``, ``room`` and ``count`` as in :func:`fill_rows`."""
    i = first + wp.tid()
    r2 = copies.radius * copies.radius
    base = start[i]
    if room.shape[0] > 0:  # a compact table's row: its room, and never past the index's end
        capacity = wp.max(wp.min(room[i], index.shape[0] - base), 0)
    n = int(0)
    for s in range(copies.start[i], copies.start[i + 1]):
        at = fixed_points[i] + copies.shift[s]
        for p in wp.hash_grid_query(copies.grid, at, copies.radius):
            d = at - moving_points[p]
            if wp.dot(d, d) < r2:
                if n < capacity:
                    index[base + n] = p
                n += 1
    count[i] = n


@wp.kernel
def table_rooms(first: int, count: wp.array(dtype=wp.int32), room: wp.array(dtype=wp.int32)):
    """room[i] = count[i] + count[i]/10 + 2: a compact table's row, laid out for the count it had at the last fill
    and the change the skin allows before the next."""
    i = first + wp.tid()
    room[i] = count[i] + count[i] / 10 + 2


@wp.kernel
def table_overflow(first: int, start: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32),
                   room: wp.array(dtype=wp.int32), entries: int):
    """room[i] = count[i] - room[i] in place, or at least 1 where row i's room runs past the index's ``entries``
    (> 0: row i did not fit; the table reduces the max, race-free, and lays its rooms out again from the counts)."""
    i = first + wp.tid()
    excess = count[i] - room[i]
    if start[i] + room[i] > entries:
        excess = wp.max(excess, 1)
    room[i] = excess


@wp.kernel
def count_neighbours_brute(
    first: int,
    box: Box,
    query_points: wp.array(dtype=wp.vec3),
    source_points: wp.array(dtype=wp.vec3),
    radius: float,
    exclude_self: int,
    counts: wp.array(dtype=wp.int32),
):
    """Brute-force O(N M) reference: #{j : |r_ij| < radius}, minimum image along periodic axes."""
    i = first + wp.tid()
    x = query_points[i]
    r2 = radius * radius
    n = int(0)
    for j in range(source_points.shape[0]):
        if exclude_self != 0 and j == i:
            continue
        d = displacement(box, x, source_points[j])
        if wp.dot(d, d) < r2:
            n += 1
    counts[i] = n
