"""EFG node layouts (warpfree.galerkin.node_layouts): regular and stratified-random grids, Cook, ring sector."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.galerkin.node_layouts import (annulus_nodes, box_sides, grid_nodes, nodes_on, quadrilateral_nodes,
                                          random_grid_nodes)

LOWER, UPPER, CELLS = np.array([-1.0, 0.5]), np.array([3.0, 2.5]), (8, 5)
COOK = np.array([[0.0, 0.0], [48.0, 44.0], [48.0, 60.0], [0.0, 44.0]])


def test_grid_nodes_count_order_spacing_and_boundary():
    layout = grid_nodes(LOWER, UPPER, CELLS)
    nx, ny = CELLS
    h = (UPPER - LOWER) / CELLS
    assert layout.position.shape == ((nx + 1) * (ny + 1), 2) and layout.position.dtype == np.float64
    j, i = np.divmod(np.arange(len(layout.position)), nx + 1)
    assert np.allclose(layout.position, LOWER + np.stack([i * h[0], j * h[1]], axis=1), rtol=0, atol=1e-14)
    assert math.isclose(layout.spacing, math.sqrt(h[0] * h[1]))
    assert layout.boundary.sum() == 2 * (nx + ny)
    on_box = np.any(np.isclose(layout.position, LOWER) | np.isclose(layout.position, UPPER), axis=1)
    assert np.array_equal(on_box, layout.boundary)


def test_random_grid_nodes_keep_boundary_nodes_on_the_boundary_and_interior_in_their_sub_cell():
    regular = grid_nodes(LOWER, UPPER, CELLS)
    layout = random_grid_nodes(LOWER, UPPER, CELLS, seed=3)
    assert layout.position.shape == regular.position.shape  # Rocha (2012) compares equal node counts
    assert np.array_equal(layout.boundary, regular.boundary) and layout.spacing == regular.spacing
    h = (UPPER - LOWER) / CELLS
    moved = layout.position - regular.position
    # a coordinate on the box's edge stays there exactly; corners do not move
    for axis in range(2):
        for side in (LOWER[axis], UPPER[axis]):
            on_side = regular.position[:, axis] == side
            assert np.all(layout.position[on_side, axis] == side)
    corners = np.all((regular.position == LOWER) | (regular.position == UPPER), axis=1)
    assert corners.sum() == 4 and np.all(moved[corners] == 0)
    assert np.all(np.abs(moved) <= 0.5 * h + 1e-14)  # each node inside its own sub-cell
    interior = ~regular.boundary
    assert np.all((layout.position[interior] > LOWER) & (layout.position[interior] < UPPER))
    assert np.all(np.abs(moved[interior]) > 0) and np.max(np.abs(moved[interior]) / h) > 0.4  # jitter is used
    edge = regular.boundary & ~corners
    assert np.all(np.count_nonzero(moved[edge], axis=1) == 1)  # edge nodes slide along their edge only


def test_random_grid_nodes_seeded_and_jitter_scaled():
    a = random_grid_nodes(LOWER, UPPER, CELLS, seed=7, jitter=0.2)
    b = random_grid_nodes(LOWER, UPPER, CELLS, seed=7, jitter=0.2)
    c = random_grid_nodes(LOWER, UPPER, CELLS, seed=8, jitter=0.2)
    assert np.array_equal(a.position, b.position)
    assert not np.allclose(a.position, c.position)
    h = (UPPER - LOWER) / CELLS
    assert np.all(np.abs(a.position - grid_nodes(LOWER, UPPER, CELLS).position) <= 0.2 * h + 1e-14)
    still = random_grid_nodes(LOWER, UPPER, CELLS, seed=7, jitter=0.0)
    assert np.array_equal(still.position, grid_nodes(LOWER, UPPER, CELLS).position)


def edge_cross(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Cross product of each counter-clockwise edge with (point - edge start), (n, 4): >= 0 inside."""
    edge = np.roll(corners, -1, axis=0) - corners
    rel = points[:, None, :] - corners[None]
    return edge[None, :, 0] * rel[..., 1] - edge[None, :, 1] * rel[..., 0]


@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_quadrilateral_nodes_inside_cook_with_boundary_nodes_on_its_edges(jitter):
    layout = quadrilateral_nodes(COOK, (12, 9), seed=1, jitter=jitter)
    assert layout.position.shape == (13 * 10, 2)
    assert math.isclose(layout.spacing, math.sqrt(1440.0 / 108))
    cross = edge_cross(layout.position, COOK) / np.hypot(*(np.roll(COOK, -1, axis=0) - COOK).T)
    assert np.all(cross >= -1e-12)  # every node inside (signed distance to every edge >= 0)
    assert np.all(np.min(np.abs(cross[layout.boundary]), axis=1) < 1e-12)  # boundary nodes on an edge
    assert np.all(np.min(np.abs(cross[~layout.boundary]), axis=1) > 1e-6)
    for k in range(4):
        assert np.any(np.all(layout.position == COOK[k], axis=1))  # the corners stay


@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_annulus_nodes_within_radii_and_angles(jitter):
    inner, outer, a1, centre = 1.0, 2.0, math.pi / 2, np.array([0.5, 0.25])
    layout = annulus_nodes(inner, outer, 0.0, a1, (6, 10), seed=4, jitter=jitter, centre=centre)
    assert layout.position.shape == (7 * 11, 2)
    rel = layout.position - centre
    r, theta = np.hypot(*rel.T), np.arctan2(rel[:, 1], rel[:, 0])
    tol = 1e-12
    assert np.all((r >= inner - tol) & (r <= outer + tol) & (theta >= -tol) & (theta <= a1 + tol))
    on = (np.abs(r - inner) < tol) | (np.abs(r - outer) < tol) | (np.abs(theta) < tol) | (np.abs(theta - a1) < tol)
    assert np.array_equal(on, layout.boundary)
    assert math.isclose(layout.spacing, math.sqrt(0.75 * math.pi / 60))
    if jitter:
        assert not np.allclose(layout.position, annulus_nodes(inner, outer, 0.0, a1, (6, 10), centre=centre).position)


def test_nodes_on_picks_a_side():
    layout = random_grid_nodes((0.0, 0.0), (2.0, 1.0), (4, 3), seed=0)
    left = nodes_on(layout, lambda x, y, tol: np.abs(x) <= tol)
    assert left.dtype == np.int64 and np.array_equal(left, np.arange(0, 20, 5))
    corner = nodes_on(layout, lambda x, y, tol: (np.abs(x - 2) <= tol) & (np.abs(y - 1) <= tol))
    assert np.array_equal(corner, [19])


def raises_naming(name: str, call, *args, **kwargs) -> None:
    with pytest.raises(ParameterError) as caught:
        call(*args, **kwargs)
    assert caught.value.name == name


def test_bad_input():
    raises_naming("cells", grid_nodes, LOWER, UPPER, (0, 3))
    raises_naming("cells", grid_nodes, LOWER, UPPER, (2.5, 3))
    raises_naming("upper", grid_nodes, LOWER, (3.0, 0.5), CELLS)
    raises_naming("lower", grid_nodes, (np.inf, 0.0), UPPER, CELLS)
    raises_naming("jitter", random_grid_nodes, LOWER, UPPER, CELLS, 1, jitter=0.6)
    raises_naming("jitter", random_grid_nodes, LOWER, UPPER, CELLS, 1, jitter=-0.1)
    raises_naming("seed", random_grid_nodes, LOWER, UPPER, CELLS, None)
    raises_naming("seed", quadrilateral_nodes, COOK, (2, 2), jitter=0.3)
    raises_naming("corners", quadrilateral_nodes, COOK[::-1], (2, 2))
    raises_naming("inner", annulus_nodes, 0.0, 1.0, 0.0, 1.0, (2, 2))
    raises_naming("angle1", annulus_nodes, 1.0, 2.0, 0.0, 2 * math.pi, (2, 2))
    raises_naming("outer", annulus_nodes, 1.0, 1.0, 0.0, 1.0, (2, 2))
    layout = grid_nodes(LOWER, UPPER, CELLS)
    raises_naming("tol", nodes_on, layout, lambda x, y, tol: x > 0, tol=-1)
    raises_naming("predicate", nodes_on, layout, lambda x, y, tol: x)


def test_box_sides_are_counter_clockwise_polylines_through_the_boundary_nodes():
    layout = random_grid_nodes((0.0, -1.0), (4.0, 1.0), (8, 4), seed=3)
    sides = box_sides(layout.position, (0.0, -1.0), (4.0, 1.0))
    assert sum(len(s) for s in sides) == int(layout.boundary.sum()) + 4       # the corners close two sides each
    for s, nxt in zip(sides, sides[1:] + sides[:1]):
        assert np.array_equal(s[-1], nxt[0])                                   # one closed loop
    loop = np.vstack([s[:-1] for s in sides])
    area = 0.5 * np.sum(loop[:, 0] * np.roll(loop[:, 1], -1) - np.roll(loop[:, 0], -1) * loop[:, 1])
    assert area == pytest.approx(8.0)                                          # positive: counter-clockwise
    with pytest.raises(ParameterError) as err:
        box_sides(layout.position, (0.0, -1.0), (5.0, 1.0))
    assert err.value.name == "nodes"
