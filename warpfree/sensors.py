"""Sensors: what a run samples on an interval of its own, apart from its outputs, as time series with units.

A sensor's sample times are 0, Δ, 2Δ, …; it is sampled after the first step that ends at or past each, and the row
holds that step's time: a sensor never shortens a step, so adding one changes nothing else in the run (a step that
passes several sample times gives one row). Its rows are kept in the run's checkpoints (a resumed run continues them
bitwise), in ``sensors/<name>.csv`` (a header line of columns with their units, then one row per sample; the rows
since the last write appended at every output and at the end, the whole file written at a run's or resume's first) and in ``summary.json`` (``sensors``: kind, file, columns, samples). Every rank samples
(the values come from the rank that holds them) and the first writes.

- :class:`FieldSensor`: a solver's fields at points (``solver.field_at(points)``: the fluid's, the Galerkin solvers');
- :class:`PressureSensor`: the pressure at points, 0 Pa (gauge) where no fluid is, as a wetted pressure transducer
  reads in air; or its mean over them (a transducer's face, ``panel`` on the command line);
- family sensors beside their solvers: the fluid's water gauges and forces on solids
  (``warpfree.solvers.wcsph.sensors``).

``--sensor NAME=KIND:ARGS[@INTERVAL]`` adds one to any scene from the command line (:func:`parse_sensor`), and
``TimeLoop.add_sensor`` from Python.
"""

from __future__ import annotations

import importlib.util
import io
import math
import os
import re
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from .errors import ParameterError, require_positive

__all__ = ["Sensor", "FieldSensor", "PressureSensor", "SENSOR_KINDS", "parse_sensor", "due_time", "write_csv", "append_csv"]

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
#: the output interval of a sensor made without one (s): 1 kHz, the rate of the SPHERIC test 2 pressure records
DEFAULT_INTERVAL = 1.0e-3


class Sensor(ABC):
    """One sensor: ``name`` (its file's name), ``interval`` (s between samples, > 0). A subclass gives its columns,
    checks the solver it is given before the run, and samples it."""

    kind: ClassVar[str] = "sensor"

    def __init__(self, name: str, interval: float = DEFAULT_INTERVAL):
        if not isinstance(name, str) or not _NAME.match(name):
            raise ParameterError("sensor", f"a sensor's name is letters, digits, '_', '.' or '-' (a file name), "
                                           f"got {name!r}")
        self.name = name
        self.interval = require_positive("sensor", interval)

    @abstractmethod
    def columns(self, solver) -> list[tuple[str, str]]:
        """(column name, unit) of each sampled value, in order (the time column comes first, not listed)."""

    def check(self, solver) -> None:
        """Refuse, naming ``sensor``, a solver this sensor cannot read (called when the sensor is added)."""

    @abstractmethod
    def sample(self, solver) -> np.ndarray:
        """The values now, one per column (float64); called on every rank."""

    def describe(self) -> dict:
        """The sensor for ``summary.json``."""
        return {"kind": self.kind, "interval": self.interval}


class FieldSensor(Sensor):
    """Fields of a solver at fixed points: ``solver.field_at(points)`` (a dict of per-point arrays, vectors as
    (m, 3)); ``fields``: the names to record, with their units; ``dry``: the value written where the solver has no
    value (NaN: none)."""

    kind: ClassVar[str] = "field"

    def __init__(self, name: str, points, fields: dict[str, str], interval: float = DEFAULT_INTERVAL,
                 dry: float = math.nan):
        super().__init__(name, interval)
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim == 1:
            pts = pts.reshape(1, -1)
        if pts.ndim != 2 or pts.shape[0] == 0 or pts.shape[1] not in (1, 2, 3) or not np.all(np.isfinite(pts)):
            raise ParameterError("sensor", f"{name}: points must be finite coordinates, one row per point, got "
                                           f"{np.asarray(points).tolist()!r}")
        self.points = pts
        self.fields = dict(fields)
        self.dry = float(dry)
        self._widths: dict[str, int] = {}

    def check(self, solver) -> None:
        if not hasattr(solver, "field_at"):
            raise ParameterError("sensor", f"{self.name}: the {solver.name} solver gives no fields at points")
        if self.points.shape[1] not in (solver.dim, 3):
            raise ParameterError("sensor", f"{self.name}: points need {solver.dim} coordinates, got "
                                           f"{self.points.shape[1]}")
        values = self._values(solver)
        for field in self.fields:
            if field not in values:
                raise ParameterError("sensor", f"{self.name}: no field {field!r}; the solver gives "
                                               f"{', '.join(sorted(values))}")
            v = np.asarray(values[field])
            self._widths[field] = 1 if v.ndim == 1 else v.shape[1]

    def columns(self, solver) -> list[tuple[str, str]]:
        out = []
        for k in range(len(self.points)):
            for field, unit in self.fields.items():
                width = self._widths.get(field, 1)
                suffix = "" if len(self.points) == 1 else f"_{k}"
                out += ([(f"{field}{suffix}", unit)] if width == 1 else
                        [(f"{field}_{'xyz'[c]}{suffix}", unit) for c in range(width)])
        return out

    def _values(self, solver) -> dict:
        """The solver's fields at the points (name -> per-point values)."""
        return solver.field_at(self.points)

    def sample(self, solver) -> np.ndarray:
        values = self._values(solver)
        dry = self._dry(values)
        row = []
        for k in range(len(self.points)):
            for field in self.fields:
                v = np.atleast_1d(np.asarray(values[field][k], dtype=np.float64))
                row.extend(np.where(dry[k], self.dry, v))
        return np.asarray(row, dtype=np.float64)

    def _dry(self, values: dict) -> np.ndarray:
        """Per point: no value there (every recorded field NaN)."""
        return np.all([~np.isfinite(np.asarray(values[f], dtype=np.float64).reshape(len(self.points), -1)).any(1)
                       for f in self.fields], axis=0)

    def describe(self) -> dict:
        return {**super().describe(), "points": self.points.tolist(), "fields": self.fields}


class PressureSensor(FieldSensor):
    """The pressure (Pa) at fixed points, 0 (gauge) where no fluid is: a pressure transducer's reading. On a wall,
    put the point on the wall's face: where the solver gives a ``wall_pressure`` (the fluid's: the average over the
    water and the wall on both sides of the face, ``WCSPHSolver.field_at``) it is read, else its ``pressure``.

    ``mean=True``: one column, the mean over the points: a transducer whose face is sampled at them (a dry point
    counts 0, so a face half wet reads half its wet part's pressure, as the force on it over its area)."""

    kind: ClassVar[str] = "pressure"

    def __init__(self, name: str, points, interval: float = DEFAULT_INTERVAL, mean: bool = False):
        super().__init__(name, points, {"pressure": "Pa"}, interval, dry=0.0)
        self.mean = bool(mean)

    def _values(self, solver) -> dict:
        values = solver.field_at(self.points)
        return {"pressure": values.get("wall_pressure", values["pressure"])}

    def columns(self, solver) -> list[tuple[str, str]]:
        return [("pressure", "Pa")] if self.mean else super().columns(solver)

    def sample(self, solver) -> np.ndarray:
        values = super().sample(solver)
        return np.array([values.mean()]) if self.mean else values

    def describe(self) -> dict:
        d = super().describe()
        d.pop("fields")
        return {**d, "mean": self.mean}


def due_time(interval: float, last_time: float | None) -> float:
    """The next sample time of a sensor sampled last at ``last_time`` (None: never): the first multiple of
    ``interval`` after it (0 for the first sample)."""
    if last_time is None:
        return 0.0
    return (math.floor(last_time / interval * (1.0 + 1e-12) + 1e-9) + 1) * interval


def write_csv(path: str, header: list[tuple[str, str]], rows: np.ndarray) -> None:
    """``rows`` (n, 1 + columns) as CSV under a header of ``name [unit]`` columns (time first), replaced whole and
    atomically (a kill leaves the previous file)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    names = ",".join(f"{name} [{unit}]" if unit else name for name, unit in header)
    with open(tmp, "w") as f:
        f.write(names + "\n")
        if len(rows):
            np.savetxt(f, np.asarray(rows, dtype=np.float64), delimiter=",", fmt="%.9g")
    os.replace(tmp, path)


def append_csv(path: str, rows: np.ndarray) -> None:
    """Append ``rows`` to a CSV :func:`write_csv` made, in one write (a kill leaves whole rows: a resumed run writes
    the file whole again from its checkpoint)."""
    buffer = io.StringIO()
    np.savetxt(buffer, np.asarray(rows, dtype=np.float64), delimiter=",", fmt="%.9g")
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    try:
        os.write(fd, buffer.getvalue().encode())
    finally:
        os.close(fd)


#: kind -> (how ``--sensor`` writes its arguments, the function that makes one from a name, points and interval)
SENSOR_KINDS: dict[str, tuple[str, object]] = {
    "pressure": ("X,Y[,Z][;X,Y[,Z]...]: points (m)", lambda name, points, interval: PressureSensor(name, points,
                                                                                                   interval)),
    "panel": ("X,Y[,Z];X,Y[,Z][;...]: points of a transducer's face (m), their mean pressure",
              lambda name, points, interval: PressureSensor(name, points, interval, mean=True)),
}


def register_kind(kind: str, usage: str, make) -> None:
    """Let ``--sensor`` make sensors of ``kind`` (a family's: ``make(name, points, interval)``)."""
    SENSOR_KINDS[kind] = (usage, make)


def parse_sensor(text: str) -> Sensor:
    """A sensor from ``NAME=KIND:X,Y[,Z][;X,Y[,Z]...][@INTERVAL]`` (``--sensor``); a malformed one: ParameterError
    naming ``sensor`` with the form expected."""
    _load_family_kinds()
    kinds = ", ".join(f"{k} ({usage})" for k, (usage, _) in sorted(SENSOR_KINDS.items()))
    form = f"NAME=KIND:COORDINATES[@INTERVAL], KIND one of {kinds}"
    m = re.match(r"^\s*([^=\s]+)\s*=\s*([A-Za-z_]+)\s*:\s*([^@]+?)\s*(?:@\s*(\S+))?\s*$", text or "")
    if not m:
        raise ParameterError("sensor", f"{text!r} is not {form}")
    name, kind, coordinates, interval = m.groups()
    if kind not in SENSOR_KINDS:
        raise ParameterError("sensor", f"{text!r}: unknown kind {kind!r}; {form}")
    try:
        points = [[float(v) for v in point.split(",")] for point in coordinates.split(";") if point.strip()]
        seconds = DEFAULT_INTERVAL if interval is None else float(interval)
    except ValueError:
        raise ParameterError("sensor", f"{text!r}: numbers expected; {form}") from None
    if not points or len({len(p) for p in points}) != 1:
        raise ParameterError("sensor", f"{text!r}: every point needs the same number of coordinates; {form}")
    return SENSOR_KINDS[kind][1](name, points, seconds)


def _load_family_kinds() -> None:
    """Import every family's ``sensors`` module (``warpfree/solvers/<family>/sensors.py``), which registers its kinds:
    found, not listed, so a new family's sensors need no edit here."""
    import importlib
    import pkgutil

    import warpfree.solvers as families

    for family in pkgutil.iter_modules(families.__path__):
        if family.ispkg and importlib.util.find_spec(f"warpfree.solvers.{family.name}.sensors") is not None:
            importlib.import_module(f"warpfree.solvers.{family.name}.sensors")
