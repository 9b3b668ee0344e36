"""SPEM's E and H sets spread over the ranks of a run.

A run of one process is a one-rank partition: its sets are the model's, over the model's own arrays and rows (no
copy), and its refreshes do nothing.

Both sets are static: they are cut once (:class:`~warpfree.parallel.Decomposition`, weighed by their rows' lengths)
and each rank holds the particles its box owns and, as ghosts, every particle a row of its own reaches (the depth is
the longest row of the model's, measured). The rows themselves are the model's, which every rank builds: a rank takes
its own particles' rows, their coefficients and their order unchanged, with the columns renumbered to the particles
it holds (:func:`~warpfree.parallel.halo.take_rows`), so every update sums the one process's terms in its order. A
step refreshes Ez on the ghost E particles after the E phase and H on the ghost H particles after the H phase; the
sources and the total-field boundary act on a rank's own particles only.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpfree.neighbours import host_rows
from warpfree.parallel import CutMethod, Decomposition, Partition, World
from warpfree.parallel.halo import take_rows

__all__ = ["FieldSpread"]


def _row_reach(rows, own: np.ndarray, other: np.ndarray) -> float:
    """The longest distance (m) from a particle to a particle of its row."""
    start, count, index = (rows.start.numpy(), rows.count.numpy(), rows.index.numpy())
    n = own.shape[0]
    count = count[:n]
    owner = np.repeat(np.arange(n), count)
    entries = np.repeat(start[:n] - np.concatenate([[0], np.cumsum(count)[:-1]]), count) + np.arange(count.sum())
    if not entries.size:
        return 0.0
    return float(np.sqrt(np.max(np.sum((own[owner] - other[index[entries]]) ** 2, axis=1))))


class FieldSpread:
    """The decomposition of an :class:`~warpfree.solvers.spem.model.SPEMModel` over ``world``'s ranks, the E and H
    sets' :class:`~warpfree.parallel.Partition` (``electric``, ``magnetic``) and the model's rows taken for them."""

    def __init__(self, world: World, model, method: CutMethod = CutMethod.RCB):
        self.world = world
        self.model = model
        xe = model.layout.e_position.astype(np.float64)
        xh = model.layout.h_position.astype(np.float64)
        if xe.shape[1] < 3:
            xe = np.hstack([xe, np.zeros((len(xe), 3 - xe.shape[1]))])
            xh = np.hstack([xh, np.zeros((len(xh), 3 - xh.shape[1]))])
        reach = max(_row_reach(model.e_rows.rows, xe, xh), _row_reach(model.h_rows.rows, xh, xe))
        #: ghosts are the particles within the longest row's reach of a box (a hair more, against rounding)
        self.depth = reach * (1.0 + 1e-9) + 1e-12
        cost = np.concatenate([model.e_rows.rows.count.numpy()[:len(xe)],
                               model.h_rows.rows.count.numpy()[:len(xh)]]).astype(np.float64) + 1.0
        self.decomposition = Decomposition.build(world.size, np.vstack([xe, xh]), cost, model.reach, model.dim,
                                                 method)
        self.electric = Partition.of_all(world, self.decomposition, self.depth, xe)
        self.magnetic = Partition.of_all(world, self.decomposition, self.depth, xh)

    def held_set(self, name: str, whole, part: Partition, state: dict[str, np.ndarray], device: str):
        """The set this rank steps: ``whole`` (the model's :class:`~warpfree.particles.ParticleSet`)'s held rows and
        the ``state`` fields (whole-set values: the initial fields, the held flag), on ``part``. In one process a view
        over the model's own arrays (no copy), with the state's arrays beside them (the model is left as it is)."""
        from warpfree.particles import ParticleSet

        if part.whole:
            arrays = dict(whole.fields)
        else:
            arrays = {k: wp.array(part.take(v.numpy()), dtype=v.dtype, device=device) for k, v in whole.fields.items()}
        for k, v in state.items():
            arrays[k] = wp.array(part.take(v), dtype=wp.int32 if v.dtype.kind == "i" else float, device=device)
        return ParticleSet.view(name, self.model.dim, arrays, partition=part)

    def rows(self, rows, coefficient: wp.array, own: Partition, other: Partition):
        """(rows, coefficients) of ``own``'s held particles (ghost rows empty), columns in ``other``'s held order:
        the model's own in one process."""
        if own.whole:
            return rows, coefficient
        start, count, index = rows.start.numpy(), rows.count.numpy(), rows.index.numpy()
        mine = own.owned_index
        counts, local, entries = take_rows(start, count, index, own.ids[mine], other)
        per_row = np.zeros(own.n, dtype=np.int64)
        per_row[mine] = counts
        dev = coefficient.device
        coef = coefficient.numpy()[entries]
        return (host_rows(per_row, local, dev),
                wp.array(coef if coef.size else np.zeros((1, 3), np.float32), dtype=wp.vec3, device=dev))

    def owned_electric(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Of E particles ``ids`` (global), those this rank owns: (their held indices, their positions in ``ids``)."""
        return self.owned(self.electric, ids)

    @staticmethod
    def owned(part, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Of the particles ``ids`` (global) of the set ``part`` spreads, those this rank owns: (their held indices,
        their positions in ``ids``)."""
        if part.whole:
            return ids, np.arange(ids.size)
        at = np.searchsorted(part.ids, ids)
        at = np.minimum(at, max(part.n - 1, 0))
        mine = np.flatnonzero((part.n > 0) & (part.ids[at] == ids) & part.owned[at]) if part.n else np.zeros(0, int)
        return at[mine], mine

    def plane_wave(self, wave):
        """A :class:`~warpfree.solvers.spem.plane_wave.DevicePlaneWave` on this rank's own targets: each target's row
        (over the other set) kept as it is, its columns renumbered: ``wave`` itself in one process."""
        if self.electric.whole:
            return wave
        for targets, rows, coefficient, n, own, other, tag in (
                ("e_targets", "e_rows", "e_coefficient", "n_e", self.electric, self.magnetic, "e"),
                ("h_targets", "h_rows", "h_coefficient", "n_h", self.magnetic, self.electric, "h")):
            whole = getattr(wave, targets).numpy()[:getattr(wave, n)].astype(np.int64)
            r = getattr(wave, rows)
            at = np.searchsorted(own.ids, whole)
            at = np.minimum(at, max(own.n - 1, 0))
            keep = np.flatnonzero((own.ids[at] == whole) & own.owned[at]) if own.n else np.zeros(0, np.int64)
            counts, local, entries = take_rows(r.start.numpy(), r.count.numpy(), r.index.numpy(), keep, other)
            dev = getattr(wave, coefficient).device
            coef = getattr(wave, coefficient).numpy()[entries]
            setattr(wave, targets, wp.array(at[keep].astype(np.int32) if keep.size else np.zeros(1, np.int32),
                                            dtype=wp.int32, device=dev))
            setattr(wave, rows, host_rows(counts, local, dev))
            setattr(wave, coefficient, wp.array(coef if coef.size else np.zeros((1, 3), np.float32),
                                                dtype=wp.vec3, device=dev))
            setattr(wave, n, int(keep.size))
        return wave

    def describe(self) -> dict:
        """The distributed layout for ``summary.json`` (``{"distributed": ...}``; nothing in one process): E and H
        particles owned and ghost per rank."""
        if self.electric.whole:
            return {}
        counts = np.concatenate(self.world.allgather(np.array(
            [self.electric.n_owned, self.electric.n_ghosts, self.magnetic.n_owned, self.magnetic.n_ghosts],
            dtype=np.int64))).reshape(self.world.size, 4)
        held = counts.sum()
        return {"distributed": {"ranks": self.world.size, "depth": self.depth,
                                "electric_owned": counts[:, 0].tolist(), "electric_ghosts": counts[:, 1].tolist(),
                                "magnetic_owned": counts[:, 2].tolist(), "magnetic_ghosts": counts[:, 3].tolist(),
                                "ghost_fraction": float((counts[:, 1].sum() + counts[:, 3].sum()) / max(held, 1)),
                                "decomposition": self.decomposition.describe()}}
