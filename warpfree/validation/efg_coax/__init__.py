"""The coaxial line: the electrostatic potential between two circles, an analytic solution (no data files; see
``README.md``).

-Δφ = 0 for a < r < b, φ = 0 on r = a (the conductor), φ = 1 on r = b (the shield):
φ = ln(r/a)/ln(b/a), |∇φ| = 1/(r ln(b/a)), and the capacitance per unit length (unit permittivity)
C = ∫ |∇φ|² dA = 2π/ln(b/a). ``scenes/efg_coax.py`` solves it with EFG on the exact circles.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["potential", "field_magnitude", "capacitance"]


def potential(p, a: float, b: float) -> np.ndarray:
    """φ = ln(r/a)/ln(b/a) at points ``p`` (n, 2)."""
    return np.log(np.hypot(p[:, 0], p[:, 1]) / a) / math.log(b / a)


def field_magnitude(r, a: float, b: float):
    """|∇φ| = 1/(r ln(b/a)) at radius ``r``."""
    return 1.0 / (np.asarray(r, dtype=np.float64) * math.log(b / a))


def capacitance(a: float, b: float) -> float:
    """C = 2π/ln(b/a) per unit length, unit permittivity (the field energy ∫|∇φ|² dA at unit voltage)."""
    return 2.0 * math.pi / math.log(b / a)
