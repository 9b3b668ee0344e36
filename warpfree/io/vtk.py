"""VTU particle snapshots and a PVD time-series index for ParaView.

Layout of one series called ``name`` under ``out_dir``::

    out_dir/name.pvd                    the index (ParaView "Collection": timestep + file per entry)
    out_dir/vtk/name_0000000.vtu        one unstructured grid per written step (vertex cells)

Every file is written to a temporary name and moved into place with :func:`os.replace`, and the PVD is
rewritten in full after each snapshot, so both are valid at any moment (a run killed mid-write leaves
the previous index intact). Times are stored with ``repr(float)`` and read back exactly. A VTU holds at least one
point (one without any is not readable), so a set without points makes no series.

Units: each point-data array (and the points) may carry its unit as an XML attribute of its ``DataArray``,
``units="Pa"`` (non-ASCII characters as character references: ``units="&#955;_D"``). VTK (ParaView) and meshio read
the files as before and leave the attribute aside; :func:`read_units` reads it back.

Resume: ``VtuSeries(out_dir, name, resume_after_time=t)`` reads the existing index, keeps the entries with
``time <= t`` and appends after them; entries later than ``t`` (written after the checkpoint the run
resumes from) are dropped from the index (and an index left with none is removed: an empty collection is no
series). Their VTU files are left on disk; re-written steps overwrite them.
"""

from __future__ import annotations

import html
import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ["VtuSeries", "read_pvd", "read_snapshot", "read_units", "write_pvd", "write_pvtu", "write_vtu", "vtk_type"]


def _atomic_target(path: Path) -> Path:
    return path.with_name(f".{path.name}.tmp{os.getpid()}")


def write_pvd(path: str | os.PathLike, entries: list[tuple[float, str]]) -> None:
    """Write a ParaView collection file listing ``(time, relative_file)`` entries (atomically)."""
    path = Path(path)
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "  <Collection>",
    ]
    for t, f in entries:
        lines.append(f'    <DataSet timestep="{float(t)!r}" group="" part="0" file="{f}"/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    tmp = _atomic_target(path)
    tmp.write_text("\n".join(lines), encoding="utf-8")
    os.replace(tmp, path)


def read_pvd(path: str | os.PathLike) -> list[tuple[float, str]]:
    """Entries ``(time, file)`` of a PVD collection in file order (file paths as written, relative)."""
    root = ET.parse(Path(path)).getroot()
    out = []
    for ds in root.iter("DataSet"):
        out.append((float(ds.get("timestep", "0")), ds.get("file", "")))
    return out


def _as_points(points) -> np.ndarray:
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] not in (1, 2, 3):
        raise ParameterError("points", f"must have shape (N, 3) (or (N, 2) in 2D), got {p.shape}")
    if p.shape[1] < 3:
        p = np.concatenate([p, np.zeros((p.shape[0], 3 - p.shape[1]), dtype=p.dtype)], axis=1)
    if not np.issubdtype(p.dtype, np.floating):
        p = p.astype(np.float64)
    return np.ascontiguousarray(p)


def _as_field(name: str, values, n: int) -> np.ndarray:
    v = np.asarray(values)
    if v.ndim == 0 or v.shape[0] != n:
        raise ParameterError(f"fields[{name!r}]", f"must have {n} rows (one per point), got shape {v.shape}")
    if v.dtype == np.bool_:
        v = v.astype(np.uint8)
    elif v.dtype == np.float16:
        v = v.astype(np.float32)
    elif v.dtype.kind not in "fiu":
        raise ParameterError(f"fields[{name!r}]", f"must be numeric, got dtype {v.dtype}")
    if v.ndim == 2 and v.shape[1] == 2:
        # 2D vectors as vec3 so ParaView's glyphs and calculators see a vector.
        v = np.concatenate([v, np.zeros((n, 1), dtype=v.dtype)], axis=1)
    if v.ndim > 2:
        v = v.reshape(n, -1)
    return np.ascontiguousarray(v)


def _check_step(step) -> int:
    step = int(step)
    if step < 0:
        raise ParameterError("step", f"must be >= 0, got {step}")
    return step


def _unit_attribute(unit: str) -> bytes:
    return b' units="' + html.escape(str(unit), quote=True).encode("ascii", "xmlcharrefreplace") + b'"'


#: a data array's opening tag up to its name, in the XML meshio writes
_DATA_ARRAY = re.compile(rb'<P?DataArray [^>]*?Name="([^"]*)"')


def _with_units(xml: bytes, sections: dict[bytes, dict[str, str]]) -> bytes:
    """``xml`` with a ``units`` attribute on the data arrays named in ``sections`` ({section tag: {array name: unit}},
    e.g. ``{b"PointData": {"pressure": "Pa"}}``), each looked for between its section's opening and closing tags."""
    edits = []
    for tag, units in sections.items():
        start, end = xml.find(b"<" + tag), xml.find(b"</" + tag + b">")
        if start < 0 or end < 0 or not units:
            continue
        for match in _DATA_ARRAY.finditer(xml, start, end):
            unit = units.get(html.unescape(match.group(1).decode("ascii")))
            if unit is not None:
                edits.append((match.end(), _unit_attribute(unit)))
    out, at = [], 0
    for position, text in sorted(edits):
        out += [xml[at:position], text]
        at = position
    return b"".join(out + [xml[at:]])


def write_vtu(path: str | os.PathLike, points: np.ndarray, fields: dict[str, np.ndarray] | None = None,
              units: dict[str, str] | None = None) -> Path:
    """One VTU file of vertex cells (atomically): ``points`` (N, 3) (or (N, 1), (N, 2), padded with zeros; N >= 1);
    every entry of ``fields`` becomes point data: (N,) scalars, (N, 3) vectors ((N, 2) are padded), (N, k).
    ``units``: the unit of each field by name, and of the points as ``"position"``, recorded in the file (see the
    module's docstring)."""
    import meshio

    path = Path(path)
    pts = _as_points(points)
    n = pts.shape[0]
    if n == 0:
        raise ParameterError("points", "a VTU needs at least one point (a file without any is not readable)")
    point_data = {str(k): _as_field(str(k), v, n) for k, v in (fields or {}).items()}
    cells = [("vertex", np.arange(n, dtype=np.int64).reshape(-1, 1))]
    tmp = _atomic_target(path)
    meshio.write(str(tmp), meshio.Mesh(pts, cells, point_data=point_data), file_format="vtu")
    if units:
        sections = {b"Points": {"Points": units["position"]} if "position" in units else {},
                    b"PointData": {k: units[k] for k in point_data if k in units}}
        tmp.write_bytes(_with_units(tmp.read_bytes(), sections))
    os.replace(tmp, path)
    return path


def read_units(path: str | os.PathLike) -> dict[str, str]:
    """The units a VTU or PVTU file records (:func:`write_vtu`): {field: unit}, and ``"position"`` for the points."""
    root = ET.parse(Path(path)).getroot()
    units = {}
    for points in (*root.iter("Points"), *root.iter("PPoints")):
        for array in points:
            if "units" in array.attrib:
                units["position"] = array.attrib["units"]
    for data in (*root.iter("PointData"), *root.iter("PPointData")):
        for array in data:
            if "units" in array.attrib:
                units[array.attrib["Name"]] = array.attrib["units"]
    return units


#: NumPy dtype -> VTK XML type name
_VTK_TYPES = {"float32": "Float32", "float64": "Float64", "int8": "Int8", "int16": "Int16", "int32": "Int32",
              "int64": "Int64", "uint8": "UInt8", "uint16": "UInt16", "uint32": "UInt32", "uint64": "UInt64"}


def vtk_type(values) -> tuple[str, int]:
    """(VTK type name, components) of a point field as :func:`write_vtu` writes it."""
    v = _as_field("field", values, np.shape(values)[0])
    return _VTK_TYPES[v.dtype.name], 1 if v.ndim == 1 else v.shape[1]


def write_pvtu(path: str | os.PathLike, pieces: list[str], points, fields: dict[str, np.ndarray],
               units: dict[str, str] | None = None) -> None:
    """A parallel VTU index (atomically): the VTU ``pieces`` (paths relative to ``path``'s folder) of one snapshot,
    each written by :func:`write_vtu` with point fields like ``fields`` (any rows of them: their types and widths are
    declared) and points like ``points``; ``units`` as :func:`write_vtu` records them. ParaView opens it, or the PVD
    that lists it, as one dataset."""
    path = Path(path)
    units = units or {}

    def unit(name: str) -> str:
        return _unit_attribute(units[name]).decode("ascii") if name in units else ""

    point_type = _VTK_TYPES[_as_points(points).dtype.name]
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="PUnstructuredGrid" version="0.1" byte_order="LittleEndian">',
             '  <PUnstructuredGrid GhostLevel="0">', "    <PPointData>"]
    for name, values in fields.items():
        kind, components = vtk_type(values)
        lines.append(f'      <PDataArray type="{kind}" Name="{name}" NumberOfComponents="{components}"{unit(name)}/>')
    lines += ["    </PPointData>", "    <PPoints>",
              f'      <PDataArray type="{point_type}" NumberOfComponents="3"{unit("position")}/>', "    </PPoints>"]
    lines += [f'    <Piece Source="{piece}"/>' for piece in pieces]
    lines += ["  </PUnstructuredGrid>", "</VTKFile>", ""]
    tmp = _atomic_target(path)
    tmp.write_text("\n".join(lines), encoding="utf-8")
    os.replace(tmp, path)


def read_snapshot(path: str | os.PathLike) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(points, point fields) of one snapshot: a ``.vtu``, or a ``.pvtu`` whose pieces are joined in the order of
    their ``global_id`` (which is then left out): a distributed run's snapshot reads as the one process's."""
    import meshio

    path = Path(path)
    if path.suffix != ".pvtu":
        mesh = meshio.read(str(path))
        return mesh.points, dict(mesh.point_data)
    root = ET.parse(path).getroot()
    pieces = [meshio.read(str(path.parent / p.get("Source"))) for p in root.iter("Piece")]
    ids = np.concatenate([m.point_data["global_id"] for m in pieces])
    order = np.argsort(ids, kind="stable")
    points = np.concatenate([m.points for m in pieces])[order]
    names = [k for k in pieces[0].point_data if k != "global_id"]
    return points, {k: np.concatenate([m.point_data[k] for m in pieces])[order] for k in names}


class VtuSeries:
    """A time series of particle snapshots: one VTU per step plus a PVD index.

    Parameters
    ----------
    out_dir: output folder (created); VTU files go to ``out_dir/vtk``.
    name: series name (file stem).
    resume_after_time: if given, keep the existing index entries with time <= this value and append
        after them; otherwise any existing index is replaced by the new series.
    extension: "vtu", or "pvtu" for a distributed run's snapshots (a parallel index of the ranks' pieces).
    """

    def __init__(self, out_dir: str | os.PathLike, name: str, resume_after_time: float | None = None,
                 extension: str = "vtu"):
        if not name or any(c in name for c in "/\\\0"):
            raise ParameterError("name", f"must be a plain file stem, got {name!r}")
        self.out_dir = Path(out_dir)
        self.name = name
        self.extension = extension
        self.vtk_dir = self.out_dir / "vtk"
        self.vtk_dir.mkdir(parents=True, exist_ok=True)
        self.pvd_path = self.out_dir / f"{name}.pvd"
        self._entries: list[tuple[float, str]] = []
        if resume_after_time is not None:
            t_max = float(resume_after_time)
            if math.isnan(t_max):
                raise ParameterError("resume_after_time", "must be a number, got nan")
            if self.pvd_path.exists():
                self._entries = [(t, f) for t, f in read_pvd(self.pvd_path) if t <= t_max]
                if self._entries:
                    write_pvd(self.pvd_path, self._entries)
                else:  # every entry came after the checkpoint: no series yet
                    self.pvd_path.unlink()

    @property
    def entries(self) -> list[tuple[float, str]]:
        """``(time, file relative to out_dir)`` of every indexed snapshot, in write order."""
        return list(self._entries)

    def path_for(self, step: int) -> Path:
        return self.vtk_dir / f"{self.name}_{int(step):07d}.{self.extension}"

    def piece_for(self, step: int, rank: int) -> Path:
        """Rank ``rank``'s piece of snapshot ``step`` (a distributed run)."""
        return self.vtk_dir / f"{self.name}_{int(step):07d}_{int(rank):04d}.vtu"

    def record(self, step: int, time: float) -> tuple[Path, list[tuple[float, str]]]:
        """Enter snapshot ``step`` at simulation time ``time`` (s) in the index, without writing anything.

        Returns the VTU path to write and the index entries to write after it (in that order, so that
        the index never names a missing file). A step recorded again (after a resume) replaces its entry.
        """
        step = _check_step(step)
        time = float(time)
        if not math.isfinite(time):
            raise ParameterError("time", f"must be finite, got {time}")
        path = self.path_for(step)
        rel = path.relative_to(self.out_dir).as_posix()
        self._entries = [(t, f) for t, f in self._entries if f != rel]
        self._entries.append((time, rel))
        return path, list(self._entries)

    def write(self, step: int, time: float, points: np.ndarray, fields: dict[str, np.ndarray] | None = None,
              units: dict[str, str] | None = None) -> Path:
        """Write snapshot ``step`` at simulation time ``time`` (s) now and update the index; returns the VTU path."""
        path = write_vtu(self.path_for(_check_step(step)), points, fields, units)  # bad fields: nothing indexed
        _, entries = self.record(step, time)
        write_pvd(self.pvd_path, entries)
        return path

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"VtuSeries({str(self.out_dir)!r}, {self.name!r}, entries={len(self._entries)})"
