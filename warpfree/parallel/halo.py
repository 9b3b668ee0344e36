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
- :meth:`Partition.refresh`: ghosts get their owners' current values (every step, for the fields a step reads),
  packed and unpacked on the arrays' device (``kernels/halo.py``); :meth:`Partition.start_refresh` and
  :meth:`Partition.finish_refresh` split it around work that reads no ghost;
- :meth:`Partition.gather`: owned values of every rank in global-id order (outputs, diagnostics).

A set's ids need not be 0..N-1: a set that items join and leave (a plasma with wall sources and absorbing walls)
issues each new item the next id and never reuses one, so its ids are sparse and ``count``, the size of the id space
(every id is below it), is the number of ids ever issued. Nothing here scales with ``count`` but :meth:`gather` of a
set whose ids are 0..N-1 (an array of N rows, which it fills).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .decomposition import Decomposition, Mirrors
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
    ghosts rank s owns), both in global-id order; ``count``: the size of the id space (every id is below it: the set's
    global size when its ids are 0..N-1, the ids ever issued when items join and leave); ``mirrors``: planes across
    which a rank also holds the items whose mirror image is near its box (:class:`~.decomposition.Mirrors`), or None."""

    def __init__(self, world: World, decomposition: Decomposition, depth: float, ids: np.ndarray, owned: np.ndarray,
                 send: dict[int, np.ndarray], receive: dict[int, np.ndarray], count: int,
                 mirrors: Mirrors | None = None):
        self.world = world
        self.decomposition = decomposition
        self.depth = float(depth)
        self.mirrors = mirrors
        self.ids = ids
        self.owned = owned
        self.owned_index = np.flatnonzero(owned)
        self.send = send
        self.receive = receive
        self.count = int(count)
        self._plans: dict[tuple, _RefreshPlan] = {}
        self._pending: _RefreshPlan | None = None   # the plan whose messages start_refresh started
        self._ghost_rows: dict[str, wp.array] = {}     # device -> the ghosts' held rows (int32), for set_ghosts
        self._ghost_fills: dict[tuple, object] = {}    # (array, value) -> set_ghosts' recorded launch (holds both)

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
                 points: np.ndarray, count: int, mirrors: Mirrors | None = None) -> "Partition":
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
            near = own[decomposition.near(points[own], r, depth, mirrors)] if own.size else own
            if near.size:
                send[r] = near
            theirs = np.flatnonzero(owner == r)
            if theirs.size:
                receive[r] = theirs
        return cls(world, decomposition, depth, ids, owned, send, receive, count, mirrors)

    @classmethod
    def of_all(cls, world: World, decomposition: Decomposition, depth: float, points: np.ndarray,
               mirrors: Mirrors | None = None) -> "Partition":
        """The part of this rank when every rank knows every item's position (``points``: all N, global order)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ids = np.flatnonzero(decomposition.held_by(points, world.rank, depth, mirrors))
        return cls.of_items(world, decomposition, depth, ids, points[ids], points.shape[0], mirrors)

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
            to_r = (owner == r) | decomposition.near(p, r, self.depth, self.mirrors)
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
        part = Partition.of_items(world, decomposition, self.depth, ids, new_points, self.count, self.mirrors)
        self.release()
        return part, out

    # -- using one ------------------------------------------------------------------------------------------
    def take(self, values):
        """The held rows of an array over all items (global order): set-up data every rank has (a copy)."""
        return np.array(values) if self.whole else np.asarray(values)[self.ids]

    def refresh(self, *arrays) -> None:
        """Give every ghost its owner's current values in each of ``arrays`` (held rows: 1-D Warp arrays on one
        device): :meth:`start_refresh` then :meth:`finish_refresh`."""
        self.start_refresh(*arrays)
        self.finish_refresh()

    def start_refresh(self, *arrays) -> None:
        """Pack the rows every neighbour rank needs of ``arrays`` on the device and start the messages; the ghosts
        change only at :meth:`finish_refresh`, which must come before anything reads a ghost row of ``arrays`` or
        writes an owned one (work that does neither may run between the two). Nothing to do in one process.

        The first refresh of a list of arrays on this part makes its :class:`_RefreshPlan` (index arrays, buffers,
        recorded launches, persistent MPI requests), kept while the part and the arrays are."""
        if self._pending is not None:
            raise RuntimeError("a refresh is under way on this part: finish_refresh() first")
        if not self.send and not self.receive:
            return
        key = tuple(_address(a) for a in arrays)
        plan = self._plans.pop(key, None)
        if plan is None:
            plan = _RefreshPlan(self, arrays)
            while len(self._plans) >= MAX_PLANS:  # the oldest: arrays a rebuild has replaced
                self._plans.pop(next(iter(self._plans))).free()
        self._plans[key] = plan                   # the most recently used last
        plan.start()
        self._pending = plan

    def finish_refresh(self) -> None:
        """Wait for the messages :meth:`start_refresh` started and unpack them into the ghost rows (nothing when no
        refresh is under way)."""
        plan, self._pending = self._pending, None
        if plan is not None:
            plan.finish()

    def set_ghosts(self, array, value) -> None:
        """Set every ghost row of ``array`` (held rows, a 1-D Warp array) to ``value`` on its device: a reduction over
        the held rows then sees the owned rows and ``value`` alone (a neutral value: 0 in a max of values >= 0).
        Nothing in one process."""
        if self.n_ghosts == 0:
            return
        from warpfree.kernels.halo import fill_rows

        key = (_address(array), str(value))
        launch = self._ghost_fills.get(key)
        if launch is None:  # recorded once per array and value, replayed every step
            rows = self._ghost_rows.get(str(array.device))
            if rows is None:
                rows = _int32([np.flatnonzero(~self.owned)], array.device)
                self._ghost_rows[str(array.device)] = rows
            launch = wp.launch(fill_rows, dim=rows.shape[0], inputs=[0, rows, value, array], device=array.device,
                               record_cmd=True)
            self._ghost_fills[key] = launch
        launch.launch()

    def release(self) -> None:
        """Free the refresh plans' MPI requests (a part that a redistribution has replaced)."""
        self.finish_refresh()
        for plan in self._plans.values():
            plan.free()
        self._plans.clear()
        self._ghost_fills.clear()

    def gather(self, values) -> np.ndarray:
        """The owned rows of ``values`` (held rows) of every rank, in global-id order, on every rank (a copy): as many
        rows as the set has items (fewer than ``count`` when its ids are sparse)."""
        v, _ = host_view(values)
        if self.whole:
            return np.array(v)
        ids = self.world.allgather(self.ids[self.owned_index].astype(np.int64))
        rows = np.concatenate(self.world.allgather(np.ascontiguousarray(v[self.owned_index])))
        all_ids = np.concatenate(ids)
        if all_ids.size != self.count:  # sparse ids: the rows sorted by id
            return rows[np.argsort(all_ids, kind="stable")]
        out = np.empty((self.count,) + v.shape[1:], dtype=v.dtype)
        out[all_ids] = rows
        return out

    def owned_values(self, values) -> np.ndarray:
        """A copy of the owned rows of ``values`` (held rows)."""
        v, _ = host_view(values)
        return np.array(v[self.owned_index])

    def describe(self) -> dict:
        """The partition for ``summary.json``: items held, owned, ghosts and the neighbouring ranks."""
        return {"held": self.n, "owned": self.n_owned, "ghosts": self.n_ghosts,
                "neighbours": sorted(set(self.send) | set(self.receive))}


def whole_from_pieces(pieces: list[dict], names, ids: str, count: int | None, owned: str | None = None,
                      rows: str | None = None) -> dict[str, np.ndarray]:
    """The whole set's values of ``names`` from the checkpoint pieces of any number of processes (one process's piece
    holds every item), in id order: each piece's held rows (as many as its ``piece[ids]``, or its first
    ``piece[rows]``) with their global ids ``piece[ids]``; with ``owned`` only the rows ``piece[owned]`` marks (a ghost
    is its owner's copy: without it the first piece's copy of each item is taken). ``count``: the set's global size
    when its ids are 0..count-1 (each must be there: row i is item i); None for sparse ids (a set that items joined
    and left: the rows of the ids present, ascending, which the result holds under ``ids`` too). A piece whose rows do
    not match its ids, an item owned twice or, with ``count``, one missing: ParameterError naming ``resume``."""
    from warpfree.errors import ParameterError

    gids, takes = [], []
    for piece in pieces:
        held = int(piece[rows]) if rows is not None else np.asarray(piece[ids]).shape[0]
        gid = np.asarray(piece[ids][:held]).astype(np.int64)
        if gid.size != held or (held and (gid.min() < 0 or (count is not None and gid.max() >= count))):
            raise ParameterError("resume", "a checkpoint piece does not match this scene")
        gids.append(gid)
        takes.append(np.asarray(piece[owned][:held]).astype(bool) if owned is not None else None)
    every = np.concatenate(gids) if gids else np.zeros(0, np.int64)
    if owned is None:   # the first copy of each item, in piece order
        taken = np.zeros(every.size, dtype=bool)
        taken[np.unique(every, return_index=True)[1]] = True
    else:
        taken = np.concatenate(takes) if takes else np.zeros(0, bool)
    kept = every[taken]
    order = np.argsort(kept, kind="stable")
    kept = kept[order]
    if kept.size > 1 and np.any(kept[1:] == kept[:-1]):
        raise ParameterError("resume", "the checkpoint's pieces own an item twice")
    if count is not None and not np.array_equal(kept, np.arange(count)):
        raise ParameterError("resume", f"the checkpoint's pieces hold {kept.size} of the {count} items")
    whole: dict[str, np.ndarray] = {}
    for k in names:
        parts = [np.asarray(piece[k])[:gid.size] for piece, gid in zip(pieces, gids)]
        whole[k] = np.concatenate(parts)[taken][order]
    if count is None and ids not in whole:
        whole[ids] = kept
    return whole


def _address(array) -> tuple:
    """What identifies an array's memory (a refresh plan holds it, its packed views and recorded launches)."""
    if not isinstance(array, wp.array):
        raise TypeError(f"refresh takes Warp arrays, got {type(array).__name__}")
    return (array.ptr, array.shape, str(array.dtype), str(array.device))


class _RefreshPlan:
    """The made-once parts of refreshing one list of arrays (1-D Warp arrays on one device) on one
    :class:`Partition`.

    Per direction one byte buffer on the arrays' device holds every neighbour's message in turn (neighbours in rank
    order); a message holds the fields in turn (each array's rows, in the part's ``send[r]``/``receive[s]`` order),
    every block starting on a multiple of ``align`` bytes (16 and every field's item size), so that each field sees
    the whole buffer as an array of its type. Per field, one launch packs every outgoing row
    (``kernels/halo.py: pack_rows``, over all neighbours, through the int32 held rows and slots made here) and one
    unpacks every incoming row; the launches are recorded once and replayed. The MPI requests are persistent, made
    here over the buffers MPI reads and writes:

    - CPU arrays: the device buffers themselves (host memory; their NumPy views, no copy);
    - GPU arrays, CUDA-aware MPI (:func:`~warpfree.parallel.world.cuda_aware_mpi`): the device buffers (Warp arrays,
      through ``__cuda_array_interface__``);
    - GPU arrays otherwise: one pinned host buffer per direction, with one copy each way per refresh.
    """

    def __init__(self, part: Partition, arrays):
        from warpfree.kernels.halo import TYPES, pack_rows, unpack_rows

        from .world import cuda_aware_mpi

        if not arrays:
            raise ValueError("refresh: no array given")
        device = arrays[0].device
        for a in arrays:
            if a.ndim != 1 or a.device != device or a.dtype not in TYPES:
                raise ValueError(f"refresh takes 1-D arrays of {', '.join(t.__name__ for t in TYPES)} on one device; "
                                 f"got {a.dtype.__name__} {a.shape} on {a.device}")
        self.arrays = arrays                       # kept alive while the plan packs and unpacks them
        self.device = device
        sizes = [wp.types.type_size_in_bytes(a.dtype) for a in arrays]
        self.align = math.lcm(16, *sizes)
        staged = device.is_cuda and not cuda_aware_mpi()
        self._send = _Direction(part.send, arrays, sizes, self.align, device, staged)
        self._receive = _Direction(part.receive, arrays, sizes, self.align, device, staged)
        self._pack = self._send.launches(pack_rows, outgoing=True)
        self._unpack = self._receive.launches(unpack_rows, outgoing=False)
        self.messages = part.world.persistent_exchange(self._send.messages(), self._receive.messages())

    def start(self) -> None:
        """Pack, hand the packed bytes to MPI (a copy to pinned memory when staged), start every message."""
        for launch in self._pack:
            launch.launch()
        if self.device.is_cuda:
            if self._send.host is not None:
                wp.copy(self._send.host, self._send.buffer)
            wp.synchronize_stream(wp.get_stream(self.device))   # MPI reads the bytes now
        self.messages.start()

    def finish(self) -> None:
        """Wait for every message, then unpack (after a copy from pinned memory when staged)."""
        self.messages.wait()
        if self._receive.host is not None:
            wp.copy(self._receive.buffer, self._receive.host)  # on the stream the unpacking runs on
        for launch in self._unpack:
            launch.launch()

    def free(self) -> None:
        self.messages.free()


class _Direction:
    """One direction of a :class:`_RefreshPlan`: the messages to (or from) each neighbour rank, laid out in one
    buffer on the device (``buffer``; ``host``: its pinned host copy when staged, else None), the held rows
    (``rows``, int32, neighbours in turn) and, per field, each row's element in the buffer seen as that field's
    type (``slots``)."""

    def __init__(self, index: dict[int, np.ndarray], arrays, sizes: list[int], align: int, device, staged: bool):
        self.arrays, self.sizes, self.device = arrays, sizes, device
        self.ranges: dict[int, tuple[int, int]] = {}   # neighbour -> (first byte, bytes) of its message
        rows, slots, at = [], [[] for _ in arrays], 0
        for rank in sorted(index):
            held = np.asarray(index[rank], dtype=np.int64)
            start = at
            for f, size in enumerate(sizes):
                slots[f].append(at // size + np.arange(held.size, dtype=np.int64))
                at += _round_up(held.size * size, align)
            self.ranges[rank] = (start, at - start)
            rows.append(held)
        self.count = int(sum(r.size for r in rows))
        self.bytes = at
        self.buffer = wp.zeros(max(at, 1), dtype=wp.uint8, device=device)
        self.host = wp.zeros(max(at, 1), dtype=wp.uint8, device="cpu", pinned=True) if staged else None
        self.rows = _int32(rows, device)
        self.slots = [_int32(s, device) for s in slots]
        # each field's view of the whole buffer (the buffer keeps the memory)
        self.views = [wp.array(ptr=self.buffer.ptr, dtype=a.dtype, shape=(max(at, 1) // size,), device=device)
                      for a, size in zip(arrays, sizes)]

    def launches(self, kernel, outgoing: bool) -> list:
        """The recorded launches of ``kernel`` (pack or unpack), one per field over every row of this direction."""
        if self.count == 0:
            return []
        out = []
        for values, view, slots in zip(self.arrays, self.views, self.slots):
            inputs = [0, values, self.rows, slots, view] if outgoing else [0, view, slots, self.rows, values]
            out.append(wp.launch(kernel, dim=self.count, inputs=inputs, device=self.device, record_cmd=True))
        return out

    def messages(self) -> dict:
        """Per neighbour rank, the bytes MPI sends from (or receives into): slices of the host buffer (NumPy) or of the
        device buffer (a GPU array, for a CUDA-aware MPI)."""
        if self.host is not None or self.device.is_cpu:
            whole = (self.host if self.host is not None else self.buffer).numpy()
            return {r: whole[a:a + n] for r, (a, n) in self.ranges.items()}
        return {r: self.buffer[a:a + n] for r, (a, n) in self.ranges.items()}


def _round_up(n: int, align: int) -> int:
    return -(-n // align) * align


def _int32(parts: list[np.ndarray], device) -> wp.array:
    values = np.concatenate(parts) if parts else np.zeros(0, np.int64)
    if values.size and values.max() > np.iinfo(np.int32).max:
        raise ValueError("a halo of more than 2**31 rows or buffer elements")
    return wp.array(values.astype(np.int32), dtype=wp.int32, device=device)


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
