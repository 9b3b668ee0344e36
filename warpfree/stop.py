"""Stopping a run on request: Ctrl-C (SIGINT) or SIGTERM (``kill``, a batch system's time limit, ``mpiexec``
passing on a Ctrl-C) ends a time-dependent run at the end of the step it is taking, with that step's pending
outputs written and a checkpoint of it kept, so that ``warpfree run --resume`` continues it.

:class:`StopSignals` is installed around a run (in the main thread). The first signal only records the request;
the time loop asks :meth:`StopSignals.agreed` after every step and stops when it says so. A second signal ends the
run at once (:class:`StopNow`, a ``KeyboardInterrupt``), keeping what is on disk and saying so in ``summary.json``.
A signal that the process was started with ignored (a background job of a shell script ignores Ctrl-C) stays
ignored. In a distributed run every rank must stop after the same step: each step every rank puts its request into
a non-blocking reduction (``MPI.Iallreduce``, max) and reads the previous step's, which every rank reads alike; so
the ranks stop together one step after the first of them was asked, and a step never waits for the vote.
"""

from __future__ import annotations

import signal
import threading

import numpy as np

__all__ = ["StopSignals", "StopNow", "SIGNAL_NAMES", "exit_code"]

#: the signals that ask a run to stop, and how the messages name them
SIGNAL_NAMES = {signal.SIGINT: "Ctrl-C (SIGINT)", signal.SIGTERM: "SIGTERM"}


def exit_code(signum: int) -> int:
    """The exit status of a process ended by signal ``signum``, as a shell reports it: 128 + the signal number (130
    for SIGINT, 143 for SIGTERM)."""
    return 128 + int(signum)


class StopNow(KeyboardInterrupt):
    """A second Ctrl-C or SIGTERM: the run ends at once, in the middle of what it was doing (``signum``: the signal)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class StopSignals:
    """Records SIGINT and SIGTERM while installed (``with StopSignals(world) as stop:``); :attr:`requested` is the
    first signal's number (None: none yet). Installed only in the main thread (Python delivers signals there);
    elsewhere it records nothing and the signals act as usual."""

    def __init__(self, world=None, enabled: bool = True):
        self.world = world
        self.enabled = enabled
        self.requested: int | None = None
        self._previous: dict[int, object] = {}
        self._vote = None   # a distributed run's reduction in flight: (request, send buffer, receive buffer)

    def __enter__(self) -> "StopSignals":
        if self.enabled and threading.current_thread() is threading.main_thread():
            for signum in SIGNAL_NAMES:
                if signal.getsignal(signum) is not signal.SIG_IGN:  # ignored by whoever started us: stays so
                    self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous = {}
        if self._vote is not None:  # every rank started it: every rank completes it
            self._vote[0].Wait()
            self._vote = None

    def _handle(self, signum, frame) -> None:
        if self.requested is None:
            self.requested = signum
            return
        # a second signal: stop at once (the handlers are back as they were for a third)
        for number, handler in self._previous.items():
            signal.signal(number, handler if handler is not None else signal.SIG_DFL)
        raise StopNow(signum)

    def agreed(self) -> int | None:
        """After a step: the signal to stop for, the same on every rank (None: go on). In one process, the request
        itself; in a distributed run, the largest request that every rank put into the previous step's vote."""
        if not self.enabled or self.world is None or not self.world.distributed:
            return self.requested
        from mpi4py import MPI

        result = None
        if self._vote is not None:
            request, _, received = self._vote
            request.Wait()
            result = int(received[0]) or None
        send = np.array([self.requested or 0], dtype=np.int64)
        received = np.zeros(1, dtype=np.int64)
        self._vote = (self.world.comm.Iallreduce(send, received, op=MPI.MAX), send, received)
        return result
