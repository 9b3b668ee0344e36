"""Solids on their true surfaces (warpfree/solvers/wcsph/solids.py): which side a particle is on and how deep, and the penalty
that keeps fluid out; 2D polygons (extruded prisms) and 3D meshes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.kernels.wcsph_solids import add_surface_penalty
from warpfree.solvers.wcsph.solids import Solids


@pytest.fixture(scope="module")
def launcher():
    L = Launcher("cpu", 2, min_items_per_thread=1)
    yield L
    L.close()


def points(p):
    p = np.asarray(p, dtype=np.float32)
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p), np.float32)])
    return wp.array(p, dtype=wp.vec3)


def test_container_and_obstacle_in_2d(launcher):
    box = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    hole = np.array([[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6]], float)
    s = Solids(launcher, 2, containers=[box], obstacles=[hole])
    got = s.penetration(points([[0.1, 0.1], [0.5, 0.5], [1.2, 0.5], [0.45, 0.5], [-0.3, 0.2]]))
    assert got.count == 4 and got.max_depth == pytest.approx(0.3, abs=1e-6) and got.first_index == 4
    assert got.where == "outside container 0"
    inside_hole = s.penetration(points([[0.5, 0.5], [0.2, 0.2]]))
    assert inside_hole.count == 1 and inside_hole.where == "inside obstacle 0"
    assert inside_hole.max_depth == pytest.approx(0.1, abs=1e-6)


def test_concave_container_2d(launcher):
    l_shape = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    got = Solids(launcher, 2, containers=[l_shape]).penetration(points([[1.5, 1.5], [0.5, 1.5], [1.5, 0.5],
                                                                         [1.1, 1.2]]))
    assert got.count == 2 and got.max_depth == pytest.approx(0.5, abs=1e-6)


def test_no_false_alarm_near_a_corner_of_a_small_elongated_tank(launcher):
    """A 5.7 cm column in a 15a x 2a tank: points almost equidistant from two sides (a tie within Warp's default
    tolerance, which once gave them the outside sign) are all inside."""
    a = 0.05715
    tank = np.array([[0, 0], [15 * a, 0], [15 * a, 2 * a], [0, 2 * a]])
    t = np.linspace(0.001, 0.099, 300)
    near_bisector = np.column_stack([t + 1e-4 * np.sin(50 * t), t])
    assert not Solids(launcher, 2, containers=[tank]).penetration(points(near_bisector))


def test_rotated_boxes_in_3d(launcher):
    tank = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    rock = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    for m in (tank, rock):
        m.apply_transform(trimesh.transformations.rotation_matrix(0.4, (1, 1, 0)))
    s = Solids(launcher, 3, containers=[tank], obstacles=[rock])
    rng = np.random.default_rng(3)
    p = rng.uniform(-0.8, 0.8, (3000, 3))
    got = s.penetration(points(p))
    # reference: trimesh's signed distance (> 0 inside)
    out_tank = np.maximum(-trimesh.proximity.signed_distance(tank, p), 0.0)
    in_rock = np.maximum(trimesh.proximity.signed_distance(rock, p), 0.0)
    depth = np.maximum(out_tank, in_rock)
    assert got.count == np.count_nonzero(depth > 1e-6) and got.max_depth == pytest.approx(depth.max(), abs=1e-5)


def test_penalty_pushes_back_within_its_reach_and_stays_in_the_plane(launcher):
    box = np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float)
    s = Solids(launcher, 2, containers=[box])
    pen = s.penalty(0.02, 62.6)
    x = points([[2.0, 0.01], [0.005, 2.0], [2.0, 0.03], [2.0, -0.001]])
    acc = wp.zeros(4, dtype=wp.vec3)
    launcher.launch(add_surface_penalty, 4, [pen, wp.array(np.ones(4, np.int32)), x, acc])
    a = acc.numpy()
    k = 62.6 ** 2 / 0.02 ** 2
    np.testing.assert_allclose(a[0], [0, k * 0.01, 0], rtol=1e-4)          # pushed up off the floor
    np.testing.assert_allclose(a[1], [k * 0.015, 0, 0], rtol=1e-4)         # pushed right off the left wall
    assert np.all(a[2] == 0)                                               # beyond its reach: nothing
    assert a[3, 1] == pytest.approx(k * 0.021, rel=1e-4)                   # through the floor: pushed back harder
    assert np.all(a[:, 2] == 0)                                            # exactly in the plane


def test_bad_solids_name_the_parameter(launcher):
    with pytest.raises(ParameterError, match="solids"):
        Solids(launcher, 2, containers=[np.zeros((2, 2))])
    with pytest.raises(ParameterError, match="solids"):
        Solids(launcher, 3, containers=[trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]])])
    with pytest.raises(ParameterError, match="dim"):
        Solids(launcher, 1)
