"""Shapes and cell fractions (``warpfree.shapes``): distances against closed forms, the fraction of a square a
straight boundary cuts against exact polygon clipping, areas of discs, ellipses, curves and holed polygons from the
cell means, and bad shapes refused by name."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.geometry import clip_polygon, polygon_area
from warpfree.shapes import Disc, Ellipse, Interval, Polygon, cell_means, curve, half_plane_fraction


def lattice(spacing, half):
    k = np.arange(-half, half + 1)
    x, y = np.meshgrid(k * spacing, k * spacing, indexing="ij")
    return np.stack([x.ravel(), y.ravel()], axis=1)


def covered_area(shape, spacing, half, depth=4):
    centres = lattice(spacing, half)
    mean, _ = cell_means([shape], np.array([[1.0]]), centres, spacing, np.zeros((len(centres), 1)), depth=depth)
    return float(mean.sum()) * spacing ** 2


def test_half_plane_fraction_is_the_clipped_square_area():
    rng = np.random.default_rng(3)
    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    for _ in range(200):
        angle = rng.uniform(0.0, 2.0 * math.pi)
        n = np.array([math.cos(angle), math.sin(angle)])
        if rng.uniform() < 0.1:  # axis-aligned boundaries too
            n = np.array([1.0, 0.0]) if rng.uniform() < 0.5 else np.array([0.0, -1.0])
        d = rng.uniform(-0.75, 0.75)
        # inside: d + n·u < 0, i.e. n·u <= -d
        try:
            exact = polygon_area(clip_polygon(square, n, -d))
        except ParameterError:  # the half-plane leaves nothing
            exact = 0.0
        got = half_plane_fraction(np.array([d]), n[None, :], np.array([1.0]))[0]
        assert got == pytest.approx(exact, abs=1e-12)


def test_distances_against_closed_forms():
    disc = Disc((1.0, 2.0), 0.5)
    assert disc.signed_distance(np.array([[1.0, 2.0], [2.0, 2.0]])) == pytest.approx([-0.5, 0.5])
    square = Polygon([[0, 0], [1, 0], [1, 1], [0, 1]])
    assert square.signed_distance(np.array([[0.5, 0.5], [2.0, 0.5], [0.5, 0.9], [2.0, 2.0]])) == \
        pytest.approx([-0.5, 1.0, -0.1, math.sqrt(2.0)])
    ring = Polygon([[[-1, -1], [1, -1], [1, 1], [-1, 1]], [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]])
    assert ring.signed_distance(np.array([[0.0, 0.0], [0.75, 0.0]])) == pytest.approx([0.5, -0.25])
    line = Interval(0.2, 0.7)
    assert line.signed_distance(np.array([[0.0], [0.3], [1.0]])) == pytest.approx([0.2, -0.1, 0.3])
    ellipse = Ellipse((0.0, 0.0), (2.0, 1.0), angle=math.pi / 2)  # the long axis along y
    assert ellipse.signed_distance(np.array([[0.0, 2.0], [1.0, 0.0], [0.0, 0.0]])) == pytest.approx([0, 0, -1],
                                                                                                     abs=1e-12)
    assert ellipse.contains(np.array([[0.0, 1.9], [1.1, 0.0]])).tolist() == [True, False]


@pytest.mark.parametrize("spacing", [0.1, 0.05])
def test_cell_means_give_the_areas(spacing):
    """A disc, an ellipse, a parametric curve and a square with a hole: the covered area from the cells' means within
    2e-5 of the exact one (the pieces' half-planes at 1/16 of a cell; a staircase of the centres is off by 1e-2)."""
    half = int(round(1.2 / spacing))
    disc = Disc((0.013, 0.021), 0.777)
    assert covered_area(disc, spacing, half) == pytest.approx(math.pi * 0.777 ** 2, rel=2e-5)
    ellipse = Ellipse((0.01, -0.02), (0.9, 0.4), angle=0.3)
    assert covered_area(ellipse, spacing, half) == pytest.approx(math.pi * 0.36, rel=2e-5)
    flower = curve(lambda s: (0.6 + 0.2 * np.cos(6 * np.pi * s))[:, None]
                   * np.stack([np.cos(2 * np.pi * s), np.sin(2 * np.pi * s)], axis=1), tolerance=1e-7)
    assert covered_area(flower, spacing, half) == pytest.approx(math.pi * (0.36 + 0.02), rel=2e-5)
    holed = Polygon([[[-1, -1], [1, -1], [1, 1], [-1, 1]], [[-0.3, -0.4], [0.5, -0.4], [0.5, 0.3], [-0.3, 0.3]]])
    assert covered_area(holed, spacing, half) == pytest.approx(4.0 - 0.8 * 0.7, rel=2e-5)


def test_layering_and_one_dimension():
    """A later shape covers an earlier one; a 1D interval's cells are exact."""
    centres = lattice(0.1, 12)
    big, small = Disc((0, 0), 1.0), Disc((0, 0), 0.5)
    values = np.array([[1.0], [10.0]])
    mean, _ = cell_means([big, small], values, centres, 0.1, np.zeros((len(centres), 1)))
    assert float(mean.sum()) * 0.01 == pytest.approx(math.pi * (1.0 - 0.25) + 10.0 * math.pi * 0.25, rel=2e-5)
    x = (np.arange(-10, 11) * 0.1)[:, None]
    mean, normal = cell_means([Interval(-0.33, 0.47)], np.array([[2.0]]), x, 0.1, np.ones((21, 1)))
    assert float((mean[:, 0] - 1.0).sum()) * 0.1 == pytest.approx(0.8, abs=1e-12)
    assert mean[np.argmin(np.abs(x[:, 0] + 0.3)), 0] == pytest.approx(1.0 + 0.8)  # the cell [-0.35, -0.25]: 80 % in
    assert abs(normal[np.argmin(np.abs(x[:, 0] - 0.5)), 0]) == pytest.approx(1.0)


def test_bad_shapes_are_refused_by_name():
    with pytest.raises(ParameterError, match="disc.radius"):
        Disc((0, 0), -1.0)
    with pytest.raises(ParameterError, match="ellipse.semi_axes"):
        Ellipse((0, 0), (1.0, 0.0))
    with pytest.raises(ParameterError, match="polygon"):
        Polygon([[0, 0], [1, 1], [2, 2]])
    with pytest.raises(ParameterError, match="interval.upper"):
        Interval(1.0, 0.5)
    with pytest.raises(ParameterError, match="curve"):
        curve(lambda s: s, tolerance=1e-3)
