"""Open boundaries of a WCSPH fluid: inlets and outlets as buffer zones of particles (Tafuni et al. 2018).

An :class:`Opening` is a plane through ``point`` with the unit ``normal`` pointing into the domain, and behind it a
buffer of depth T (``thickness``) filled with fluid particles, as a lattice continuing the fluid's (the scene lays
them out with the rest of the fluid). A buffer particle takes no rates: each step it gets the opening's values at the
predicted state (``kernels/wcsph_open.py``: a prescribed velocity or the fluid's mirrored one, a prescribed pressure
at the plane or the fluid's extrapolated one) and moves with its velocity. Whether an opening lets fluid in or out
follows from the flow; one that prescribes a velocity into the domain is an inlet.

Particles are made and taken out where the neighbour tables are rebuilt (about every skin/2 of motion: the buffer is
at least one support plus the skin deep, so the fluid next to a plane never sees the buffer's far end):

- a buffer particle that crossed its plane into the domain since the last build becomes fluid, and a new buffer
  particle is made a depth T behind where it crossed (the buffer's lattice continues: T is whole spacings);
- a particle beyond a buffer's far end (depth > T + dx/2: it left the domain through the opening) is taken out.

Each new particle gets the next id (never reused; sorted by the crossing particle's id, so that any number of ranks
issues the ids the one process does). The fluid particles all have one mass, so the fluid's mass in the domain and
in the buffers changes only by whole particles, counted per opening (made, taken out).

A particle that flows back out of the domain into an inflow buffer and crosses again makes a second particle: an
opening's flow should keep one direction over its whole cross-section (an outlet far enough downstream of a wake).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels.wcsph_open import Openings as OpeningsStruct

__all__ = ["Opening", "Openings"]


@dataclass
class Opening:
    """An inlet or outlet: the plane through ``point`` (m) with ``normal`` pointing into the domain, and its buffer.

    velocity: the fluid's velocity in the buffer (m/s; ``dim`` or 3 components), pointing into the domain (an inlet);
        None: the fluid's own, mirrored across the plane (zero normal gradient: an outflow or a pressure inlet).
    pressure: the pressure at the plane (Pa), continued into the buffer with the fluid's gradient; None: the fluid's,
        extrapolated to first order. An opening prescribes its velocity, its pressure or both. Where the flow's
        pressure would fall below zero (a body's wake), an outlet's background pressure of a few ρU² keeps it
        positive: water under tension opens voids.
    ramp: the prescribed velocity's start-up (s): it rises as U (1 - cos(π t/ramp))/2 from 0 to U, so that the water
        at rest is not struck at once (a weakly compressible fluid rings with the sound it makes); 0: U from t = 0.
    thickness: the buffer's depth T (m), whole spacings, at least the kernel's support plus the tables' skin; None:
        the depth of the fluid the scene laid behind the plane (its deepest particle's, to the next half spacing). The
        buffer must be full: its particles a lattice of spacing dx from the plane to T (a particle made behind one
        that crossed sits T behind it, where the lattice continues).
    name: what reports call it (default ``opening k``).
    """

    point: tuple
    normal: tuple
    velocity: tuple | None = None
    pressure: float | None = None
    ramp: float = 0.0
    thickness: float | None = None
    name: str = ""


def _vector(name: str, value, dim: int) -> np.ndarray:
    """A finite (3,) float64 vector from ``dim`` or 3 components (z = 0 in 2D)."""
    v = np.asarray(value, dtype=float).ravel() if value is not None else np.zeros(0)
    if v.shape not in ((dim,), (3,)) or not np.all(np.isfinite(v)):
        raise ParameterError(name, f"must be {dim} finite numbers, got {value!r}")
    v = np.concatenate([v, np.zeros(3 - v.size)])
    if dim == 2 and v[2] != 0.0:
        raise ParameterError(name, "must lie in the plane in 2D (z component 0)")
    return v


class Openings:
    """The openings of a fluid (checked against its parameters): their planes and buffers on the host, and the
    struct the kernels take.

    Parameters
    ----------
    openings: the :class:`Opening` s, in order (a particle behind two planes belongs to the first).
    params: the fluid's :class:`~warpfree.solvers.wcsph.model.FluidParams` (spacing, support, skin, container).
    skin: the neighbour tables' skin (m).
    fluid: the fluid's initial positions ((n, 3)): the buffers' particles among them.
    """

    def __init__(self, openings, params, skin: float, device, fluid: np.ndarray):
        dim = params.dim
        self.count = len(openings)
        self.names, points, normals, velocities, pressures, thickness = [], [], [], [], [], []
        least = params.support + skin
        for k, o in enumerate(openings):
            if not isinstance(o, Opening):
                raise ParameterError("openings", f"must be Opening s, got {type(o).__name__}")
            self.names.append(o.name or f"opening {k}")
            point, normal = _vector("point", o.point, dim), _vector("normal", o.normal, dim)
            length = float(np.linalg.norm(normal))
            if length == 0.0:
                raise ParameterError("normal", "must not be zero")
            normal = normal / length
            if o.velocity is None and o.pressure is None:
                raise ParameterError("openings", f"{self.names[-1]} prescribes neither a velocity nor a pressure: give "
                                                 "it one or both")
            velocity = np.zeros(3)
            if o.velocity is not None:
                velocity = _vector("velocity", o.velocity, dim)
                if not velocity @ normal > 0.0:
                    raise ParameterError("velocity", f"{self.names[-1]}'s velocity {velocity[:dim].tolist()} must point "
                                                     f"into the domain (along its normal {normal[:dim].tolist()})")
            if not (math.isfinite(float(o.ramp)) and float(o.ramp) >= 0.0):
                raise ParameterError("ramp", f"must be a finite time >= 0 (s), got {o.ramp!r}")
            if o.pressure is not None and not math.isfinite(float(o.pressure)):
                raise ParameterError("pressure", f"must be finite, got {o.pressure!r}")
            behind = -((np.asarray(fluid, np.float64) - point) @ normal)
            behind = behind[behind > 0.0]
            if behind.size == 0:
                raise ParameterError("openings", f"{self.names[-1]} has no fluid behind its plane: lay its buffer's "
                                                 f"particles out with the fluid")
            # a lattice's last row stands dx/2 from the buffer's far end: its depth, in whole spacings
            laid = round((behind.max() + 0.5 * params.dx) / params.dx) * params.dx
            depth = laid if o.thickness is None else float(o.thickness)
            if abs(behind.max() + 0.5 * params.dx - depth) > 0.25 * params.dx:
                raise ParameterError("thickness", f"{self.names[-1]}'s buffer is {depth:.4g} m deep but the fluid laid "
                                                  f"behind its plane reaches {behind.max():.4g} m: fill it with a "
                                                  f"lattice to its far end, the last row dx/2 from it")
            if not depth >= least * (1.0 - 1e-9):
                raise ParameterError("thickness", f"{self.names[-1]}'s buffer is {depth:.4g} m deep: it must be at "
                                                  f"least the support plus the skin, {least:.4g} m")
            turns = depth / params.dx
            if abs(turns - round(turns)) > 1e-6:
                raise ParameterError("thickness", f"must be whole spacings dx = {params.dx:.4g} m (its new particles "
                                                  f"continue the buffer's lattice), got {depth:.4g} m")
            for a in range(3):
                if params.periodic[a] and abs(normal[a]) > 1e-12:
                    raise ParameterError("normal", f"{self.names[-1]} faces the periodic axis {'xyz'[a]}")
            # where a leaving particle may be before it is taken out: half a spacing past the far end, and the skin
            far = point - (depth + 0.5 * params.dx + skin) * normal
            lo, hi = np.asarray(params.container_lo, float), np.asarray(params.container_hi, float)
            if np.any(far[:dim] < lo[:dim]) or np.any(far[:dim] > hi[:dim]):
                raise ParameterError("container_hi", f"the container box must hold {self.names[-1]}'s buffer and the "
                                                     f"skin beyond it, to {far[:dim].round(6).tolist()}")
            points.append(point)
            normals.append(normal)
            velocities.append(velocity)
            pressures.append(0.0 if o.pressure is None else float(o.pressure))
            thickness.append(depth)
        #: how far past a buffer's far end a particle is taken out (m): half a spacing, so that a particle made at the
        #: far end itself (behind one that has only just crossed the plane) is never taken out by rounding
        self.margin = 0.5 * params.dx
        self.point, self.normal = np.array(points), np.array(normals)
        self.velocity, self.thickness = np.array(velocities), np.array(thickness)
        self.set_velocity = np.array([o.velocity is not None for o in openings])
        self.set_pressure = np.array([o.pressure is not None for o in openings])
        self.pressure = np.array(pressures)
        self.ramp = np.array([float(o.ramp) for o in openings])
        s = OpeningsStruct()
        s.count = self.count
        s.point = wp.array(self.point.astype(np.float32), dtype=wp.vec3, device=device)
        s.normal = wp.array(self.normal.astype(np.float32), dtype=wp.vec3, device=device)
        s.velocity = wp.array(self.velocity.astype(np.float32), dtype=wp.vec3, device=device)
        s.ramp = wp.array(self.ramp, dtype=wp.float64, device=device)
        s.set_velocity = wp.array(self.set_velocity.astype(np.int32), dtype=wp.int32, device=device)
        s.pressure = wp.array(self.pressure.astype(np.float32), dtype=float, device=device)
        s.set_pressure = wp.array(self.set_pressure.astype(np.int32), dtype=wp.int32, device=device)
        #: what the kernels take
        self.struct = s

    def signed_distance(self, x: np.ndarray) -> np.ndarray:
        """(n, count): each point's distance from each plane (m), positive in the domain; as the kernels compute it
        (float32)."""
        x = np.asarray(x, dtype=np.float32)
        return np.stack([((x - self.point[k].astype(np.float32)) * self.normal[k].astype(np.float32)).sum(axis=1)
                         for k in range(self.count)], axis=1) if self.count else np.zeros((len(x), 0), np.float32)

    def zone(self, x: np.ndarray) -> np.ndarray:
        """(n,) int: the opening whose buffer holds each point (the first whose plane it is behind), -1 in the
        domain."""
        behind = self.signed_distance(x) < 0.0
        first = np.argmax(behind, axis=1) if self.count else np.zeros(len(x), int)
        return np.where(behind.any(axis=1), first, -1)

    def beyond(self, x: np.ndarray, zone: np.ndarray) -> np.ndarray:
        """(n,) bool: points past their buffer's far end (deeper than its thickness, by more than :attr:`margin`): they
        have left the fluid."""
        out = np.zeros(len(x), dtype=bool)
        held = np.flatnonzero(zone >= 0)
        if held.size:
            d = self.signed_distance(x[held])[np.arange(held.size), zone[held]]
            out[held] = d < -(self.thickness[zone[held]] + self.margin)
        return out

    def describe(self) -> list[dict]:
        """The openings for ``summary.json``."""
        return [{"name": self.names[k], "point": self.point[k].tolist(), "normal": self.normal[k].tolist(),
                 "thickness": float(self.thickness[k]),
                 "velocity": self.velocity[k].tolist() if self.set_velocity[k] else None, "ramp": float(self.ramp[k]),
                 "pressure": float(self.pressure[k]) if self.set_pressure[k] else None}
                for k in range(self.count)]
