"""The time of a run on the device, so that a step needs nothing from the host and reads back one small report.

:class:`DeviceClock` holds t, Δt, the landing times and the step's status in one float64 array
(``warpfree.kernels.clock``), followed by slots a solver fills with its own step report (WCSPH: the largest
displacement, speed, acceleration and its status). The solver's kernels read t and Δt there; each step
:meth:`DeviceClock.launch_choose` picks the step on the device and :meth:`DeviceClock.launch_advance` moves the time
on (a step ends with both in one launch: :meth:`DeviceClock.launch_advance_and_choose`, or the solver's own final
kernel); :meth:`DeviceClock.set` chooses again after the host changed the landing times; :meth:`DeviceClock.report` reads the whole array back, once per step (on a GPU the step's only synchronisation),
and caches it until the next launch. The host writes only when the run sets the clock up, at each output (the next
landing time) and for a step taken with a given Δt (:meth:`set_step`, tests and set-up).

Every time-dependent solver has one, made by the base class (``warpfree.solver``); the time loop sets it up and reads
it once per step. A solver whose kernels read it keeps the array in its state (checkpointed with it: a resumed run
continues on the same clock); the rule that picks and lands a step is the kernel's alone (``kernels/clock.py``).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.kernels import clock as K

from .device import Launcher

__all__ = ["DeviceClock", "refusal"]

_NAMES = {"time": K.TIME, "step": K.STEP, "next_output": K.NEXT_OUTPUT, "end": K.END, "fixed": K.FIXED,
          "status": K.STATUS, "limit": K.LIMIT, "taken": K.TAKEN}


def refusal(status: float, fixed: float, limit: float, unit: str = "s") -> str | None:
    """The message of a step refused with ``status`` (None when it was taken)."""
    if status == K.STATUS_BROKEN:
        return f"non-finite or broken state: the stable time step is {limit}"
    if status == K.STATUS_ABOVE:
        return f"dt = {fixed:.4g} {unit} exceeds the stable (CFL) limit {limit:.4g} {unit}"
    return None


class DeviceClock:
    """t, Δt and the landing times of a run on ``launcher``'s device, plus ``report_slots`` of the solver's own."""

    def __init__(self, launcher: Launcher, report_slots: int = 0, time: float = 0.0):
        self.launcher = launcher
        self.report_slots = int(report_slots)
        host = np.zeros(K.SLOTS + self.report_slots)
        host[K.TIME] = float(time)
        host[K.NEXT_OUTPUT] = host[K.END] = math.inf
        self.values = wp.array(host, dtype=wp.float64, device=launcher.device)
        self._host: np.ndarray | None = host.copy()

    # -- host side: set-up, outputs, the one read per step --------------------------------------------------------
    def set(self, **slots: float) -> None:
        """Write clock slots by name (``time``, ``next_output``, ``end``, ``fixed``, ``limit``, ``step``): one host
        write of the clock's slots (the solver's report slots are left as they are)."""
        host = self.report().copy()
        for name, value in slots.items():
            host[_NAMES[name]] = float(value)
        self.values[: K.SLOTS].assign(host[: K.SLOTS])
        self._host = host
        if "step" not in slots:  # a step ends by choosing the next; a change of the landing times chooses again
            self.launch_choose()

    def report(self) -> np.ndarray:
        """The whole clock array on the host, read once after each launch (cached until the next)."""
        if self._host is None:
            self._host = self.values.numpy().copy()
        return self._host

    @property
    def report_values(self) -> wp.array:
        """The solver's report slots on the device (a view of the clock's array after its own slots)."""
        return self.values[K.SLOTS:]

    def read_report(self) -> np.ndarray:
        """The solver's report slots on the host, from the clock's one read per step (:meth:`report`)."""
        return self.report()[K.SLOTS:]

    def invalidate(self) -> None:
        """The device array changed (a launch that writes it): the next :meth:`report` reads it again."""
        self._host = None

    @property
    def time(self) -> float:
        """The simulated time t the clock holds (s, or the solver's time unit), read from its report."""
        return float(self.report()[K.TIME])

    @property
    def step(self) -> float:
        """The time step Δt the clock chose last (the next step's, after a step ended; 0 for a refused one), read from
        its report: the device's choice is the only one (``kernels/clock.py: choose``)."""
        return float(self.report()[K.STEP])

    def problem(self, unit: str = "s") -> str | None:
        """The message of a step the clock refused (a broken limit, a fixed step above it), else None."""
        r = self.report()
        return refusal(r[K.STATUS], r[K.FIXED], r[K.LIMIT], unit)

    @property
    def last_step(self) -> float:
        """The Δt of the last step taken (0 before the first), read from its report."""
        return float(self.report()[K.TAKEN])

    @property
    def limit(self) -> float:
        """The limit the last choice was made under (the solver's stable step, or the rule's), read from its report."""
        return float(self.report()[K.LIMIT])

    def set_step(self, dt: float) -> None:
        """A step of a given ``dt`` (``solver.step(dt)``): Δt written, no landing time (t + Δt as it is)."""
        self.set(step=dt, next_output=math.inf, end=math.inf)

    # -- device side ------------------------------------------------------------------------------------------------
    def launch_choose(self) -> None:
        """Pick this step's Δt on the device (``kernels/clock.py: choose_step``)."""
        self.launcher.launch(K.choose_step, 1, [self.values])
        self._host = None

    def launch_advance(self) -> None:
        """Move the time on by the step's Δt (``kernels/clock.py: advance_time``)."""
        self.launcher.launch(K.advance_time, 1, [self.values])
        self._host = None

    def launch_advance_and_choose(self) -> None:
        """The end of a step: the time moved on and the next step's Δt picked, in one launch."""
        self.launcher.launch(K.advance_and_choose, 1, [self.values])
        self._host = None
