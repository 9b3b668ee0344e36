"""The load distributions of Mendes (2010) §3.2.2 as index maps over the launcher's chunks."""

import numpy as np
import pytest

from warpfree.device import Launcher
from warpfree.distribution import Distribution, launch_order
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
