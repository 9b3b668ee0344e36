"""A step recorded as Warp graphs and replayed: the launches of a step without Python in between.

Recording (``Launcher.capturing``) captures a step's launches once; replaying a graph (``wp.capture_launch``) runs them
again with whatever the arrays hold then, so everything that changes from step to step must live in device arrays
(the time and Δt: ``warpfree.clock``). A step may need a decision on the host between its parts (a moving set's
neighbour rebuild, decided from the step report the host reads anyway): :class:`StepGraph` replays its parts in order,
graphs and such host callables alike. On a GPU a graph removes the per-launch cost of Python and the driver; on the
CPU it is how the tests check that a step is replayable (replayed steps bitwise equal to stepped ones).
"""

from __future__ import annotations

from collections.abc import Callable

import warp as wp

__all__ = ["StepGraph"]


class StepGraph:
    """Parts of a step in order: recorded Warp graphs and host callables (``part()``: a decision from the last report,
    and the launches it makes, run directly). ``after()`` runs after every replay (e.g. the clock's cache reset)."""

    def __init__(self, parts: list, after: Callable[[], None] | None = None):
        self.parts = list(parts)
        self.after = after

    @property
    def graphs(self) -> int:
        """How many of the parts are recorded Warp graphs (the others are host calls)."""
        return sum(1 for p in self.parts if not callable(p))

    def replay(self) -> None:
        """Replay the step: each recorded graph launched, each host call made, in order."""
        for part in self.parts:
            if callable(part):
                part()
            else:
                wp.capture_launch(part)
        if self.after is not None:
            self.after()
