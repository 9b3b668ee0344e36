"""Units as outputs show them: an SI quantity scaled to the prefix that reads best (4.75e-9 s as 4.75 ns, a 3e-3 m
resistor as 3 mm)."""

from __future__ import annotations

import math

__all__ = ["SI_PREFIXES", "display_scale"]

#: SI prefixes, largest first: (factor, symbol)
SI_PREFIXES = ((1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p"), (1e-15, "f"))


def display_scale(amount: float, unit: str | None, base: str, fraction: float) -> tuple[float, str | None]:
    """(factor, unit) to show quantities up to ``amount`` in: in the SI ``base`` unit ("s", "m"), the largest prefix
    that puts ``amount`` at ``fraction`` of it or more (divide by the factor); any other unit (PIC's 1/ω_pe, a
    scene's consistent units) as it is, factor 1."""
    if unit != base or not (math.isfinite(amount) and amount > 0):
        return 1.0, unit
    for factor, symbol in SI_PREFIXES:
        if amount >= fraction * factor * (1 - 1e-12):
            return factor, symbol + base
    return SI_PREFIXES[-1][0], SI_PREFIXES[-1][1] + base
