"""NeighbourGrid, neighbour_counts and neighbour_list against brute force (warpfree/neighbours.py).

Counts from the HashGrid must equal the O(N M) brute-force kernel exactly: both test the same float32
distance ``|x_i - y_j| < radius`` (strict), so any difference is a missed or duplicated candidate.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpfree import neighbours as nb
from warpfree.errors import ParameterError
from warpfree.neighbours import NeighbourGrid, neighbour_counts, neighbour_counts_brute, neighbour_list


def check_counts(launcher, grid, query, exclude_self=False, min_mean=1.0):
    """Grid counts == brute-force counts; returns the counts. ``min_mean`` guards against a vacuous test."""
    got = neighbour_counts(launcher, grid, query, exclude_self=exclude_self)
    ref = neighbour_counts_brute(launcher, query, grid.positions, grid.radius, exclude_self=exclude_self)
    assert got.dtype == np.int32 and got.shape == (query.shape[0],)
    mismatch = np.flatnonzero(got != ref)
    assert mismatch.size == 0, (
        f"{mismatch.size} of {len(ref)} counts differ, e.g. query {mismatch[0]}: grid {got[mismatch[0]]} "
        f"vs brute {ref[mismatch[0]]}"
    )
    assert ref.mean() >= min_mean
    return got


def rows(offsets: wp.array, indices: wp.array) -> list[np.ndarray]:
    off = offsets.numpy()
    idx = indices.numpy()
    return [idx[off[i]:off[i + 1]] for i in range(len(off) - 1)]


def check_csr(launcher, grid, query_np, query, exclude_self=False):
    """Each CSR row is exactly the set of sources within the cut-off (NumPy, float64 distances).

    Pairs within 1e-5 of the cut-off could go either way in float32, so a row must contain every
    source with d < r - 1e-5 and only sources with d < r + 1e-5; its length must equal the brute count.
    """
    offsets, indices = neighbour_list(launcher, grid, query, exclude_self=exclude_self)
    src = grid.positions.numpy().astype(np.float64)
    q = np.asarray(query_np, dtype=np.float32).astype(np.float64)
    d = np.linalg.norm(q[:, None, :] - src[None, :, :], axis=2)
    if exclude_self:
        n = min(len(q), len(src))
        d[np.arange(n), np.arange(n)] = np.inf
    r = grid.radius
    ref_counts = neighbour_counts_brute(launcher, query, grid.positions, r, exclude_self=exclude_self)
    off = offsets.numpy()
    assert off.shape == (len(q) + 1,) and off[0] == 0
    assert np.array_equal(np.diff(off), ref_counts)
    for i, row in enumerate(rows(offsets, indices)):
        s = set(row.tolist())
        assert len(s) == len(row), f"row {i} has duplicates"
        sure = set(np.flatnonzero(d[i] < r - 1e-5).tolist())
        maybe = set(np.flatnonzero(d[i] < r + 1e-5).tolist())
        assert sure <= s <= maybe, f"row {i}: missing {sorted(sure - s)}, extra {sorted(s - maybe)}"
    return offsets, indices


# --- counts vs brute force ---------------------------------------------------------------------------


@pytest.mark.parametrize("policy", ["always", "static"])
def test_random_3d_negative_coordinates(launcher, vec3, policy):
    rng = np.random.default_rng(0)
    p = rng.uniform(-1.0, 1.0, size=(4000, 3))
    x = vec3(p)
    grid = NeighbourGrid(x, 0.15, dim=3, policy=policy)
    check_counts(launcher, grid, x, min_mean=5.0)
    check_counts(launcher, grid, x, exclude_self=True, min_mean=5.0)


def test_2d_set(launcher, vec3):
    rng = np.random.default_rng(1)
    p = rng.uniform(-1.0, 1.0, size=(4000, 2))
    x = vec3(p)
    grid = NeighbourGrid(x, 0.08, dim=2)
    check_counts(launcher, grid, x, min_mean=5.0)
    check_counts(launcher, grid, x, exclude_self=True, min_mean=5.0)


def test_1d_set(launcher, vec3):
    rng = np.random.default_rng(14)
    p = np.zeros((2000, 3))
    p[:, 0] = rng.uniform(-1.0, 1.0, size=2000)
    x = vec3(p)
    grid = NeighbourGrid(x, 0.01, dim=1)
    check_counts(launcher, grid, x, min_mean=5.0)


def test_empty_sets(launcher, vec3):
    rng = np.random.default_rng(15)
    x = vec3(rng.uniform(-1.0, 1.0, size=(50, 3)))
    empty = wp.zeros(0, dtype=wp.vec3, device="cpu")
    grid = NeighbourGrid(x, 0.3, dim=3)
    assert neighbour_counts(launcher, grid, empty).shape == (0,)
    offsets, _ = neighbour_list(launcher, grid, empty)
    assert np.array_equal(offsets.numpy(), [0])
    grid_empty = NeighbourGrid(empty, 0.3, dim=3)
    assert np.all(neighbour_counts(launcher, grid_empty, x) == 0)
    offsets, _ = neighbour_list(launcher, grid_empty, x)
    assert np.all(offsets.numpy() == 0)


def test_exclude_self(launcher, vec3):
    rng = np.random.default_rng(2)
    x = vec3(rng.uniform(-0.5, 0.5, size=(2000, 3)))
    grid = NeighbourGrid(x, 0.1, dim=3)
    with_self = check_counts(launcher, grid, x)
    without = check_counts(launcher, grid, x, exclude_self=True)
    assert np.array_equal(with_self, without + 1)  # distinct points: each sees itself exactly once
    assert np.all(with_self >= 1)


@pytest.mark.parametrize("dim", [2, 3])
def test_points_on_cell_faces_strict_cutoff(launcher, vec3, dim):
    """A lattice with spacing == radius: every point sits on a cell face and its nearest neighbours are
    at exactly the cut-off, which is excluded (strict ``<``)."""
    s = 0.25  # exact in float32, so lattice distances are exact too
    k = np.arange(-6, 7)
    idx = np.stack(np.meshgrid(*[k] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    p = idx * s
    x = vec3(p)
    grid = NeighbourGrid(x, s, dim=dim)
    # NumPy agrees on the geometry: the smallest distance is exactly the radius
    d = np.linalg.norm(p[:50, None, :] - p[None, :, :], axis=2)
    d[d == 0.0] = np.inf
    assert d.min() == s
    brute = neighbour_counts_brute(launcher, x, x, s, exclude_self=True)
    assert np.all(brute == 0)
    assert np.all(neighbour_counts(launcher, grid, x, exclude_self=True) == 0)
    assert np.all(check_counts(launcher, grid, x) == 1)
    offsets, _ = neighbour_list(launcher, grid, x, exclude_self=True)
    assert np.all(offsets.numpy() == 0)

    # radius = 2 * spacing: every other lattice plane is a cell face; interior points see
    # (dim 2) 8 neighbours with |k|^2 in {1, 2, 3} (the 4 at |k| = 2 exactly are excluded), (dim 3) 26.
    grid2 = NeighbourGrid(x, 2 * s, dim=dim)
    counts = check_counts(launcher, grid2, x, exclude_self=True)
    interior = np.all(np.abs(idx) <= 4, axis=1)
    assert np.all(counts[interior] == (8 if dim == 2 else 26))


def test_cross_set_query(launcher, vec3):
    """Query points from one set, sources from another, different sizes; queries may lie outside."""
    rng = np.random.default_rng(3)
    src_np = rng.uniform(-1.0, 1.0, size=(3000, 3))
    qry_np = rng.uniform(-1.3, 1.3, size=(1100, 3))
    src = vec3(src_np)
    qry = vec3(qry_np)
    grid = NeighbourGrid(src, 0.2, dim=3, policy="static")
    check_counts(launcher, grid, qry, min_mean=5.0)
    check_csr(launcher, grid, qry_np, qry)
    # and the other way round (a bigger query set than the source set)
    grid_q = NeighbourGrid(qry, 0.2, dim=3)
    check_counts(launcher, grid_q, src, min_mean=1.0)


@pytest.mark.parametrize("offset", [1.0e3, -1.0e3])
def test_large_offset(launcher, vec3, offset):
    rng = np.random.default_rng(4)
    p = offset + rng.uniform(0.0, 1.0, size=(3000, 3))
    x = vec3(p)
    grid = NeighbourGrid(x, 0.1, dim=3)
    check_counts(launcher, grid, x, min_mean=5.0)
    check_counts(launcher, grid, x, exclude_self=True, min_mean=5.0)


def test_aliasing_clusters_3d(launcher, vec3):
    """50k points in 8 clusters placed exactly one hash-table period apart, so their cells share buckets;
    candidates from aliased cells must be rejected by the distance test."""
    n = 50_000
    radius = 0.1
    side = nb._grid_dims(3, n)[0]
    period = side * radius  # cell width == query radius for the default policy
    rng = np.random.default_rng(5)
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 2)], dtype=np.float64)
    p = rng.uniform(0.0, 1.0, size=(n, 3)) + corners[rng.integers(0, 8, size=n)] * period - 0.5 * period
    x = vec3(p)
    grid = NeighbourGrid(x, radius, dim=3)
    q = vec3(p[:2000])  # a prefix, so exclude_self (j == i) keeps its meaning
    check_counts(launcher, grid, q, min_mean=10.0)
    check_counts(launcher, grid, q, exclude_self=True, min_mean=10.0)


def test_more_points_than_hash_cells_2d(launcher, vec3):
    """100k points in 2D: more points than the 256x256 hash table, in a box spanning ~400 cells/axis."""
    n = 100_000
    dims = nb._grid_dims(2, n)
    assert n > dims[0] * dims[1] * dims[2]
    rng = np.random.default_rng(6)
    p = rng.uniform(-4.0, 4.0, size=(n, 2))
    x = vec3(p)
    grid = NeighbourGrid(x, 0.02, dim=2)
    q = vec3(p[:1000])
    check_counts(launcher, grid, q, min_mean=1.0)
    check_counts(launcher, grid, q, exclude_self=True, min_mean=0.5)


# --- CSR lists -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("exclude_self", [False, True])
def test_neighbour_list_rows_match_brute_force(launcher, vec3, dim, exclude_self):
    rng = np.random.default_rng(7 + dim)
    p = rng.uniform(-1.0, 1.0, size=(700, dim))
    x = vec3(p)
    p3 = x.numpy()
    grid = NeighbourGrid(x, 0.3 if dim == 3 else 0.15, dim=dim, policy="static")
    offsets, indices = check_csr(launcher, grid, p3, x, exclude_self=exclude_self)
    assert offsets.numpy()[-1] > 5 * len(p)
    for i, row in enumerate(rows(offsets, indices)):
        assert (i in set(row.tolist())) != exclude_self


def test_neighbour_list_thread_count_independent(make_launcher, vec3):
    rng = np.random.default_rng(9)
    x = vec3(rng.uniform(-1.0, 1.0, size=(3000, 3)))
    grid = NeighbourGrid(x, 0.2, dim=3)
    ref = neighbour_list(make_launcher(threads=1), grid, x)
    for threads in (2, 3):
        got = neighbour_list(make_launcher(threads=threads), grid, x)
        assert np.array_equal(got[0].numpy(), ref[0].numpy())
        assert np.array_equal(got[1].numpy(), ref[1].numpy())  # same lists in the same order


# --- rebuild policy ------------------------------------------------------------------------------------


def test_policy_static_never_rebuilds(launcher, vec3):
    rng = np.random.default_rng(10)
    p = rng.uniform(-1.0, 1.0, size=(500, 3))
    grid = NeighbourGrid(vec3(p), 0.2, dim=3, policy="static")
    assert grid.builds == 1
    assert grid.query_radius == grid.radius
    for shift in (0.0, 0.01, 5.0):
        assert grid.update(vec3(p + shift)) is False
        assert grid.update() is False
    assert grid.builds == 1


def test_policy_always_rebuilds(launcher, vec3):
    rng = np.random.default_rng(11)
    p = rng.uniform(-1.0, 1.0, size=(1500, 3))
    grid = NeighbourGrid(vec3(p), 0.2, dim=3, policy="always")
    assert grid.query_radius == grid.radius
    for k in range(1, 4):
        moved = p + rng.normal(scale=0.3, size=p.shape)  # far more than a cell
        assert grid.update(vec3(moved)) is True
        assert grid.builds == 1 + k
        check_counts(launcher, grid, grid.positions, min_mean=3.0)
    assert grid.update() is True
    assert grid.builds == 5


def _moved(rng, p, distance):
    """Every point moved by exactly ``distance`` (float64) in a random direction."""
    d = rng.normal(size=p.shape)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return p + distance * d


def test_policy_skin(launcher, vec3):
    rng = np.random.default_rng(12)
    radius, skin = 0.15, 0.06
    p = rng.uniform(-1.0, 1.0, size=(3000, 3))
    grid = NeighbourGrid(vec3(p), radius, dim=3, policy="skin", skin=skin)
    assert grid.query_radius == pytest.approx(radius + skin)
    assert grid.builds == 1
    ref_before = neighbour_counts_brute(launcher, grid.positions, grid.positions, radius)

    # every point moves 0.45 * skin: no rebuild, and the counts with the stale grid are still exact
    p1 = _moved(rng, p, 0.45 * skin)
    x1 = vec3(p1)
    assert grid.update(x1) is False
    assert grid.builds == 1
    assert grid.positions is x1
    counts = check_counts(launcher, grid, x1, min_mean=3.0)
    check_counts(launcher, grid, x1, exclude_self=True, min_mean=3.0)
    assert not np.array_equal(counts, ref_before), "the move should change some neighbourhoods"
    check_csr(launcher, grid, x1.numpy()[:400], vec3(x1.numpy()[:400]))

    # moving in place (same array) is seen too: drift further, past skin/2 in total -> rebuild
    p2 = _moved(rng, p1, 0.2 * skin)
    drift = np.max(np.linalg.norm(p2.astype(np.float32) - p.astype(np.float32), axis=1))
    assert drift > 0.5 * skin
    x1.assign(p2.astype(np.float32))
    assert grid.update() is True
    assert grid.builds == 2
    check_counts(launcher, grid, x1, min_mean=3.0)

    # a move well beyond skin/2 rebuilds; counts stay exact
    builds = grid.builds
    p3 = _moved(rng, p2, 2.0 * skin)
    x3 = vec3(p3)
    assert grid.update(x3) is True
    assert grid.builds == builds + 1
    check_counts(launcher, grid, x3, min_mean=3.0)
    # right after a rebuild, a tiny move does not rebuild
    assert grid.update(vec3(p3 + 1e-3 * skin)) is False
    assert grid.builds == builds + 1


def test_skin_drift_measured_from_last_build(launcher, vec3):
    """Small steps that each stay below skin/2 but add up beyond it trigger a rebuild."""
    rng = np.random.default_rng(13)
    radius, skin = 0.2, 0.1
    p = rng.uniform(-1.0, 1.0, size=(800, 3))
    grid = NeighbourGrid(vec3(p), radius, dim=3, policy="skin", skin=skin)
    direction = np.array([1.0, 0.0, 0.0])
    rebuilt = []
    for k in range(1, 9):
        x = vec3(p + k * 0.2 * skin * direction)
        rebuilt.append(grid.update(x))
        check_counts(launcher, grid, x, min_mean=3.0)
    # moved 0.2, 0.4 (no), 0.6 (> 0.5: rebuild), then 0.2, 0.4 (no), 0.6 (rebuild), ...
    assert rebuilt == [False, False, True, False, False, True, False, False]
    assert grid.builds == 3


# --- bad input ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("radius", [0.0, -0.1, float("nan"), float("inf"), "x"])
def test_bad_radius(vec3, radius):
    x = vec3(np.zeros((4, 3)))
    with pytest.raises(ParameterError, match="radius"):
        NeighbourGrid(x, radius, dim=3)


@pytest.mark.parametrize("policy", ["sometimes", "", "Static", None])
def test_bad_policy(vec3, policy):
    x = vec3(np.zeros((4, 3)))
    with pytest.raises(ParameterError, match="policy"):
        NeighbourGrid(x, 0.1, dim=3, policy=policy)


@pytest.mark.parametrize("skin", [0.0, -0.01, float("nan")])
def test_bad_skin(vec3, skin):
    x = vec3(np.zeros((4, 3)))
    with pytest.raises(ParameterError, match="skin"):
        NeighbourGrid(x, 0.1, dim=3, policy="skin", skin=skin)


def test_bad_dim(vec3):
    with pytest.raises(ParameterError, match="dim"):
        NeighbourGrid(vec3(np.zeros((4, 3))), 0.1, dim=4)


def test_neighbour_table_rows_equal_brute_force_and_grow_when_full(make_launcher):
    """The one-pass fixed-capacity table: same neighbour sets as brute force; a too-small capacity
    grows until every row fits (nothing dropped), bitwise the same for 1 and 2 threads."""
    from warpfree.neighbours import NeighbourTable

    rng = np.random.default_rng(3)
    pts = rng.uniform(-1.0, 1.0, size=(3000, 3)).astype(np.float32)
    r = 0.2
    tables = []
    for threads in (1, 2):
        launcher = make_launcher(threads=threads)
        x = wp.array(pts, dtype=wp.vec3, device=launcher.device)
        grid = NeighbourGrid(x, r, 3, policy="static")
        table = NeighbourTable(launcher, capacity=4)
        table.fill(grid, x, exclude_self=True)
        assert table.grows >= 1 and table.capacity >= table.counts.numpy().max()
        tables.append((table.counts.numpy().copy(), table.indices.numpy().copy(), table.capacity))
    counts, indices, cap = tables[0]
    assert np.array_equal(counts, tables[1][0]) and np.array_equal(indices, tables[1][1])
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=-1)
    for i in range(0, len(pts), 97):
        expect = set(np.flatnonzero((d[i] < r) & (np.arange(len(pts)) != i)).tolist())
        got = indices[i * cap: i * cap + counts[i]].tolist()
        assert len(got) == len(set(got)) and set(got) == expect
