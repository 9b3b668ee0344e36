"""Checkpoints: the state arrays, the time loop's scalars and its series, in one ``.npz`` per step.

Layout: ``<run>/checkpoints/step_XXXXXXXX.npz`` (eight digits), the two newest kept; a distributed run's ranks
each write their own, ``step_XXXXXXXX_rank_RRRR_of_NNNN.npz`` (``piece``: :func:`piece_name`). Inside:
``loop`` (JSON text: time, step, outputs written), ``series__<name>`` (float64 arrays: probe and
diagnostic series up to this step) and ``state__<name>`` (every array of the solver's
:class:`~warpfree.solver.State`, in its own dtype, so a resume is bitwise).

A checkpoint is written to a hidden temporary file, flushed to disk, then moved into place with
:func:`os.replace`: a kill at any moment leaves either the previous files or the new one, never a
file that :func:`latest` would pick up half written (only names matching ``step_XXXXXXXX.npz``
count; leftovers of a killed write are removed by the next save).
"""

from __future__ import annotations

import json
import os
import re
import zipfile

import numpy as np

from ..errors import ParameterError

__all__ = ["save", "load", "latest", "newest_first", "step_of", "piece_name", "piece_sets", "KEEP"]

#: checkpoints kept per run (the newest)
KEEP = 2


def piece_name(rank: int, size: int) -> str:
    """The suffix of rank ``rank``'s checkpoints in a run of ``size`` ranks."""
    return f"rank_{int(rank):04d}_of_{int(size):04d}"


def _patterns(piece: str | None):
    tail = "" if piece is None else "_" + re.escape(piece)
    return re.compile(rf"^step_(\d{{8}}){tail}\.npz$"), re.compile(rf"^\.step_\d{{8}}{tail}\.npz\.tmp\d*$")


def step_of(path: str) -> int:
    """The step number of a checkpoint's file name."""
    return int(re.match(r"^step_(\d{8})", os.path.basename(path)).group(1))


def save(directory: str, step: int, loop: dict, series: dict[str, np.ndarray], state: dict[str, np.ndarray],
         keep: int = KEEP, piece: str | None = None) -> str:
    """Write checkpoint ``step`` into ``directory`` (created) and keep the ``keep`` newest (of this ``piece``: a
    distributed run's rank, :func:`piece_name`); returns its path."""
    os.makedirs(directory, exist_ok=True)
    tail = "" if piece is None else f"_{piece}"
    name, leftover_name = _patterns(piece)
    path = os.path.join(directory, f"step_{int(step):08d}{tail}.npz")
    tmp = os.path.join(directory, f".step_{int(step):08d}{tail}.npz.tmp{os.getpid()}")
    payload = {"loop": np.array(json.dumps(loop))}
    payload.update({f"series__{k}": np.asarray(v, dtype=np.float64) for k, v in series.items()})
    payload.update({f"state__{k}": v for k, v in state.items()})
    with open(tmp, "wb") as f:
        np.savez(f, **payload)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    names = sorted(f for f in os.listdir(directory) if name.match(f))
    for old in names[:-keep]:
        os.remove(os.path.join(directory, old))
    for leftover in (f for f in os.listdir(directory) if leftover_name.match(f)):
        os.remove(os.path.join(directory, leftover))
    return path


def newest_first(directory: str, piece: str | None = None) -> list[str]:
    """The checkpoints in ``directory`` (complete names only, of this ``piece``), newest first."""
    if not os.path.isdir(directory):
        return []
    name, _ = _patterns(piece)
    return [os.path.join(directory, f) for f in sorted((f for f in os.listdir(directory) if name.match(f)),
                                                       reverse=True)]


def latest(directory: str, piece: str | None = None) -> str | None:
    """The newest checkpoint in ``directory`` (of this ``piece``), or None."""
    paths = newest_first(directory, piece)
    return paths[0] if paths else None


def load(path: str) -> tuple[dict, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """(loop scalars, series, state arrays) of a checkpoint; a damaged file raises ParameterError('resume')."""
    try:
        with np.load(path) as data:
            loop = json.loads(str(data["loop"]))
            series = {k[len("series__"):]: data[k] for k in data.files if k.startswith("series__")}
            state = {k[len("state__"):]: data[k] for k in data.files if k.startswith("state__")}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise ParameterError("resume", f"cannot read checkpoint {path}: {exc}") from None
    return loop, series, state


def piece_sets(directory: str) -> dict[int, dict[int, list[str]]]:
    """The complete checkpoints of distributed runs in ``directory``: rank count -> step -> the ranks' files in rank
    order (a step missing a rank's file is left out)."""
    if not os.path.isdir(directory):
        return {}
    found: dict[int, dict[int, dict[int, str]]] = {}
    for f in os.listdir(directory):
        m = re.match(r"^step_(\d{8})_rank_(\d{4})_of_(\d{4})\.npz$", f)
        if m:
            step, rank, size = (int(g) for g in m.groups())
            found.setdefault(size, {}).setdefault(step, {})[rank] = os.path.join(directory, f)
    return {size: {step: [ranks[r] for r in range(size)] for step, ranks in steps.items() if len(ranks) == size}
            for size, steps in found.items()}
