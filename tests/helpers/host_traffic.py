"""Counting the host's reads and writes of device arrays while code runs, on the CPU device through the code path a
GPU takes: every ``wp.array.numpy()`` is a read (a device-to-host copy on a GPU), every ``assign`` and every array
made from host data a write (a host-to-device copy). A step that needs no host would count none."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import warp as wp


@dataclass
class Traffic:
    reads: int = 0
    writes: int = 0
    where: list = field(default_factory=list)  # (kind, the calling function) of every access

    def per_step(self, steps: int) -> tuple[float, float]:
        return self.reads / steps, self.writes / steps


@contextmanager
def host_traffic():
    """``with host_traffic() as t: ...``: ``t.reads`` and ``t.writes`` count the accesses made inside."""
    import inspect

    traffic = Traffic()
    cls = wp.array
    numpy, assign, init = cls.numpy, cls.assign, cls.__init__

    def caller() -> str:
        frame = inspect.currentframe().f_back.f_back
        return f"{frame.f_code.co_filename.rsplit('/', 1)[-1]}:{frame.f_code.co_name}"

    def counted_numpy(self, *args, **kwargs):
        traffic.reads += 1
        traffic.where.append(("read", caller()))
        return numpy(self, *args, **kwargs)

    def counted_assign(self, *args, **kwargs):
        traffic.writes += 1
        traffic.where.append(("write", caller()))
        return assign(self, *args, **kwargs)

    def counted_init(self, data=None, *args, **kwargs):
        if data is not None:
            traffic.writes += 1
            traffic.where.append(("write", caller()))
        return init(self, data, *args, **kwargs)

    cls.numpy, cls.assign, cls.__init__ = counted_numpy, counted_assign, counted_init
    try:
        yield traffic
    finally:
        cls.numpy, cls.assign, cls.__init__ = numpy, assign, init
