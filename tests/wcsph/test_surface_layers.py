"""Boundary particles from the true surface (warpfree/solvers/wcsph/surface_layers.py): every layer at its distance from the
surface whatever the orientation, no gaps, no two particles too close, a density of one per dx^dim."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from warpfree import device
from warpfree.errors import ParameterError
from warpfree.solvers.wcsph.surface_layers import surface_layers

DX = 0.05


def polygon_distance(poly: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance to the boundary, inside) of 2D points, float64 reference."""
    d2 = np.full(len(pts), np.inf)
    inside = np.zeros(len(pts), bool)
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        ab = b - a
        t = np.clip(((pts - a) @ ab) / (ab @ ab), 0.0, 1.0)
        d2 = np.minimum(d2, np.sum((pts - a - t[:, None] * ab) ** 2, axis=1))
        crosses = (a[1] > pts[:, 1]) != (b[1] > pts[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = a[0] + (pts[:, 1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        inside ^= crosses & (pts[:, 0] < x_at)
    return np.sqrt(d2), inside


def boundary_samples(poly: np.ndarray, spacing: float) -> np.ndarray:
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        n = int(np.ceil(np.linalg.norm(b - a) / spacing))
        out.append(a + np.linspace(0, 1, n, endpoint=False)[:, None] * (b - a))
    return np.vstack(out)


def check_layers_2d(poly, walls, side, layers):
    dist, inside = polygon_distance(poly, walls)
    assert np.all(inside == (side == "inside"))
    k = np.floor(dist / DX)                      # layer index from the distance
    assert np.all(np.abs(dist - (k + 0.5) * DX) <= 0.05 * DX + 1e-9) and k.max() == layers - 1
    assert cKDTree(walls).query(walls, k=2)[0][:, 1].min() >= 0.6 * DX - 1e-9
    first = walls[k == 0]
    gap = cKDTree(first).query(boundary_samples(poly, DX / 10))[0]
    assert gap.max() <= 0.75 * DX   # every boundary point within sqrt(1/4 + 1/4) dx = 0.71 dx of a first-layer particle
    return k


@pytest.fixture(autouse=True)
def _launcher():
    device.use("cpu", 2)


@pytest.mark.parametrize("angle", [0.0, 15.0, 30.0, 45.0])
@pytest.mark.parametrize("side", ["outside", "inside"])
def test_rotated_rectangle_layers(angle, side):
    th = np.radians(angle)
    rot = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    poly = np.array([[0, 0], [1, 0], [1, 0.5], [0, 0.5]], float) @ rot.T + [0.3, -0.2]
    walls = surface_layers(poly, DX, 3, side)
    k = check_layers_2d(poly, walls, side, 3)
    # one particle per dx² of wall: the layer's length (perimeter ± the corners' arcs or cuts) / dx
    for layer in range(3):
        d = (layer + 0.5) * DX
        length = 3.0 + (2 * np.pi * d if side == "outside" else -8 * d)
        assert abs(np.sum(k == layer) - length / DX) <= 0.06 * length / DX + 2


def test_concave_polygon_layers():
    """An L-shaped container: the reflex corner (the wall side closes in) trims the overlapping layers."""
    poly = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    for side in ("outside", "inside"):
        check_layers_2d(poly, surface_layers(poly, DX, 2, side), side, 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("side", ["outside", "inside"])
def test_rotated_box_layers_3d(seed, side):
    box = trimesh.creation.box(extents=(0.8, 0.5, 0.4))
    box.apply_transform(trimesh.transformations.compose_matrix(
        angles=Rotation.random(random_state=seed).as_euler("xyz"), translate=(0.1, -0.3, 0.2)))
    walls = surface_layers(box, DX, 2, side)
    signed = trimesh.proximity.signed_distance(box, walls)     # > 0 inside (trimesh's convention)
    dist = np.abs(signed)
    assert np.all((signed > 0) == (side == "inside"))
    k = np.floor(dist / DX)
    assert np.all(np.abs(dist - (k + 0.5) * DX) <= 0.05 * DX + 1e-9) and k.max() == 1
    assert cKDTree(walls).query(walls, k=2)[0][:, 1].min() >= 0.6 * DX - 1e-9
    # a surface point is at most half a cell diagonal across from a first-layer particle, which stands dx/2 off
    # the surface: sqrt(1/2 + 1/4) dx = 0.866 dx for a perfect grid of spacing dx
    surface = trimesh.sample.sample_surface_even(box, 4000, radius=DX / 8, seed=seed)[0]
    assert cKDTree(walls[k == 0]).query(surface)[0].max() <= 0.9 * DX
    # one particle per dx² of the layer's surface: at d = dx/2 outside a box of sides a, b, c that surface is
    # its area plus quarter cylinders along the edges and a sphere's worth of corners; inside, the shrunk box
    a, b, c, d = 0.8, 0.5, 0.4, 0.5 * DX
    if side == "outside":
        area = 2 * (a * b + b * c + a * c) + d * 4 * (a + b + c) * np.pi / 2 + 4 * np.pi * d * d
    else:
        area = 2 * ((a - 2 * d) * (b - 2 * d) + (b - 2 * d) * (c - 2 * d) + (a - 2 * d) * (c - 2 * d))
    assert abs(np.sum(k == 0) - area / DX ** 2) <= 0.06 * area / DX ** 2


def test_bad_input_names_the_parameter():
    poly = np.array([[0, 0], [1, 0], [1, 1]], float)
    with pytest.raises(ParameterError, match="layers"):
        surface_layers(poly, DX, 0, "outside")
    with pytest.raises(ParameterError, match="side"):
        surface_layers(poly, DX, 1, "above")
    with pytest.raises(ParameterError, match="dx"):
        surface_layers(poly, -1.0, 1, "outside")
    with pytest.raises(ParameterError, match="polygon"):
        surface_layers(np.zeros((2, 2)), DX, 1, "outside")
    with pytest.raises(ParameterError, match="mesh"):
        surface_layers(trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]]), DX, 1, "inside")
