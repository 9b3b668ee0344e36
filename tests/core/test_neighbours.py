"""Neighbour structures against brute force (warpfree/neighbours.py): free and periodic space, static
CSR lists, fixed-capacity tables, moving sets with a skin, node → particle gathers (with a skin, and through the
GatherGrid rebuilt every step).

Counts from the HashGrid must equal the O(N M) brute-force kernel exactly: both test the same float32
displacement (``warpfree.kernels.space``) against the radius (strict ``<``), so any difference is a
missed or duplicated candidate. Periodic boxes go through image points, the brute force through the
minimum image: equality checks the images.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import warp as wp

from helpers import kernels_for_tests as kt
from warpfree import neighbours as nb
from warpfree.errors import ParameterError
from warpfree.neighbours import (MovingNeighbours, NeighbourGrid, NeighbourList, NeighbourTable,
                                 neighbour_counts_brute)
from warpfree.space import Space


def free(dim=3):
    return Space.free(dim)


def check_counts(launcher, space, grid, source, query, exclude_self=False, min_mean=1.0):
    """NeighbourList counts == brute-force counts; returns the list. ``min_mean`` guards against a vacuous test."""
    lst = NeighbourList(grid, query, exclude_self=exclude_self)
    got = lst.counts()
    ref = neighbour_counts_brute(launcher, space, query, source, grid.radius, exclude_self=exclude_self)
    assert got.shape == (query.shape[0],)
    mismatch = np.flatnonzero(got != ref)
    assert mismatch.size == 0, (f"{mismatch.size} of {len(ref)} counts differ, e.g. query {mismatch[0]}: "
                                f"grid {got[mismatch[0]]} vs brute {ref[mismatch[0]]}")
    assert ref.mean() >= min_mean
    return lst


def check_rows(space, lst, query_np, source_np, radius, exclude_self=False):
    """Each row is exactly the set of sources within the radius (NumPy float64, minimum image); pairs within
    1e-5 of the radius may go either way in float32."""
    off, idx = lst.offsets(), lst.indices()
    q = np.asarray(query_np, np.float32).astype(np.float64)
    s = np.asarray(source_np, np.float32).astype(np.float64)
    d = np.linalg.norm(space.displacement(q[:, None, :], s[None, :, :]), axis=2)
    if exclude_self:
        n = min(len(q), len(s))
        d[np.arange(n), np.arange(n)] = np.inf
    for i in range(len(q)):
        row = idx[off[i]:off[i + 1]].tolist()
        assert len(set(row)) == len(row), f"row {i} has duplicates"
        sure = set(np.flatnonzero(d[i] < radius - 1e-5).tolist())
        maybe = set(np.flatnonzero(d[i] < radius + 1e-5).tolist())
        assert sure <= set(row) <= maybe, f"row {i}: missing {sorted(sure - set(row))}, extra {sorted(set(row) - maybe)}"


# --- free space -----------------------------------------------------------------------------------------


def test_random_3d_negative_coordinates(launcher, vec3):
    rng = np.random.default_rng(0)
    x = vec3(rng.uniform(-1.0, 1.0, size=(4000, 3)))
    grid = NeighbourGrid(launcher, 0.15, free(), x)
    check_counts(launcher, free(), grid, x, x, min_mean=5.0)
    check_counts(launcher, free(), grid, x, x, exclude_self=True, min_mean=5.0)


@pytest.mark.parametrize("dim", [1, 2])
def test_1d_and_2d_sets(launcher, vec3, dim):
    rng = np.random.default_rng(dim)
    p = np.zeros((3000, 3))
    p[:, :dim] = rng.uniform(-1.0, 1.0, size=(3000, dim))
    x = vec3(p)
    grid = NeighbourGrid(launcher, 0.01 if dim == 1 else 0.08, free(dim), x)
    check_counts(launcher, free(dim), grid, x, x, min_mean=5.0)
    check_counts(launcher, free(dim), grid, x, x, exclude_self=True, min_mean=4.0)


def test_empty_sets(launcher, vec3):
    rng = np.random.default_rng(15)
    x = vec3(rng.uniform(-1.0, 1.0, size=(50, 3)))
    empty = wp.zeros(0, dtype=wp.vec3, device="cpu")
    grid = NeighbourGrid(launcher, 0.3, free(), x)
    lst = NeighbourList(grid, empty)
    assert lst.counts().shape == (0,) and np.array_equal(lst.offsets(), [0])
    grid_empty = NeighbourGrid(launcher, 0.3, free(), empty)
    lst = NeighbourList(grid_empty, x)
    assert np.all(lst.counts() == 0) and np.all(lst.offsets() == 0)


def test_exclude_self(launcher, vec3):
    rng = np.random.default_rng(2)
    x = vec3(rng.uniform(-0.5, 0.5, size=(2000, 3)))
    grid = NeighbourGrid(launcher, 0.1, free(), x)
    with_self = check_counts(launcher, free(), grid, x, x).counts()
    without = check_counts(launcher, free(), grid, x, x, exclude_self=True).counts()
    assert np.array_equal(with_self, without + 1) and np.all(with_self >= 1)


@pytest.mark.parametrize("dim", [2, 3])
def test_points_on_cell_faces_strict_cutoff(launcher, vec3, dim):
    """A lattice with spacing == radius: every point sits on a cell face and its nearest neighbours are
    at exactly the cut-off, which is excluded (strict ``<``)."""
    s = 0.25  # exact in float32, so lattice distances are exact too
    k = np.arange(-6, 7)
    idx = np.stack(np.meshgrid(*[k] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    x = vec3(idx * s)
    sp = free(dim)
    grid = NeighbourGrid(launcher, s, sp, x)
    assert np.all(check_counts(launcher, sp, grid, x, x, exclude_self=True, min_mean=0.0).counts() == 0)
    grid2 = NeighbourGrid(launcher, 2 * s, sp, x)
    counts = check_counts(launcher, sp, grid2, x, x, exclude_self=True).counts()
    interior = np.all(np.abs(idx) <= 4, axis=1)
    assert np.all(counts[interior] == (8 if dim == 2 else 26))


def test_cross_set_query_rows(launcher, vec3):
    """Query points from one set, sources from another; queries may lie outside the sources' bounds."""
    rng = np.random.default_rng(3)
    src_np = rng.uniform(-1.0, 1.0, size=(3000, 3))
    qry_np = rng.uniform(-1.3, 1.3, size=(600, 3))
    src, qry = vec3(src_np), vec3(qry_np)
    grid = NeighbourGrid(launcher, 0.2, free(), src)
    lst = check_counts(launcher, free(), grid, src, qry, min_mean=5.0)
    check_rows(free(), lst, qry_np, src_np, 0.2)


@pytest.mark.parametrize("offset", [1.0e3, -1.0e3])
def test_large_offset(launcher, vec3, offset):
    rng = np.random.default_rng(4)
    x = vec3(offset + rng.uniform(0.0, 1.0, size=(3000, 3)))
    grid = NeighbourGrid(launcher, 0.1, free(), x)
    check_counts(launcher, free(), grid, x, x, exclude_self=True, min_mean=5.0)


def test_aliasing_clusters_3d(launcher, vec3):
    """50k points in 8 clusters placed exactly one hash-table period apart, so their cells share buckets;
    candidates from aliased cells must be rejected by the distance test."""
    n, radius = 50_000, 0.1
    period = nb._grid_dims(3, n)[0] * radius
    rng = np.random.default_rng(5)
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 2)], dtype=np.float64)
    p = rng.uniform(0.0, 1.0, size=(n, 3)) + corners[rng.integers(0, 8, size=n)] * period - 0.5 * period
    x = vec3(p)
    grid = NeighbourGrid(launcher, radius, free(), x)
    check_counts(launcher, free(), grid, x, vec3(p[:2000]), exclude_self=True, min_mean=10.0)


def test_more_points_than_hash_cells_2d(launcher, vec3):
    n = 100_000
    dims = nb._grid_dims(2, n)
    assert n > dims[0] * dims[1] * dims[2]
    rng = np.random.default_rng(6)
    p = rng.uniform(-4.0, 4.0, size=(n, 2))
    x = vec3(p)
    grid = NeighbourGrid(launcher, 0.02, free(2), x)
    check_counts(launcher, free(2), grid, x, vec3(p[:1000]), min_mean=1.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_list_rows_match_brute_force(launcher, vec3, dim):
    rng = np.random.default_rng(7 + dim)
    x = vec3(rng.uniform(-1.0, 1.0, size=(700, dim)))
    r = 0.3 if dim == 3 else 0.15
    grid = NeighbourGrid(launcher, r, free(dim), x)
    lst = check_counts(launcher, free(dim), grid, x, x, exclude_self=True)
    assert lst.n_pairs > 5 * 700
    check_rows(free(dim), lst, x.numpy(), x.numpy(), r, exclude_self=True)


def test_list_thread_count_independent(make_launcher, vec3):
    rng = np.random.default_rng(9)
    x = vec3(rng.uniform(-1.0, 1.0, size=(3000, 3)))
    got = []
    for threads in (1, 2, 3):
        launcher = make_launcher(threads=threads)
        lst = NeighbourList(NeighbourGrid(launcher, 0.2, free(), x), x)
        got.append((lst.offsets(), lst.indices()))
    for off, idx in got[1:]:
        assert np.array_equal(off, got[0][0]) and np.array_equal(idx, got[0][1])  # same rows, same order


# --- periodic space --------------------------------------------------------------------------------------


def periodic_box(dim, length, axes=None, lower=-0.5):
    flags = [a < dim if axes is None else a in axes for a in range(3)]
    lo = np.full(3, lower, dtype=float)
    return Space(dim, lo, lo + np.asarray(length, dtype=float) * np.ones(3), flags)


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("supports", [2.0, 2.5, 3.0])
def test_periodic_counts_small_boxes(launcher, vec3, dim, supports):
    """Boxes only 2 to 3 supports wide: every pair found once, across every face and corner."""
    r = 0.2
    sp = periodic_box(dim, supports * r)
    rng = np.random.default_rng(int(10 * supports) + dim)
    p = np.zeros((400, 3))
    p[:, :dim] = sp.lower[:dim] + rng.uniform(0.0, 1.0, size=(400, dim)) * sp.length[:dim]
    x = vec3(p)
    grid = NeighbourGrid(launcher, r, sp, x)
    assert grid.n_images > 0
    lst = check_counts(launcher, sp, grid, x, x, exclude_self=True, min_mean=3.0)
    check_rows(sp, lst, p, p, r, exclude_self=True)


@pytest.mark.parametrize("dim", [2, 3])
def test_periodic_points_exactly_on_the_faces(launcher, vec3, dim):
    """A lattice with points exactly on the lower faces (and one on an upper face): pairs across faces
    at exactly the radius are excluded, those inside it counted once."""
    s, n = 0.125, 8                      # box side 1.0 = 8 spacings, exact in float32
    k = np.arange(n)
    idx = np.stack(np.meshgrid(*[k] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    p = np.zeros((len(idx) + 1, 3))
    p[:-1, :dim] = idx * s
    p[-1, :dim] = 1.0                    # on the upper corner: the image of point 0
    sp = Space(dim, (0, 0, 0), (1, 1, 1), [a < dim for a in range(3)])
    x = vec3(p)
    for r, interior in ((s, 0), (2 * s, 8 if dim == 2 else 26)):
        grid = NeighbourGrid(launcher, r, sp, x)
        counts = check_counts(launcher, sp, grid, x, x, exclude_self=True, min_mean=0.0).counts()
        # a periodic lattice has no boundary: every lattice point away from the duplicate corner point
        # (which sits on point 0) has the interior count
        far = np.linalg.norm(sp.displacement(p[1:-1], p[-1]), axis=1) > 2 * r
        assert far.sum() >= 10 and np.all(counts[1:-1][far] == interior)


def test_periodic_only_some_axes(launcher, vec3):
    """A channel periodic in x only: no pairs across the y faces."""
    r = 0.1
    sp = Space(2, (0, 0, 0), (0.3, 1.0, 0), (True, False, False))
    rng = np.random.default_rng(21)
    p = np.zeros((1500, 3))
    p[:, 0] = rng.uniform(0, 0.3, 1500)
    p[:, 1] = rng.uniform(0, 1.0, 1500)
    x = vec3(p)
    lst = check_counts(launcher, sp, NeighbourGrid(launcher, r, sp, x), x, x, exclude_self=True, min_mean=5.0)
    check_rows(sp, lst, p[:300], p, r, exclude_self=True)


def test_periodic_box_too_small_is_refused(launcher, vec3):
    sp = periodic_box(2, 0.35)
    with pytest.raises(ParameterError, match="radius"):
        NeighbourGrid(launcher, 0.2, sp, vec3(np.zeros((3, 3))))
    with pytest.raises(ParameterError, match="skin"):
        MovingNeighbours(launcher, periodic_box(2, 0.42), vec3(np.zeros((3, 3))), 0.2, 0.02)


# --- tables --------------------------------------------------------------------------------------------


def test_table_rows_equal_brute_force_and_grow_when_full(make_launcher):
    """The compact table: rows end to end, each with room for its count + count/10 + 2, the same sets as brute
    force; a refill of the same rows keeps the arrays and needs no second pass; points moved so that rows outgrow their
    rooms are laid out and filled again (the index grown), nothing dropped; bitwise the same for 1 and 2 threads."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1.0, 1.0, size=(3000, 3)).astype(np.float32)
    r = 0.2
    tables = []
    for threads in (1, 2):
        launcher = make_launcher(threads=threads)
        x = wp.array(pts, dtype=wp.vec3, device=launcher.device)
        table = NeighbourTable(launcher, capacity=4)
        grid = NeighbourGrid(launcher, r, free(), x)
        table.fill(grid, x, exclude_self=True)
        c, start = table.counts().copy(), table.rows.start.numpy()[: len(pts)].copy()  # (views on the CPU)
        room = c + c // 10 + 2
        assert table.capacity >= table.n_pairs == room.sum() and c.sum() > 4 * len(pts)
        assert np.array_equal(start, np.r_[0, np.cumsum(room)[:-1]])
        index = np.concatenate([table.row(i) for i in range(len(pts))])
        kept, grows = table.rows.index, table.grows
        table.fill(grid, x, exclude_self=True)  # the same rows again: the arrays are kept, one pass
        assert table.rows.index is kept and table.grows == grows and table.refills == 0
        assert np.array_equal(np.concatenate([table.row(i) for i in range(len(pts))]), index)
        # the points drawn together: every row outgrows its room, the table lays out and fills again
        squeezed = wp.array(0.7 * pts, dtype=wp.vec3, device=launcher.device)
        table.fill(NeighbourGrid(launcher, r, free(), squeezed), squeezed, exclude_self=True)
        assert table.refills == 1 and table.grows == grows + 1
        d = np.linalg.norm(0.7 * pts[:, None, :] - 0.7 * pts[None, :, :], axis=-1)
        for i in range(0, len(pts), 211):
            assert set(table.row(i).tolist()) == set(np.flatnonzero((d[i] < r) & (np.arange(len(pts)) != i)).tolist())
        tables.append((c.copy(), index))
    counts, indices = tables[0]
    assert np.array_equal(counts, tables[1][0]) and np.array_equal(indices, tables[1][1])
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=-1)
    for i in range(0, len(pts), 97):
        expect = set(np.flatnonzero((d[i] < r) & (np.arange(len(pts)) != i)).tolist())
        got = indices[counts[:i].sum(): counts[:i + 1].sum()].tolist()
        assert len(got) == len(set(got)) and set(got) == expect


# --- moving sets ------------------------------------------------------------------------------------------


def _random_walk(rng, p, step, sp):
    d = rng.normal(size=p.shape)
    d[:, sp.dim:] = 0.0
    d *= step / np.linalg.norm(d, axis=1, keepdims=True)
    return sp.wrap(p + d)


@pytest.mark.parametrize("periodic", [False, True])
def test_moving_tables_with_skin_equal_rebuild_every_step(launcher, vec3, periodic):
    """Particles random-walk (in a periodic box, wrapping across its faces); the tables with a skin,
    rebuilt only when a particle may have moved skin/2, keep exactly the pairs within the radius that a
    rebuild every step finds: fluid-fluid, fluid → wall (static), wall → fluid and node → particle."""
    r, skin = 0.1, 0.03
    sp = Space(2, (0, 0, 0), (1, 1, 0), (periodic, periodic, False)) if periodic else free(2)
    rng = np.random.default_rng(30)
    p = np.zeros((1200, 3))
    p[:, :2] = rng.uniform(0, 1, (1200, 2))
    walls = np.zeros((300, 3))
    walls[:, :2] = rng.uniform(0, 1, (300, 2))
    x = vec3(p)
    w = vec3(walls)
    mov = MovingNeighbours(launcher, sp, x, r, skin, static_sets={"walls": w})
    tables = {"ff": mov.add_table("ff", "moving", "moving", capacity=8, exclude_self=True),
              "fw": mov.add_table("fw", "moving", "walls"),
              "wf": mov.add_table("wf", "walls", "moving")}
    mov.rebuild()
    moved, rebuilt = 0.0, 0
    for step in range(40):
        p = _random_walk(rng, p, 0.004, sp)
        x.assign(p.astype(np.float32))
        moved += 0.004
        if mov.needs_rebuild(moved):
            mov.rebuild()
            moved, rebuilt = 0.0, rebuilt + 1
        since_build = sp.displacement(x.numpy(), mov.position_at_build.numpy())
        assert np.linalg.norm(since_build, axis=1).max() <= moved + 1e-6  # the bound the rebuild decision uses
        for name, (q, s, excl) in {"ff": (x, x, True), "fw": (x, w, False), "wf": (w, x, False)}.items():
            kept = wp.zeros(q.shape[0], dtype=wp.int32)
            launcher.launch(kt.count_within_rows, q.shape[0], [tables[name].rows, sp.box, q, s, r, kept])
            ref = neighbour_counts_brute(launcher, sp, q, s, r, exclude_self=excl)
            assert np.array_equal(kept.numpy(), ref), (step, name)
    assert 3 <= rebuilt <= 12 and mov.builds == rebuilt + 1


def test_node_gathers_from_moving_particles(launcher, vec3):
    """Static nodes gather a weighted sum over the moving particles near them (the PIC deposit pattern),
    through a moving-set table with a skin: equal to the float64 brute force sum after the particles moved."""
    r, skin = 0.15, 0.05
    sp = Space(2, (0, 0, 0), (1, 1, 0), (True, True, False))
    rng = np.random.default_rng(31)
    p = np.zeros((2000, 3))
    p[:, :2] = rng.uniform(0, 1, (2000, 2))
    g = np.stack(np.meshgrid(np.linspace(0, 0.9, 10), np.linspace(0, 0.9, 10)), -1).reshape(-1, 2)
    nodes_np = np.hstack([g, np.zeros((100, 1))])
    x, nodes = vec3(p), vec3(nodes_np)
    mov = MovingNeighbours(launcher, sp, x, r, skin, static_sets={"nodes": nodes})
    table = mov.add_table("node_particles", "nodes", "moving")
    mov.rebuild()
    p = _random_walk(rng, p, 0.02, sp)          # less than skin/2: no rebuild needed
    x.assign(p.astype(np.float32))
    assert not mov.needs_rebuild(0.02)
    out = wp.zeros(100, dtype=float)
    launcher.launch(kt.gather_weights, 100, [table.rows, sp.box, nodes, x, r, out])
    d = np.linalg.norm(sp.displacement(nodes_np[:, None, :2], p[None, :, :2]), axis=2)
    ref = np.where(d < r, (1 - d / r) ** 2, 0.0).sum(axis=1)
    np.testing.assert_allclose(out.numpy(), ref, rtol=2e-5)
    assert ref.min() > 1.0



@pytest.mark.parametrize("axes", [(0, 1), (0,), ()])
def test_gather_grid_rows_equal_brute_force(launcher, vec3, axes):
    """Fixed points gather from moving ones through a GatherGrid (no images of the moving points; the fixed points
    query at their static periodic copies): every row is exactly the set of moving points within the radius
    (minimum image), none twice, at the first build and after the points moved and the grid was rebuilt. A box
    2.2 radii wide puts every fixed point within reach of a face, most within reach of two (a corner)."""
    r = 0.15
    sp = Space(2, (0.0, 0.0, 0.0), (0.33, 0.5, 0.0), tuple(a in axes for a in range(3)))
    rng = np.random.default_rng(7 + len(axes))
    fixed_np = np.zeros((60, 3))
    fixed_np[:, :2] = rng.uniform(0.0, 1.0, (60, 2)) * sp.length[:2]
    moving_np = np.zeros((500, 3))
    moving_np[:, :2] = rng.uniform(0.0, 1.0, (500, 2)) * sp.length[:2]
    fixed = vec3(fixed_np)
    gather = nb.GatherGrid(NeighbourGrid(launcher, r, sp, fixed))
    moving = vec3(moving_np)
    gather.build(moving)
    lst = NeighbourList(gather, fixed)
    check_rows(sp, lst, fixed_np[:, :2], moving_np[:, :2], r)
    assert lst.counts().mean() > 20.0
    for _ in range(2):  # move (wrapping across the periodic faces), rebuild, refill a table
        moving_np = _random_walk(rng, moving_np, 0.05, sp)
        if axes != (0, 1):  # keep the points in the box along a wall
            moving_np[:, :2] = np.clip(moving_np[:, :2], 0.0, sp.length[:2])
        moving.assign(moving_np.astype(np.float32))
        gather.build(moving)
        table = NeighbourTable(launcher, capacity=4)
        table.fill(gather, fixed)
        rows = [table.row(i).tolist() for i in range(60)]
        off = np.r_[0, np.cumsum([len(row) for row in rows])]
        flat = SimpleNamespace(offsets=lambda: off, indices=lambda: np.array(sum(rows, []), dtype=np.int64))
        check_rows(sp, flat, fixed_np[:, :2], moving_np[:, :2], r)
    assert gather.builds == 3
    with pytest.raises(ParameterError, match="query_points"):
        NeighbourList(gather, vec3(fixed_np[:10]))

# --- bad input -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("radius", [0.0, -0.1, float("nan"), float("inf"), "x"])
def test_bad_radius(launcher, vec3, radius):
    with pytest.raises(ParameterError, match="radius"):
        NeighbourGrid(launcher, radius, free(), vec3(np.zeros((4, 3))))


@pytest.mark.parametrize("skin", [-0.01, float("nan")])
def test_bad_skin(launcher, vec3, skin):
    with pytest.raises(ParameterError, match="skin"):
        MovingNeighbours(launcher, free(), vec3(np.zeros((4, 3))), 0.1, skin)


def test_bad_table_sets(launcher, vec3):
    mov = MovingNeighbours(launcher, free(), vec3(np.zeros((4, 3))), 0.1, 0.01, {"walls": vec3(np.ones((2, 3)))})
    with pytest.raises(ParameterError, match="source"):
        mov.add_table("x", "moving", "nodes")
    with pytest.raises(ParameterError, match="source"):
        mov.add_table("x", "walls", "walls")
