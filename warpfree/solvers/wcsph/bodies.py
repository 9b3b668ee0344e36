"""Rigid bodies among a fluid's walls: wall particles (and a true surface) that move together.

A scene gives each body as a :class:`RigidBody`: its wall particles, optionally its surface (a closed polygon in 2D,
a watertight mesh in 3D: the penalty and the audit follow it) and its motion, a :class:`PrescribedMotion` (a
piston, a flap, a paddle, a container shaken: translation and rotation given as functions or tables of time). The
model appends the bodies' particles to the walls (after the obstacles') and :class:`Bodies` holds what the device
needs: each wall's body and its offset in the body's frame, the motions' spline tables
(``kernels/wcsph_bodies.py`` has the equations).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import warp as wp
from scipy.interpolate import CubicSpline

from warpfree.errors import ParameterError
from warpfree.geometry import is_mesh
from warpfree.kernels import wcsph_bodies as bk
from warpfree.particles import to_vec3

__all__ = ["PrescribedMotion", "RigidBody", "Bodies", "DEGREES_OF_FREEDOM", "polygon_mass_properties"]


class PrescribedMotion:
    """A rigid motion given in time: the reference point moves by ``displacement(t)`` from where it starts and the body
    turns by ``angle(t)`` (rad, right-handed) about ``axis`` through that point.

    Parameters
    ----------
    times: (K >= 2,) increasing times (s) at which the motion is given.
    displacement: (K, dim) displacements (m) at ``times``, or a function of t (s) returning one (dim,); default none.
    angle: (K,) angles (rad) at ``times``, or a function of t; default none.
    axis: the rotation axis (3 components; in 2D the z axis, the default).
    centre: the reference point at t = 0 (m): the centre of rotation; default the body particles' centroid.

    The motion between the given times is the cubic spline through them with zero velocity at both ends: the body
    rests at its first position before ``times[0]`` and at its last after ``times[-1]``, with position, velocity and
    acceleration continuous (sample a function finely enough: at 40 points a period a sine is within 1e-5 of its
    amplitude).
    """

    def __init__(self, times, displacement=None, angle=None, axis=(0.0, 0.0, 1.0), centre=None):
        try:
            self.times = np.asarray(times, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise ParameterError("times", "must be a sequence of numbers (s)") from None
        if self.times.size < 2 or not np.all(np.isfinite(self.times)) or np.any(np.diff(self.times) <= 0.0):
            raise ParameterError("times", f"must be at least 2 finite, increasing times, got {self.times.size}")
        self._displacement, self._angle = displacement, angle
        axis = np.asarray(axis, dtype=np.float64).ravel()
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or not np.linalg.norm(axis) > 0.0:
            raise ParameterError("axis", f"must be 3 finite numbers, not all zero, got {axis.tolist()}")
        self.axis = axis / np.linalg.norm(axis)
        self.centre = None if centre is None else np.asarray(centre, dtype=np.float64).ravel()

    def values(self, dim: int) -> np.ndarray:
        """(K, 4) float64: the displacement's x, y, z and the angle at :attr:`times`."""
        out = np.zeros((self.times.size, bk.MOTION_CHANNELS))
        for name, given, cols in (("displacement", self._displacement, dim), ("angle", self._angle, 1)):
            if given is None:
                continue
            if callable(given):
                v = np.array([np.asarray(given(float(t)), dtype=np.float64).ravel() for t in self.times])
            else:
                try:
                    v = np.asarray(given, dtype=np.float64)
                except (TypeError, ValueError):
                    raise ParameterError(name, "must be numbers or a function of time") from None
            v = v.reshape(self.times.size, -1) if v.size == self.times.size * cols else v
            if v.shape != (self.times.size, cols):
                raise ParameterError(name, f"must give {cols} value(s) at each of the {self.times.size} times, got "
                                           f"shape {np.shape(v)}")
            if not np.all(np.isfinite(v)):
                raise ParameterError(name, "must be finite")
            if name == "angle":
                out[:, 3] = v[:, 0]
            else:
                out[:, :dim] = v
        return out

    def spline(self, dim: int) -> np.ndarray:
        """(K - 1, 4, 4) float64 coefficients a_k of each piece, channel by channel: value Σ_k a_k (t - t_p)^k."""
        c = CubicSpline(self.times, self.values(dim), axis=0, bc_type="clamped").c  # (4, K-1, 4), highest power first
        return np.ascontiguousarray(np.transpose(c[::-1], (1, 2, 0)))

    def at(self, t: float, dim: int) -> tuple[np.ndarray, float]:
        """The displacement (3,) and the angle at time t (s), on the host (float64): for plots and checks."""
        spline = CubicSpline(self.times, self.values(dim), axis=0, bc_type="clamped")
        v = spline(np.clip(t, self.times[0], self.times[-1]))
        return v[:3], float(v[3])


#: the slices of a body's state row: position, rotation, velocity, spin, acceleration, spin rate
BODY_SLICES = tuple(slice(c, c + n) for c, n in ((bk.BODY_POSITION, 3), (bk.BODY_ROTATION, 4), (bk.BODY_VELOCITY, 3),
                                                 (bk.BODY_SPIN, 3), (bk.BODY_ACCELERATION, 3), (bk.BODY_SPIN_RATE, 3)))
#: the degrees of freedom a body can be held in: translations along x, y, z and rotations about them
DEGREES_OF_FREEDOM = ("x", "y", "z", "rx", "ry", "rz")
#: those of a 2D body
PLANAR_FREEDOM = ("x", "y", "rz")


@dataclass
class RigidBody:
    """A body among the walls: its wall ``particles`` ((M, dim), m, at t = 0), its ``motion`` and optionally its true
    ``surface`` (2D: a closed (P, 2) polygon; 3D: a watertight trimesh mesh) at t = 0, which the fluid is kept out
    of and audited against as an obstacle's, or kept inside as a container's with ``holds_fluid`` (a tank that is
    shaken).

    Without a ``motion`` the body floats: the fluid's force and moment on its wall particles and its weight move it
    (Newton–Euler, in step with the fluid's leapfrog). It then needs its ``surface`` and ``density`` (kg/m³): its mass,
    centre of mass and inertia are the solid's (in 2D per metre of depth), and its reference point is its centre of
    mass. ``free``: the degrees of freedom it may move in (``DEGREES_OF_FREEDOM``; default all: x, y, rz in 2D), e.g.
    ``("y",)`` for heave alone."""

    particles: np.ndarray
    motion: PrescribedMotion | None = None
    surface: object = None
    name: str = field(default="")
    holds_fluid: bool = False
    density: float | None = None
    free: tuple | None = None


class Bodies:
    """The bodies of a model: what the device needs to move them.

    ``count`` bodies; for every wall particle of the model (containers', obstacles', then the bodies' in order)
    ``wall_body`` ((nb,) int32, -1 for a wall at rest) and ``wall_offset`` ((nb, 3) float64, its offset from its
    body's reference point at t = 0); ``centre`` ((count, 3)) the reference points at t = 0; the prescribed motions'
    tables on the device (:meth:`launch_poses`); the floating bodies (``floating``: their indices) with their
    ``mass`` (kg; per metre in 2D), ``inertia`` ((count, 3, 3) about the centre of mass, in the body's frame) and
    ``free`` ((count, 6) 0/1 over ``DEGREES_OF_FREEDOM``)."""

    def __init__(self, bodies, dim: int, n_static_walls: int, launcher):
        self.dim = dim
        self.launcher = launcher
        self.list = list(bodies)
        for k, body in enumerate(self.list):
            if not isinstance(body, RigidBody):
                raise ParameterError("bodies", f"must be RigidBody objects, got {type(body).__name__} at {k}")
            if body.motion is not None and not isinstance(body.motion, PrescribedMotion):
                raise ParameterError("bodies", f"body {k}'s motion must be a PrescribedMotion (or none: it floats)")
        self.count = len(self.list)
        points = [to_vec3(b.particles, "bodies").astype(np.float64) if np.size(b.particles) else np.zeros((0, 3))
                  for b in self.list]
        for k, p in enumerate(points):
            if len(p) == 0:
                raise ParameterError("bodies", f"body {k} has no wall particles")
        #: (M_total, 3) float32: the bodies' wall particles at t = 0, in order (the model appends them to its walls)
        self.particles = np.vstack(points).astype(np.float32) if points else np.zeros((0, 3), np.float32)
        self.floating = [k for k, b in enumerate(self.list) if b.motion is None]
        self.prescribed_bodies = [k for k, b in enumerate(self.list) if b.motion is not None]
        self.mass = np.zeros(self.count)
        self.inertia = np.zeros((self.count, 3, 3))
        self.free = np.zeros((self.count, 6))
        centres = []
        for k, (b, p) in enumerate(zip(self.list, points)):
            if b.motion is None:
                centres.append(self._mass_properties(k, b))
            else:
                centres.append(b.motion.centre if b.motion.centre is not None else p.mean(axis=0))
        self.centre = np.array(centres, dtype=np.float64).reshape(-1, 3)
        if self.centre.size and (self.centre.shape[1] != 3 or not np.all(np.isfinite(self.centre))):
            raise ParameterError("centre", f"must be 3 finite coordinates, got {self.centre.tolist()}")
        if dim == 2:
            for k in self.prescribed_bodies:
                if abs(self.list[k].motion.axis[2]) != 1.0:
                    raise ParameterError("axis", f"a 2D body turns about the z axis, body {k} has "
                                                 f"{self.list[k].motion.axis}")
            for k in range(self.count):
                if self.centre[k, 2] != 0.0:
                    raise ParameterError("centre", f"a 2D body's centre lies in the plane (z = 0), body {k}'s does not")
        n_walls = n_static_walls + len(self.particles)
        self.wall_body = np.full(n_walls, -1, np.int32)
        self.wall_offset = np.zeros((n_walls, 3))
        start = n_static_walls
        for k, p in enumerate(points):
            self.wall_body[start:start + len(p)] = k
            self.wall_offset[start:start + len(p)] = p.astype(np.float32).astype(np.float64) - self.centre[k]
            start += len(p)
        self._tables()

    def _mass_properties(self, k: int, body: RigidBody) -> np.ndarray:
        """A floating body's mass, inertia (about its centre of mass) and free degrees of freedom from its surface and
        density; returns its centre of mass."""
        density = body.density
        if density is None or not np.isfinite(density) or not density > 0.0:
            raise ParameterError("density", f"floating body {k} needs a positive density (kg/m³), got {density!r}")
        if body.surface is None:
            raise ParameterError("bodies", f"floating body {k} needs its surface: its mass and inertia come from it")
        if self.dim == 2:
            area, centroid, polar = polygon_mass_properties(body.surface)
            self.mass[k] = density * area
            self.inertia[k] = np.eye(3) * density * polar  # only rz turns a 2D body
            centre = np.array([centroid[0], centroid[1], 0.0])
        else:
            if not is_mesh(body.surface) or not body.surface.is_watertight:
                raise ParameterError("bodies", f"floating body {k}'s surface must be a watertight mesh")
            mesh = body.surface.copy()
            mesh.density = float(density)
            self.mass[k] = float(mesh.mass)
            self.inertia[k] = np.asarray(mesh.moment_inertia, dtype=np.float64)
            centre = np.asarray(mesh.center_mass, dtype=np.float64)
        allowed = PLANAR_FREEDOM if self.dim == 2 else DEGREES_OF_FREEDOM
        free = allowed if body.free is None else tuple(body.free)
        bad = [f for f in free if f not in allowed]
        if bad or not free:
            raise ParameterError("free", f"body {k}'s degrees of freedom are some of {allowed}, got {free!r}")
        self.free[k] = [1.0 if f in free else 0.0 for f in DEGREES_OF_FREEDOM]
        return centre

    def _tables(self) -> None:
        """The prescribed motions' spline tables on the device."""
        dev = self.launcher.device
        prescribed = [self.list[k] for k in self.prescribed_bodies]
        splines = [b.motion.spline(self.dim) for b in prescribed]
        times = [b.motion.times for b in prescribed]
        start = np.concatenate([[0], np.cumsum([len(t) for t in times])]).astype(np.int32)
        self.table_start = wp.array(start, dtype=wp.int32, device=dev)
        self.times = wp.array(np.concatenate(times) if times else np.zeros(2), dtype=wp.float64, device=dev)
        self.coefficients = wp.array(np.concatenate(splines) if splines else np.zeros((1, 4, 4)), dtype=wp.float64,
                                     device=dev)
        centres = self.centre[self.prescribed_bodies] if prescribed else np.zeros((1, 3))
        self.start_position = wp.array(centres, dtype=wp.vec3d, device=dev)
        axes = np.array([b.motion.axis for b in prescribed]).reshape(-1, 3) if prescribed else np.zeros((1, 3))
        self.axis = wp.array(axes, dtype=wp.vec3d, device=dev)
        self.prescribed = wp.array(np.array(self.prescribed_bodies or [0], dtype=np.int32), dtype=wp.int32,
                                   device=dev)

    def initial_state(self) -> np.ndarray:
        """(count, BODY_COLUMNS) float64: every body at its reference point, unturned, at rest."""
        state = np.zeros((self.count, bk.BODY_COLUMNS))
        state[:, bk.BODY_POSITION:bk.BODY_POSITION + 3] = self.centre
        state[:, bk.BODY_ROTATION + 3] = 1.0
        return state

    def launch_poses(self, clock: wp.array, at_step_end: bool, state: wp.array) -> None:
        """Every prescribed body's state at the clock's time (+ its step with ``at_step_end``)."""
        if not self.prescribed_bodies:
            return
        self.launcher.launch(bk.prescribed_poses, len(self.prescribed_bodies), [clock, int(at_step_end), self.table_start, self.times,
                                                               self.coefficients, self.start_position, self.axis,
                                                               self.prescribed, state])

    def wall_positions(self, state: np.ndarray, static_positions: np.ndarray) -> np.ndarray:
        """(nb, 3) float64: every wall where the bodies' ``state`` ((count, BODY_COLUMNS)) puts it, on the host (the
        walls at rest at ``static_positions``): which rank holds which wall in a distributed run."""
        out = np.asarray(static_positions, dtype=np.float64).copy()
        moving = self.wall_body >= 0
        b = self.wall_body[moving]
        q = state[b, bk.BODY_ROTATION:bk.BODY_ROTATION + 4]
        out[moving] = state[b, bk.BODY_POSITION:bk.BODY_POSITION + 3] + quat_rotate(q, self.wall_offset[moving])
        return out

    def surfaces(self) -> list[tuple[object, int, np.ndarray, bool]]:
        """(surface, body, centre, holds fluid) of every body that has one."""
        return [(b.surface, k, self.centre[k], bool(b.holds_fluid)) for k, b in enumerate(self.list)
                if b.surface is not None]

    def describe(self) -> list[dict]:
        """The bodies for ``summary.json``: name, wall particles, reference point and motion's table span."""
        out = []
        for k, b in enumerate(self.list):
            d = {"name": b.name or f"body {k}", "wall_particles": int(np.count_nonzero(self.wall_body == k)),
                 "centre": self.centre[k].tolist()}
            if b.motion is None:
                d.update(motion="floating", density=float(b.density), mass=float(self.mass[k]),
                         inertia=self.inertia[k].tolist(),
                         free=[f for f, on in zip(DEGREES_OF_FREEDOM, self.free[k]) if on])
            else:
                d.update(motion="prescribed", table=[float(b.motion.times[0]), float(b.motion.times[-1]),
                                                     int(b.motion.times.size)])
            out.append(d)
        return out


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` rotated by the unit quaternions ``q`` (x, y, z, w), float64 (as ``wp.quat_rotate``)."""
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)




def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The quaternion product a b (x, y, z, w): the rotation b, then a."""
    av, aw, bv, bw_ = a[:3], a[3], b[:3], b[3]
    return np.concatenate([aw * bv + bw_ * av + np.cross(av, bv), [aw * bw_ - np.dot(av, bv)]])


def rotation_quat(rotation: np.ndarray) -> np.ndarray:
    """The unit quaternion of a rotation vector (its direction the axis, its length the angle, rad)."""
    angle = float(np.linalg.norm(rotation))
    if angle == 0.0:
        return np.array([0.0, 0.0, 0.0, 1.0])
    return np.concatenate([np.sin(0.5 * angle) * rotation / angle, [np.cos(0.5 * angle)]])


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion (x, y, z, w)."""
    return np.column_stack([quat_rotate(q, e) for e in np.eye(3)])


def polygon_mass_properties(polygon) -> tuple[float, np.ndarray, float]:
    """A closed polygon's area (m²), centroid (2,) and polar second moment of area about the centroid (m⁴): the
    shoelace sums, Σ over edges of (x_i y_{i+1} - x_{i+1} y_i) times 1/2, (p_i + p_{i+1})/6 and
    (x_i² + x_i x_{i+1} + x_{i+1}² + y_i² + y_i y_{i+1} + y_{i+1}²)/12; either orientation."""
    p = np.asarray(polygon, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3 or not np.all(np.isfinite(p)):
        raise ParameterError("bodies", f"a 2D body's surface is a closed (P >= 3, 2) polygon, got shape {p.shape}")
    if np.allclose(p[0], p[-1]):
        p = p[:-1]
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * cross.sum()
    if area == 0.0:
        raise ParameterError("bodies", "a 2D body's surface must enclose an area")
    cx = ((x + xn) * cross).sum() / (6.0 * area)
    cy = ((y + yn) * cross).sum() / (6.0 * area)
    polar_origin = ((x * x + x * xn + xn * xn + y * y + y * yn + yn * yn) * cross).sum() / 12.0
    sign = np.sign(area)
    area = abs(area)
    polar = sign * polar_origin - area * (cx * cx + cy * cy)
    return float(area), np.array([cx, cy]), float(polar)
