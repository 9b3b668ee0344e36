"""A layout's quality where its shape functions are evaluated (``warpfree.galerkin.layout_quality``): the Lebesgue
constants Σ|φ_I| from the kernel against the shape functions, nodes that serve no Gauss point refused by name, and on
the plate with an elliptical hole (exact stresses) a spacing that jumps 8x refused where it would have solved wrong."""

from __future__ import annotations

import re

import numpy as np
import pytest

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.galerkin import layout_quality
from warpfree.galerkin.layout_quality import LEBESGUE_LIMIT, layout_report
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.galerkin.node_layouts import box_sides, grid_nodes
from warpfree.galerkin.quadrature import rectangle_cells
from warpfree.scene_loader import load_scene
from warpfree.solvers.efg.boundary import Essential
from warpfree.solvers.efg.solver import PoissonSolver


@pytest.fixture(scope="module")
def launcher():
    return Launcher("cpu", 2)


@pytest.mark.parametrize("basis", ["linear", "quadratic"])
def test_lebesgue_constants_are_the_sums_of_the_shape_functions_magnitudes(launcher, basis):
    """Λ(x) = Σ_I |φ_I(x)| from the kernel equals the sum over the shape functions' row (any thread split); at least
    1 (Σ φ_I = 1); the spacings around a point deep inside a uniform grid do not spread."""
    nodes = grid_nodes((0.0, 0.0), (1.0, 1.0), (12, 12)).position
    model = MLSModel(nodes, MLSSettings(basis=basis, d_max=3.0), launcher=launcher)
    points = np.random.default_rng(3).uniform(0.0, 1.0, (500, 2))
    shape = model.shape_at(points)
    report = layout_report(model, shape)
    sums = np.asarray(abs(shape.matrix()).sum(axis=1)).ravel()
    assert report.lebesgue_max == pytest.approx(sums.max(), rel=1e-12)
    assert report.lebesgue_mean == pytest.approx(sums.mean(), rel=1e-12)
    assert report.lebesgue_mean >= 1.0 - 1e-12
    assert report.worst_point == int(np.argmax(sums))
    assert report.points == 500 and report.support_min == int(shape.counts.min()) and report.unserved_nodes == 0
    centre = layout_report(model, model.shape_at(np.array([[0.5, 0.5]])))
    assert centre.worst_spread == pytest.approx(1.0, abs=1e-12)


def test_nodes_that_serve_no_gauss_point_are_refused_by_name(launcher):
    """Five nodes far outside the cells (their supports hold no Gauss point) left empty rows, a singular system
    blamed on the matrix; now refused before assembly, naming the first of them and why."""
    grid = grid_nodes((0.0, 0.0), (1.0, 1.0), (4, 4)).position
    cluster = np.array([[5.0, 5.0], [5.1, 5.0], [5.0, 5.1], [5.1, 5.1], [5.05, 5.2]])
    model = MLSModel(np.vstack([grid, cluster]), MLSSettings(d_max=2.0), launcher=launcher)
    linear = lambda p: (1.0 + p[:, 0])[:, None]  # noqa: E731
    solver = PoissonSolver(model, rectangle_cells((0, 0), (1, 1), (4, 4), 2), integration="gauss",
                           essential=[Essential(v, linear, (True,)) for v in box_sides(grid, (0, 0), (1, 1))])
    with pytest.raises(ParameterError, match=r"nodes: node 25 at \(5, 5\) serves no Gauss point \(5 such nodes\)"):
        solver.solve()


def _plate(jump: float, d_max: float):
    """The quarter plate with an elliptical hole (a = 0.25, b = 0.5), spacing 0.04 within r = 0.8 and ``jump``
    times that beyond, linear basis: its solver (not yet solved)."""
    scene = load_scene("efg_plate_hole")
    a, b = 0.25, 0.5
    region = scene.plate_region(2.0, a, b)
    nodes = region.nodes(0.04 * jump, size=lambda p: np.where(np.hypot(p[:, 0], p[:, 1]) < 0.8, 0.04, 0.04 * jump))
    return scene, scene.plate_solver(region, nodes, a, b, 1.0, 1.0, "linear", d_max)


def test_a_spacing_that_jumps_8x_is_refused_where_it_would_solve_wrong(monkeypatch):
    """The plate's spacing jumping 2x at r = 0.8 (d_max 1.6): Λ 1.5, energy-norm error of the stresses 8.9e-3. Jumping
    8x: Λ 60 where the coarse nodes meet the fine, and (solved with the check off) an energy error of 48; refused,
    naming the place, its Λ, the jump in spacing there and the three nodes serving it."""
    scene, good = _plate(2.0, 1.6)
    good.solve()
    assert good.layout.lebesgue_max < 2.0
    assert scene.plate_errors(good, 0.25, 0.5, 1.0)["energy_error"] < 1.5e-2
    _, bad = _plate(8.0, 1.6)
    with pytest.raises(ParameterError, match=r"nodes: the shape functions at Gauss point \d+ \(.*\) amplify the "
                                             r"nodal values' errors up to Λ = Σ\|φ_I\| = 60.2 \(at most 5\): the "
                                             r"node spacing changes (\d+\.\d)x within the reach of the 3 nodes serving "
                                             r"it: grade the layout more gently or raise d_max \(now 1.6\)") as refused:
        bad.solve()
    assert float(re.search(r"changes (\d+\.\d)x", str(refused.value)).group(1)) > 6.0
    monkeypatch.setattr(layout_quality, "LEBESGUE_LIMIT", np.inf)
    _, bad = _plate(8.0, 1.6)
    bad.solve()
    assert bad.layout.lebesgue_max > 10 * LEBESGUE_LIMIT
    assert scene.plate_errors(bad, 0.25, 0.5, 1.0)["energy_error"] > 1.0
