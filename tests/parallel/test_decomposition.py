"""The decomposition and the partition of an item set, in one process: boxes that tile space and balance the cost,
owners and ghosts against brute force, the plans every rank makes alike, and refusals."""

from __future__ import annotations

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.parallel import Decomposition, Partition, World, imbalance


class RankOf(World):
    """Rank ``rank`` of ``size`` without MPI: what a rank computes alone (its part at set-up) can be checked in
    one process for every rank."""

    def __init__(self, rank: int, size: int):
        super().__init__()
        self.rank, self.size = rank, size


def points(n=4000, seed=0, box=(4.0, 2.0)):
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(0, box[0], n), rng.uniform(0, box[1], n), np.zeros(n)]


@pytest.mark.parametrize("method,size", [("slabs", 2), ("slabs", 5), ("rcb", 3), ("rcb", 8)])
def test_boxes_tile_space_on_cell_faces_and_balance_the_cost(method, size):
    x = points()
    cell = 0.1
    dec = Decomposition.build(size, x, None, cell, 2, method, domain_lower=(0.0, 0.0, 0.0))
    owner = dec.owner(x)
    contains = np.stack([np.all((x >= dec.lower[r]) & (x < dec.upper[r]), axis=1) for r in range(size)], axis=1)
    assert np.all(contains.sum(axis=1) == 1) and np.array_equal(np.argmax(contains, axis=1), owner)
    finite = dec.lower[np.isfinite(dec.lower)]
    assert np.allclose(finite / cell, np.round(finite / cell), atol=1e-9)      # cuts on cell faces
    counts = np.bincount(owner, minlength=size)
    # uniform items: each box within a cell's column of items of the mean (slabs along x: 20 per cell column)
    assert imbalance(counts) < 1.0 + 2.0 * (len(x) * cell / 4.0) / (len(x) / size)
    if method == "slabs":
        assert np.all(np.isinf(dec.lower[:, 1])) and np.all(np.isinf(dec.upper[:, 1]))


def test_the_cost_moves_the_cuts():
    x = points()
    cost = np.where(x[:, 0] < 1.0, 9.0, 1.0)
    dec = Decomposition.build(2, x, cost, 0.1, 2, "slabs", domain_lower=(0.0, 0.0, 0.0))
    per_rank = np.bincount(dec.owner(x), weights=cost, minlength=2)
    column = np.bincount(np.floor(x[:, 0] / 0.1).astype(int), weights=cost)  # the cost of one cell's column
    assert dec.upper[0, 0] < 1.0                                              # the dear items share a slab
    assert imbalance(per_rank) <= 1.0 + 0.5 * column.max() / per_rank.mean()  # within half a column


def test_nearness_is_the_distance_to_a_box_across_periodic_faces():
    x = points(2000)
    dec = Decomposition.build(3, x, None, 0.1, 2, "slabs", domain_lower=(0.0, 0.0, 0.0),
                              domain_upper=(4.0, 2.0, 1.0), periodic=(True, False, False))
    depth = 0.25
    for r in range(3):
        lo, hi = dec.lower[r, 0], dec.upper[r, 0]
        gap = np.minimum.reduce([np.maximum(np.maximum(lo - (x[:, 0] + s), (x[:, 0] + s) - hi), 0.0)
                                 for s in (-4.0, 0.0, 4.0)])
        assert np.array_equal(dec.near(x, r, depth), gap <= depth)


@pytest.mark.parametrize("size", [2, 3, 5])
def test_every_rank_plans_the_exchange_its_neighbours_expect(size):
    """What rank s sends rank r (its own items near r's box) is what r expects from s (the ghosts s owns), in the
    same global order; every item is owned once; a rank holds everything within the depth of its box."""
    x = points(3000, seed=2)
    depth = 0.3
    dec = Decomposition.build(size, x, None, 0.1, 2, "rcb")
    parts = [Partition.of_all(RankOf(r, size), dec, depth, x) for r in range(size)]
    owned = np.concatenate([p.ids[p.owned_index] for p in parts])
    assert np.array_equal(np.sort(owned), np.arange(len(x)))
    for r, p in enumerate(parts):
        assert np.all(np.diff(p.ids) > 0)
        expected = np.flatnonzero((dec.owner(x) == r) | dec.near(x, r, depth))
        assert np.array_equal(p.ids, expected)
        for s, q in enumerate(parts):
            if s != r:
                sent = q.ids[q.send.get(r, np.zeros(0, int))]
                received = p.ids[p.receive.get(s, np.zeros(0, int))]
                assert np.array_equal(sent, received)


def test_more_ranks_than_cells_are_refused_naming_the_ranks():
    x = points(500, box=(0.35, 0.2))
    with pytest.raises(ParameterError, match=r"ranks: 5 ranks cannot cut the domain at the support size: it spans "
                                             r"4 cells"):
        Decomposition.build(5, x, None, 0.1, 2, "slabs", domain_lower=(0.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="decomposition: .octree. is not a choice: choose from rcb, slabs"):
        Decomposition.build(2, x, None, 0.1, 2, "octree")


def test_a_decomposition_survives_a_manifest():
    dec = Decomposition.build(4, points(), None, 0.1, 2, "rcb")
    back = Decomposition.from_dict(dec.to_dict())
    x = points(100, seed=9)
    assert np.array_equal(back.owner(x), dec.owner(x))


@pytest.mark.parametrize("method,size,periodic", [("rcb", 3, (True, False, False)), ("rcb", 5, (False, False, False)),
                                                  ("slabs", 4, (False, True, False)), ("rcb", 4, (True, True, False))])
def test_the_owner_lookup_is_the_box_test(method, size, periodic):
    """The owner found from the faces' grid is the box that holds the point (points across periodic faces and on
    faces included: lower faces closed, upper open)."""
    rng = np.random.default_rng(3)
    points = np.zeros((4000, 3))
    points[:, :2] = rng.uniform(0.0, 1.0, (4000, 2)) ** 2
    dec = Decomposition.build(size, points, None, 0.05, 2, method, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), periodic)
    probes = rng.uniform(-0.5, 1.5, (3000, 3))
    for a in range(2):  # some exactly on a face
        faces = np.unique(np.concatenate([dec.lower[:, a], dec.upper[:, a]]))
        faces = faces[np.isfinite(faces)]
        if faces.size:
            probes[50 * a: 50 * a + 50, a] = rng.choice(faces, 50)
    probes[:, 2] = 0.0
    assert np.array_equal(dec.owner(probes), dec._box_of(probes))
