"""The fluid's own sensors: water gauges (``height``), the force on solids (``force``) and a rigid body's motion
(``body``). Pressure sensors are the
core's (:class:`warpfree.sensors.PressureSensor`, through :meth:`WCSPHSolver.field_at`).

A force sensor records the fluid's force on the obstacles' wall particles (or the containers') and its moment about a
point: the reaction to the wall terms of the fluid's momentum equation, particle by particle (``WCSPHSolver.force_on``),
so it is the force the solid exerts on the water, reversed, not an integral of sampled pressures.

A water gauge reads the height of the free surface above a base point, along the vertical (against gravity), as a
wave gauge or a resistance probe does: the filled fraction s(z) = Σ_j V_j W_j of the fluid (``field_at``) is sampled
every dx/4 up the line, from one smoothing length above the base (at the base itself, on a floor, s is about 1/2
under water too: the floor cuts the support) to the highest wall; the surface is the first crossing of s = 1/2 going
up (a flat surface's s is 1/2 at the surface), interpolated linearly between the samples around it. A layer thinner
than one smoothing length reads 0 (it cannot be told from a wet floor at this resolution); water above the line's
top reads the whole line.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from warpfree.errors import ParameterError
from warpfree.sensors import DEFAULT_INTERVAL, Sensor, register_kind

__all__ = ["WaterGauge", "ForceSensor", "BodySensor"]

#: the filled fraction at a free surface (a flat surface of uniform fluid: half the support filled)
SURFACE_FILLED = 0.5


class WaterGauge(Sensor):
    """The free surface's height (m) above each of ``bases`` (points on a floor: (x, y) in 2D, (x, y, z) in 3D),
    measured along the vertical."""

    kind: ClassVar[str] = "height"

    def __init__(self, name: str, bases, interval: float = DEFAULT_INTERVAL):
        super().__init__(name, interval)
        pts = np.asarray(bases, dtype=np.float64)
        pts = pts.reshape(1, -1) if pts.ndim == 1 else pts
        if pts.ndim != 2 or pts.shape[0] == 0 or pts.shape[1] not in (2, 3) or not np.all(np.isfinite(pts)):
            raise ParameterError("sensor", f"{name}: a gauge's bases are finite points, one row each, got "
                                           f"{np.asarray(bases).tolist()!r}")
        self.bases = pts
        self._line: np.ndarray | None = None   # (samples,) heights above a base sampled
        self._up: np.ndarray | None = None

    def check(self, solver) -> None:
        if getattr(solver, "name", "") != "wcsph":
            raise ParameterError("sensor", f"{self.name}: a water gauge reads a WCSPH fluid, not {solver.name}")
        if self.bases.shape[1] not in (solver.dim, 3):
            raise ParameterError("sensor", f"{self.name}: bases need {solver.dim} coordinates, got "
                                           f"{self.bases.shape[1]}")
        params = solver.model.params
        g = np.asarray(params.gravity, dtype=np.float64)
        if not np.linalg.norm(g) > 0:
            raise ParameterError("sensor", f"{self.name}: a water gauge measures against gravity; this fluid has none")
        self._up = -g / np.linalg.norm(g)
        bases = self._bases3()
        every = np.asarray(solver.model.position_np, dtype=np.float64)
        top = float(np.max((every[:, None, :] - bases[None, :, :]) @ self._up))
        start, step = params.h, 0.25 * params.dx
        if not top > start:
            raise ParameterError("sensor", f"{self.name}: no wall or water above the base {self.bases[0].tolist()}")
        self._line = start + step * np.arange(int(np.ceil((top - start) / step)) + 1)

    def _bases3(self) -> np.ndarray:
        out = np.zeros((len(self.bases), 3))
        out[:, :self.bases.shape[1]] = self.bases
        return out

    def columns(self, solver) -> list[tuple[str, str]]:
        return [("height" if len(self.bases) == 1 else f"height_{k}", "m") for k in range(len(self.bases))]

    def sample(self, solver) -> np.ndarray:
        line = self._line
        points = (self._bases3()[:, None, :] + line[None, :, None] * self._up[None, None, :]).reshape(-1, 3)
        filled = solver.field_at(points)["filled"].reshape(len(self.bases), len(line))
        return np.array([surface_height(line, s) for s in filled])

    def describe(self) -> dict:
        return {**super().describe(), "bases": self.bases.tolist()}


def surface_height(heights: np.ndarray, filled: np.ndarray) -> float:
    """The first height, going up, where ``filled`` drops below :data:`SURFACE_FILLED` (linear between the samples
    around it); 0 when the first sample is already below, the last height when none is."""
    below = np.flatnonzero(filled < SURFACE_FILLED)
    if below.size == 0:
        return float(heights[-1])
    k = int(below[0])
    if k == 0:
        return 0.0
    s0, s1 = filled[k - 1], filled[k]
    return float(heights[k - 1] + (s0 - SURFACE_FILLED) / (s0 - s1) * (heights[k] - heights[k - 1]))


class ForceSensor(Sensor):
    """The fluid's force (N; per metre of depth in 2D) on ``walls`` ("obstacles" or "containers") and its moment about
    ``about`` (N m; in 2D the z component only)."""

    kind: ClassVar[str] = "force"
    WALLS = ("obstacles", "containers")

    def __init__(self, name: str, about, walls: str = "obstacles", interval: float = DEFAULT_INTERVAL):
        super().__init__(name, interval)
        if walls not in self.WALLS:
            raise ParameterError("sensor", f"{name}: walls must be one of {', '.join(self.WALLS)}, got {walls!r}")
        point = np.asarray(about, dtype=np.float64).reshape(-1)
        if point.size not in (2, 3) or not np.all(np.isfinite(point)):
            raise ParameterError("sensor", f"{name}: the moment's centre is one point, got {np.asarray(about).tolist()!r}")
        self.walls, self.about = walls, point
        self._dim = 3

    def check(self, solver) -> None:
        if getattr(solver, "name", "") != "wcsph":
            raise ParameterError("sensor", f"{self.name}: a force sensor reads a WCSPH fluid, not {solver.name}")
        model = solver.model
        count = model.nb - model.n_container_walls if self.walls == "obstacles" else model.n_container_walls
        if count == 0:
            raise ParameterError("sensor", f"{self.name}: this scene has no {self.walls}")
        if self.about.size not in (solver.dim, 3):
            raise ParameterError("sensor", f"{self.name}: the centre needs {solver.dim} coordinates")
        self._dim = solver.dim

    def columns(self, solver) -> list[tuple[str, str]]:
        unit, moment = ("N/m", "N") if self._dim == 2 else ("N", "N m")
        forces = [(f"force_{a}", unit) for a in "xyz"[:self._dim]]
        return forces + ([("moment_z", moment)] if self._dim == 2 else [(f"moment_{a}", moment) for a in "xyz"])

    def sample(self, solver) -> np.ndarray:
        force, moment = solver.force_on(self.walls, self.about)
        return np.concatenate([force[:self._dim], moment[2:] if self._dim == 2 else moment])

    def describe(self) -> dict:
        return {**super().describe(), "walls": self.walls, "about": self.about.tolist()}


class BodySensor(Sensor):
    """The motion of rigid body ``body`` (its index in the model's ``bodies``): its reference point's position (m;
    for a floating body its centre of mass), its rotation (2D: the angle about z, rad; 3D: the quaternion x, y, z, w),
    velocity (m/s) and spin (rad/s), and the fluid's force on it (N; per metre in 2D) and moment about the reference
    point (``WCSPHSolver.body_loads``)."""

    kind: ClassVar[str] = "body"

    def __init__(self, name: str, body: int = 0, interval: float = DEFAULT_INTERVAL):
        super().__init__(name, interval)
        if not isinstance(body, (int, np.integer)) or body < 0:
            raise ParameterError("sensor", f"{name}: a body's index is a whole number >= 0, got {body!r}")
        self.body = int(body)
        self._dim = 3

    def check(self, solver) -> None:
        if getattr(solver, "name", "") != "wcsph":
            raise ParameterError("sensor", f"{self.name}: a body sensor reads a WCSPH fluid, not {solver.name}")
        bodies = solver.model.bodies
        if bodies is None or self.body >= bodies.count:
            raise ParameterError("sensor", f"{self.name}: this scene has {0 if bodies is None else bodies.count} "
                                           f"bodies, no body {self.body}")
        self._dim = solver.dim

    def columns(self, solver) -> list[tuple[str, str]]:
        d = self._dim
        force, moment = ("N/m", "N") if d == 2 else ("N", "N m")
        cols = [(a, "m") for a in "xyz"[:d]]
        cols += [("angle", "rad")] if d == 2 else [(f"q{a}", "") for a in "xyzw"]
        cols += [(f"v{a}", "m/s") for a in "xyz"[:d]]
        cols += [("spin", "rad/s")] if d == 2 else [(f"spin_{a}", "rad/s") for a in "xyz"]
        cols += [(f"force_{a}", force) for a in "xyz"[:d]]
        cols += [("moment_z", moment)] if d == 2 else [(f"moment_{a}", moment) for a in "xyz"]
        return cols

    def sample(self, solver) -> np.ndarray:
        from warpfree.kernels import wcsph_bodies as bk

        d, b = self._dim, self.body
        row = solver.body_state()[b]
        force, moment = (v[b] for v in solver.body_loads())
        q = row[bk.BODY_ROTATION:bk.BODY_ROTATION + 4]
        rotation = [2.0 * np.arctan2(q[2], q[3])] if d == 2 else list(q)
        spin = row[bk.BODY_SPIN:bk.BODY_SPIN + 3]
        return np.array(list(row[:d]) + rotation + list(row[bk.BODY_VELOCITY:bk.BODY_VELOCITY + d])
                        + ([spin[2]] if d == 2 else list(spin)) + list(force[:d])
                        + ([moment[2]] if d == 2 else list(moment)))

    def describe(self) -> dict:
        return {**super().describe(), "body": self.body}


def _force_sensor(name, points, interval):
    if len(points) != 1:
        raise ParameterError("sensor", f"{name}: a force sensor takes one point, the moment's centre")
    return ForceSensor(name, points[0], "obstacles", interval)


register_kind("force", "X,Y[,Z]: the moment's centre (m); on the obstacles", _force_sensor)
register_kind("height", "X,Y[,Z][;...]: base points on the floor (m)",
              lambda name, points, interval: WaterGauge(name, points, interval))
register_kind("body", "K: the index of a rigid body of the scene (its position, rotation, velocity and load)",
              lambda name, points, interval: BodySensor(name, _body_index(name, points), interval))


def _body_index(name, points) -> int:
    value = np.asarray(points, dtype=np.float64).ravel()
    if value.size != 1 or value[0] != np.round(value[0]) or value[0] < 0:
        raise ParameterError("sensor", f"{name}: a body sensor takes one body index, got {value.tolist()!r}")
    return int(value[0])
