"""The device clock: the time, the step and the landing time that a time-dependent solver's kernels read.

A solver whose step never waits on the host keeps its time on the device (``warpfree.clock.DeviceClock``): one float64
array of :data:`SLOTS` slots (plus the solver's own report slots after them). :func:`choose` picks the
step from the solver's limit (``LIMIT``: its stable step, computed on the device, or the rule's constant step), the
run's fixed step (``FIXED``, 0: none) and the next landing time (``NEXT_OUTPUT``, ``END``), the solver's kernels read
it, and :func:`advance` moves the time on; a step ends by advancing and choosing the next step in one launch (for
WCSPH inside its ``finish_step``), and the host's :meth:`~warpfree.clock.DeviceClock.set` chooses again. This is
the one place the rule lives: the time loop and every solver read the step it chose.
Single-thread kernels; float64.
"""

import warp as wp

TIME = wp.constant(0)         # t (the solver's time unit)
STEP = wp.constant(1)         # Δt of the step under way
NEXT_OUTPUT = wp.constant(2)  # the next output time: a step shortens to land on it
END = wp.constant(3)          # the end of the run
FIXED = wp.constant(4)        # the run's fixed step (0: the solver's limit each step)
STATUS = wp.constant(5)       # 0 ok; STATUS_BROKEN: the limit is not a positive number; STATUS_ABOVE: FIXED > limit
LIMIT = wp.constant(6)        # the solver's stable step for this step (or its rule's constant step)
TAKEN = wp.constant(7)        # Δt of the last step taken (0 before the first)
SLOTS = wp.constant(8)

STATUS_OK = 0.0
STATUS_BROKEN = 1.0
STATUS_ABOVE = 2.0


@wp.func
def choose(clock: wp.array(dtype=wp.float64)):
    """clock[STEP] = the step to take now (``TimeLoop.next_dt``): the fixed step or the limit, shortened to land on
    the next output time or the end, halved into two below twice the step (no sliver before an output). A limit that
    is not positive, or a fixed step above it, sets ``STATUS`` and a zero step (the state is left as it is)."""
    one = wp.float64(1.0)
    limit = clock[LIMIT]
    fixed = clock[FIXED]
    status = wp.float64(STATUS_OK)
    if not (limit > wp.float64(0.0)):  # NaN included
        status = wp.float64(STATUS_BROKEN)
    elif fixed > wp.float64(0.0) and fixed > limit * (one + wp.float64(1.0e-6)):
        status = wp.float64(STATUS_ABOVE)
    dt = limit
    if fixed > wp.float64(0.0):
        dt = fixed
    remaining = wp.min(clock[NEXT_OUTPUT], clock[END]) - clock[TIME]
    if remaining <= dt * (one + wp.float64(1.0e-9)):
        dt = remaining
    elif remaining < wp.float64(2.0) * dt:
        dt = wp.float64(0.5) * remaining
    if status != wp.float64(STATUS_OK):
        dt = wp.float64(0.0)
    clock[STATUS] = status
    clock[STEP] = dt


@wp.func
def advance(clock: wp.array(dtype=wp.float64)):
    """t += Δt, or t = the next output time where t + Δt lands on it to 1e-12 (``TimeLoop``'s rule); Δt kept as the
    step taken."""
    t = clock[TIME]
    clock[TAKEN] = clock[STEP]
    target = clock[NEXT_OUTPUT]
    moved = t + clock[STEP]
    if wp.abs(moved - target) <= wp.float64(1.0e-12) * wp.max(wp.float64(1.0), t):
        moved = target
    clock[TIME] = moved


@wp.kernel
def choose_step(first: int, clock: wp.array(dtype=wp.float64)):
    """:func:`choose` (after the host set the clock)."""
    choose(clock)


@wp.kernel
def advance_time(first: int, clock: wp.array(dtype=wp.float64)):
    """:func:`advance` (a step of a given Δt)."""
    advance(clock)


@wp.kernel
def advance_and_choose(first: int, clock: wp.array(dtype=wp.float64)):
    """The end of a step: :func:`advance`, then :func:`choose` the next step (one launch)."""
    advance(clock)
    choose(clock)
