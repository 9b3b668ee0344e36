"""Regions bounded by exact curves (``warpfree.galerkin.region``): areas and lengths to round-off, booleans of curved
shapes, nodes on the curves and clear of them inside, graded layouts, the cells tiling the true region, and EFG on
them: the patch test on curved Dirichlet boundaries and the coaxial line's surface field at second order."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warpfree import device
from warpfree.errors import ParameterError
from warpfree.galerkin.curves import Piece, Segment, SplineCurve
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.galerkin.region import Region
from warpfree.solvers.efg.region_conditions import essential
from warpfree.solvers.efg.solver import PoissonSolver


def _ring(a: float = 1.0, b: float = 2.0) -> Region:
    return Region.disc((0.0, 0.0), b, "outer") - Region.disc((0.0, 0.0), a, "inner")


def test_a_ring_s_area_perimeter_and_cells_are_exact():
    ring = _ring()
    exact_area = math.pi * 3.0
    assert ring.area == pytest.approx(exact_area, rel=1e-13)
    assert ring.tags == ["outer", "inner"]
    nodes = ring.nodes(0.2)
    cells = ring.cells(nodes, degree=5)
    assert cells.weight.sum() == pytest.approx(exact_area, rel=1e-13)   # curved cells tile the true ring
    assert np.all(cells.weight > 0) and np.all(ring.signed_distance(cells.position) < 1e-12)
    for tag, radius, outward in (("outer", 2.0, 1.0), ("inner", 1.0, -1.0)):
        bp = ring.boundary_points(nodes, tag, order=3)
        assert bp.weight.sum() == pytest.approx(2.0 * math.pi * radius, rel=1e-13)
        assert np.allclose(np.hypot(*bp.position.T), radius, rtol=1e-13)
        assert np.allclose(bp.normal, outward * bp.position / radius, atol=1e-12)  # out of the region
    bp = ring.boundary_points(nodes)
    assert np.sum(bp.weight * np.einsum("ij,ij->i", bp.position, bp.normal)) == pytest.approx(2 * exact_area, rel=1e-13)
    # the nodes: every boundary node on its circle, every inside node at least 0.45 spacings in
    r = np.hypot(*nodes.position.T)
    on = nodes.boundary
    assert np.all(np.minimum(np.abs(r[on] - 1.0), np.abs(r[on] - 2.0)) < 1e-12)
    assert np.all(ring.signed_distance(nodes.position[~on]) < -0.45 * 0.2)


def test_booleans_of_curved_shapes_keep_exact_curves():
    r, d = 1.0, 1.2  # two discs of radius 1, centres 1.2 apart: the lens 2 r² acos(d/2r) - (d/2) sqrt(4r² - d²)
    lens = 2.0 * r * r * math.acos(d / (2 * r)) - 0.5 * d * math.sqrt(4 * r * r - d * d)
    left, right = Region.disc((0.0, 0.0), r, "left"), Region.disc((d, 0.0), r, "right")
    assert (left & right).area == pytest.approx(lens, rel=1e-12)
    assert (left | right).area == pytest.approx(2 * math.pi - lens, rel=1e-12)
    assert (left - right).area == pytest.approx(math.pi - lens, rel=1e-12)
    assert set((left - right).tags) == {"left", "right"}  # the bite keeps the cutting disc's tag
    plate = Region.rectangle((-2.0, -1.0), (2.0, 1.0), ["bottom", "right", "top", "left"])
    hole = Region.ellipse((0.3, 0.0), (0.6, 0.2), angle=0.4, tag="hole")
    holed = plate - hole
    assert holed.area == pytest.approx(8.0 - math.pi * 0.6 * 0.2, rel=1e-13)
    assert holed.tags == ["bottom", "right", "top", "left", "hole"]
    # a bite out of a side: the rectangle less a disc on its top edge (half the disc inside)
    bitten = plate - Region.disc((0.0, 1.0), 0.5, "notch")
    assert bitten.area == pytest.approx(8.0 - math.pi * 0.125, rel=1e-12)
    cells = bitten.cells(bitten.nodes(0.1), degree=5)
    assert cells.weight.sum() == pytest.approx(bitten.area, rel=1e-12)


def test_a_spline_region_and_a_graded_layout():
    angle = np.linspace(0.0, 2 * math.pi, 9)[:-1]
    blob = Region.spline(np.stack([(1 + 0.3 * np.cos(3 * angle)) * np.cos(angle),
                                   (1 + 0.3 * np.cos(3 * angle)) * np.sin(angle)], axis=1), tag="skin")
    dense = blob.pieces[0].point(np.linspace(0.0, 1.0, 200001)[:-1])
    shoelace = 0.5 * abs(np.sum(dense[:, 0] * np.roll(dense[:, 1], -1) - np.roll(dense[:, 0], -1) * dense[:, 1]))
    assert blob.area == pytest.approx(shoelace, rel=1e-9)
    # graded toward the corner (1, 1) of a square: spacing 0.01 there, 0.1 far away
    square = Region.rectangle((0.0, 0.0), (1.0, 1.0))
    size = lambda p: np.clip(0.01 + 0.25 * np.hypot(p[:, 0] - 1.0, p[:, 1] - 1.0), 0.01, 0.1)  # noqa: E731
    nodes = square.nodes(0.1, size=size)
    from scipy.spatial import cKDTree

    gap = cKDTree(nodes.position).query(nodes.position, k=2)[0][:, 1]
    near = np.hypot(nodes.position[:, 0] - 1, nodes.position[:, 1] - 1) < 0.05
    far = np.hypot(nodes.position[:, 0] - 1, nodes.position[:, 1] - 1) > 0.8
    assert np.median(gap[near]) < 0.03 and 0.04 < np.median(gap[far]) <= 0.1
    assert square.cells(nodes, 2).weight.sum() == pytest.approx(1.0, rel=1e-12)


def _linear_field_error(region: Region, tags, h: float) -> float:
    exact = lambda p: (1.0 + 2.0 * p[:, 0] - 3.0 * p[:, 1])[:, None]  # noqa: E731
    nodes = region.nodes(h)
    cells = region.cells(nodes)
    solver = PoissonSolver(MLSModel(nodes.position, MLSSettings(d_max=2.5)), cells, conductivity=1.0,
                           essential=essential(region, nodes, tags, exact))
    solver.solve()
    u = solver.field_at(cells.position)[0]
    return float(np.max(np.abs(u.ravel() - exact(cells.position).ravel())))


def test_linear_fields_are_reproduced_and_converge_with_dirichlet_on_curves():
    """The patch test, u = 1 + 2x - 3y held on the whole boundary (multipliers at the boundary nodes), consistent
    integration on the region's cells: on straight pieces (a plate less a polygonal hole) EFG's linear basis
    reproduces it to round-off; on curves (a disc less an elliptic hole) the multipliers' hats, linear along each
    piece, carry the field's normal flux only to second order where the normal turns, and the error falls with it
    (measured 2.6e-4, 3.5e-5 at spacings 0.12, 0.06)."""
    device.use("cpu", 2)
    plate = Region.rectangle((0.0, 0.0), (2.0, 1.0), "side") - Region.polygon([(0.6, 0.3), (1.1, 0.35), (0.8, 0.7)],
                                                                            "hole")
    assert _linear_field_error(plate, ["side", "hole"], 0.1) < 1e-9
    curved = Region.disc((0.0, 0.0), 1.0, "outer") - Region.ellipse((0.2, 0.1), (0.4, 0.2), 0.5, "hole")
    coarse, fine = (_linear_field_error(curved, ["outer", "hole"], h) for h in (0.12, 0.06))
    assert fine < 5e-5 and coarse / fine > 4.0, (coarse, fine)


def _coax_field_error(h: float) -> float:
    a, b = 1.0, 2.0
    ring = _ring(a, b)
    nodes = ring.nodes(h)
    held = (essential(ring, nodes, "inner", lambda p: np.zeros((len(p), 1)))
            + essential(ring, nodes, "outer", lambda p: np.ones((len(p), 1))))
    solver = PoissonSolver(MLSModel(nodes.position, MLSSettings(basis="quadratic", d_max=3.0)),
                           ring.cells(nodes), conductivity=1.0, essential=held)
    solver.solve()
    surface = ring.boundary_points(nodes, "inner", order=4).position
    grad = solver.field_at(surface)[1].reshape(len(surface), -1)[:, :2]
    return float(np.max(np.abs(np.linalg.norm(grad, axis=1) * a * math.log(b / a) - 1.0)))


@pytest.mark.slow
def test_the_coaxial_line_s_surface_field_converges_at_second_order():
    """φ = ln(r/a)/ln(b/a) between circles r = a (φ = 0) and r = b (φ = 1) held on the exact circles: the field
    |∇φ| = 1/(r ln(b/a)) at r = a, its largest relative error over the inner circle, quadratic basis: 1.0e-2, 2.4e-3,
    6.5e-4 at spacings 0.2, 0.1, 0.05 (measured); asked: below 1e-3 at 0.05, order above 1.7 on each halving."""
    device.use("cpu", 2)
    errors = [_coax_field_error(h) for h in (0.2, 0.1, 0.05)]
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert errors[-1] < 1e-3 and min(orders) > 1.7, (errors, orders)


def test_bad_regions_are_named():
    with pytest.raises(ParameterError, match="region"):
        Region([[Piece(Segment((0, 0), (1, 0)), 0, 1), Piece(Segment((1, 0), (1, 1)), 0, 1)]])  # open
    with pytest.raises(ParameterError, match="tags"):
        Region.rectangle((0, 0), (1, 1)).boundary_points(Region.rectangle((0, 0), (1, 1)).nodes(0.2), "lid")
    with pytest.raises(ParameterError, match="spacing"):
        Region.disc((0, 0), 1.0).nodes(0.0)
    with pytest.raises(ParameterError, match="region"):  # boundaries that run together
        Region.rectangle((0, 0), (1, 1)) - Region.rectangle((0.5, 0), (1.5, 1))
    with pytest.raises(ParameterError, match="spline"):
        SplineCurve([(0, 0), (0, 0), (1, 1)])
