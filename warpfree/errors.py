"""Errors raised by warpfree, and the checks of bad input that raise them.

Bad input raises :class:`ParameterError` (a ``ValueError``) naming the parameter and the allowed range; the checks
here (:func:`require_finite`, :func:`require_positive`, :func:`require_integer`, :func:`require_bool`,
:func:`require_memory`; a closed choice is a :class:`warpfree.parameters.Choice`) are the only copies of each rule. A
library function names its own argument; a scene that passes a quantity derived from its parameters wraps the call in
:func:`reported_as`, so that the user reads the name they set. Nothing is clamped or reinterpreted: a value is accepted as given or refused.
A run that goes wrong (non-finite values, particles leaving the container) raises :class:`RunError` after the
simulation loop has kept its last good checkpoint on disk; a run stopped on request (Ctrl-C, SIGTERM) raises
:class:`RunInterrupted` after keeping its last completed step.
"""

import difflib
import math
import numbers
import os
from collections.abc import Iterable
from contextlib import contextmanager


class ParameterError(ValueError):
    """A parameter is out of its allowed range; the message names it (``name``; ``detail`` is the rest)."""

    def __init__(self, name: str, message: str):
        self.name = name
        self.detail = message
        super().__init__(f"{name}: {message}")


@contextmanager
def reported_as(**names: str):
    """Inside, a :class:`ParameterError` about an internal name (an argument of a library function that a scene
    computed from its own parameters) is raised again about the scene parameter(s) the user set: ``names`` maps
    internal -> scene names (``with reported_as(length_x="box"): ...`` gives ``box: length_x must be > 0, got 0``).
    An error may name several parameters (``"dx, layers"``: the count they make together); each is mapped."""
    try:
        yield
    except ParameterError as err:
        parts = parameter_names(err.name)
        if not any(p in names for p in parts):
            raise
        mapped = []
        for p in parts:
            for q in parameter_names(names.get(p, p)):
                if q not in mapped:
                    mapped.append(q)
        raise ParameterError(", ".join(mapped), f"{err.name} {err.detail}" if len(parts) == 1 and err.name != mapped[0]
                             else err.detail) from None


def parameter_names(name: str) -> list[str]:
    """The parameters an error names: ``"dx, layers"`` -> ``["dx", "layers"]``."""
    return [p.strip() for p in name.split(",") if p.strip()]


def closest_names(name: str, names: Iterable[str]) -> str:
    """A hint for an unknown ``name``: the closest of ``names`` ("did you mean ...?"), then all of them."""
    names = sorted(names)
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(close)}? " if close else ""
    return f"{hint}choose from {', '.join(names)}"


class RunError(RuntimeError):
    """A run stopped because its state went bad; ``step`` is the step at which it was detected."""

    def __init__(self, message: str, step: int | None = None, last_good: str | None = None):
        self.message = message
        self.step = step
        self.last_good = last_good
        text = message if step is None else f"step {step}: {message}"
        if last_good:
            text += f" (last good state kept in {last_good})"
        super().__init__(text)


class RunInterrupted(Exception):
    """A run stopped on request (Ctrl-C, SIGTERM: ``signum``) at the end of step ``step``, at simulated time
    ``time``, with that step's outputs written and its state kept in the checkpoint ``kept`` (None: nothing could be
    kept, e.g. a static solve)."""

    def __init__(self, signum: int, step: int | None = None, time: float | None = None, kept: str | None = None):
        self.signum, self.step, self.time, self.kept = signum, step, time, kept
        super().__init__(f"interrupted by signal {signum}" + (f" after step {step}" if step is not None else ""))


def require_finite(name: str, value) -> float:
    """Return ``float(value)`` if it is a finite number, else raise naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ParameterError(name, f"must be finite, got {v}")
    return v


def require_positive(name: str, value, allow_zero: bool = False) -> float:
    """Return ``float(value)`` if it is finite and > 0 (>= 0 with ``allow_zero``), else raise."""
    v = require_finite(name, value)
    if v < 0 or (v == 0 and not allow_zero):
        raise ParameterError(name, f"must be {'>= 0' if allow_zero else '> 0'}, got {v}")
    return v


def require_integer(name: str, value, minimum: int | None = None, maximum: int | None = None) -> int:
    """Return ``value`` as an ``int`` if it is an integer (not a bool, not a float) in [minimum, maximum]."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ParameterError(name, f"must be an integer{_range_text(minimum, maximum)}, got {value!r}")
    v = int(value)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        raise ParameterError(name, f"must be an integer{_range_text(minimum, maximum)}, got {v}")
    return v


def _range_text(minimum, maximum) -> str:
    if minimum is not None and maximum is not None:
        return f" from {minimum} to {maximum}"
    if minimum is not None:
        return f" >= {minimum}"
    return f" <= {maximum}" if maximum is not None else ""


def require_bool(name: str, value) -> bool:
    """Return ``value`` if it is ``True`` or ``False`` (a string, a number or None is refused, never read as truthy)."""
    if not isinstance(value, bool):
        try:
            import numpy as np
        except ImportError:  # pragma: no cover - numpy is a dependency
            np = None
        if np is None or not isinstance(value, np.bool_):
            raise ParameterError(name, f"must be true or false, got {value!r}")
    return bool(value)


def available_memory() -> int | None:
    """Bytes of memory this machine can give a process now: the kernel's estimate of available memory (free memory
    plus caches it can drop, ``MemAvailable``), else the free pages; None where the system says neither."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return None


def require_memory(name: str, count: float, bytes_each: float, what: str) -> None:
    """The memory guard: refuse, naming ``name``, work that needs more memory than the machine has available,
    before allocating it. Every layout builder (fluid, EM, EFG, NEM and PIC points) calls it with its count.

    ``count`` items of about ``bytes_each`` bytes each over the whole run (``what`` says what they are, e.g.
    "particles with their neighbour tables"); the message gives the count, the bytes and the memory available.
    """
    need = float(count) * float(bytes_each)
    free = available_memory()
    if free is not None and need > free:
        raise ParameterError(name, f"gives {count:.3g} {what}, which need {_bytes(need)} of memory; this machine has "
                                   f"{_bytes(free)} available (use a coarser spacing or a smaller domain)")


def _bytes(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB", "PB"):
        if n < 1024 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PB"  # pragma: no cover
