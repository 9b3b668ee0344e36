"""SPEM's sensor for ``--sensor``: ``NAME=em:X,Y[;X,Y...]@INTERVAL`` records Ez (V/m), Hx and Hy (A/m) at points
(``SPEMSolver.field_at``: the quadratic fit of the particles around each; Ez and Hy in 1D) every INTERVAL seconds of
simulated time (give one: the default 1 ms of the fluid's transducers is longer than most EM runs)."""

from __future__ import annotations

from typing import ClassVar

from warpfree.sensors import DEFAULT_INTERVAL, FieldSensor, register_kind

__all__ = ["EMFieldSensor"]


class EMFieldSensor(FieldSensor):
    """Ez, Hx and Hy at fixed points (Ez and Hy on a 1D line), with their units."""

    kind: ClassVar[str] = "em"

    def __init__(self, name: str, points, interval: float = DEFAULT_INTERVAL):
        super().__init__(name, points, {"ez": "V/m", "hx": "A/m", "hy": "A/m"}, interval)

    def check(self, solver) -> None:
        if getattr(solver, "dim", 2) == 1:
            self.fields = {"ez": "V/m", "hy": "A/m"}
        super().check(solver)


register_kind("em", "X,Y[;X,Y...]: points (m), Ez, Hx and Hy there (give @INTERVAL in s)",
              lambda name, points, interval: EMFieldSensor(name, points, interval))
