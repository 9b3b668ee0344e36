"""Neighbours for every pattern the solvers use, all over ``wp.HashGrid`` and all race-free.

- :class:`NeighbourGrid`: a HashGrid over a *source* point set (plus periodic images when the
  space has periodic axes). Any point set may query it: same-set (fluid–fluid), cross-set
  (fluid → wall, E → H, Gauss point → node).
- :class:`NeighbourList`: static CSR rows built once (SPEM E↔H, EFG Gauss point → node, walls).
- :class:`NeighbourTable`: fixed-capacity rows refilled in one pass; grows (×1.25 of the longest
  row) and refills when a row overflows, so no neighbour is ever dropped.
- :class:`MovingNeighbours`: moving sets with a skin (WCSPH's fluid, and its wall-aware relaxation):
  tables of candidates within radius + skin at the positions of the last build, rebuilt when a particle
  may have moved more than half the skin. Static sets (walls, the relaxation's surface points) query it
  and are queried by it.
- :class:`GatherGrid`: fixed points gathering from a moving set rebuilt every step (PIC's nodes from its
  particles, ``warpfree.solvers.pic.coupling``): a HashGrid over the moving points with no images, queried by each
  fixed point at its static periodic copies, so a build only sorts (no count, no placement, no read).

Rows of all of them are :class:`warpfree.kernels.neighbours.NeighbourRows` (``.rows``), so a solver
kernel reads any of them the same way. Periodic axes: image points in the grid, original indices in
the rows, minimum-image displacements in the kernels (``warpfree.space``). Cell width = query radius.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
import warp as wp

from .device import Launcher
from .errors import ParameterError, require_positive
from .reduce import Reduction
from .space import Space
from warpfree.kernels import neighbours as nk

__all__ = ["NeighbourGrid", "NeighbourList", "NeighbourTable", "MovingNeighbours", "GatherGrid", "empty_rows",
           "neighbour_counts_brute"]

_INT32_MAX = 2**31 - 1


#: the points each hash grid has room for, as Warp reserves them (``warp/native/hashgrid.cpp``: 1.5 times the points of
#: a build that outgrew the room): what :mod:`warpfree.memory` counts for a grid
_GRID_ROOM: "weakref.WeakKeyDictionary[wp.HashGrid, int]" = weakref.WeakKeyDictionary()


def build_hash_grid(grid: wp.HashGrid, points: wp.array, radius: float) -> None:
    """``grid.build(points, radius)``, keeping the room Warp reserves for the points (:func:`grid_points_reserved`)."""
    n = int(points.shape[0])
    if n > _GRID_ROOM.get(grid, 0):
        _GRID_ROOM[grid] = n * 3 // 2
    grid.build(points, radius)


def grid_points_reserved(grid: wp.HashGrid) -> int:
    """The points ``grid`` holds room for (0 before its first build through :func:`build_hash_grid`)."""
    return _GRID_ROOM.get(grid, 0)


def _rooms(room: wp.array | None, launcher: Launcher) -> wp.array:
    """A fill's per-row room, or the launcher's empty array (every row takes the scalar capacity)."""
    if room is not None:
        return room
    empty = _NO_ROOM.get(launcher)
    if empty is None:
        empty = _NO_ROOM[launcher] = wp.empty(0, dtype=wp.int32, device=launcher.device)
    return empty


#: the empty room array per launcher (a fill without rows of their own)
_NO_ROOM: "weakref.WeakKeyDictionary[Launcher, wp.array]" = weakref.WeakKeyDictionary()


def _require_points(positions: wp.array) -> None:
    """Refuse a point set a hash grid cannot take (it needs ``wp.vec3`` positions), naming ``positions``."""
    if positions.dtype != wp.vec3:
        raise ParameterError("positions", f"must be a wp.array of wp.vec3, got {positions.dtype}")


def _grid_dims(dim: int, n_points: int) -> tuple[int, int, int]:
    """Hash table size: about one cell per point, at most 256 (2D) or 128 (3D) per axis (the hash wraps beyond)."""
    if dim < 3:
        side = int(min(256, max(8, math.ceil(math.sqrt(max(n_points, 1))))))
        return side, side, 1
    side = int(min(128, max(8, math.ceil(max(n_points, 1) ** (1.0 / 3.0)))))
    return side, side, side


class NeighbourGrid:
    """HashGrid over a source point set, with periodic images.

    Parameters
    ----------
    launcher: runs the image kernels.
    radius: query radius (m): rows list the sources strictly closer than this; also the cell width.
    space: :class:`~warpfree.space.Space` (its periodic axes need sides >= 2 radius).
    positions: ``wp.array(dtype=wp.vec3)`` of the source set; :meth:`build` may pass new ones.
    sized_for: the number of grid points (sources and images) the hash table is sized for (default: those of the
        first build). A rank of a distributed run holds part of a set and sizes its table for the whole set's, as the
        one process does, so that queries return neighbours in the same order (:mod:`warpfree.parallel.halo`).
    """

    def __init__(self, launcher: Launcher, radius: float, space: Space, positions: wp.array | None = None,
                 sized_for: int | None = None):
        self.launcher = launcher
        self.sized_for = sized_for
        self.radius = require_positive("radius", radius)
        self.space = space
        space.require_room(self.radius, "radius")
        self.grid: wp.HashGrid | None = None
        self.points: wp.array | None = None      # the grid's points: sources, then images
        self.source_id: wp.array | None = None   # grid point -> source index
        self.n_sources = 0
        self.builds = 0
        if positions is not None:
            self.build(positions)

    @property
    def id(self):
        """The Warp hash grid's id, as kernels take it."""
        return self.grid.id

    def build(self, positions: wp.array) -> None:
        """(Re)build over ``positions`` (and their images across periodic faces)."""
        _require_points(positions)
        n = positions.shape[0]
        self.n_sources = n
        dev = self.launcher.device
        if self.space.is_periodic and n > 0:
            self.points, self.source_id = self._with_images(positions)
        else:
            self.points = positions
            if self.source_id is None or self.source_id.shape[0] != n:
                self.source_id = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device=dev)
        if self.grid is None:
            size = self.points.shape[0] if self.sized_for is None else self.sized_for
            self.grid = wp.HashGrid(*_grid_dims(self.space.dim, size), device=dev)
        build_hash_grid(self.grid, self.points, self.radius)
        self.builds += 1

    def grid_points(self, positions: wp.array) -> int:
        """The grid points a build over ``positions`` makes: the sources and their periodic images (one read)."""
        n = positions.shape[0]
        if not self.space.is_periodic or n == 0:
            return n
        counts = wp.zeros(n, dtype=wp.int32, device=self.launcher.device)
        self.launcher.launch(nk.count_images, n, [positions, self.space.box, self.radius, counts], once=True)
        return n + int(counts.numpy().sum())

    #: room kept beyond a build's sources and images in the arrays a periodic build reuses
    HEADROOM = 1.25

    def _room(self, name: str, size: int, dtype) -> wp.array:
        """A kept array of at least ``size`` items (grown by :attr:`HEADROOM` when a build outgrows it), its first
        ``size`` as a view: a rebuild allocates nothing while the set fits."""
        kept = self.__dict__.setdefault("_kept", {})
        if name not in kept or kept[name].shape[0] < size:
            kept[name] = wp.zeros(max(1, int(math.ceil(self.HEADROOM * size))), dtype=dtype,
                                  device=self.launcher.device)
        return kept[name][:size]

    def _with_images(self, positions: wp.array) -> tuple[wp.array, wp.array]:
        L, n = self.launcher, positions.shape[0]
        box = self.space.box
        counts = self._room("counts", n, wp.int32)
        L.launch(nk.count_images, n, [positions, box, self.radius, counts])
        offsets = self._room("offsets", n, wp.int32)
        wp.utils.array_scan(counts, offsets, inclusive=False)
        total = int(offsets.numpy()[-1] + counts.numpy()[-1]) if n else 0  # one read per build
        extended = self._room("extended", n + total, wp.vec3)
        source_id = self._room("source_id", n + total, wp.int32)
        L.launch(nk.place_images, n, [positions, box, self.radius, offsets, n, extended, source_id])
        return extended, source_id

    def copies(self) -> tuple[np.ndarray, np.ndarray]:
        """Each source's copies in the grid as CSR rows (host, read once): ``start`` (n + 1, int32) and ``shift`` (the
        float32 vec3 offset of each copy from its source, the source itself first with a zero shift). A gather that
        must find points within reach of a source's periodic copies queries another grid at these."""
        points = self.points.numpy()
        source = self.source_id.numpy()
        order = np.argsort(source, kind="stable")  # the source itself (slot i < n) before its images
        start = np.zeros(self.n_sources + 1, dtype=np.int32)
        start[1:] = np.cumsum(np.bincount(source, minlength=self.n_sources))
        shift = (points[order] - points[source[order]]).astype(np.float32)
        return start, shift

    @property
    def n_images(self) -> int:
        """How many periodic image points the grid holds beyond its sources."""
        return 0 if self.points is None else self.points.shape[0] - self.n_sources

    def fill(self, query_points: wp.array, exclude_self: bool, capacity: int,
             start: wp.array, count: wp.array, index: wp.array, room: wp.array | None = None) -> None:
        """Launch :func:`warpfree.kernels.neighbours.fill_rows` for every query point (``room``: each row's, else
        ``capacity`` for all)."""
        n = query_points.shape[0]
        self.launcher.launch(nk.fill_rows, n, [self.grid.id, query_points, self.points, self.source_id, self.radius,
                                               int(exclude_self), int(capacity), _rooms(room, self.launcher), start,
                                               count, index])



class GatherGrid:
    """A HashGrid over a moving point set, rebuilt every step, that a fixed point set gathers from.

    The moving points get no images. In a periodic box each fixed point queries the grid at its own copies, those
    ``fixed`` (a :class:`NeighbourGrid` over the fixed set, with its images) holds, read once here: they never change,
    so a :meth:`build` is Warp's sort alone, with nothing counted, placed or read. A copy takes only the moving points
    within :attr:`radius` of it; a periodic side >= 2 radius leaves one such copy per point, so no moving point is
    found twice (``kernels/neighbours.py``: :class:`~warpfree.kernels.neighbours.GatherCopies`, ``copy_takes``).

    ``fixed``: the fixed set's grid; its radius is the query radius (its images cover the copies a query at that
    radius needs). The hash table has a cell per radius-sized cell of the box and of the copies' reach beyond it
    (up to 256 a side), so no two cells a query visits share a hash slot. Kernels read :attr:`copies`; :meth:`fill`
    makes rows (:class:`NeighbourList` or :class:`NeighbourTable` take a GatherGrid as they take a NeighbourGrid, with
    the fixed set, in its order, as the query points).
    """

    def __init__(self, fixed: NeighbourGrid):
        self.launcher = fixed.launcher
        self.radius = fixed.radius
        self.space = space = fixed.space
        dev = self.launcher.device
        dims = [min(256, int(np.ceil(space.length[a] / self.radius)) + 4) for a in range(space.dim)]
        self.grid = wp.HashGrid(*(dims + [1] * (3 - len(dims))), device=dev)
        start, shift = fixed.copies()
        self.n_fixed = fixed.n_sources
        self.copies = nk.GatherCopies()
        self.copies.grid = self.grid.id
        self.copies.start = wp.array(start, dtype=wp.int32, device=dev)
        self.copies.shift = wp.array(shift, dtype=wp.vec3, device=dev)
        self.copies.radius = self.radius
        self.copies.periodic = int(any(space.periodic[: space.dim]))
        self.points: wp.array | None = None   # the moving points of the last build
        self.builds = 0

    @property
    def id(self):
        """The Warp hash grid's id, as kernels take it."""
        return self.grid.id

    def build(self, positions: wp.array) -> None:
        """(Re)build over the moving ``positions`` (``wp.vec3``; an empty set has nothing to build: no query runs)."""
        _require_points(positions)
        if positions.shape[0]:
            build_hash_grid(self.grid, positions, self.radius)
        self.points = positions
        self.builds += 1

    def fill(self, query_points: wp.array, exclude_self: bool, capacity: int,
             start: wp.array, count: wp.array, index: wp.array, room: wp.array | None = None) -> None:
        """Launch :func:`warpfree.kernels.neighbours.fill_gather_rows` for every fixed point (``query_points``: the
        fixed set's positions, in the order of ``fixed``): row i holds the moving points within the radius."""
        if exclude_self:
            raise ParameterError("exclude_self", "a fixed set never holds a moving point")
        n = query_points.shape[0]
        if n != self.n_fixed:
            raise ParameterError("query_points", f"must be the {self.n_fixed} fixed points, got {n}")
        if self.points is None or self.points.shape[0] == 0:
            count.zero_()
            return
        self.launcher.launch(nk.fill_gather_rows, n, [self.copies, query_points, self.points, int(capacity),
                                                      _rooms(room, self.launcher), start, count, index])

class NeighbourList:
    """Static CSR rows: for each query point, the grid's sources within ``grid.radius``, built once.

    Two passes (count, then fill at the prefix-summed starts), each writing only its own row.
    ``exclude_self`` drops source i from row i when the query set is the source set.
    """

    def __init__(self, grid: NeighbourGrid, query_points: wp.array, exclude_self: bool = False):
        dev = grid.launcher.device
        n = query_points.shape[0]
        self.n = n
        count = wp.zeros(max(n, 1), dtype=wp.int32, device=dev)
        start = wp.zeros(max(n, 1), dtype=wp.int32, device=dev)
        empty = wp.zeros(1, dtype=wp.int32, device=dev)
        if n:
            grid.fill(query_points, exclude_self, 0, start, count, empty)
            wp.utils.array_scan(count, start, inclusive=False)
            total = int(start.numpy()[n - 1] + count.numpy()[n - 1])
        else:
            total = 0
        index = wp.zeros(max(total, 1), dtype=wp.int32, device=dev)
        if n:
            grid.fill(query_points, exclude_self, _INT32_MAX, start, count, index)
        self.n_pairs = total
        self.rows = nk.NeighbourRows()
        self.rows.start, self.rows.count, self.rows.index = start, count, index

    def offsets(self) -> np.ndarray:
        """CSR offsets (n + 1,) on the host."""
        out = np.zeros(self.n + 1, dtype=np.int64)
        if self.n:
            out[:-1] = self.rows.start.numpy()[: self.n]
            out[-1] = self.n_pairs
        return out

    def indices(self) -> np.ndarray:
        """CSR column indices (n_pairs,) on the host."""
        return self.rows.index.numpy()[: self.n_pairs]

    def counts(self) -> np.ndarray:
        """Neighbours per query point (host copy)."""
        return self.rows.count.numpy()[: self.n]


class NeighbourTable:
    """Compact rows, laid out end to end from the last fill's counts with room to spare, refilled in one pass.

    Row i is ``index[start[i] : start[i] + count[i]]``, with room for ``room[i]`` = count + count/10 + 2 entries from
    the previous fill (between two rebuilds the skin lets a count change little): ``start`` is the exclusive prefix
    sum of the rooms, all on the device. A fill writes each row up to its room (never past the index's end) and counts
    every neighbour; if a row did not fit (one device max, the one value a fill reads), the rows are laid out again
    from the true counts, the index grown to hold them, and filled again. New rows are counted first. Memory follows the neighbours each row has: rows of one fixed capacity (the longest row's) held
    4-26x the entries the wall rows of the 3D dam break use. The arrays are kept between fills and grow with
    :attr:`HEADROOM` when outgrown (``grows`` counts it).
    """

    #: room allocated beyond a fill's rows or entries when it outgrows the arrays (a count that grew once grows again)
    HEADROOM = 1.1

    def __init__(self, launcher: Launcher, capacity: int = 32):
        """``capacity``: no longer a bound (rows take what they need); kept so that callers may state the expected
        neighbours per row."""
        self.launcher = launcher
        self.per_row = max(1, int(capacity))
        self.rows = nk.NeighbourRows()
        self.room: wp.array | None = None
        self.n = -1
        self._rows_allocated = -1     # rows the arrays have room for (>= n)
        self._entries_allocated = 0   # entries the index has room for (>= n_pairs)
        self._counted = False         # the counts hold a fill's (of these rows)
        self._worst = Reduction(launcher, wp.int32, "max")
        self.grows = 0
        self.refills = 0

    @property
    def capacity(self) -> int:
        """Entries the index has room for."""
        return self._entries_allocated

    def _allocate_rows(self, n: int) -> None:
        dev = self.launcher.device
        if n > self._rows_allocated:
            rows = max(n, 1) if self._rows_allocated < 0 else int(math.ceil(self.HEADROOM * n))
            self.rows.count = wp.zeros(rows, dtype=wp.int32, device=dev)
            self.rows.start = wp.zeros(rows, dtype=wp.int32, device=dev)
            self.room = wp.zeros(rows, dtype=wp.int32, device=dev)
            if self._rows_allocated >= 0:
                self.grows += 1
            self._rows_allocated = rows
            self._worst.reserve(rows)  # the overflow check's buffers with the rows (its first launch may be in a step)
            self._counted = False
            if self._entries_allocated == 0:  # a placeholder until the first fill has counted its rows
                self.rows.index = wp.empty(1, dtype=wp.int32, device=dev)
        elif n != self.n:
            self._counted = False  # other rows (a set laid out again): their counts are not these rows'
        self.n = n

    def _allocate_entries(self, total: int) -> None:
        if total > self._entries_allocated:
            if self._entries_allocated > 0:
                self.grows += 1
            total = int(math.ceil(self.HEADROOM * total))
            self.rows.index = wp.empty(max(total, 1), dtype=wp.int32, device=self.launcher.device)
            self._entries_allocated = max(total, 1)

    def _lay_out(self, n: int) -> None:
        """Rooms from the counts and starts from the rooms, on the device (nothing read: a row the index cannot hold
        is written no further than its end and reported as an overflow)."""
        self.launcher.launch(nk.table_rooms, n, [self.rows.count, self.room])
        wp.utils.array_scan(self.room[:n], self.rows.start[:n], inclusive=False)

    def _entries_laid_out(self, n: int) -> int:
        """Entries the rooms laid out take (two reads: the last row's start and room)."""
        return int(self.rows.start[n - 1:n].numpy()[0]) + int(self.room[n - 1:n].numpy()[0])

    @property
    def n_pairs(self) -> int:
        """Entries the rows' rooms take, the index's used part (read on request: diagnostics, not steps)."""
        n = self.n
        if n <= 0:
            return 0
        # after a fill ``room`` holds each row's excess (count - room, <= 0): the last row's room is count - excess
        return (int(self.rows.start[n - 1:n].numpy()[0]) + int(self.rows.count[n - 1:n].numpy()[0])
                - int(self.room[n - 1:n].numpy()[0]))

    def _check_fit(self, n: int) -> None:
        """``room`` := each row's excess, on the device: count - room, or at least 1 where the row runs past the
        index's end (``table_overflow``)."""
        rows = self.rows
        self.launcher.launch(nk.table_overflow, n, [rows.start, rows.count, self.room, rows.index.shape[0]])

    def fill(self, grid: NeighbourGrid, query_points: wp.array, exclude_self: bool = False) -> None:
        """Rows for every query point: the grid's sources within ``grid.radius``. A refill of the same rows reads one
        value (the worst excess), and two more when a row outgrew its room (where the rows laid out again end); new
        rows are counted first and read where their rows end."""
        n = query_points.shape[0]
        self._allocate_rows(n)
        if n == 0:
            return
        rows = self.rows
        if not self._counted:  # no counts of these rows yet: count, lay out from the counts, fill (every row fits)
            grid.fill(query_points, exclude_self, 0, rows.start, rows.count, rows.index)
            self._lay_out(n)
            self._allocate_entries(self._entries_laid_out(n))
            grid.fill(query_points, exclude_self, 0, rows.start, rows.count, rows.index, room=self.room)
            self._counted = True
            self._check_fit(n)
            return
        self._lay_out(n)
        grid.fill(query_points, exclude_self, 0, rows.start, rows.count, rows.index, room=self.room)
        self._check_fit(n)
        self._worst.launch(self.room, n)
        if int(self._worst.value()) > 0:  # a row outgrew its room or the index: lay out from the true counts, again
            self.refills += 1
            self._lay_out(n)
            self._allocate_entries(self._entries_laid_out(n))
            grid.fill(query_points, exclude_self, 0, rows.start, rows.count, rows.index, room=self.room)
            self._check_fit(n)

    def counts(self) -> np.ndarray:
        """Neighbours per row (host copy)."""
        return self.rows.count.numpy()[: max(self.n, 0)]

    def row(self, i: int) -> np.ndarray:
        """Source indices of row i (host copy, for tests and diagnostics)."""
        s, c = int(self.rows.start.numpy()[i]), int(self.rows.count.numpy()[i])
        return self.rows.index.numpy()[s: s + c]


class GridPairs:
    """A moving set's pairs with itself read from its grid at every sweep, no rows stored: kernels take
    :class:`~warpfree.kernels.neighbours.PairGrid` and query the grid of the last build at each particle's position
    then (``kernels/neighbours.py``: ``pair_in_reach``), visiting the candidates a table's row would hold, in the same
    order, so the sums are bitwise a table's. Memory: none beyond the grid (a table of the 3D dam break's fluid pairs
    holds ~100 four-byte entries a particle); work: each sweep tests the grid's candidates (the cells' points, about
    6.4x those within reach in 3D, 2.9x in 2D) where a table's rows hold only those within reach.

    ``moving``: the :class:`MovingNeighbours` whose moving set it pairs (its grid and its positions at build)."""

    def __init__(self, moving: "MovingNeighbours"):
        self.moving = moving
        self._struct = nk.PairGrid()
        self._count: wp.array | None = None

    def struct(self) -> nk.PairGrid:
        """The pairs as kernels take them, from the grid of the last build (its arrays may be new at each build)."""
        grid, s = self.moving.grids[MovingNeighbours.MOVING], self._struct
        s.grid, s.points, s.source_id, s.reach = grid.id, grid.points, grid.source_id, grid.radius
        return s

    def counts(self) -> np.ndarray:
        """Candidates per particle at the last build (a count-only pass over the grid; for load balance, not steps)."""
        grid, at = self.moving.grids[MovingNeighbours.MOVING], self.moving.position_at_build
        n = at.shape[0]
        if self._count is None or self._count.shape[0] < n:
            self._count = wp.zeros(max(n, 1), dtype=wp.int32, device=self.moving.launcher.device)
        count = self._count[:n]
        if n:
            grid.fill(at, True, 0, count, count, count)  # capacity 0: counts only (start and index unread)
        return count.numpy()[:n].copy()


class MovingNeighbours:
    """Neighbour tables of a moving set kept valid with a skin (Verlet lists), with static sets beside it.

    Tables hold the candidates within ``radius + skin`` at :attr:`position_at_build` (the moving
    positions at the last build); kernels test the true distance against ``radius``. A pair closer
    than ``radius`` now was closer than ``radius + skin`` at the build as long as no particle has
    moved more than ``skin/2`` since, which :meth:`needs_rebuild` checks from a bound the solver
    reduces on the device (no per-particle host read). The tables depend only on
    :attr:`position_at_build` (part of the solver's state), so a resumed run rebuilds exactly the
    tables it had.

    Parameters
    ----------
    launcher, space: as for :class:`NeighbourGrid`.
    positions: the moving set's current positions (``wp.vec3``; the solver moves them in place).
    radius: interaction radius (m). skin: extra margin (m), >= 0 (0: rebuild every step).
    static_sets: name -> positions of static sets (walls, nodes) that query or are queried.
    position_at_build: the array to keep the build positions in (a solver passes its state's), or None.
    static_at_build: name -> an array for a static set that moves all the same (walls of a rigid body, moved by the
        solver, not integrated here): its positions are kept there at each :meth:`rebuild` and its grid is built
        from them, so that its tables stay valid while it too moves less than skin/2 (the solver's bound covers it).
    sized_for: set name ("moving" or a static set's) -> the grid points its hash table is sized for
        (:class:`NeighbourGrid`; a distributed run's ranks pass the whole sets').
    """

    MOVING = "moving"

    def __init__(self, launcher: Launcher, space: Space, positions: wp.array, radius: float, skin: float,
                 static_sets: dict[str, wp.array] | None = None, position_at_build: wp.array | None = None,
                 sized_for: dict[str, int] | None = None, static_at_build: dict[str, wp.array] | None = None):
        self.launcher = launcher
        self.space = space
        self.radius = require_positive("radius", radius)
        self.skin = require_positive("skin", skin, allow_zero=True)
        space.require_room(self.radius + self.skin, "skin")
        self.positions = positions
        if position_at_build is None:
            position_at_build = wp.clone(positions)
        elif position_at_build.shape != positions.shape or position_at_build.dtype != positions.dtype:
            raise ParameterError("position_at_build", f"must be like positions ({positions.shape[0]} vec3)")
        self.position_at_build = position_at_build
        self.static_sets = dict(static_sets or {})
        self.static_at_build = self._at_build(static_at_build)
        reach = self.radius + self.skin
        sized_for = dict(sized_for or {})
        self.grids = {self.MOVING: NeighbourGrid(launcher, reach, space, sized_for=sized_for.get(self.MOVING))}
        for name, pos in self.static_sets.items():
            self.grids[name] = NeighbourGrid(launcher, reach, space, pos, sized_for=sized_for.get(name))
        self.tables: dict[str, tuple[NeighbourTable, str, str, bool]] = {}
        self.builds = 0

    def add_table(self, name: str, query: str, source: str, capacity: int = 32,
                  exclude_self: bool = False) -> NeighbourTable:
        """A table of ``source`` candidates for every point of ``query`` ("moving" or a static set name).
        A table between two static sets belongs in a :class:`NeighbourList` instead."""
        for role, set_name in (("query", query), ("source", source)):
            if set_name != self.MOVING and set_name not in self.static_sets:
                raise ParameterError(role, f"unknown set {set_name!r}; have 'moving' and {sorted(self.static_sets)}")
        if query != self.MOVING and source != self.MOVING:
            raise ParameterError("source", "a table between two static sets never changes: use NeighbourList")
        table = NeighbourTable(self.launcher, capacity)
        self.tables[name] = (table, query, source, exclude_self)
        return table

    def _at_build(self, static_at_build: dict[str, wp.array] | None) -> dict[str, wp.array]:
        out = dict(static_at_build or {})
        for name, arr in out.items():
            pos = self.static_sets.get(name)
            if pos is None or arr.shape != pos.shape or arr.dtype != pos.dtype:
                raise ParameterError("static_at_build", f"{name!r} must be like the static set of that name")
        return out

    def follow(self, positions: wp.array, position_at_build: wp.array,
               static_sets: dict[str, wp.array] | None = None,
               static_at_build: dict[str, wp.array] | None = None) -> None:
        """The same sets laid out anew (a rank's part after a migration): the moving set's ``positions`` and
        ``position_at_build`` arrays, the static sets' new positions (their grids built over them at once). The grids'
        hash tables and the tables' arrays are kept (reused while they fit); the tables are filled at the next
        :meth:`rebuild`."""
        if position_at_build.shape != positions.shape or position_at_build.dtype != positions.dtype:
            raise ParameterError("position_at_build", f"must be like positions ({positions.shape[0]} vec3)")
        new_static = dict(static_sets or {})
        if set(new_static) != set(self.static_sets):
            raise ParameterError("static_sets", f"must name the same sets as before: {sorted(self.static_sets)}")
        self.positions, self.position_at_build, self.static_sets = positions, position_at_build, new_static
        self.static_at_build = self._at_build(static_at_build)
        for name, pos in new_static.items():
            if name not in self.static_at_build:  # a moving one's grid: at the next build
                self.grids[name].build(pos)

    def table(self, name: str) -> NeighbourTable:
        """The neighbour table called ``name``."""
        return self.tables[name][0]

    def needs_rebuild(self, moved_bound: float) -> bool:
        """True when a particle may have moved more than skin/2 since the build (``moved_bound`` >= the
        largest displacement since the build, m)."""
        return self.skin == 0.0 or not math.isfinite(moved_bound) or moved_bound > 0.5 * self.skin

    def rebuild(self) -> None:
        """Build at the current positions: copy them to :attr:`position_at_build`, then :meth:`build_tables`."""
        wp.copy(self.position_at_build, self.positions)
        for name, at_build in self.static_at_build.items():
            wp.copy(at_build, self.static_sets[name])
        self.build_tables()

    def build_tables(self) -> None:
        """Grid of the moving set and every table, from :attr:`position_at_build` (also after a resume)."""
        self.grids[self.MOVING].build(self.position_at_build)
        for name, at_build in self.static_at_build.items():
            self.grids[name].build(at_build)
        for table, query, source, exclude_self in self.tables.values():
            q = (self.position_at_build if query == self.MOVING
                 else self.static_at_build.get(query, self.static_sets[query]))
            table.fill(self.grids[source], q, exclude_self)
        self.builds += 1


def empty_rows(n: int, device: str) -> nk.NeighbourRows:
    """Rows of a table with no sources (a fluid without walls, a region without free boundary): all empty. Also the
    rows a two-pass kernel counts into (:func:`lay_out_rows`)."""
    rows = nk.NeighbourRows()
    rows.start = wp.zeros(max(n, 1), dtype=wp.int32, device=device)
    rows.count = wp.zeros(max(n, 1), dtype=wp.int32, device=device)
    rows.index = wp.zeros(1, dtype=wp.int32, device=device)
    return rows


def lay_out_rows(rows: nk.NeighbourRows, n: int, name: str) -> tuple[np.ndarray, int]:
    """After a kernel's count pass into ``rows.count`` (``n`` rows): the starts (the exclusive prefix sum) and an
    index array for the fill pass, on ``rows``; returns (counts (n,) int64 on the host, total entries). A total past
    the int32 index range is refused naming ``name`` (the parameter that sets the rows' width)."""
    counts = rows.count.numpy()[:n].astype(np.int64)
    starts = np.zeros(n, dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    total = int(counts.sum())
    if total >= 2**31:
        raise ParameterError(name, f"{total} row entries exceed the int32 index range")
    device = rows.count.device
    rows.start = wp.array(starts.astype(np.int32) if n else np.zeros(1, np.int32), dtype=wp.int32, device=device)
    rows.index = wp.zeros(max(total, 1), dtype=wp.int32, device=device)
    return counts, total


def host_rows(counts: np.ndarray, index: np.ndarray, device: str) -> nk.NeighbourRows:
    """Rows from host ``counts`` (n,) and ``index`` (their entries, row after row): CSR with the starts the
    exclusive prefix sum of the counts."""
    counts = np.asarray(counts, dtype=np.int64)
    starts = np.zeros(counts.size, dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    rows = nk.NeighbourRows()
    rows.start = wp.array(starts.astype(np.int32) if counts.size else np.zeros(1, np.int32), dtype=wp.int32,
                          device=device)
    rows.count = wp.array(counts.astype(np.int32) if counts.size else np.zeros(1, np.int32), dtype=wp.int32,
                          device=device)
    index = np.asarray(index)
    rows.index = wp.array(index.astype(np.int32) if index.size else np.zeros(1, np.int32), dtype=wp.int32,
                          device=device)
    return rows


def neighbour_counts_brute(launcher: Launcher, space: Space, query_points: wp.array, source_points: wp.array,
                           radius: float, exclude_self: bool = False) -> np.ndarray:
    """Brute-force neighbour counts (O(N M), minimum image): the reference of the tests."""
    n = query_points.shape[0]
    counts = wp.zeros(max(n, 1), dtype=wp.int32, device=launcher.device)
    launcher.launch(nk.count_neighbours_brute, n, [space.box, query_points, source_points, float(radius),
                                                   int(exclude_self), counts])
    return counts.numpy()[:n]
