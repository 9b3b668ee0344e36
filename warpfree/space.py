"""The space of a scene: its dimension and, optionally, a box whose axes may be periodic.

A periodic axis of side L identifies x and x + L: positions are kept in [lower, lower + L) and the
displacement between two particles is the minimum image (``warpfree.kernels.space``). Neighbour
queries see across a periodic face through image points (``warpfree.neighbours``), which needs
L >= 2 × (query radius) so that no pair is counted twice; :meth:`Space.require_room` checks it.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .errors import ParameterError, require_finite
from warpfree.kernels.space import Box, Box2d

__all__ = ["Space"]


class Space:
    """``dim`` (1, 2 or 3), an optional box ``lower``..``upper`` (3 numbers each; unused axes may be
    anything finite) and ``periodic`` (three booleans; only axes < dim may be periodic, and only with a box).
    """

    def __init__(self, dim: int, lower=None, upper=None, periodic=(False, False, False)):
        if dim not in (1, 2, 3):
            raise ParameterError("dim", f"must be 1, 2 or 3, got {dim!r}")
        self.dim = int(dim)
        flags = tuple(bool(p) for p in periodic)
        if len(flags) != 3:
            raise ParameterError("periodic", f"must be three booleans (x, y, z), got {periodic!r}")
        if any(flags[a] for a in range(self.dim, 3)):
            raise ParameterError("periodic", f"only the first {self.dim} axes of a {self.dim}D space can be "
                                             f"periodic, got {flags}")
        self.periodic = flags
        if lower is None or upper is None:
            if any(flags):
                raise ParameterError("periodic", "periodic axes need a box: give lower and upper")
            self.lower = np.zeros(3)
            self.upper = np.ones(3)
            self.bounded = False
        else:
            self.lower = _three("lower", lower)
            self.upper = _three("upper", upper)
            if np.any(self.upper[: self.dim] <= self.lower[: self.dim]):
                raise ParameterError("upper", f"the box needs lower < upper, got {self.lower} .. {self.upper}")
            self.bounded = True
        self.length = np.where(self.upper > self.lower, self.upper - self.lower, 1.0)

    @classmethod
    def free(cls, dim: int) -> "Space":
        """Unbounded space without periodic axes."""
        return cls(dim)

    @property
    def is_periodic(self) -> bool:
        """True when any axis is periodic."""
        return any(self.periodic)

    @property
    def box(self) -> Box:
        """The ``wp.struct`` kernels take (``warpfree.kernels.space.Box``)."""
        b = Box()
        b.lower = wp.vec3(*self.lower.astype(np.float32))
        b.length = wp.vec3(*self.length.astype(np.float32))
        b.inv_length = wp.vec3(*(1.0 / self.length).astype(np.float32))
        b.periodic = wp.vec3(*[1.0 if p else 0.0 for p in self.periodic])
        return b

    @property
    def box2d(self) -> Box2d:
        """The float64 2D box of the MLS kernels (``warpfree.kernels.space.Box2d``)."""
        b = Box2d()
        b.lower = wp.vec2d(*self.lower[:2].astype(np.float64))
        b.length = wp.vec2d(*self.length[:2].astype(np.float64))
        b.inv_length = wp.vec2d(*(1.0 / self.length[:2]).astype(np.float64))
        b.periodic = wp.vec2d(*[1.0 if p else 0.0 for p in self.periodic[:2]])
        return b

    def require_room(self, radius: float, name: str = "radius") -> None:
        """Refuse a periodic side shorter than 2 × ``radius``: a pair would meet through two images."""
        for a in range(3):
            if self.periodic[a] and self.length[a] < 2.0 * radius:
                raise ParameterError(name, f"{radius:.6g} is more than half the periodic box side along "
                                           f"{'xyz'[a]} ({self.length[a]:.6g}); enlarge the box or shorten the "
                                           f"radius (neighbour radius + skin)")

    def wrap(self, points: np.ndarray) -> np.ndarray:
        """Positions (N, >= dim) brought into the box along the periodic axes (NumPy, float64)."""
        p = np.array(points, dtype=np.float64, copy=True)
        for a in range(min(3, p.shape[1])):
            if self.periodic[a]:
                p[:, a] = self.lower[a] + np.mod(p[:, a] - self.lower[a], self.length[a])
        return p

    def displacement(self, xi: np.ndarray, xj: np.ndarray) -> np.ndarray:
        """x_i - x_j with the minimum image along periodic axes (NumPy reference, float64)."""
        d = np.asarray(xi, dtype=np.float64) - np.asarray(xj, dtype=np.float64)
        for a in range(min(3, d.shape[-1])):
            if self.periodic[a]:
                d[..., a] -= self.length[a] * np.round(d[..., a] / self.length[a])
        return d

    def describe(self) -> dict:
        """The space for ``summary.json``: dimension, periodic axes, bounds (None when unbounded)."""
        return {"dim": self.dim, "periodic": list(self.periodic),
                "lower": self.lower.tolist() if self.bounded else None,
                "upper": self.upper.tolist() if self.bounded else None}

    def __repr__(self) -> str:
        return f"Space(dim={self.dim}, periodic={self.periodic}, box={self.bounded})"


def _three(name: str, values) -> np.ndarray:
    try:
        v = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be three numbers, got {values!r}") from None
    if v.shape != (3,):
        raise ParameterError(name, f"must be three numbers, got {values!r}")
    for c in v:
        require_finite(name, c)
    return v
