"""The EFG solvers' boundary conditions on a region's tagged pieces, on the exact curves
(``warpfree.galerkin.region``): values held (Lagrange multipliers, penalty or direct substitution), fluxes or
tractions, and load-free pieces."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from warpfree.galerkin.region import Region, RegionNodes

from .boundary import Essential, Free, Natural

__all__ = ["essential", "natural", "free"]


def _name(tags) -> str:
    return "+".join([tags] if isinstance(tags, str) else list(tags))


def essential(region: Region, nodes: RegionNodes, tags: str | Sequence[str],
              value: Callable[[np.ndarray], np.ndarray], constrained: tuple = (True,), order: int = 3,
              name: str | None = None) -> list[Essential]:
    """ū = ``value(points)`` on the pieces tagged ``tags``: one :class:`Essential` a piece, its multipliers at the
    piece's boundary nodes with hats linear in the curve's parameter (``Region.essential_quadrature``);
    ``constrained``: which components are prescribed (Poisson: (True,); elasticity (True, False) holds u_x)."""
    name = name or _name(tags)
    return [Essential(vertices, value, tuple(constrained), order, name, curve=curve)
            for vertices, curve in region.essential_quadrature(nodes, tags, order)]


def natural(region: Region, nodes: RegionNodes, tags: str | Sequence[str],
            value: Callable[[np.ndarray, np.ndarray], np.ndarray], order: int = 3, name: str | None = None) -> Natural:
    """A flux or traction ``value(points, normals)`` on the exact pieces tagged ``tags``."""
    return Natural(region.boundary_points(nodes, tags, order), value, name or _name(tags))


def free(region: Region, nodes: RegionNodes, tags: str | Sequence[str], order: int = 3) -> Free:
    """The load-free pieces tagged ``tags`` (part of consistent integration's boundary)."""
    return Free(region.boundary_points(nodes, tags, order))
