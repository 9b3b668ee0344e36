"""Particle generators and boundary samplers (warpfree/geometry.py) against analytic counts and sets.

Boxes and squares are checked point by point against sets computed independently with NumPy
(analytic distance to an axis-aligned box), the sphere against its volume.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import trimesh

from warpfree import geometry as geo
from warpfree.errors import ParameterError


def as_set(points, dx):
    """Points as a set of integer-ish tuples in units of dx/2 (lattice points are odd multiples)."""
    return set(map(tuple, np.rint(np.asarray(points) / (0.5 * dx)).astype(np.int64).tolist()))


def box_distance(p, lo, hi):
    """Analytic distance from outside points to an axis-aligned box (0 inside)."""
    return np.linalg.norm(np.maximum(np.maximum(lo - p, 0.0), p - hi), axis=1)


def raises(name):
    """pytest.raises for a ParameterError naming ``name``."""
    return pytest.raises(ParameterError, match=rf"^{name}:")


LO3, HI3 = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.6, 0.6])


# ------------------------------------------------------------------------------------------ lattices


@pytest.mark.parametrize("lo,hi,dx", [((0, 0, 0), (1.0, 0.6, 0.3), 0.1), ((-1, 2), (1.0, 2.6), 0.05),
                                      ((0.1, 0.2, 0.3), (0.4, 0.5, 0.6), 0.01)])
def test_lattice_box_counts_and_centres(lo, hi, dx):
    p = geo.lattice_box(lo, hi, dx)
    lo, hi = np.array(lo, float), np.array(hi, float)
    n = np.rint((hi - lo) / dx).astype(int)
    assert p.dtype == np.float64 and p.shape == (np.prod(n), len(lo))
    k = (p - lo) / dx - 0.5  # integer cell indices
    assert np.allclose(k, np.rint(k), atol=1e-9)
    assert np.all(p > lo) and np.all(p < hi)
    assert np.allclose(p.min(0), lo + 0.5 * dx) and np.allclose(p.max(0), hi - 0.5 * dx)
    assert len(as_set(p, dx)) == len(p)


def test_lattice_box_whole_cells_only():
    assert len(geo.lattice_box((0, 0), (1.05, 0.5), 0.1)) == 10 * 5


def test_jittered_lattice_bounds_and_seed():
    lo, hi, dx, a = (0, 0, 0), (1, 0.5, 0.5), 0.05, 0.3
    base = geo.lattice_box(lo, hi, dx)
    p = geo.jittered_lattice(lo, hi, dx, a, seed=3)
    assert p.shape == base.shape
    off = np.abs(p - base)
    assert off.max() <= a * dx and off.max() > 0.8 * a * dx
    assert np.all(p > 0) and np.all(p < np.array(hi))
    assert np.array_equal(p, geo.jittered_lattice(lo, hi, dx, a, seed=3))
    assert not np.array_equal(p, geo.jittered_lattice(lo, hi, dx, a, seed=4))
    assert np.array_equal(geo.jittered_lattice(lo, hi, dx, 0.0), base)


# ------------------------------------------------------------------------------------------ 3D fill


def test_fill_mesh_sphere_volume():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    dx = 0.05
    p = geo.fill_mesh(sphere, dx)
    assert p.shape[1] == 3
    assert abs(len(p) * dx**3 / sphere.volume - 1.0) < 0.03
    assert np.linalg.norm(p, axis=1).max() < 1.0
    assert sphere.contains(p[::200]).all()


def test_fill_mesh_box_matches_lattice_box():
    dx = 0.05
    p = geo.fill_mesh(geo.box_mesh(LO3, HI3), dx, origin=LO3)
    assert as_set(p, dx) == as_set(geo.lattice_box(LO3, HI3, dx), dx)


def test_fill_mesh_points_on_faces_are_not_inside():
    box = geo.box_mesh((0, 0, 0), (1, 1, 1))
    p = geo.fill_mesh(box, 0.1, origin=(-0.05, -0.05, -0.05))  # lattice points at 0, 0.1, ..., 1
    assert len(p) == 9**3
    assert np.allclose(p.min(0), 0.1) and np.allclose(p.max(0), 0.9)


def test_fill_mesh_nonconvex_matches_contains():
    ring = trimesh.creation.annulus(r_min=0.3, r_max=1.0, height=0.5, sections=24)
    dx = 0.1
    p = geo.fill_mesh(ring, dx)
    kmin, kmax = geo._index_range(*ring.bounds, ring.bounds[0], dx)
    block = geo._lattice(ring.bounds[0], dx, kmin, tuple(kmax - kmin + 1))
    assert as_set(p, dx) == as_set(block[ring.contains(block)], dx)


def test_fill_mesh_200k_candidates_fast():
    sphere = trimesh.creation.icosphere(subdivisions=4)
    t = time.perf_counter()
    p = geo.fill_mesh(sphere, 2.0 / 58)  # 58^3 = 195k candidates
    assert time.perf_counter() - t < 3.0
    assert len(p) > 95_000


# ------------------------------------------------------------------------------------------ 3D shells


def analytic_box_shell(lo, hi, dx, layers, side):
    """Lattice points (origin lo) in the shell of a box, from the analytic box distance."""
    r = layers * dx
    n = np.rint((hi - lo) / dx).astype(int)
    axes = [lo[a] + (np.arange(-layers - 1, n[a] + layers + 1) + 0.5) * dx for a in range(3)]
    p = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    outside = np.any((p < lo) | (p > hi), axis=1)
    if side == "outside":
        return p[outside & (box_distance(p, lo, hi) <= r)]
    depth = np.minimum(p - lo, hi - p).min(axis=1)
    return p[~outside & (depth <= r)]


@pytest.mark.parametrize("side", ["outside", "inside"])
def test_shell_lattice_box_matches_analytic(side):
    dx, layers = 0.05, 3
    box = geo.box_mesh(LO3, HI3)
    p = geo.shell_lattice(box, dx, layers, side, origin=LO3)
    ref = analytic_box_shell(LO3, HI3, dx, layers, side)
    assert len(p) == len(ref)
    assert as_set(p, dx) == as_set(ref, dx)
    outside = np.any((p < LO3) | (p > HI3), axis=1)
    if side == "outside":
        assert outside.all()
        assert box_distance(p, LO3, HI3).max() <= layers * dx + 1e-12
    else:
        assert not outside.any()


def test_shell_and_fill_partition_the_lattice():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    dx = 0.1
    fill = as_set(geo.fill_mesh(sphere, dx), dx)
    shell_out = geo.shell_lattice(sphere, dx, 2, "outside")
    shell_in = as_set(geo.shell_lattice(sphere, dx, 2, "inside"), dx)
    assert not fill & as_set(shell_out, dx)
    assert shell_in <= fill
    r = np.linalg.norm(shell_out, axis=1)
    assert r.min() > 0.98 and r.max() <= 1.0 + 2 * dx + 1e-9


def test_shell_lattice_nonconvex_matches_trimesh():
    ring = trimesh.creation.annulus(r_min=0.3, r_max=1.0, height=0.5, sections=16)
    dx, layers = 0.1, 2
    p = geo.shell_lattice(ring, dx, layers, "outside")
    o = ring.bounds[0]
    kmin, kmax = geo._index_range(ring.bounds[0] - layers * dx, ring.bounds[1] + layers * dx, o, dx)
    block = geo._lattice(o, dx, kmin, tuple(kmax - kmin + 1))
    sd = trimesh.proximity.signed_distance(ring, block)  # > 0 inside
    ref = block[(sd <= 0) & (-sd <= layers * dx)]
    assert as_set(p, dx) == as_set(ref, dx)


def test_shell_lattice_big_box_is_fast():
    t = time.perf_counter()
    p = geo.shell_lattice(geo.box_mesh(LO3, HI3), 0.01, 3, "outside", origin=LO3)
    assert time.perf_counter() - t < 15.0
    assert len(p) > 100 * 60 * 3 * 2


# ------------------------------------------------------------------------------------------ surface


def test_sample_surface_spacing_and_normals():
    box = geo.box_mesh(LO3, HI3)
    dx = 0.03
    p, n = geo.sample_surface(box, dx, seed=1)
    assert p.shape == n.shape and p.shape[1] == 3
    assert abs(len(p) / (box.area / dx**2) - 1.0) < 0.1
    from scipy.spatial import cKDTree

    d, _ = cKDTree(p).query(p, k=2)
    assert d[:, 1].min() >= 0.7 * dx and d[:, 1].max() < 2.0 * dx
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert box_distance(p, LO3, HI3).max() < 1e-9  # on the surface
    on_face = np.isclose(p, LO3) | np.isclose(p, HI3)
    assert on_face.any(axis=1).all()
    assert np.all(np.einsum("ij,ij->i", p - box.centroid, n) > 0)  # outward
    q, _ = geo.sample_surface(box, dx, seed=1)
    assert np.array_equal(p, q)


# ------------------------------------------------------------------------------------------ 2D


SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


@pytest.mark.parametrize("orientation", [1, -1])
def test_polygon_layers_square_outside(orientation):
    dx, layers = 0.1, 3
    p = geo.polygon_boundary_layers(SQUARE[::orientation], dx, layers, "outside")
    # 4 edge strips of 10 x 3 plus 4 corner blocks of 3 x 3 minus the cell beyond radius 3 dx
    corner = sum((i + 0.5) ** 2 + (j + 0.5) ** 2 <= layers**2 for i in range(layers) for j in range(layers))
    assert corner == 8
    assert len(p) == 4 * 10 * layers + 4 * corner
    s = as_set(p, dx)
    for c in [(-0.05, -0.05), (1.05, -0.05), (1.05, 1.05), (-0.05, 1.05), (1.25, 1.15)]:
        assert as_set([c], dx) <= s
    assert not np.any(np.all((p > 0) & (p < 1), axis=1))
    # the same set from the analytic box distance on the same lattice
    g = (np.arange(-5, 15) + 0.5) * dx
    grid = np.stack([a.ravel() for a in np.meshgrid(g, g, indexing="ij")], axis=1)
    d = np.linalg.norm(np.maximum(np.maximum(-grid, 0), grid - 1), axis=1)
    assert s == as_set(grid[(d > 0) & (d <= layers * dx)], dx)


def test_polygon_layers_square_inside_and_fill():
    dx = 0.1
    inner = geo.polygon_boundary_layers(SQUARE, dx, 3, "inside")
    assert len(inner) == 100 - 16
    fill = geo.fill_polygon(SQUARE[::-1], dx)
    assert as_set(fill, dx) == as_set(geo.lattice_box((0, 0), (1, 1), dx), dx)
    assert as_set(inner, dx) <= as_set(fill, dx)


def test_polygon_lattice_alignment_with_origin():
    dx = 0.1
    tri = np.array([[0.03, 0.0], [1.0, 0.02], [0.5, 0.9]])
    origin = (0.0, 0.0)
    fill = geo.fill_polygon(tri, dx, origin=origin)
    walls = geo.polygon_boundary_layers(tri, dx, 2, "outside", origin=origin)
    k = np.concatenate([fill, walls]) / dx - 0.5
    assert np.allclose(k, np.rint(k), atol=1e-9)
    assert not as_set(fill, dx) & as_set(walls, dx)
    area = abs(geo._signed_area(tri))
    assert abs(len(fill) * dx**2 / area - 1) < 0.1


def test_fill_polygon_nonconvex():
    ell = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    p = geo.fill_polygon(ell, 0.1)
    assert len(p) == 300
    assert not np.any((p[:, 0] > 1) & (p[:, 1] > 1))


# ------------------------------------------------------------------------------------------ sections, io


def test_mesh_section_box_world_xy():
    polys = geo.mesh_section(geo.box_mesh(LO3, HI3), (0.2, 0.1, 0.3), (0, 0, 1))
    assert len(polys) == 1
    q = polys[0]
    assert q.shape == (4, 2)
    rect = {(0.0, 0.0), (1.0, 0.0), (1.0, 0.6), (0.0, 0.6)}
    assert {tuple(np.round(v, 12)) for v in q} == rect
    assert geo._signed_area(q) == pytest.approx(0.6)


def test_mesh_section_other_axes():
    box = geo.box_mesh((0, 0, 0), (1, 2, 3))
    (yz,) = geo.mesh_section(box, (0.5, 0, 0), (1, 0, 0))
    assert np.allclose(yz.min(0), [0, 0]) and np.allclose(yz.max(0), [2, 3])
    (zx,) = geo.mesh_section(box, (0, 1, 0), (0, 1, 0))
    assert np.allclose(zx.min(0), [0, 0]) and np.allclose(zx.max(0), [3, 1])
    assert geo.mesh_section(box, (0, 0, 5), (0, 0, 1)) == []


def test_mesh_section_sphere_circle():
    sphere = trimesh.creation.icosphere(subdivisions=4)
    (c,) = geo.mesh_section(sphere, (0, 0, 0.5), (0, 0, 1))
    r = np.linalg.norm(c, axis=1)
    assert r.max() <= np.sqrt(0.75) + 1e-9 and r.min() > 0.97 * np.sqrt(0.75)
    sq = geo.fill_polygon(c, 0.05)
    assert abs(len(sq) * 0.05**2 / (np.pi * 0.75) - 1) < 0.05


def test_load_mesh(tmp_path):
    box = geo.box_mesh(LO3, HI3)
    path = tmp_path / "box.stl"
    box.export(path)
    loaded = geo.load_mesh(path)
    assert loaded.is_watertight and loaded.volume == pytest.approx(0.36)
    assert geo.load_mesh(str(path)).faces.shape == (12, 3)
    assert geo.load_mesh(box) is box
    with raises("mesh"):
        geo.load_mesh(tmp_path / "missing.stl")
    with raises("mesh"):
        geo.load_mesh(trimesh.Trimesh())
    with raises("mesh"):
        geo.load_mesh(42)


# ------------------------------------------------------------------------------------------ errors


@pytest.mark.parametrize("dx", [0, -0.1, np.nan, np.inf, "a"])
def test_bad_dx(dx):
    with raises("dx"):
        geo.lattice_box((0, 0), (1, 1), dx)
    with raises("dx"):
        geo.fill_mesh(geo.box_mesh(LO3, HI3), dx)
    with raises("dx"):
        geo.fill_polygon(SQUARE, dx)


def test_bad_boxes():
    with raises("hi"):
        geo.lattice_box((0, 0), (1, 0), 0.1)
    with raises("hi"):
        geo.lattice_box((0, 0, 0), (1, 1, 0.05), 0.1)  # thinner than dx
    with raises("hi"):
        geo.lattice_box((0, 0, 0), (1, 1), 0.1)
    with raises("lo"):
        geo.lattice_box((0,), (1,), 0.1)
    with raises("lo"):
        geo.lattice_box((0, np.nan), (1, 1), 0.1)
    with raises("lo"):
        geo.box_mesh((0, 0), (1, 1))


@pytest.mark.parametrize("amplitude", [0.5, 0.7, -0.1, np.nan])
def test_bad_amplitude(amplitude):
    with raises("amplitude"):
        geo.jittered_lattice((0, 0), (1, 1), 0.1, amplitude)


def test_bad_meshes():
    open_box = geo.box_mesh(LO3, HI3)
    open_box = trimesh.Trimesh(open_box.vertices, open_box.faces[:-1])
    with pytest.raises(ParameterError, match="mesh: is not watertight"):
        geo.fill_mesh(open_box, 0.1)
    with raises("mesh"):
        geo.shell_lattice(open_box, 0.1, 2, "outside")
    with raises("mesh"):
        geo.fill_mesh("box.stl", 0.1)
    geo.sample_surface(open_box, 0.1)  # surface sampling does not need a closed mesh


def test_bad_shell_parameters():
    box = geo.box_mesh(LO3, HI3)
    with raises("layers"):
        geo.shell_lattice(box, 0.1, 0, "outside")
    with raises("layers"):
        geo.polygon_boundary_layers(SQUARE, 0.1, 1.5, "outside")
    with raises("side"):
        geo.shell_lattice(box, 0.1, 2, "above")
    with raises("origin"):
        geo.shell_lattice(box, 0.1, 2, "inside", origin=(0, 0))
    with raises("polygon"):
        geo.fill_polygon([[0, 0], [1, 1]], 0.1)
    with raises("polygon"):
        geo.fill_polygon([[0, 0], [1, 1], [2, 2]], 0.1)  # zero area
    with raises("plane_normal"):
        geo.mesh_section(box, (0, 0, 0.3), (0, 0, 0))


def test_2d_walls_from_a_mesh_section_match_the_polygon_walls():
    """A 2D boundary from the section of a 3D tank mesh equals the one from the same rectangle."""
    from warpfree.geometry import box_mesh
    from warpfree.solvers.wcsph.scene_tools import box_walls_2d, walls_from_section

    mesh = box_mesh((0.0, 0.0, -0.5), (4.0, 4.0, 0.5))
    from_mesh, polygons = walls_from_section(mesh, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.1, 3)
    assert len(polygons) == 1
    from_box = box_walls_2d(4.0, 4.0, 0.1, 3)
    key = lambda p: np.round(p, 6)[np.lexsort(np.round(p, 6).T)]
    assert from_mesh.shape == from_box.shape
    np.testing.assert_allclose(key(from_mesh), key(from_box), atol=1e-9)


def test_fill_mesh_clearance_keeps_half_a_spacing_from_the_walls():
    """dx = 0.06 does not divide a 1 m box: without clearance a lattice row sits 0.01 m from a wall;
    with clearance dx/2 every point is >= dx/2 from the faces, and a commensurate lattice is unchanged."""
    from warpfree.geometry import box_mesh, fill_mesh

    box = box_mesh((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    raw = fill_mesh(box, 0.06)
    kept = fill_mesh(box, 0.06, clearance=0.03)
    face_dist = lambda p: np.minimum(p, 1.0 - p).min(axis=1)
    assert face_dist(raw).min() < 0.011
    assert face_dist(kept).min() >= 0.03 - 1e-9 and len(kept) == 16 ** 3
    assert len(fill_mesh(box, 0.05, clearance=0.025)) == len(fill_mesh(box, 0.05)) == 20 ** 3


def test_fill_mesh_box_divides_the_box_exactly_inside_the_mesh():
    """Cells of round((hi - lo)/dx) per axis fill the box: their centres half a cell from its faces, all inside the
    mesh, as many as the cells, and their volumes add up to the box's (the part of a larger mesh it cuts)."""
    from warpfree.geometry import box_mesh, fill_mesh_box

    tank = box_mesh((0.0, 0.0, 0.0), (2.0, 1.0, 1.0))
    lo, hi = np.array([0.77, 0.0, 0.0]), np.array([2.0, 1.0, 0.55])
    points, cell = fill_mesh_box(tank, lo, hi, 0.1)
    counts = np.round((hi - lo) / 0.1)
    assert np.allclose(cell, (hi - lo) / counts) and len(points) == int(np.prod(counts))
    assert np.isclose(len(points) * np.prod(cell), np.prod(hi - lo))
    assert np.allclose(points.min(axis=0), lo + 0.5 * cell) and np.allclose(points.max(axis=0), hi - 0.5 * cell)

