"""Errors raised by warpfree.

Bad input raises :class:`ParameterError` (a ``ValueError``) naming the parameter and the allowed range.
A run that goes wrong (non-finite values, particles leaving the container) raises :class:`RunError`
after the simulation loop has kept its last good checkpoint on disk.
"""

import math


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
