"""Errors raised by warpfree.

Bad input raises :class:`ParameterError` (a ``ValueError``) naming the parameter and the allowed range.
A run that goes wrong (non-finite values, particles leaving the container) raises :class:`RunError`
after the simulation loop has kept its last good checkpoint on disk.
"""

import math
import os


class ParameterError(ValueError):
    """A parameter is out of its allowed range; the message names it."""

    def __init__(self, name: str, message: str):
        self.name = name
        super().__init__(f"{name}: {message}")


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


def available_memory() -> int | None:
    """Bytes of memory this machine has free now (None where the system does not say)."""
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return None


def require_memory(name: str, count: float, bytes_each: float, what: str) -> None:
    """Refuse, naming ``name``, work that needs more memory than the machine has free, before allocating it.

    ``count`` items of ``bytes_each`` bytes (``what`` says what they are, e.g. "lattice points").
    """
    need = float(count) * float(bytes_each)
    free = available_memory()
    if free is not None and need > free:
        raise ParameterError(name, f"gives {count:.3g} {what}, which need {_bytes(need)} of memory; this machine has "
                                   f"{_bytes(free)} free (use a coarser spacing or a smaller domain)")


def _bytes(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB", "PB"):
        if n < 1024 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PB"  # pragma: no cover
