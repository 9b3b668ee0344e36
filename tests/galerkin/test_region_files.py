"""Regions read from files (``warpfree.galerkin.region_files``): a polygon-and-spline text file with tags, GeoJSON,
a gmsh mesh through meshio with its physical names (its chords read back as a spline within 1e-6 of the true hole),
a surface mesh's section; and files that are wrong, named with the place."""

from __future__ import annotations

import json
import math

import meshio
import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.galerkin.region import Region
from warpfree.galerkin.region_files import read_region


def test_a_text_file_with_tags_and_a_spline_loop(tmp_path):
    path = tmp_path / "cavity.txt"
    lines = ["# a cavity: its lid tagged, a spline hole", "0 0 wall", "1 0 wall", "1 1 lid", "0 1 wall", "",
             "spline hole"]
    lines += [f"{0.5 + 0.2 * math.cos(t)}, {0.5 + 0.2 * math.sin(t)}" for t in np.linspace(0, 2 * math.pi, 25)[:-1]]
    path.write_text("\n".join(lines) + "\n")
    region = read_region(str(path))
    assert region.tags == ["wall", "lid", "hole"]
    assert [p.tag for p in region.pieces][:4] == ["wall", "wall", "lid", "wall"]
    assert region.area == pytest.approx(1.0 - math.pi * 0.04, rel=2e-6)  # a periodic spline through 24 points
    bad = tmp_path / "bad.csv"
    bad.write_text("0, 0\n1, zero\n")
    with pytest.raises(ParameterError, match="bad.csv:2"):
        read_region(str(bad))


def test_geojson(tmp_path):
    path = tmp_path / "lake.geojson"
    ring = [[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]]
    island = [[1, 0.5], [1, 1.5], [2, 1.5], [2, 0.5], [1, 0.5]]
    path.write_text(json.dumps({"type": "Feature", "properties": {"tag": "shore"},
                                "geometry": {"type": "Polygon", "coordinates": [ring, island]}}))
    region = read_region(str(path))
    assert region.tags == ["shore"] and region.area == pytest.approx(5.0, rel=1e-14)


def test_a_gmsh_mesh_with_physical_names(tmp_path):
    """A plate with a circular hole meshed with triangles and tagged lines, written by meshio in gmsh's format: its
    region has the mesh's tags and area; read with splines, the hole's 32 chords give back its circle within 1e-6."""
    plate = (Region.rectangle((0.0, 0.0), (2.0, 1.0), ["bottom", "right", "top", "left"])
             - Region.disc((1.0, 0.5), 0.25, "hole"))
    nodes = plate.nodes(0.05)
    triangles = plate.triangles(nodes)
    names = list(dict.fromkeys(p.tag for p in plate.pieces))
    line_tag = np.array([names.index(plate.pieces[k].tag) + 1 for k in nodes.edge_piece])
    mesh = meshio.Mesh(np.c_[nodes.position, np.zeros(nodes.count)], [("triangle", triangles),
                                                                      ("line", nodes.edge_nodes)],
                       cell_data={"gmsh:physical": [np.full(len(triangles), 99), line_tag],
                                  "gmsh:geometrical": [np.zeros(len(triangles), int), line_tag]},
                       field_data={name: np.array([k + 1, 1]) for k, name in enumerate(names)})
    path = str(tmp_path / "plate.msh")
    meshio.write(path, mesh, file_format="gmsh22")
    chords = read_region(path)
    polygon_area = 2.0 - 0.5 * 32 * 0.25 ** 2 * math.sin(2 * math.pi / 32)
    assert chords.tags == names and chords.area == pytest.approx(polygon_area, rel=1e-12)
    assert len(chords.pieces) == 4 + 32  # the sides' collinear edges merged, the hole's chords kept
    smooth = read_region(path, curves="spline")
    assert len(smooth.pieces) == 5 and smooth.area == pytest.approx(plate.area, rel=1e-6)
    with pytest.raises(ParameterError, match="path"):
        read_region(str(tmp_path / "missing.msh"))


def test_a_surface_mesh_s_section(tmp_path):
    import trimesh

    path = str(tmp_path / "cylinder.stl")
    trimesh.creation.cylinder(radius=0.5, height=2.0, sections=64).export(path)
    region = read_region(path, tag="wall", plane_origin=(0.0, 0.0, 0.3))
    assert region.tags == ["wall"]
    # the 64-gon (an STL holds float32 vertices: its area to 1e-7)
    assert region.area == pytest.approx(0.5 * 64 * 0.25 * math.sin(2 * math.pi / 64), rel=1e-7)
    with pytest.raises(ParameterError, match="plane_origin"):
        read_region(path, plane_origin=(0.0, 0.0, 5.0))
