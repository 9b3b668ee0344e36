"""Neighbour kernels over ``wp.HashGrid``: counts and CSR neighbour lists (same-set and cross-set).

A HashGrid query returns candidates from nearby (and aliased) cells; every loop here tests the real
distance. Positions are float32 ``vec3`` (2D sets have z = 0). Gather form: thread ``i`` writes only
row ``i`` of the output, so any thread count gives the same lists in the same order.
"""

import warp as wp


@wp.kernel
def count_neighbours(
    first: int,
    grid: wp.uint64,
    query_points: wp.array(dtype=wp.vec3),
    source_points: wp.array(dtype=wp.vec3),
    query_radius: float,
    radius: float,
    exclude_self: int,
    counts: wp.array(dtype=wp.int32),
):
    """counts[i] = #{j : |x_i - y_j| < radius} (j != i when ``exclude_self``)."""
    i = first + wp.tid()
    x = query_points[i]
    n = int(0)
    for j in wp.hash_grid_query(grid, x, query_radius):
        if exclude_self != 0 and j == i:
            continue
        if wp.length(x - source_points[j]) < radius:
            n += 1
    counts[i] = n


@wp.kernel
def fill_neighbours(
    first: int,
    grid: wp.uint64,
    query_points: wp.array(dtype=wp.vec3),
    source_points: wp.array(dtype=wp.vec3),
    query_radius: float,
    radius: float,
    exclude_self: int,
    offsets: wp.array(dtype=wp.int32),
    indices: wp.array(dtype=wp.int32),
):
    """Write the neighbour indices of query i into indices[offsets[i]:offsets[i+1]]."""
    i = first + wp.tid()
    x = query_points[i]
    k = offsets[i]
    for j in wp.hash_grid_query(grid, x, query_radius):
        if exclude_self != 0 and j == i:
            continue
        if wp.length(x - source_points[j]) < radius:
            indices[k] = j
            k += 1


@wp.kernel
def count_neighbours_brute(
    first: int,
    query_points: wp.array(dtype=wp.vec3),
    source_points: wp.array(dtype=wp.vec3),
    radius: float,
    exclude_self: int,
    counts: wp.array(dtype=wp.int32),
):
    """Brute-force O(N M) reference for :func:`count_neighbours`."""
    i = first + wp.tid()
    x = query_points[i]
    n = int(0)
    for j in range(source_points.shape[0]):
        if exclude_self != 0 and j == i:
            continue
        if wp.length(x - source_points[j]) < radius:
            n += 1
    counts[i] = n


@wp.kernel
def fill_neighbour_table(
    first: int,
    grid: wp.uint64,
    query_points: wp.array(dtype=wp.vec3),
    source_points: wp.array(dtype=wp.vec3),
    query_radius: float,
    radius: float,
    exclude_self: int,
    capacity: int,
    counts: wp.array(dtype=wp.int32),
    indices: wp.array(dtype=wp.int32),
):
    """One-pass fixed-capacity table: row i holds its first ``capacity`` neighbours at
    indices[i*capacity:]; counts[i] is the true count (> capacity means the table must grow)."""
    i = first + wp.tid()
    x = query_points[i]
    base = i * capacity
    n = int(0)
    for j in wp.hash_grid_query(grid, x, query_radius):
        if exclude_self != 0 and j == i:
            continue
        if wp.length(x - source_points[j]) < radius:
            if n < capacity:
                indices[base + n] = j
            n += 1
    counts[i] = n
