"""Load distributions: which items each thread's chunk of a launch holds (Mendes 2010, §3.2.2, Figs 3.4-3.7).

The launcher (``warpfree.device.Launcher``) splits a launch of n items into contiguous chunks of launch
indices, one per thread. A kernel that reads its item through an index map, ``i = order[first + tid]``,
gets any assignment of items to threads without a change to the launcher, and stays race-free and bitwise
reproducible as long as item i writes only its own slots (a gather): the order of the items changes which
thread computes them, not what is computed.

The thesis's four strategies, as index maps for ``parts`` chunks:

- ``blocks``: contiguous blocks of indices (its "sequential", Fig. 3.4): the identity;
- ``alternating``: round-robin by index, thread c takes i ≡ c (mod parts) (its "AD", Fig. 3.5);
- ``random``: a random permutation, equal counts per thread (its "RD", Fig. 3.6), seeded;
- ``neighbours``: by neighbourhood size (Fig. 3.7): items sorted by their cost (the neighbour count) and dealt
  to the chunks in a serpentine (1..parts, parts..1, ...) so that every chunk holds the same number of items
  and nearly the same total cost; within a chunk in index order.

Each map fills the chunks of ``Launcher.chunks(n, parts)`` exactly (their sizes differ by at most one).

:func:`dealt_blocks` is a fifth map, for a set whose work gathers in one run of indices that changes during a run
(the walls next to the water of a dam break): blocks of consecutive indices dealt round-robin to the chunks, so that
each chunk holds a share of every region without reading the work, and threads write apart from each other.
"""

from __future__ import annotations

import numpy as np

from warpfree.errors import ParameterError, require_integer
from warpfree.parameters import Choice

__all__ = ["Distribution", "launch_order", "dealt_blocks"]

#: indices per block of :func:`dealt_blocks`: 64 float32 (256 bytes, 4 cache lines) per item array, so two threads
#: share a cache line at a block's edge at most, and a run of a few thousand busy items still spans dozens of blocks
DEALT_BLOCK = 64


class Distribution(Choice):
    """Which items each thread's chunk of a launch holds (the load distribution over threads)."""

    BLOCKS = "blocks", "contiguous blocks of indices"
    ALTERNATING = "alternating", "round-robin by index"
    RANDOM = "random", "a seeded random permutation, equal counts per thread"
    NEIGHBOURS = "neighbours", "dealt by neighbour count, so that every thread has about the same work"


def _chunk_sizes(n: int, parts: int) -> np.ndarray:
    """The sizes of the launcher's contiguous chunks (``Launcher.chunks``): (n(c+1))//k - (nc)//k."""
    k = max(1, min(parts, n))
    c = np.arange(k + 1)
    return np.diff((n * c) // k)


def launch_order(kind: Distribution, n: int, parts: int, cost: np.ndarray | None = None,
                 seed: int = 0) -> np.ndarray:
    """The index map (int32, a permutation of 0..n-1) of distribution ``kind`` (a :class:`Distribution` or its
    text) for ``parts`` chunks; ``cost`` (n,): the work per item (``neighbours`` only)."""
    kind = Distribution.of("distribution", kind)
    require_integer("parts", parts, minimum=1)
    index = np.arange(n)
    sizes = _chunk_sizes(n, int(parts))
    if kind is Distribution.BLOCKS or n == 0:
        return index.astype(np.int32)
    if kind is Distribution.RANDOM:
        return np.random.default_rng(seed).permutation(n).astype(np.int32)
    k = sizes.size
    if kind is Distribution.ALTERNATING:
        groups = [index[c::k] for c in range(k)]
    else:
        if cost is None or np.shape(cost) != (n,):
            raise ParameterError("distribution", "'neighbours' needs the cost (neighbour count) of every item")
        by_cost = np.argsort(-np.asarray(cost), kind="stable")
        lap = np.arange(n) // k
        slot = np.arange(n) % k
        chunk = np.where(lap % 2 == 0, slot, k - 1 - slot)  # serpentine: 0..k-1, k-1..0, ...
        groups = [np.sort(by_cost[chunk == c]) for c in range(k)]
    # the groups have the chunks' sizes (n mod k of them one longer) in another order: pair them by size
    placed = [None] * k
    for chunk, group in zip(np.argsort(sizes, kind="stable"), sorted(groups, key=len)):
        placed[chunk] = group
    return np.concatenate(placed).astype(np.int32)


def dealt_blocks(n: int, parts: int, block: int = DEALT_BLOCK) -> np.ndarray:
    """The index map (int32) that deals blocks of ``block`` consecutive indices round-robin to ``parts`` chunks
    (block b to chunk b mod parts), cut at ``Launcher.chunks(n, parts)``'s boundaries: each chunk holds every
    ``parts``-th block (up to one block more or less where the blocks do not divide evenly), in index order. A work
    that varies slowly along the indices is then shared evenly whatever region holds it; one chunk (a GPU launch)
    gets the identity."""
    require_integer("parts", parts, minimum=1)
    require_integer("block", block, minimum=1)
    index = np.arange(n)
    owner = (index // int(block)) % int(parts)
    return np.concatenate([index[owner == c] for c in range(int(parts))] or [index]).astype(np.int32)
