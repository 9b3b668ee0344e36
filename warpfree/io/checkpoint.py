"""Checkpoints: the state arrays, the time loop's scalars and its series, in one ``.npz`` per step.

Layout: ``<run>/checkpoints/step_XXXXXXXX.npz`` (eight digits), the two newest kept. Inside:
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

__all__ = ["save", "load", "latest", "newest_first", "KEEP"]

#: checkpoints kept per run (the newest)
KEEP = 2
_NAME = re.compile(r"^step_(\d{8})\.npz$")
_TMP = re.compile(r"^\.step_\d{8}\.npz\.tmp\d*$")


def save(directory: str, step: int, loop: dict, series: dict[str, np.ndarray], state: dict[str, np.ndarray],
         keep: int = KEEP) -> str:
    """Write checkpoint ``step`` into ``directory`` (created) and keep the ``keep`` newest; returns its path."""
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, f"step_{int(step):08d}.npz")
    tmp = os.path.join(directory, f".step_{int(step):08d}.npz.tmp{os.getpid()}")
    payload = {"loop": np.array(json.dumps(loop))}
    payload.update({f"series__{k}": np.asarray(v, dtype=np.float64) for k, v in series.items()})
    payload.update({f"state__{k}": v for k, v in state.items()})
    with open(tmp, "wb") as f:
        np.savez(f, **payload)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    names = sorted(f for f in os.listdir(directory) if _NAME.match(f))
    for old in names[:-keep]:
        os.remove(os.path.join(directory, old))
    for leftover in (f for f in os.listdir(directory) if _TMP.match(f)):
        os.remove(os.path.join(directory, leftover))
    return path


def newest_first(directory: str) -> list[str]:
    """The checkpoints in ``directory`` (complete names only), newest first."""
    if not os.path.isdir(directory):
        return []
    return [os.path.join(directory, f) for f in sorted((f for f in os.listdir(directory) if _NAME.match(f)),
                                                       reverse=True)]


def latest(directory: str) -> str | None:
    """The newest checkpoint in ``directory``, or None."""
    paths = newest_first(directory)
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
