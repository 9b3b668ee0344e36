"""Variationally consistent integration (``warpfree.galerkin.consistent_integration``) against its defining property:
at order n the Galerkin equations of every polynomial field of degree n hold exactly at every node,

    r_I = Σ_g w_g ∇ψ_I·∇u + Σ_g w_g φ_I Δu - Σ_b w_b φ_I ∇u·n_b = 0,

and a node whose Gauss points cannot resolve the degree of the order falls back to the order they resolve."""

from __future__ import annotations

import numpy as np
import pytest

from warpfree.galerkin.consistent_integration import consistent_test_gradients
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.galerkin.node_layouts import grid_nodes, random_grid_nodes
from warpfree.galerkin.quadrature import rectangle_cells, segment_points

#: u = Σ c_ij x^i y^j of each degree: random coefficients, fixed seed
COEFFICIENTS = np.random.default_rng(7).uniform(-1.0, 1.0, (5, 5))


def _polynomial(degree):
    """(∇u (n, 2), Δu (n,)) of u = Σ_{i+j <= degree} c_ij x^i y^j at points p."""
    def derivatives(p):
        x, y = p[:, 0], p[:, 1]
        grad, lap = np.zeros_like(p), np.zeros(len(p))
        for i in range(degree + 1):
            for j in range(degree + 1 - i):
                c = COEFFICIENTS[i, j]
                if i:
                    grad[:, 0] += c * i * x ** (i - 1) * y ** j
                if j:
                    grad[:, 1] += c * j * x ** i * y ** (j - 1)
                if i > 1:
                    lap += c * i * (i - 1) * x ** (i - 2) * y ** j
                if j > 1:
                    lap += c * j * (j - 1) * x ** i * y ** (j - 2)
        return grad, lap
    return derivatives


def _box_boundary(lower, upper, pieces):
    """The box's sides, counter-clockwise, ``pieces`` segments each, 3 Gauss points per segment."""
    (x0, y0), (x1, y1) = lower, upper
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]])
    t = np.linspace(0.0, 1.0, pieces + 1)[:, None]
    sides = [(1 - t) * a + t * b for a, b in zip(corners[:-1], corners[1:])]
    return [segment_points(s[:-1], s[1:], 3) for s in sides]


def _residuals(model, cells, boundary, order, derivatives):
    """r_I (N,) and the scale Σ_g w_g |∇ψ_I·∇u| per node, with the test gradients of ``order``."""
    shape = model.shape_at(cells.position)
    pieces = [(model.shape_at(b.position), b.weight, b.normal, -1) for b in boundary]
    test, _ = consistent_test_gradients(model, shape, cells.weight, pieces, order)
    index = shape.rows.index.numpy()[: shape.n_entries]
    grad, lap = derivatives(cells.position)
    w = np.repeat(cells.weight, shape.counts)
    stiff = w * np.sum(test.numpy()[: shape.n_entries] * np.repeat(grad, shape.counts, axis=0), axis=1)
    source = w * shape.phi.numpy()[: shape.n_entries] * np.repeat(lap, shape.counts)
    r = np.bincount(index, weights=stiff + source, minlength=model.node_count)
    scale = np.bincount(index, weights=np.abs(stiff), minlength=model.node_count)
    for (bshape, bw, normal, _), b in zip(pieces, boundary):
        flux = np.sum(derivatives(b.position)[0] * normal, axis=1) * bw
        r -= np.bincount(bshape.rows.index.numpy()[: bshape.n_entries],
                         weights=np.repeat(flux, bshape.counts) * bshape.phi.numpy()[: bshape.n_entries],
                         minlength=model.node_count)
    return r, scale


@pytest.mark.parametrize("layout", ["regular", "random"])
@pytest.mark.parametrize("order", [1, 2, 3])
def test_galerkin_equations_of_fields_of_the_order_s_degree_hold_at_every_node(launcher, layout, order):
    """Unit square, 8 x 8 nodes (regular, or one random node per cell), linear MLS at d_max 2.5, 2 x 2 Gauss points
    per cell: at order n every node's residual for a degree-n field is round-off (measured <= 8e-16 of the largest
    stiffness term; asserted 1e-10), and for a degree n + 1 field it is not (measured 1.9e-4 .. 1.2e-3; asserted
    1e-6): the order is exactly what it claims."""
    n = 8
    nodes = (grid_nodes((0, 0), (1, 1), (n, n)) if layout == "regular"
             else random_grid_nodes((0, 0), (1, 1), (n, n), seed=3)).position
    model = MLSModel(nodes, MLSSettings(d_max=2.5), launcher=launcher)
    cells = rectangle_cells((0, 0), (1, 1), (n, n), 2)
    boundary = _box_boundary((0, 0), (1, 1), n)
    exact, scale = _residuals(model, cells, boundary, order, _polynomial(order))
    assert np.abs(exact).max() < 1e-10 * scale.max(), np.abs(exact).max() / scale.max()
    beyond, scale = _residuals(model, cells, boundary, order, _polynomial(order + 1))
    assert np.abs(beyond).max() > 1e-6 * scale.max(), np.abs(beyond).max() / scale.max()


def test_gauss_points_on_two_lines_fall_back_to_the_order_they_resolve(launcher):
    """A strip one cell high: every support holds 2 x 2 points on two lines (y = const), which cannot tell y² from
    y, so order 2 (which asks them to resolve degree 2) falls back to order 1 at every node, to round-off; on two
    cell rows (four lines) it does not."""
    def gradients(rows, order):
        nodes = grid_nodes((0, 0), (1, 0.1 * rows), (10, rows)).position
        model = MLSModel(nodes, MLSSettings(d_max=2.5), launcher=launcher)
        cells = rectangle_cells((0, 0), (1, 0.1 * rows), (10, rows), 2)
        shape = model.shape_at(cells.position)
        pieces = [(model.shape_at(b.position), b.weight, b.normal, -1)
                  for b in _box_boundary((0, 0), (1, 0.1 * rows), 10)]
        return consistent_test_gradients(model, shape, cells.weight, pieces, order)[0].numpy()

    one_row = gradients(1, 2) - gradients(1, 1)
    assert np.abs(one_row).max() < 1e-12
    two_rows = gradients(2, 2) - gradients(2, 1)
    assert np.abs(two_rows).max() > 1e-6
