"""Exact boundary curves of 2D regions, and the pieces a region's boundary is made of (host-side NumPy, float64, m).

A :class:`Curve` is a parametric curve x(t) with its derivative x'(t): a straight :class:`Segment`, a
:class:`CircleCurve` (x = c + r (cos t, sin t)), an :class:`EllipseCurve` (x = c + R(φ) (a cos t, b sin t)) and a
:class:`SplineCurve` (a cubic spline through points, chord-length parameter, periodic when closed). A :class:`Piece`
is the part of a curve between two parameters, traversed from ``t0`` to ``t1`` (either order), with a ``tag`` that
names it for boundary conditions; a piece's own parameter is s in [0, 1] (t = t0 + s (t1 - t0)). Quadrature on a
piece (``warpfree.galerkin.region``) samples the exact curve, so that integrals along it and over the cells it bounds
converge at the method's order rather than at a polygon's.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.legendre import leggauss

from warpfree.errors import ParameterError, require_positive

__all__ = ["Curve", "Segment", "CircleCurve", "EllipseCurve", "SplineCurve", "Piece"]

#: Gauss-Legendre points per interval and intervals per piece of the length integrals (64 x 16 points: a piece of an
#: ellipse of axis ratio 10 to 1e-12)
_LENGTH_INTERVALS, _LENGTH_ORDER = 64, 16


def _xy(name: str, value) -> np.ndarray:
    try:
        p = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be two numbers (x, y), got {value!r}") from None
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ParameterError(name, f"must be two finite numbers (x, y), got {value!r}")
    return p


class Curve(ABC):
    """x(t) for t in :attr:`t_range` (m); :attr:`closed`: x(t_range[0]) = x(t_range[1])."""

    closed: bool = False
    t_range: tuple[float, float] = (0.0, 1.0)
    #: parameters where the curve is less smooth (a spline's knots): integrals along it break there
    breaks: np.ndarray = np.zeros(0)

    @abstractmethod
    def point(self, t: np.ndarray) -> np.ndarray:
        """(n, 2) points at parameters ``t`` (n,)."""

    @abstractmethod
    def derivative(self, t: np.ndarray) -> np.ndarray:
        """(n, 2) dx/dt at ``t``."""

    @abstractmethod
    def describe(self) -> dict:
        """The curve for a summary."""


class Segment(Curve):
    """x(t) = a + t (b - a), t in [0, 1]."""

    def __init__(self, a, b):
        self.a, self.b = _xy("a", a), _xy("b", b)
        if np.array_equal(self.a, self.b):
            raise ParameterError("segment", f"has zero length: both ends at {self.a.tolist()}")

    def point(self, t):
        return self.a + np.asarray(t, dtype=np.float64)[:, None] * (self.b - self.a)

    def derivative(self, t):
        return np.broadcast_to(self.b - self.a, (np.size(t), 2)).copy()

    def describe(self):
        return {"kind": "segment", "a": self.a.tolist(), "b": self.b.tolist()}


class CircleCurve(Curve):
    """x(t) = c + r (cos t, sin t), t in [0, 2π]."""

    closed = True
    t_range = (0.0, 2.0 * math.pi)

    def __init__(self, centre, radius: float):
        self.centre, self.radius = _xy("centre", centre), require_positive("radius", radius)

    def point(self, t):
        t = np.asarray(t, dtype=np.float64)
        return self.centre + self.radius * np.stack([np.cos(t), np.sin(t)], axis=1)

    def derivative(self, t):
        t = np.asarray(t, dtype=np.float64)
        return self.radius * np.stack([-np.sin(t), np.cos(t)], axis=1)

    def describe(self):
        return {"kind": "circle", "centre": self.centre.tolist(), "radius": self.radius}


class EllipseCurve(Curve):
    """x(t) = c + R(angle) (a cos t, b sin t), t in [0, 2π] (semi-axes a, b; angle of the first axis, rad)."""

    closed = True
    t_range = (0.0, 2.0 * math.pi)

    def __init__(self, centre, semi_axes, angle: float = 0.0):
        self.centre = _xy("centre", centre)
        axes = _xy("semi_axes", semi_axes)
        if np.any(axes <= 0.0):
            raise ParameterError("semi_axes", f"must both be > 0, got {axes.tolist()}")
        self.semi_axes, self.angle = axes, float(angle)
        c, s = math.cos(self.angle), math.sin(self.angle)
        self._rotation = np.array([[c, -s], [s, c]])

    def point(self, t):
        t = np.asarray(t, dtype=np.float64)
        local = np.stack([self.semi_axes[0] * np.cos(t), self.semi_axes[1] * np.sin(t)], axis=1)
        return self.centre + local @ self._rotation.T

    def derivative(self, t):
        t = np.asarray(t, dtype=np.float64)
        local = np.stack([-self.semi_axes[0] * np.sin(t), self.semi_axes[1] * np.cos(t)], axis=1)
        return local @ self._rotation.T

    def describe(self):
        return {"kind": "ellipse", "centre": self.centre.tolist(), "semi_axes": self.semi_axes.tolist(),
                "angle": self.angle}


class SplineCurve(Curve):
    """The cubic spline through ``points`` (m, 2) with the chord-length parameter t in [0, total chord]: periodic
    (C2 all round) when ``closed`` (the first point is not repeated), else with natural ends."""

    def __init__(self, points, closed: bool = True):
        from scipy.interpolate import CubicSpline

        try:
            p = np.asarray(points, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParameterError("spline", "must be an (m, 2) array of points") from None
        if p.ndim != 2 or p.shape[1] != 2 or not np.all(np.isfinite(p)):
            raise ParameterError("spline", f"must be (m, 2) finite points, got shape {p.shape}")
        if closed and len(p) > 1 and np.allclose(p[0], p[-1]):
            p = p[:-1]
        if len(p) < (3 if closed else 2):
            raise ParameterError("spline", f"needs at least {3 if closed else 2} distinct points, got {len(p)}")
        ring = np.vstack([p, p[:1]]) if closed else p
        chord = np.linalg.norm(np.diff(ring, axis=0), axis=1)
        if np.any(chord == 0.0):
            raise ParameterError("spline", f"point {int(np.flatnonzero(chord == 0.0)[0])} repeats its predecessor")
        knots = np.concatenate([[0.0], np.cumsum(chord)])
        self.closed, self.points = bool(closed), p
        self.t_range = (0.0, float(knots[-1]))
        self._spline = CubicSpline(knots, ring, bc_type="periodic" if closed else "natural", axis=0)
        self.breaks = knots
        self._derivative = self._spline.derivative()

    def point(self, t):
        return self._spline(np.asarray(t, dtype=np.float64))

    def derivative(self, t):
        return self._derivative(np.asarray(t, dtype=np.float64))

    def describe(self):
        return {"kind": "spline", "points": len(self.points), "closed": self.closed}


@dataclass
class Piece:
    """The part of ``curve`` from parameter ``t0`` to ``t1`` (either order: the direction of travel), named ``tag``.
    Its own parameter s in [0, 1]: x(s) = curve.point(t0 + s (t1 - t0))."""

    curve: Curve
    t0: float
    t1: float
    tag: str = "boundary"

    def parameter(self, s) -> np.ndarray:
        """The curve's parameter t at ``s``."""
        return self.t0 + np.asarray(s, dtype=np.float64) * (self.t1 - self.t0)

    def point(self, s) -> np.ndarray:
        """(n, 2) points at ``s`` (n,)."""
        return self.curve.point(self.parameter(np.atleast_1d(s)))

    def tangent(self, s) -> np.ndarray:
        """(n, 2) dx/ds at ``s``: the curve's derivative times (t1 - t0), along the direction of travel."""
        return self.curve.derivative(self.parameter(np.atleast_1d(s))) * (self.t1 - self.t0)

    @property
    def start(self) -> np.ndarray:
        return self.point(0.0)[0]

    @property
    def end(self) -> np.ndarray:
        return self.point(1.0)[0]

    def reversed(self) -> "Piece":
        return Piece(self.curve, self.t1, self.t0, self.tag)

    def part(self, s0: float, s1: float) -> "Piece":
        """The piece between its own parameters s0 and s1 (same curve, same tag)."""
        return Piece(self.curve, float(self.parameter(s0)), float(self.parameter(s1)), self.tag)

    def partition(self) -> np.ndarray:
        """Own parameters that cut the piece for integrals along it: 64 equal intervals and the curve's breaks."""
        span = self.t1 - self.t0
        inner = (np.asarray(self.curve.breaks, dtype=np.float64) - self.t0) / span if span else np.zeros(0)
        inner = inner[(inner > 1e-12) & (inner < 1.0 - 1e-12)]
        edges = np.unique(np.concatenate([np.linspace(0.0, 1.0, _LENGTH_INTERVALS + 1), inner]))
        return edges

    def integrate(self, function) -> float:
        """∫ f ds over the piece's own parameter, ``function(s)`` -> (n,) at Gauss points of :meth:`partition`."""
        g, w = leggauss(_LENGTH_ORDER)
        edges = self.partition()
        h = np.diff(edges)
        nodes = (edges[:-1, None] + 0.5 * h[:, None] * (g[None, :] + 1.0)).ravel()
        values = np.asarray(function(nodes), dtype=np.float64).reshape(len(h), -1)
        return float(np.sum((values * w[None, :]).sum(axis=1) * 0.5 * h))

    def arc_lengths(self, s) -> np.ndarray:
        """Arc length from s = 0 to each of ``s`` (m), by Gauss-Legendre on :meth:`partition`."""
        g, w = leggauss(_LENGTH_ORDER)
        edges = self.partition()
        h = np.diff(edges)
        nodes = (edges[:-1, None] + 0.5 * h[:, None] * (g[None, :] + 1.0)).ravel()
        speed = np.linalg.norm(self.tangent(nodes), axis=1).reshape(len(h), -1)
        per = (speed * w[None, :]).sum(axis=1) * 0.5 * h
        cumulative = np.concatenate([[0.0], np.cumsum(per)])
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        k = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, len(h) - 1)
        out = cumulative[k].copy()
        for j in np.unique(k):  # the partial interval, by Gauss on [edges[j], s]
            m = k == j
            a, b = edges[j], s[m]
            x = a + 0.5 * (b[:, None] - a) * (g[None, :] + 1.0)
            v = np.linalg.norm(self.tangent(x.ravel()), axis=1).reshape(x.shape)
            out[m] += (v * w[None, :]).sum(axis=1) * 0.5 * (b - a)
        return out

    @property
    def length(self) -> float:
        """The piece's arc length (m)."""
        return float(self.arc_lengths(1.0)[0])

    def at_lengths(self, fractions) -> np.ndarray:
        """The s at which the arc length is ``fractions`` (in [0, 1]) of the piece's: Newton from the fine
        partition's interpolation (to 1e-13 of the length)."""
        fractions = np.asarray(fractions, dtype=np.float64)
        grid = np.linspace(0.0, 1.0, 4 * _LENGTH_INTERVALS + 1)
        cumulative = self.arc_lengths(grid)
        total = cumulative[-1]
        target = fractions * total
        s = np.interp(target, cumulative, grid)
        for _ in range(30):
            err = self.arc_lengths(s) - target
            speed = np.linalg.norm(self.tangent(s), axis=1)
            step = err / np.maximum(speed, 1e-300)
            s = np.clip(s - step, 0.0, 1.0)
            if np.max(np.abs(err), initial=0.0) <= 1e-13 * total:
                break
        return s

    def describe(self) -> dict:
        return {"tag": self.tag, "t0": self.t0, "t1": self.t1, **self.curve.describe()}
