"""The load distributions of Mendes (2010) §3.2.2 as index maps over the launcher's chunks."""

import numpy as np
import pytest

from warpfree.device import Launcher
from warpfree.distribution import Distribution, dealt_blocks, launch_order
from warpfree.errors import ParameterError


def chunks_of(order, n, parts):
    return [order[first:first + count] for first, count in Launcher.chunks(Launcher.__new__(Launcher), n, parts)]


@pytest.mark.parametrize("n,parts", [(10, 3), (7, 5), (1000, 2), (5, 8), (1, 2)])
@pytest.mark.parametrize("kind", Distribution.texts())
def test_every_distribution_is_a_permutation_that_fills_the_chunks(kind, n, parts):
    cost = (np.arange(n) * 7) % 5
    order = launch_order(kind, n, parts, cost=cost)
    assert order.dtype == np.int32 and np.array_equal(np.sort(order), np.arange(n))
    chunks = chunks_of(order, n, parts)
    if kind == "blocks":
        assert np.array_equal(order, np.arange(n))
    if kind == "alternating":  # each chunk holds one residue class mod the chunk count
        k = len(chunks)
        assert all(np.unique(c % k).size == 1 for c in chunks)
    if kind == "neighbours":  # equal counts, total costs within one item's largest cost
        totals = [cost[c].sum() for c in chunks]
        assert max(totals) - min(totals) <= cost.max()


def test_random_is_seeded_and_bad_kinds_are_named():
    assert np.array_equal(launch_order("random", 100, 2, seed=3), launch_order("random", 100, 2, seed=3))
    assert not np.array_equal(launch_order("random", 100, 2, seed=3), launch_order("random", 100, 2, seed=4))
    with pytest.raises(ParameterError, match="^distribution"):
        launch_order("cyclic", 10, 2)
    with pytest.raises(ParameterError, match="^distribution"):
        launch_order("neighbours", 10, 2)  # no cost


@pytest.mark.parametrize("n,parts,block", [(1000, 2, 64), (1000, 3, 64), (10, 4, 3), (5, 8, 64), (0, 2, 64)])
def test_dealt_blocks_is_a_permutation_of_index_ordered_chunks(n, parts, block):
    order = dealt_blocks(n, parts, block)
    assert order.dtype == np.int32 and np.array_equal(np.sort(order), np.arange(n))
    assert np.array_equal(dealt_blocks(n, 1, block), np.arange(n))       # one chunk (a GPU launch): the identity
    for c, chunk in enumerate(chunks_of(order, n, parts)):
        # chunk c: the blocks b = c mod parts, but for the rows the cut at the launcher's even boundaries moves
        assert np.count_nonzero((chunk // block) % parts != c) <= parts * block


def test_dealt_blocks_share_a_run_of_busy_items_evenly():
    """Work only on one run of indices, as on the walls next to a dam break's water (the 3D dam break at dx = 0.035:
    its 132 812 wall-pressure candidates lie on walls 2 436..26 538 of 41 611, 90 % of them in the first of two
    contiguous chunks); here a run within the first half, of uneven work: with blocks of 64 dealt round-robin each
    of 2 or 4 chunks gets its share to within two blocks' work (the run's ends cut blocks)."""
    n = 41_611
    cost = np.zeros(n)
    cost[2436:20000] = 1.0 + (np.arange(20000 - 2436) % 37)
    for parts in (2, 4):
        shares = [cost[c].sum() for c in chunks_of(dealt_blocks(n, parts), n, parts)]
        assert max(shares) - min(shares) <= 2 * 64 * cost.max()
    assert cost[: n // 2].sum() == cost.sum()                              # contiguous halves: one holds it all
