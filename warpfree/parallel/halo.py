"""One set of items (particles, nodes) spread over the ranks: each rank's own items, its ghosts, and their exchange.

An item has a global id, its index in the one-process run. A rank holds the items its box owns
(:class:`~warpfree.parallel.decomposition.Decomposition`) and, as ghosts, every item within ``depth`` of its box
(one support plus the neighbour tables' skin), all of them in global-id order. Kept in that order, and with every
rank's hash grid sized as the one process sizes it, a rank's neighbour queries return an owned item's neighbours in
the order the one process does (Warp's hash grid sorts its points by cell with a stable sort), so the sums over them,
and the results, are bitwise those of one process.

- :meth:`Partition.of_all`: the rank's part when every rank knows every item (at set-up);
- :meth:`Partition.redistribute`: each rank sends its own items to every rank that needs them (their new owner and
  the ranks whose boxes they are near) and the part is made anew from what arrives (moving items, at a rebuild);
- :meth:`Partition.refresh`: ghosts get their owners' current values (every step, for the fields a step reads);
- :meth:`Partition.gather`: owned values of every rank in global-id order (outputs, diagnostics).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .decomposition import Decomposition
from .world import World

__all__ = ["Partition", "host_view"]


def host_view(array):
    """(NumPy array of ``array``'s values, write-back): a view for NumPy or a CPU Warp array (writing it writes the
    array), a copy with a function that copies it back for a GPU array."""
    if isinstance(array, np.ndarray):
        return array, None
    values = array.numpy()
    if array.device.is_cpu:
        return values, None
    return values, (lambda: array.assign(values))


def _rows(values: np.ndarray) -> np.ndarray:
    """(n, bytes) uint8 view of n rows of any dtype and trailing shape."""
    values = np.ascontiguousarray(values)
    width = values.dtype.itemsize * int(np.prod(values.shape[1:], dtype=np.int64))
    return values.reshape(-1).view(np.uint8).reshape(values.shape[0], width)


class Partition:
    """This rank's part of one item set: ``ids`` (sorted global ids of the items it holds), ``owned`` (bool, per held
    item), ``send[r]`` (held indices of owned items rank r holds as ghosts) and ``receive[s]`` (held indices of the
    ghosts rank s owns), both in global-id order; ``count``: the set's global size."""

    def __init__(self, world: World, decomposition: Decomposition, depth: float, ids: np.ndarray, owned: np.ndarray,
                 send: dict[int, np.ndarray], receive: dict[int, np.ndarray], count: int):
        self.world = world
        self.decomposition = decomposition
        self.depth = float(depth)
        self.ids = ids
        self.owned = owned
        self.owned_index = np.flatnonzero(owned)
        self.send = send
        self.receive = receive
        self.count = int(count)

    @property
    def n(self) -> int:
        """Items held (owned and ghosts)."""
        return self.ids.size

    @property
    def n_owned(self) -> int:
        return self.owned_index.size

    @property
    def n_ghosts(self) -> int:
        return self.n - self.n_owned

    # -- making one -----------------------------------------------------------------------------------------
    @classmethod
    def of_items(cls, world: World, decomposition: Decomposition, depth: float, ids: np.ndarray,
                 points: np.ndarray, count: int) -> "Partition":
        """The part made from exactly the items this rank holds (global ``ids``, ascending, and their ``points``):
        owned where the box holds them; each owned item sent to every other rank it is near; each ghost received
        from the rank that owns it. Every rank computes the same owner and nearness for an item from the same
        position, so the plans match without a message."""
        rank = world.rank
        owner = decomposition.owner(points)
        owned = owner == rank
        send, receive = {}, {}
        own = np.flatnonzero(owned)
        for r in range(world.size):
            if r == rank:
                continue
            near = own[decomposition.near(points[own], r, depth)] if own.size else own
            if near.size:
                send[r] = near
            theirs = np.flatnonzero(owner == r)
            if theirs.size:
                receive[r] = theirs
        return cls(world, decomposition, depth, ids, owned, send, receive, count)

    @classmethod
    def of_all(cls, world: World, decomposition: Decomposition, depth: float, points: np.ndarray) -> "Partition":
        """The part of this rank when every rank knows every item's position (``points``: all N, global order)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        owner = decomposition.owner(points)
        held = (owner == world.rank) | decomposition.near(points, world.rank, depth)
        ids = np.flatnonzero(held)
        return cls.of_items(world, decomposition, depth, ids, points[ids], points.shape[0])

    def redistribute(self, decomposition: Decomposition, points: np.ndarray, fields: dict[str, np.ndarray]):
        """Move the items to where they now belong: each rank sends each item it owns, with its ``fields`` (held
        rows, NumPy), to the rank whose box holds its position ``points`` (held rows) and to every rank it is near;
        the new part is made from what arrives. Returns (the new :class:`Partition`, its fields: held rows in
        global-id order, each of the dtype and trailing shape given)."""
        world, rank = self.world, self.world.rank
        own = self.owned_index
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)[own]
        gid = self.ids[own].astype(np.int64)
        owner = decomposition.owner(p)
        names = sorted(fields)
        rows = [_rows(np.asarray(fields[k])[own]) for k in names]
        widths = [r.shape[1] for r in rows]
        packed = np.hstack([_rows(gid), _rows(p)] + rows)
        sends, keep = {}, None
        for r in range(world.size):
            to_r = (owner == r) | decomposition.near(p, r, self.depth)
            if not np.any(to_r):
                continue
            block = packed[to_r].reshape(-1)
            if r == rank:
                keep = block
            else:
                sends[r] = block
        sizes = world.exchange_sizes({r: b.size for r, b in sends.items()})
        received = world.exchange(sends, sizes)
        blocks = [keep] if keep is not None else []
        blocks += [received[s] for s in sorted(received)]
        width = packed.shape[1]
        table = np.concatenate(blocks).reshape(-1, width) if blocks else np.zeros((0, width), np.uint8)
        ids = np.ascontiguousarray(table[:, :8]).view(np.int64).reshape(-1)
        order = np.argsort(ids, kind="stable")
        table, ids = table[order], ids[order]
        new_points = np.ascontiguousarray(table[:, 8:32]).view(np.float64).reshape(-1, 3)
        out, at = {}, 32
        for k, w in zip(names, widths):
            ref = np.asarray(fields[k])
            out[k] = np.ascontiguousarray(table[:, at:at + w]).view(ref.dtype).reshape((-1,) + ref.shape[1:])
            at += w
        part = Partition.of_items(world, decomposition, self.depth, ids, new_points, self.count)
        return part, out

    # -- using one ------------------------------------------------------------------------------------------
    def take(self, values):
        """The held rows of an array over all items (global order): set-up data every rank has."""
        return np.asarray(values)[self.ids]

    def refresh(self, *arrays) -> None:
        """Give every ghost its owner's current values in each of ``arrays`` (held rows: Warp or NumPy arrays)."""
        if not self.send and not self.receive:
            return
        views = [host_view(a) for a in arrays]
        sends = {}
        for r, index in self.send.items():
            sends[r] = np.hstack([_rows(v[index]) for v, _ in views]).reshape(-1)
        widths = [_rows(v[:0]).shape[1] for v, _ in views]
        row = sum(widths)
        received = self.world.exchange(sends, {s: index.size * row for s, index in self.receive.items()})
        for s, index in self.receive.items():
            table = received[s].reshape(index.size, row)
            at = 0
            for (v, _), w in zip(views, widths):
                v[index] = np.ascontiguousarray(table[:, at:at + w]).view(v.dtype).reshape((-1,) + v.shape[1:])
                at += w
        for _, write_back in views:
            if write_back is not None:
                write_back()

    def gather(self, values) -> np.ndarray:
        """The owned rows of ``values`` (held rows) of every rank, in global-id order, on every rank."""
        v, _ = host_view(values)
        ids = self.world.allgather(self.ids[self.owned_index].astype(np.int64))
        rows = self.world.allgather(np.ascontiguousarray(v[self.owned_index]))
        all_ids = np.concatenate(ids)
        out = np.empty((self.count,) + v.shape[1:], dtype=v.dtype)
        out[all_ids] = np.concatenate(rows)
        return out

    def owned_values(self, values) -> np.ndarray:
        """A copy of the owned rows of ``values`` (held rows)."""
        v, _ = host_view(values)
        return np.array(v[self.owned_index])

    def describe(self) -> dict:
        return {"held": self.n, "owned": self.n_owned, "ghosts": self.n_ghosts,
                "neighbours": sorted(set(self.send) | set(self.receive))}


def as_warp(values: np.ndarray, dtype, device) -> wp.array:
    """A Warp array of held rows (a new allocation)."""
    return wp.array(np.ascontiguousarray(values), dtype=dtype, device=device)


def take_rows(start: np.ndarray, count: np.ndarray, index: np.ndarray, rows: np.ndarray,
              columns: "Partition") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The global CSR rows ``rows`` (global row ids, in the order wanted) of a static neighbour structure (``start``,
    ``count`` per global row; ``index``: global column ids), with their columns as held indices of ``columns``:
    (count per row, held column index per entry, the entries' positions in the global arrays, to take their
    coefficients). Every column must be held (the ghost depth covers the rows' reach); else RuntimeError."""
    rows = np.asarray(rows, dtype=np.int64)
    starts = start[rows].astype(np.int64)
    counts = count[rows].astype(np.int64)
    total = int(counts.sum())
    first = np.repeat(starts - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    entries = first + np.arange(total, dtype=np.int64)
    wanted = index[entries].astype(np.int64)
    local = np.searchsorted(columns.ids, wanted)
    local = np.minimum(local, max(columns.n - 1, 0))
    if total and (columns.n == 0 or not np.array_equal(columns.ids[local], wanted)):
        raise RuntimeError("a row reaches an item this rank does not hold: the ghost layer is too thin")
    return counts, local, entries
