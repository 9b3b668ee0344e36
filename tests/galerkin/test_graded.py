"""Cells and nodes graded toward points (``warpfree.galerkin.graded``): the regular grid at 0 levels, a partition
of the box, cell size in proportion to the distance, shared corners counted once."""

from __future__ import annotations

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.galerkin.graded import graded_box, merged_nodes, side_vertices
from warpfree.galerkin.node_layouts import grid_nodes
from warpfree.galerkin.quadrature import rectangle_cells


def test_no_levels_is_the_regular_grid_and_its_cells():
    box = graded_box((0.0, 1.0), (3.0, 2.0), (6, 2), [(1.0, 1.0)], 0)
    assert np.array_equal(box.nodes(), grid_nodes((0.0, 1.0), (3.0, 2.0), (6, 2)).position)
    q, r = box.gauss_points(3), rectangle_cells((0.0, 1.0), (3.0, 2.0), (6, 2), 3)
    assert np.allclose(q.position, r.position, rtol=0, atol=1e-15) and np.allclose(q.weight, r.weight, rtol=1e-14)
    assert np.array_equal(q.cell, r.cell)


def test_graded_cells_partition_the_box_and_shrink_toward_the_point():
    corner = np.array([1.0, 1.0])
    box = graded_box((0.0, 0.0), (3.0, 1.0), (12, 4), [corner], 5, reach=2.0)
    lo, hi = box.cell_bounds()
    assert np.sum(np.prod(hi - lo, axis=1)) == pytest.approx(3.0, rel=1e-14)
    assert box.gauss_points(2).weight.sum() == pytest.approx(3.0, rel=1e-14)
    side = hi[:, 0] - lo[:, 0]
    assert side.min() == pytest.approx(0.25 / 32, rel=1e-14)
    # a split cell's parent lay within reach (2 × its side 2s) of the point: the child within 2·2s + the parent's diagonal
    gap = np.maximum(np.maximum(lo - corner, corner - hi), 0.0)
    distance = np.hypot(gap[:, 0], gap[:, 1])
    refined = side < 0.25
    assert np.all(distance[refined] < (2.0 * 2 + 2 * np.sqrt(2)) * side[refined])
    coarse_near = (side > 0.25 / 32) & (distance < 2.0 * side)
    assert not coarse_near.any()                                      # nothing within reach left unsplit
    # nodes: the distinct cell corners, a few dozen per level, not 4^levels
    nodes = box.nodes()
    assert len(np.unique(np.round(nodes * 1e9), axis=0)) == len(nodes)
    assert len(nodes) < 65 + 5 * 200


def test_boxes_that_meet_share_their_nodes_once_and_sides_list_them_in_order():
    a = graded_box((0.0, 0.0), (3.0, 1.0), (3, 1), [(1.0, 1.0)], 2)
    b = graded_box((1.0, 1.0), (2.0, 2.0), (1, 1), [(1.0, 1.0)], 2)
    nodes = merged_nodes([a.nodes(), b.nodes()], 0.25 * 0.25)
    assert len(nodes) == len(a.nodes()) + len(b.nodes()) - len(side_vertices(b.nodes(), (1.0, 1.0), (2.0, 1.0),
                                                                                   1e-12))
    v = side_vertices(nodes, (2.0, 1.0), (1.0, 1.0), 1e-12)
    assert v[0] == pytest.approx([2.0, 1.0]) and v[-1] == pytest.approx([1.0, 1.0])
    assert np.all(np.diff(v[:, 0]) < 0) and np.allclose(v[:, 1], 1.0)


def test_bad_levels_and_reach_are_refused_by_name():
    with pytest.raises(ParameterError, match="levels"):
        graded_box((0, 0), (1, 1), (2, 2), [(0.5, 0.5)], -1)
    with pytest.raises(ParameterError, match="reach"):
        graded_box((0, 0), (1, 1), (2, 2), [(0.5, 0.5)], 2, reach=0.0)
    with pytest.raises(ParameterError, match="toward"):
        graded_box((0, 0), (1, 1), (2, 2), [(0.5, 0.5, 0.5)], 2)
