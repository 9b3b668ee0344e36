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

from .decomposition import Decomposition
from .world import World

__all__ = ["Partition", "host_view", "whole_from_pieces"]

#: refresh plans a part keeps (the lists of arrays it refreshes: two or three per solver)
MAX_PLANS = 4


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
        self._plans: dict[tuple, _RefreshPlan] = {}

    @property
    def whole(self) -> bool:
        """True in a run of one process: this part is the whole set, in global order, with no ghost, and
        :meth:`refresh`, :meth:`gather` and :meth:`take` are identities (a copy at most)."""
        return self.world.size == 1

    @property
    def n(self) -> int:
        """Items held (owned and ghosts)."""
        return self.ids.size

    @property
    def n_owned(self) -> int:
        """The number of items this rank owns."""
        return self.owned_index.size

    @property
    def n_ghosts(self) -> int:
        """The number of ghost items this rank holds for its neighbours' support."""
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
        self.release()
        return part, out

    # -- using one ------------------------------------------------------------------------------------------
    def take(self, values):
        """The held rows of an array over all items (global order): set-up data every rank has (a copy)."""
        return np.array(values) if self.whole else np.asarray(values)[self.ids]

    def refresh(self, *arrays) -> None:
        """Give every ghost its owner's current values in each of ``arrays`` (held rows: Warp or NumPy arrays).

        Arrays in host memory (NumPy, Warp CPU) go through a :class:`_RefreshPlan` made at their first refresh on
        this part and kept while the part and the arrays are: its buffers, its host views and its persistent MPI
        requests are made once, so a refresh is a gather into the send buffer per array, one start and wait of
        every message, and a scatter out of the receive buffer per array. GPU arrays stage through the host."""
        if not self.send and not self.receive:
            return
        if not all(_in_host_memory(a) for a in arrays):
            self._refresh_staged(arrays)
            return
        key = tuple(_address(a) for a in arrays)
        plan = self._plans.pop(key, None)
        if plan is None:
            plan = _RefreshPlan(self, arrays)
            while len(self._plans) >= MAX_PLANS:  # the oldest: arrays a rebuild has replaced
                self._plans.pop(next(iter(self._plans))).free()
        self._plans[key] = plan                   # the most recently used last
        plan.run()

    def release(self) -> None:
        """Free the refresh plans' MPI requests (a part that a redistribution has replaced)."""
        for plan in self._plans.values():
            plan.free()
        self._plans.clear()

    def _refresh_staged(self, arrays) -> None:
        """:meth:`refresh` through host copies (arrays on a GPU)."""
        views = [host_view(a) for a in arrays]
        sends = {r: _field_blocks([v[index] for v, _ in views]) for r, index in self.send.items()}
        row = sum(_rows(v[:0]).shape[1] for v, _ in views)
        received = self.world.exchange(sends, {s: index.size * row for s, index in self.receive.items()})
        for s, index in self.receive.items():
            for (v, _), block in zip(views, _split_blocks(received[s], [v for v, _ in views], index.size)):
                v[index] = block
        for _, write_back in views:
            if write_back is not None:
                write_back()

    def gather(self, values) -> np.ndarray:
        """The owned rows of ``values`` (held rows) of every rank, in global-id order, on every rank (a copy)."""
        v, _ = host_view(values)
        if self.whole:
            return np.array(v)
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
        """The partition for ``summary.json``: items held, owned, ghosts and the neighbouring ranks."""
        return {"held": self.n, "owned": self.n_owned, "ghosts": self.n_ghosts,
                "neighbours": sorted(set(self.send) | set(self.receive))}


def whole_from_pieces(pieces: list[dict], names, ids: str, count: int, owned: str | None = None,
                      rows: str | None = None) -> dict[str, np.ndarray]:
    """The whole set's values of ``names`` from the checkpoint pieces of any number of processes (one process's piece
    holds every item): each piece's held rows (as many as its ``piece[ids]``, or its first ``piece[rows]``), placed at
    their global ids ``piece[ids]``; with ``owned`` only the rows ``piece[owned]`` marks (a ghost is its owner's copy:
    without it the first piece's copy of each item is taken). ``count``: the set's global size (every id below it).
    A piece whose rows do not match its ids: ParameterError naming ``resume``."""
    from warpfree.errors import ParameterError

    whole: dict[str, np.ndarray] = {}
    seen = np.zeros(count, dtype=bool)
    for piece in pieces:
        held = int(piece[rows]) if rows is not None else np.asarray(piece[ids]).shape[0]
        gid = np.asarray(piece[ids][:held]).astype(np.int64)
        if gid.size != held or (held and (gid.min() < 0 or gid.max() >= count)):
            raise ParameterError("resume", "a checkpoint piece does not match this scene")
        take = (np.asarray(piece[owned][:held]).astype(bool) if owned is not None
                else ~seen[gid] & _first_of_each(gid))
        seen[gid[take]] = True
        for k in names:
            values = np.asarray(piece[k])[:held]
            if k not in whole:
                whole[k] = np.zeros((count,) + values.shape[1:], dtype=values.dtype)
            whole[k][gid[take]] = values[take]
    if not seen.all():
        raise ParameterError("resume", f"the checkpoint's pieces hold {int(seen.sum())} of the {count} items")
    return whole


def _first_of_each(ids: np.ndarray) -> np.ndarray:
    """True at the first occurrence of each value of ``ids``."""
    first = np.zeros(ids.size, dtype=bool)
    first[np.unique(ids, return_index=True)[1]] = True
    return first


def _in_host_memory(array) -> bool:
    return isinstance(array, np.ndarray) or array.device.is_cpu


def _address(array) -> tuple:
    """What identifies an array's memory (a refresh plan holds views of it)."""
    if isinstance(array, np.ndarray):
        return (array.__array_interface__["data"][0], array.shape, array.dtype.str)
    return (array.ptr, array.shape, str(array.dtype))


def _field_blocks(values: list[np.ndarray]) -> np.ndarray:
    """One uint8 message of several arrays of n rows: each array's bytes in turn (field-major)."""
    return np.concatenate([np.ascontiguousarray(v).reshape(-1).view(np.uint8) for v in values]) if values else \
        np.zeros(0, np.uint8)


def _split_blocks(message: np.ndarray, like: list[np.ndarray], n: int) -> list[np.ndarray]:
    """The arrays of n rows a :func:`_field_blocks` message holds, each of the dtype and trailing shape of ``like``
    (views of the message)."""
    out, at = [], 0
    for ref in like:
        size = n * int(np.prod(ref.shape[1:], dtype=np.int64)) * ref.dtype.itemsize
        out.append(message[at:at + size].view(ref.dtype).reshape((n,) + ref.shape[1:]))
        at += size
    return out


class _RefreshPlan:
    """The made-once parts of refreshing one list of host arrays on one :class:`Partition`: the arrays' NumPy
    views; per neighbour rank a send and a receive buffer, laid out field-major (each array's rows in turn), with
    typed views of each field's block; the persistent MPI requests of every message."""

    def __init__(self, part: Partition, arrays):
        self.arrays = arrays                       # kept alive while the plan holds views of them
        self.views = [host_view(a)[0] for a in arrays]
        self.gathers = []                          # (held rows to send, the send buffer's typed block) per field
        self.scatters = []                         # (held rows to receive, the receive buffer's typed block)
        sends, receives = {}, {}
        row = sum(_rows(v[:0]).shape[1] for v in self.views)
        for r, index in part.send.items():
            sends[r] = np.empty(index.size * row, np.uint8)
            for v, block in zip(self.views, _split_blocks(sends[r], self.views, index.size)):
                self.gathers.append((v, index, block))
        for s, index in part.receive.items():
            receives[s] = np.empty(index.size * row, np.uint8)
            for v, block in zip(self.views, _split_blocks(receives[s], self.views, index.size)):
                self.scatters.append((v, index, block))
        self.messages = part.world.persistent_exchange(sends, receives)

    def run(self) -> None:
        for v, index, block in self.gathers:
            np.take(v, index, axis=0, out=block, mode="clip")   # indices are held rows: in range
        self.messages.start_and_wait()
        for v, index, block in self.scatters:
            v[index] = block

    def free(self) -> None:
        self.messages.free()


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
