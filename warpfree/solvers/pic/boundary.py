"""A region's boundary as the particles meet it: its pieces as chords within 1e-7 of the exact curves, in groups (each
electrode, each kind of wall) that absorb the particles reaching them or reflect them, and the uniform cell grid the
crossing kernel walks (``kernels/pic.py: cross_boundary``).

Groups: every electrode (``warpfree.solvers.pic.electrodes``) absorbs; the other pieces are walls, each tag's as
its :class:`Wall` says (absorbing or reflecting; by default reflecting), one group per :class:`Wall`. A particle
absorbed by group g leaves with ``exit_wall`` = ``first_exit`` + g; the sort counts it against that group, so each
electrode's absorbed charge is known exactly (the count times the macro-charge). float64 chords; host set-up once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.galerkin.region import Region
from warpfree.kernels import pic as pk

from .electrodes import Electrode, piece_tags

__all__ = ["Wall", "ParticleBoundary", "CELLS_ACROSS"]

#: cells of the chords' grid across the region's larger side
CELLS_ACROSS = 128


@dataclass(frozen=True)
class Wall:
    """The region's pieces tagged ``tags`` that no electrode holds: an insulating wall (no surface charge,
    ∂u/∂n = 0) that ``absorbs`` the particles reaching it (True) or reflects them specularly (False). ``name``: how
    outputs call it (default: its tags joined by "+")."""

    tags: tuple
    absorbs: bool = False
    name: str = ""

    def __post_init__(self):
        tags = piece_tags(self.tags, "a wall")
        object.__setattr__(self, "tags", tags)
        object.__setattr__(self, "absorbs", bool(self.absorbs))
        object.__setattr__(self, "name", self.name or "+".join(tags))


class ParticleBoundary:
    """The chords of ``region``'s pieces in groups: the ``electrodes`` (absorbing), then the ``walls``, then, if any
    piece is in neither, a reflecting group "walls" of the rest. ``first_exit``: the ``exit_wall`` code of group 0.
    ``names``: the groups' names; ``absorbs``: which absorb; :attr:`struct`: the kernel's view."""

    def __init__(self, region: Region, electrodes: Sequence[Electrode], walls: Sequence[Wall], launcher: Launcher,
                 first_exit: int):
        groups = [(e.name, e.tags, True) for e in electrodes] + [(w.name, w.tags, w.absorbs) for w in walls]
        group_of: dict[str, int] = {}
        for g, (name, tags, _) in enumerate(groups):
            for t in tags:
                if t not in region.tags:
                    raise ParameterError("tags", f"{name!r}: no piece is tagged {t!r}; the region's tags: {region.tags}")
                if t in group_of:
                    raise ParameterError("tags", f"the pieces tagged {t!r} are given twice ({groups[group_of[t]][0]!r} "
                                                 f"and {name!r})")
                group_of[t] = g
        rest = [t for t in region.tags if t not in group_of]
        if rest:
            if any(name == "walls" for name, _, _ in groups):
                raise ParameterError("walls", "a group is named 'walls' and untagged pieces remain: name it otherwise")
            for t in rest:
                group_of[t] = len(groups)
            groups.append(("walls", tuple(rest), False))
        self.names = [name for name, _, _ in groups]
        self.absorbs = [absorbs for _, _, absorbs in groups]
        start, end, piece = region.chords()
        tags = np.array([p.tag for p in region.pieces], dtype=object)
        group = np.array([group_of[t] for t in tags[piece]], dtype=np.int32)
        lo, hi = region.bounds()
        cell = float(np.max(hi - lo)) / CELLS_ACROSS
        lower = lo - cell
        counts = np.maximum(1, np.ceil((hi - lower) / cell).astype(int) + 1)
        first = np.floor((np.minimum(start, end) - lower) / cell).astype(np.int64)
        last = np.floor((np.maximum(start, end) - lower) / cell).astype(np.int64)
        span = last - first + 1
        per_chord = span[:, 0] * span[:, 1]
        chord = np.repeat(np.arange(len(start)), per_chord)
        local = np.arange(chord.size) - np.repeat(np.cumsum(per_chord) - per_chord, per_chord)
        cx = first[chord, 0] + local % span[chord, 0]
        cy = first[chord, 1] + local // span[chord, 0]
        key = cy * counts[0] + cx
        order = np.lexsort((chord, key))
        cell_start = np.searchsorted(key[order], np.arange(counts[0] * counts[1] + 1)).astype(np.int32)
        dev = launcher.device
        b = pk.RegionBoundary()
        b.chord_start = wp.array(start, dtype=wp.vec2d, device=dev)
        b.chord_end = wp.array(end, dtype=wp.vec2d, device=dev)
        b.chord_group = wp.array(group, dtype=wp.int32, device=dev)
        b.group_absorbs = wp.array(np.array(self.absorbs, dtype=np.int32), dtype=wp.int32, device=dev)
        b.lower = wp.vec2d(*lower)
        b.cell = wp.float64(cell)
        b.cells_x, b.cells_y = int(counts[0]), int(counts[1])
        b.cell_start = wp.array(cell_start, dtype=wp.int32, device=dev)
        b.cell_chords = wp.array(chord[order].astype(np.int32), dtype=wp.int32, device=dev)
        b.first_exit = int(first_exit)
        #: the crossing kernel's view of the boundary (built once)
        self.struct = b
        self.chords = len(start)
        self.lower, self.upper = lo, hi

    def describe(self) -> dict:
        """The boundary for ``summary.json``: its groups (name, absorbs) and chords."""
        return {"groups": [{"name": n, "absorbs": a} for n, a in zip(self.names, self.absorbs)],
                "chords": int(self.chords)}

