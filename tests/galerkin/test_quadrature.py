"""Background quadrature for EFG/NEM (warpfree.galerkin.quadrature): exactness, areas, lengths, normals, checks."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.galerkin.quadrature import (TRIANGLE_DEGREES, annulus_cells, arc_points, gauss_legendre,
                                             polyline_points, quadrilateral_cells, rectangle_cells, segment_points,
                                             structured_quadrilateral, triangle_cells, triangle_rule)

COOK = np.array([[0.0, 0.0], [48.0, 44.0], [48.0, 60.0], [0.0, 44.0]])
TRIANGLE = np.array([[0.2, 0.1], [1.5, 0.4], [0.6, 1.3]])


# --- exact references ----------------------------------------------------------------------------------------


def rectangle_monomial(lower, upper, a: int, b: int) -> float:
    """∫∫ x^a y^b over [lower, upper]."""
    along_x = (upper[0] ** (a + 1) - lower[0] ** (a + 1)) / (a + 1)
    return along_x * (upper[1] ** (b + 1) - lower[1] ** (b + 1)) / (b + 1)


def triangle_monomial(vertices, a: int, b: int) -> float:
    """∫ x^a y^b over a triangle, exactly (fractions): x, y expanded in barycentric coordinates, then
    ∫ λ1^i λ2^j λ3^k dA = 2 A i! j! k! / (i + j + k + 2)!."""
    v = [[Fraction(float(c)) for c in row] for row in vertices]
    poly = {(0, 0, 0): Fraction(1)}
    for axis, power in ((0, a), (1, b)):
        for _ in range(power):
            grown: dict = {}
            for exps, coef in poly.items():
                for k in range(3):
                    e = list(exps)
                    e[k] += 1
                    grown[tuple(e)] = grown.get(tuple(e), 0) + coef * v[k][axis]
            poly = grown
    area = abs((v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0])) / 2
    f = math.factorial
    total = sum(coef * 2 * area * f(i) * f(j) * f(k) / Fraction(f(i + j + k + 2)) for (i, j, k), coef in poly.items())
    return float(total)


def polygon_moments(vertices) -> tuple[float, float, float]:
    """Area, ∫x dA, ∫y dA of a counter-clockwise polygon (shoelace and its first moments)."""
    x, y = vertices[:, 0], vertices[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    return cross.sum() / 2, ((x + xn) * cross).sum() / 6, ((y + yn) * cross).sum() / 6


def relative_error(value: float, exact: float) -> float:
    return abs(value - exact) / abs(exact)


# --- Gauss-Legendre and rectangles ---------------------------------------------------------------------------


@pytest.mark.parametrize("order", [1, 2, 3, 5])
def test_gauss_legendre_exact_to_degree_2n_minus_1(order):
    g, w = gauss_legendre(order)
    assert g.shape == w.shape == (order,)
    for k in range(2 * order):
        exact = (1 - (-1) ** (k + 1)) / (k + 1)
        assert abs(np.sum(w * g ** k) - exact) < 1e-14
    assert abs(np.sum(w * g ** (2 * order)) - 2 / (2 * order + 1)) > 1e-6


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_rectangle_cells_integrate_monomials_up_to_degree_2n_minus_1_per_axis(order):
    lower, upper = (0.25, 0.5), (1.75, 2.0)
    q = rectangle_cells(lower, upper, (2, 3), order)
    for a in range(2 * order):
        for b in range(2 * order):
            value = np.sum(q.weight * q.position[:, 0] ** a * q.position[:, 1] ** b)
            assert relative_error(value, rectangle_monomial(lower, upper, a, b)) < 1e-13, (a, b)
    top = 2 * order
    value = np.sum(q.weight * q.position[:, 0] ** top)
    assert relative_error(value, rectangle_monomial(lower, upper, top, 0)) > 1e-10  # one degree above fails


def test_rectangle_cells_layout_weights_and_cell_index():
    lower, upper, nx, ny, order = np.array([-1.0, 2.0]), np.array([3.0, 3.5]), 4, 3, 3
    q = rectangle_cells(lower, upper, (nx, ny), order)
    assert q.position.shape == (nx * ny * order ** 2, 2) and q.cell.dtype == np.int64
    assert abs(q.weight.sum() - 4.0 * 1.5) < 1e-13
    assert np.all(q.weight > 0)
    assert np.array_equal(np.bincount(q.cell), np.full(nx * ny, order ** 2))
    h = (upper - lower) / (nx, ny)
    ix, iy = np.floor((q.position - lower) / h).T.astype(int)
    assert np.array_equal(ix + nx * iy, q.cell)  # cell = ix + nx·iy, and every point lies in its cell


# --- triangles -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("degree", TRIANGLE_DEGREES)
def test_triangle_rule_is_exact_to_its_degree_and_not_above(degree):
    bary, w = triangle_rule(degree)
    assert np.all(w > 0) and abs(w.sum() - 1) < 1e-15
    assert np.all(bary >= 0) and np.allclose(bary.sum(axis=1), 1, atol=1e-15)
    q = triangle_cells(TRIANGLE, np.array([[0, 1, 2]]), degree)
    x, y = q.position.T
    for total in range(degree + 1):
        for a in range(total + 1):
            value = np.sum(q.weight * x ** a * y ** (total - a))
            assert relative_error(value, triangle_monomial(TRIANGLE, a, total - a)) < 1e-13, (a, total - a)
    above = max(relative_error(np.sum(q.weight * x ** a * y ** (degree + 1 - a)),
                               triangle_monomial(TRIANGLE, a, degree + 1 - a)) for a in range(degree + 2))
    assert above > 1e-8  # one degree above is not exact


def test_triangle_rule_point_counts():
    assert [len(triangle_rule(d)[1]) for d in TRIANGLE_DEGREES] == [1, 3, 6, 6, 7]


def test_triangle_cells_on_a_mesh_either_orientation():
    points = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    q = triangle_cells(points, np.array([[0, 1, 2], [0, 3, 2]]), 2)  # second triangle clockwise
    assert abs(q.weight.sum() - 2.0) < 1e-14 and np.all(q.weight > 0)
    assert abs(np.sum(q.weight * q.position[:, 0] * q.position[:, 1]) - 1.0) < 1e-13  # ∫xy = (2²/2)(1²/2)
    assert np.array_equal(q.cell, [0, 0, 0, 1, 1, 1])


# --- quadrilaterals and rings ----------------------------------------------------------------------------------


def test_cook_membrane_area_and_first_moments():
    area, mx, my = polygon_moments(COOK)
    assert area == 1440.0  # trapezoid: (44 + 16)/2 · 48
    vertices = structured_quadrilateral(COOK, (8, 6))
    assert vertices.shape == (48, 4, 2)
    q = quadrilateral_cells(vertices, 2)
    assert relative_error(q.weight.sum(), area) < 1e-13
    assert relative_error(np.sum(q.weight * q.position[:, 0]), mx) < 1e-13
    assert relative_error(np.sum(q.weight * q.position[:, 1]), my) < 1e-13
    assert np.array_equal(np.bincount(q.cell), np.full(48, 4))


def test_structured_quadrilateral_cells_tile_the_corners():
    vertices = structured_quadrilateral(COOK, (3, 2))
    assert np.allclose(vertices[0, 0], COOK[0]) and np.allclose(vertices[2, 1], COOK[1])
    assert np.allclose(vertices[5, 2], COOK[2]) and np.allclose(vertices[3, 3], COOK[3])
    assert np.allclose(vertices[0, 1], vertices[1, 0]) and np.allclose(vertices[0, 3], vertices[3, 0])  # ix + nx·iy


def test_distorted_bilinear_cell_integrates_linear_functions_exactly():
    quad = np.array([[0.0, 0.0], [2.0, 0.3], [1.7, 1.6], [0.2, 1.1]])
    area, mx, my = polygon_moments(quad)
    q = quadrilateral_cells(quad[None], 2)
    x, y = q.position.T
    assert relative_error(q.weight.sum(), area) < 1e-14
    assert relative_error(np.sum(q.weight * (3 - 2 * x + 5 * y)), 3 * area - 2 * mx + 5 * my) < 1e-14


def test_annulus_quarter_area_and_first_moment():
    inner, outer, centre = 1.0, 2.0, np.array([1.0, -2.0])
    q = annulus_cells(inner, outer, 0.0, math.pi / 2, (4, 8), 6, centre=centre)
    area = math.pi / 4 * (outer ** 2 - inner ** 2)
    assert relative_error(q.weight.sum(), area) < 1e-14
    rel = q.position - centre
    assert np.all(np.hypot(*rel.T) > inner) and np.all(np.hypot(*rel.T) < outer) and np.all(rel > 0)
    assert relative_error(np.sum(q.weight * rel[:, 0]), (outer ** 3 - inner ** 3) / 3) < 1e-12
    assert np.array_equal(np.bincount(q.cell), np.full(32, 36))


# --- boundaries ------------------------------------------------------------------------------------------------


def test_polyline_length():
    vertices = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 6.0], [-1.0, 6.0]])
    b = polyline_points(vertices, 3)
    assert abs(b.weight.sum() - 11.0) < 1e-13
    assert np.array_equal(np.bincount(b.segment), [3, 3, 3])
    assert np.allclose(np.hypot(*b.normal.T), 1.0, atol=1e-15)


@pytest.mark.parametrize("lower", [(0.0, 0.0), (1.0, 3.0)])
def test_closed_square_satisfies_the_divergence_theorem(lower):
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) + lower
    b = polyline_points(square, 2, closed=True)
    assert np.allclose(b.weight @ b.normal, 0.0, atol=1e-15)  # ∮ n dΓ = 0
    assert abs(np.sum(b.weight * np.sum(b.position * b.normal, axis=1)) - 2.0) < 1e-13  # ∮ x·n dΓ = 2 area
    assert np.all(np.sum((b.position - square.mean(axis=0)) * b.normal, axis=1) > 0)  # outward
    assert np.allclose(b.normal[b.segment == 0], [0.0, -1.0])


def test_segment_points_single_and_many():
    one = segment_points((0.0, 0.0), (0.0, 2.0), 2)
    assert np.allclose(one.normal, [1.0, 0.0]) and abs(one.weight.sum() - 2.0) < 1e-15
    many = segment_points([[0.0, 0.0], [1.0, 1.0]], [[1.0, 0.0], [1.0, 3.0]], 1)
    assert np.allclose(many.position, [[0.5, 0.0], [1.0, 2.0]]) and np.allclose(many.weight, [1.0, 2.0])


def test_arc_length_radius_and_normals():
    centre, radius = np.array([0.5, -1.0]), 2.5
    b = arc_points(centre, radius, 0.3, 1.9, 5, 4)
    assert abs(b.weight.sum() - radius * 1.6) < 1e-13
    rel = b.position - centre
    assert np.allclose(np.hypot(*rel.T), radius, atol=1e-14)
    assert np.allclose(b.normal, rel / radius, atol=1e-14)
    inward = arc_points(centre, radius, 0.3, 1.9, 5, 4, outward=False)
    assert np.allclose(inward.normal, -b.normal) and np.array_equal(inward.segment, np.repeat(np.arange(5), 4))
    circle = arc_points(centre, radius, 0.0, 2 * math.pi, 8, 8)
    assert np.allclose(circle.weight @ circle.normal, 0.0, atol=1e-13)
    assert relative_error(np.sum(circle.weight * np.sum(circle.position * circle.normal, axis=1)),
                          2 * math.pi * radius ** 2) < 1e-13


def test_annulus_quarter_boundary_satisfies_the_divergence_theorem():
    inner, outer = 1.0, 2.0
    parts = [segment_points((inner, 0.0), (outer, 0.0), 2), arc_points((0, 0), outer, 0.0, math.pi / 2, 4, 8),
             segment_points((0.0, outer), (0.0, inner), 2),
             arc_points((0, 0), inner, 0.0, math.pi / 2, 4, 8, outward=False)]
    flux = sum(p.weight @ p.normal for p in parts)
    x_dot_n = sum(np.sum(p.weight * np.sum(p.position * p.normal, axis=1)) for p in parts)
    assert np.allclose(flux, 0.0, atol=1e-13)
    assert abs(x_dot_n - 2 * math.pi / 4 * (outer ** 2 - inner ** 2)) < 1e-12


# --- bad input ------------------------------------------------------------------------------------------------


def raises_naming(name: str, call, *args, **kwargs) -> str:
    with pytest.raises(ParameterError) as caught:
        call(*args, **kwargs)
    assert caught.value.name == name
    return str(caught.value)


def test_bad_orders_degrees_and_cells():
    raises_naming("order", gauss_legendre, 0)
    raises_naming("order", rectangle_cells, (0, 0), (1, 1), (2, 2), 0)
    raises_naming("degree", triangle_rule, 9)
    raises_naming("degree", triangle_rule, 0)
    raises_naming("degree", triangle_rule, 2.0)
    raises_naming("cells", rectangle_cells, (0, 0), (1, 1), (0, 3), 2)
    raises_naming("cells", rectangle_cells, (0, 0), (1, 1), (2.5, 3), 2)
    raises_naming("cells", structured_quadrilateral, COOK, (0, 3))
    raises_naming("cells", annulus_cells, 1, 2, 0, 1, (3,), 2)
    raises_naming("pieces", arc_points, (0, 0), 1, 0, 1, 0, 2)


def test_bad_geometry():
    raises_naming("upper", rectangle_cells, (0, 0), (1, 0), (2, 2), 2)
    raises_naming("lower", rectangle_cells, (0, np.nan), (1, 1), (2, 2), 2)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    message = raises_naming("vertices", quadrilateral_cells, np.stack([square, square[::-1]]), 2)  # clockwise
    assert "cell 1" in message
    arrow = np.array([[0.0, 0.0], [2.0, 0.0], [0.5, 0.5], [0.0, 2.0]])  # non-convex: det J < 0 near a corner
    raises_naming("vertices", quadrilateral_cells, arrow[None], 2)
    raises_naming("corners", structured_quadrilateral, COOK[::-1], (2, 2))
    points = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    message = raises_naming("triangles", triangle_cells, points, np.array([[0, 1, 3], [0, 1, 2]]), 2)
    assert "triangle 1" in message
    raises_naming("triangles", triangle_cells, points, np.array([[0, 1, 4]]), 2)
    raises_naming("outer", annulus_cells, 2, 1, 0, 1, (2, 2), 2)
    raises_naming("inner", annulus_cells, -1, 1, 0, 1, (2, 2), 2)
    raises_naming("angle1", annulus_cells, 1, 2, 0, 7, (2, 2), 2)
    raises_naming("angle1", arc_points, (0, 0), 1, 1, 1, 2, 2)
    raises_naming("radius", arc_points, (0, 0), 0, 0, 1, 2, 2)
    raises_naming("end", segment_points, (1, 1), (1, 1), 2)
    raises_naming("vertices", polyline_points, [[0, 0], [1, 0], [1, 0]], 2)
    raises_naming("vertices", polyline_points, [[0, 0], [1, 0]], 2, closed=True)
