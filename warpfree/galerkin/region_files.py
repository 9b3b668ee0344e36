"""Regions from files (``warpfree.galerkin.region.Region``): polygon and spline files, GeoJSON, 2D meshes through
meshio (gmsh, VTU, Abaqus, ...) and a 3D surface mesh's section by a plane.

Formats, by the file's ending:

- ``.txt``, ``.csv``, ``.xy``, ``.dat``: one vertex a line, ``x y`` or ``x, y``, with an optional third field, the tag
  of the edge from this vertex to the next (else the ``tag`` given); a blank line ends a loop; a line ``spline`` (or
  ``spline TAG``) before a loop's vertices makes that loop the closed cubic spline through them; ``#`` starts a
  comment.
- ``.json`` / ``.geojson``: ``{"loops": [{"points": [[x, y], ...], "tags": [...] or "tag": "...", "spline": false}]}``,
  or GeoJSON (a ``Polygon``, ``MultiPolygon``, ``Feature`` or ``FeatureCollection``; a feature's ``properties.tag``
  tags its edges).
- ``.stl``, ``.obj``, ``.ply``, ``.off``, ``.glb``: a watertight surface mesh cut by the plane ``plane_origin``,
  ``plane_normal`` (``warpfree.geometry.mesh_section``).
- anything meshio reads (``.msh``, ``.vtu``, ``.vtk``, ``.inp``, ``.med``, ``.xdmf``, ...): a 2D mesh; the region is
  its cells' union, bounded by the edges of one cell only; an edge under a line cell with a gmsh physical name (or
  number) takes it as its tag.

A file's boundary is polygonal: consecutive edges in line (turning by under 1e-6 rad) with one tag merge into one
segment; with ``curves="spline"`` the runs of vertices between corners (a turn of more than ``corner_angle``
degrees, or a change of tag) become cubic splines through them, so that a circle a mesh approximates by chords is
read back as a smooth curve (its nodes then lie on the spline, not at the mesh's vertices).
"""

from __future__ import annotations

import json
import math
import os
from collections import defaultdict

import numpy as np

from warpfree.errors import ParameterError, require_positive

from .curves import Piece, Segment, SplineCurve
from .region import Region

__all__ = ["read_region", "CURVES"]

#: how a file's polygonal boundary is read: as its segments, or with splines between corners
CURVES = ("polygon", "spline")
_SURFACE = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf")
_TEXT = (".txt", ".csv", ".xy", ".dat")


def read_region(path: str, tag: str = "boundary", curves: str = "polygon", corner_angle: float = 20.0,
                plane_origin=(0.0, 0.0, 0.0), plane_normal=(0.0, 0.0, 1.0)) -> Region:
    """The region a file describes (module docstring); ``tag``: the tag of edges the file does not tag."""
    if curves not in CURVES:
        raise ParameterError("curves", f"must be one of {CURVES}, got {curves!r}")
    corner = math.radians(require_positive("corner_angle", corner_angle))
    if not os.path.isfile(path):
        raise ParameterError("path", f"no file at {path!r}")
    ext = os.path.splitext(path)[1].lower()
    if ext in _TEXT:
        loops = _text_loops(path, tag)
    elif ext in (".json", ".geojson"):
        loops = _json_loops(path, tag)
    elif ext in _SURFACE:
        from warpfree.geometry import load_mesh, mesh_section

        loops = [(np.asarray(p, dtype=np.float64), [tag] * len(p), False)
                 for p in mesh_section(load_mesh(path), plane_origin, plane_normal)]
        if not loops:
            raise ParameterError("plane_origin", f"the plane misses the mesh of {path!r}: its section is empty")
    else:
        loops = _mesh_loops(path, tag)
    return Region([_pieces(points, tags, spline, curves, corner) for points, tags, spline in loops])


# -- readers: each gives loops (vertices (m, 2), a tag per edge from vertex k to k + 1, a spline?) ------------------
def _text_loops(path: str, tag: str) -> list:
    loops, points, tags, spline_tag = [], [], [], None

    def close():
        nonlocal points, tags, spline_tag
        if points:
            p = np.array(points, dtype=np.float64)
            loops.append((p, [spline_tag] * len(p) if spline_tag is not None else tags, spline_tag is not None))
        points, tags, spline_tag = [], [], None

    with open(path, encoding="utf-8") as f:
        for number, raw in enumerate(f, 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                close()
                continue
            fields = line.replace(",", " ").split()
            if fields[0].lower() == "spline":
                close()
                spline_tag = fields[1] if len(fields) > 1 else tag
                continue
            try:
                x, y = float(fields[0]), float(fields[1])
            except (ValueError, IndexError):
                raise ParameterError("path", f"{path}:{number}: expected 'x y [tag]', got {raw.strip()!r}") from None
            points.append((x, y))
            tags.append(fields[2] if len(fields) > 2 else tag)
    close()
    if not loops:
        raise ParameterError("path", f"{path} holds no vertices")
    return loops


def _json_loops(path: str, tag: str) -> list:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except json.JSONDecodeError as exc:
        raise ParameterError("path", f"{path} is not JSON: {exc}") from None
    out = []
    if isinstance(data, dict) and "loops" in data:
        for k, loop in enumerate(data["loops"]):
            points = np.asarray(loop.get("points"), dtype=np.float64)
            tags = loop.get("tags", [loop.get("tag", tag)] * len(points))
            if len(tags) != len(points):
                raise ParameterError("path", f"{path}: loop {k} has {len(points)} points and {len(tags)} tags")
            out.append((points, [str(t) for t in tags], bool(loop.get("spline", False))))
        return out
    features = data.get("features", [data]) if isinstance(data, dict) else []
    for feature in features:
        geometry = feature.get("geometry", feature)
        feature_tag = str((feature.get("properties") or {}).get("tag", tag))
        kind, coordinates = geometry.get("type"), geometry.get("coordinates")
        polygons = [coordinates] if kind == "Polygon" else coordinates if kind == "MultiPolygon" else None
        if polygons is None:
            raise ParameterError("path", f"{path}: a GeoJSON region is a Polygon or MultiPolygon, got {kind!r}")
        for polygon in polygons:
            for ring in polygon:
                p = np.asarray(ring, dtype=np.float64)[:, :2]
                if len(p) > 1 and np.allclose(p[0], p[-1]):
                    p = p[:-1]
                out.append((p, [feature_tag] * len(p), False))
    if not out:
        raise ParameterError("path", f"{path} holds no loops")
    return out


def _mesh_loops(path: str, tag: str) -> list:
    import meshio

    try:
        mesh = meshio.read(path)
    except Exception as exc:  # meshio's own errors name the format problem
        raise ParameterError("path", f"{path} cannot be read as a mesh: {type(exc).__name__}: {exc}") from None
    x = np.asarray(mesh.points, dtype=np.float64)
    if x.shape[1] > 2 and np.ptp(x[:, 2]) > 1e-9 * max(np.ptp(x[:, :2]), 1e-300):
        raise ParameterError("path", f"{path} is not a plane mesh (its z varies); a surface mesh's section needs an "
                                     "STL, OBJ or PLY file and plane_origin, plane_normal")
    x = x[:, :2]
    corners = {"triangle": 3, "triangle6": 3, "triangle7": 3, "quad": 4, "quad8": 4, "quad9": 4, "polygon": None}
    uses = defaultdict(int)
    for block in mesh.cells:
        if block.type in corners:
            n = corners[block.type] or block.data.shape[1]
            for cell in block.data[:, :n]:
                for a, b in zip(cell, np.roll(cell, -1)):
                    uses[(min(a, b), max(a, b))] += 1
    if not uses:
        raise ParameterError("path", f"{path} holds no 2D cells (triangles, quadrilaterals, polygons)")
    boundary = [e for e, n in uses.items() if n == 1]
    names = {int(v[0]): k for k, v in (mesh.field_data or {}).items()}
    edge_tag = {}
    physical = mesh.cell_data.get("gmsh:physical")
    for k, block in enumerate(mesh.cells):
        if block.type.startswith("line") and physical is not None:
            for (a, b), p in zip(block.data[:, :2], physical[k]):
                edge_tag[(min(a, b), max(a, b))] = names.get(int(p), str(int(p)))
    # chain the boundary edges into loops, each following its cells' orientation
    directed = {}
    for block in mesh.cells:
        if block.type in corners:
            n = corners[block.type] or block.data.shape[1]
            for cell in block.data[:, :n]:
                for a, b in zip(cell, np.roll(cell, -1)):
                    if uses[(min(a, b), max(a, b))] == 1:
                        directed[int(a)] = int(b)
    out, left = [], set(directed)
    while left:
        start = min(left)
        loop, k = [start], directed[start]
        left.discard(start)
        while k != start:
            if k not in left:
                raise ParameterError("path", f"{path}: the mesh's boundary does not close at vertex {k} (a vertex "
                                             "where two boundary loops touch)")
            loop.append(k)
            left.discard(k)
            k = directed[k]
        tags = [edge_tag.get((min(a, b), max(a, b)), tag) for a, b in zip(loop, loop[1:] + loop[:1])]
        out.append((x[loop], tags, False))
    return out


# -- vertices to pieces ---------------------------------------------------------------------------------------------
def _pieces(points: np.ndarray, tags: list[str], spline: bool, curves: str, corner: float) -> list[Piece]:
    """A loop of vertices as pieces: a closed spline; or segments, consecutive ones in line with one tag merged; or,
    with ``curves="spline"``, splines through the runs between corners and tag changes."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3 or not np.all(np.isfinite(p)):
        raise ParameterError("path", f"a loop needs at least 3 finite (x, y) vertices, got shape {p.shape}")
    if spline:
        curve = SplineCurve(p, closed=True)
        return [Piece(curve, 0.0, curve.t_range[1], tags[0])]
    m = len(p)
    incoming = p - np.roll(p, 1, axis=0)
    outgoing = np.roll(p, -1, axis=0) - p
    turn = np.abs(np.arctan2(incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0],
                             np.einsum("ij,ij->i", incoming, outgoing)))
    tag_change = np.array([tags[k] != tags[k - 1] for k in range(m)])
    limit = corner if curves == "spline" else 1e-6
    breaks = np.flatnonzero((turn > limit) | tag_change)
    if breaks.size == 0:
        if curves == "spline":
            curve = SplineCurve(p, closed=True)
            return [Piece(curve, 0.0, curve.t_range[1], tags[0])]
        breaks = np.array([0])
    pieces = []
    for i, start in enumerate(breaks):
        stop = breaks[(i + 1) % len(breaks)]
        run = [(start + k) % m for k in range(((stop - start) % m) or m)] + [stop]
        vertices = p[run]
        if curves == "spline" and len(vertices) > 2:
            curve = SplineCurve(vertices, closed=False)
            pieces.append(Piece(curve, 0.0, curve.t_range[1], tags[start]))
        else:
            pieces += [Piece(Segment(a, b), 0.0, 1.0, tags[start]) for a, b in
                       ([(vertices[0], vertices[-1])] if curves == "polygon" else zip(vertices[:-1], vertices[1:]))]
    return pieces
