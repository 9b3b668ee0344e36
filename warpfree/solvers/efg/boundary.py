"""Boundary conditions of the EFG solvers: prescribed values (essential) and fluxes or tractions (natural).

Essential conditions along a polyline, three ways (``method`` of the solver):

- "lagrange" (Rocha 2012, eqs 3.34-3.36): multipliers λ_K at the polyline's vertices, linear hats N_K along its
  pieces; G_IK = -∫_Γu φ_I N_K dΓ, q_K = -∫_Γu N_K ū dΓ, and [[K, G], [Gᵀ, 0]] {u, λ} = {f, q}.
- "penalty": K + α ∫_Γu φ_I φ_J dΓ, f + α ∫_Γu φ_I ū dΓ (α: the solver's ``penalty`` times the stiffness scale).
- "direct" (Marques 2008, eq. 3.26): only with interpolating shape functions (the singular weight, φ_I(x_J) = δ_IJ):
  the nodes on the polyline take ū at their positions, eliminated as in FEM.

Natural conditions: ``value(points, normals)`` (n, components) on boundary Gauss points (a traction t = σ·n or a
flux -k ∂u/∂n... as the problem defines it), added as ∫_Γt φ_I t̄ dΓ (Rocha 2012, eq. 3.36).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from warpfree.errors import ParameterError
from warpfree.parameters import Choice

from warpfree.galerkin.quadrature import BoundaryPoints, segment_points
from warpfree.galerkin.region import CurveQuadrature

__all__ = ["EssentialMethod", "InterfaceCondition", "Essential", "Natural", "Free", "Interface", "EssentialPoints",
           "essential_points"]


class EssentialMethod(Choice):
    """How essential conditions (prescribed values) are imposed."""

    LAGRANGE = "lagrange", "Lagrange multipliers λ_K at the boundary's vertices, linear hats between them"
    PENALTY = "penalty", "a penalty α ∫ φ_I (u - ū) dΓ, α scaled to the stiffness"
    DIRECT = "direct", "direct substitution at the boundary's nodes (interpolating shape functions only)"


class InterfaceCondition(Choice):
    """What couples the materials across an interface where domain truncation splits the nodes."""

    NITSCHE = "nitsche", ("symmetric Nitsche terms: the interface flux truncation drops, its symmetric partner and a "
                          "penalty β k/h")
    NONE = "none", "domain truncation alone"


@dataclass
class Essential:
    """ū prescribed along the polyline ``vertices`` (k, 2), in order; ``value(points)`` -> (n, components);
    ``constrained``: which components are prescribed (elasticity: (True, False) fixes u_x only); ``order``: Gauss
    points per piece for the boundary integrals. ``curve``: the boundary's Gauss points and multiplier hats on the
    exact curve through ``vertices`` (``warpfree.galerkin.region.CurveQuadrature``), used instead of the
    polyline's."""

    vertices: np.ndarray
    value: Callable[[np.ndarray], np.ndarray]
    constrained: tuple = (True, True)
    order: int = 3
    name: str = "essential"
    material: int = -1  # the material whose shape functions serve this boundary (-1: every node)
    curve: CurveQuadrature | None = None


@dataclass
class Natural:
    """A flux or traction ``value(points, normals)`` -> (n, components) on boundary Gauss points ``points``."""

    points: BoundaryPoints
    value: Callable[[np.ndarray, np.ndarray], np.ndarray]
    name: str = "natural"
    material: int = -1  # the material whose shape functions serve this boundary (-1: every node)


@dataclass
class Free:
    """A load-free piece of the boundary (traction-free, insulated) of ``material``: no load, but part of the
    boundary integral of consistent integration."""

    points: BoundaryPoints
    material: int = -1


@dataclass
class Interface:
    """A material interface: boundary points whose ``points.normal`` points out of material ``inside`` into
    material ``outside``; consistent integration closes each material's region with it (twice, once per side)."""

    points: BoundaryPoints
    inside: int
    outside: int


@dataclass
class EssentialPoints:
    """Gauss points of an essential boundary with their multiplier hats: point g lies on piece ``segment[g]``
    between multipliers ``multiplier[g]`` (2,) with hat values ``hat[g]`` (2,); ``prescribed`` (n, components)."""

    points: BoundaryPoints
    multiplier: np.ndarray
    hat: np.ndarray
    prescribed: np.ndarray
    n_multipliers: int


def _polyline(vertices, name: str) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[0] < 2 or v.shape[1] < 2 or not np.all(np.isfinite(v)):
        raise ParameterError(name, f"must be at least two finite (x, y) vertices, got shape {v.shape}")
    v = v[:, :2]
    if np.any(np.linalg.norm(np.diff(v, axis=0), axis=1) == 0):
        raise ParameterError(name, "has a piece of zero length (repeated vertex)")
    return v


def essential_points(boundary: Essential, components: int) -> EssentialPoints:
    """Boundary Gauss points of ``boundary`` with their multipliers (the polyline's vertices, or its exact curve's)
    and ū."""
    v = _polyline(boundary.vertices, f"{boundary.name}.vertices")
    if len(boundary.constrained) != components or not any(boundary.constrained):
        raise ParameterError(f"{boundary.name}.constrained", f"must give {components} flags, at least one true")
    if boundary.curve is not None:
        q = boundary.curve
        ubar = np.asarray(boundary.value(q.points.position), dtype=np.float64).reshape(len(q.points.weight), -1)
        if ubar.shape[1] != components or not np.all(np.isfinite(ubar)):
            raise ParameterError(f"{boundary.name}.value", f"must return finite (n, {components}) values")
        return EssentialPoints(q.points, q.multiplier, q.hat, ubar, q.n_multipliers)
    pts = segment_points(v[:-1], v[1:], boundary.order)
    seg = np.asarray(pts.segment, dtype=np.int64)
    length = np.linalg.norm(v[1:] - v[:-1], axis=1)
    t = np.einsum("ij,ij->i", pts.position - v[seg], (v[seg + 1] - v[seg])) / length[seg] ** 2
    hat = np.stack([1.0 - t, t], axis=1)
    multiplier = np.stack([seg, seg + 1], axis=1)
    ubar = np.asarray(boundary.value(pts.position), dtype=np.float64).reshape(len(seg), -1)
    if ubar.shape[1] != components or not np.all(np.isfinite(ubar)):
        raise ParameterError(f"{boundary.name}.value", f"must return finite (n, {components}) values")
    return EssentialPoints(pts, multiplier, hat, ubar, v.shape[0])


def nodes_on_polyline(nodes: np.ndarray, vertices: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the nodes within ``tolerance`` of the polyline (for direct substitution)."""
    on = np.zeros(nodes.shape[0], dtype=bool)
    for a, b in zip(vertices[:-1], vertices[1:]):
        d = b - a
        t = np.clip((nodes - a) @ d / (d @ d), 0.0, 1.0)
        on |= np.linalg.norm(nodes - (a + t[:, None] * d), axis=1) <= tolerance
    return np.flatnonzero(on)
