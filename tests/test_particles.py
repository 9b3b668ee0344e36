"""Particle sets: named Warp arrays, 2D padding to vec3, views, bad input."""

import numpy as np
import pytest
import warp as wp

from warpfree.errors import ParameterError
from warpfree.particles import ParticleSet, to_vec3


def test_2d_positions_are_padded_with_zero_z():
    s = ParticleSet("fluid", np.array([[0.0, 1.0], [2.0, 3.0]]), dim=2)
    assert s.n == 2 and s.x.dtype == wp.vec3
    np.testing.assert_array_equal(s.x.numpy(), [[0, 1, 0], [2, 3, 0]])


def test_fields_add_and_round_trip():
    s = ParticleSet("fluid", np.zeros((3, 3)), dim=3)
    s.add("rho", 1000.0)
    s.add("v", np.ones((3, 2)), dtype=wp.vec3)
    data = s.numpy()
    assert data["rho"].tolist() == [1000.0] * 3 and data["v"][:, 2].tolist() == [0, 0, 0]
    data["rho"][:] = 2.0
    s.load(data)
    assert s["rho"].numpy().tolist() == [2.0] * 3 and "v" in s


def test_view_shares_memory_with_the_source():
    x = wp.array(np.arange(12, dtype=np.float32).reshape(4, 3), dtype=wp.vec3)
    v = ParticleSet.view("part", 3, {"x": x[1:3]})
    assert v.n == 2
    x.assign(np.zeros((4, 3), np.float32))
    assert not v.x.numpy().any()


@pytest.mark.parametrize("points", [np.zeros((3,)), np.zeros((3, 4)), np.array([[np.nan, 0.0]])])
def test_bad_positions_name_the_parameter(points):
    with pytest.raises(ParameterError, match="positions"):
        to_vec3(points)


def test_bad_field_length_and_dim():
    s = ParticleSet("fluid", np.zeros((3, 2)), dim=2)
    with pytest.raises(ParameterError, match="fluid.rho"):
        s.add("rho", np.ones(4))
    with pytest.raises(ParameterError, match="dim"):
        ParticleSet("fluid", np.zeros((3, 2)), dim=4)
    with pytest.raises(ParameterError, match="fluid.x"):
        ParticleSet.view("fluid", 2, {"v": s.x})
