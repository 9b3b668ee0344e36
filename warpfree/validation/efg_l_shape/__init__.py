"""A manufactured Poisson problem on an L-shaped (non-convex) domain with flux conditions on the re-entrant sides:
the case on which EFG's quadrature must keep the basis's order. No data files; see ``README.md``.

-Δu = s on the L [0, 2]² minus (1, 2]², u = sin(1.3x + 0.4) e^{0.7y} (smooth, so the convergence rate is the
method's, not the corner's; s = (1.3² - 0.7²) u), u prescribed on the outer sides, the flux ∂u/∂n on the two
re-entrant sides. ``scenes/efg_l_shape.py`` solves it with EFG.
"""

from __future__ import annotations

import numpy as np

__all__ = ["exact", "exact_gradient", "source", "SQUARES", "OUTER"]

SQUARES = (((0.0, 0.0), (1.0, 1.0)), ((1.0, 0.0), (2.0, 1.0)), ((0.0, 1.0), (1.0, 2.0)))
#: the outer boundary, counter-clockwise from the re-entrant corner's upper side
OUTER = np.array([[1.0, 2.0], [0.0, 2.0], [0.0, 0.0], [2.0, 0.0], [2.0, 1.0]])


def exact(p):
    """The manufactured solution u = sin(1.3 x + 0.4) exp(0.7 y) at points ``p`` (n, 2)."""
    return np.sin(1.3 * p[:, 0] + 0.4) * np.exp(0.7 * p[:, 1])


def exact_gradient(p):
    """∇u of :func:`exact` at points ``p`` (n, 2): (n, 2)."""
    return np.stack([1.3 * np.cos(1.3 * p[:, 0] + 0.4) * np.exp(0.7 * p[:, 1]), 0.7 * exact(p)], axis=1)


def source(p):
    """s = -Δu = (1.3² - 0.7²) u."""
    return (1.3 ** 2 - 0.7 ** 2) * exact(p)
