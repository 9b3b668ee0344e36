"""Progress a user can read: the set-up phases of a run announced with their wall times, and the progress bar's
simulated time in a readable unit.

Set-up code marks a phase with ``with announce("fluid layout relaxed (4 096 particles)"): ...``; when progress is
on (:func:`enable`: the command line turns it on unless ``--no-progress``), a phase that took at least
:data:`THRESHOLD_S` seconds prints one line on stderr as it ends, beside the progress bar (tqdm writes there too)::

      set-up: fluid layout relaxed (4 096 particles) 62.3 s

A threshold rather than every phase: set-up runs dozens of short phases (a neighbour list, a module loaded from
Warp's kernel cache, each 10-100 ms) whose lines would hide the few that make a silence a user notices; every
second of set-up is still in the final line (``set-up X s``). A phase can ask to be printed whatever its time
(``always=True``: the whole scene build, so a run always says when its set-up ended). Nested phases print as they
end, indented one step deeper. Progress is off by default, so tests and runs made in memory print nothing unless
they ask.
"""

from __future__ import annotations

import functools
import sys
import time
from contextlib import contextmanager

__all__ = ["THRESHOLD_S", "enable", "enabled", "stage", "announce", "announced", "report", "say", "time_scale", "group_digits"]

#: a phase that takes at least this many seconds is announced
THRESHOLD_S = 0.5

_state = {"on": False, "depth": 0, "stage": "set-up"}


def enable(on: bool = True) -> None:
    """Turn the announcements on (the command line, unless ``--no-progress``) or off."""
    _state["on"] = bool(on)


def enabled() -> bool:
    """True when announcements are on."""
    return _state["on"]


def stage(name: str) -> None:
    """The label lines are printed under from now on: ``set-up`` while a scene builds, ``run`` once it runs (a
    module compiled at the first step, a static solve's shape functions)."""
    _state["stage"] = str(name)


def say(line: str) -> None:
    """One line on stderr, written above a progress bar that is showing (``tqdm.write`` clears and redraws it)."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        print(line, file=sys.stderr, flush=True)
        return
    tqdm.write(line, file=sys.stderr)
    sys.stderr.flush()


@contextmanager
def announce(what: str, always: bool = False, label: str | None = None):
    """Time the phase inside; when progress is on and it took at least :data:`THRESHOLD_S` s (or ``always``), print
    ``  <label>: <what> <seconds> s`` as it ends (``label``: default the current :func:`stage`)."""
    if not _state["on"]:
        yield
        return
    t0 = time.perf_counter()
    _state["depth"] += 1
    try:
        yield
    finally:
        _state["depth"] -= 1
    seconds = time.perf_counter() - t0
    if always or seconds >= THRESHOLD_S:
        report(what, seconds, label)


def announced(describe):
    """A function's calls announced as set-up phases (:func:`announce`): ``describe`` is the phase's name, or a
    function of the call's arguments giving it (``lambda positions, *a, **k: f"... ({len(positions)} particles)"``).
    With progress off the function is called as it is."""
    def decorate(function):
        @functools.wraps(function)
        def announced_call(*args, **kwargs):
            if not _state["on"]:
                return function(*args, **kwargs)
            with announce(_name(describe, function, args, kwargs)):
                return function(*args, **kwargs)
        return announced_call
    return decorate


def _name(describe, function, args, kwargs) -> str:
    """A phase's name from ``describe``; the function's own name if describing the call fails (never the run)."""
    if not callable(describe):
        return str(describe)
    try:
        return str(describe(*args, **kwargs))
    except Exception:  # noqa: BLE001 - a name is never worth an error
        return function.__qualname__


def report(what: str, seconds: float, label: str | None = None) -> None:
    """Print ``  <label>: <what> <seconds> s`` now, when progress is on (a phase timed elsewhere)."""
    if _state["on"]:
        say(f"{'  ' * (1 + _state['depth'])}{label or _state['stage']}: {what} {seconds:.1f} s")


def group_digits(n: int) -> str:
    """An integer with thin groups of three digits, as a count is printed in a phase's name (``4 096``)."""
    return f"{int(n):,}".replace(",", " ")


def time_scale(t_end: float, unit: str) -> tuple[float, str]:
    """The factor and unit a simulated time is shown in: seconds get the largest SI prefix that puts ``t_end`` at
    0.01 or more (a 4.75e-9 s EM run reads 4.75 ns, not 0.0000 s; a 0.8 s dam break stays in s); any other unit
    (PIC's 1/ω_pe) is shown as it is."""
    from .units import display_scale

    return display_scale(t_end, unit, "s", 0.01)
