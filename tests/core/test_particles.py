"""Particle sets: 1D/2D padding to float32 vec3 positions, named fields, views, bad input."""

import numpy as np
import pytest
import warp as wp

from warpfree.errors import ParameterError
from warpfree.particles import ParticleSet, to_vec3


@pytest.mark.parametrize("dim,points,expect", [
    (1, [[0.5], [2.0]], [[0.5, 0, 0], [2.0, 0, 0]]),
    (2, [[0.0, 1.0], [2.0, 3.0]], [[0, 1, 0], [2, 3, 0]]),
    (3, [[1.0, 2.0, 3.0]], [[1, 2, 3]]),
])
def test_positions_are_padded_to_vec3(dim, points, expect):
    s = ParticleSet("fluid", np.array(points), dim=dim)
    assert s.n == len(points) and s.position.dtype == wp.vec3 and s.dim == dim
    np.testing.assert_array_equal(s.position.numpy(), expect)


def test_fields_add_and_round_trip():
    s = ParticleSet("fluid", np.zeros((3, 3)), dim=3)
    s.add("density", 1000.0)
    s.add("velocity", np.ones((3, 2)), dtype=wp.vec3)
    data = s.numpy()
    assert data["density"].tolist() == [1000.0] * 3 and data["velocity"][:, 2].tolist() == [0, 0, 0]
    data["density"][:] = 2.0
    s.load(data)
    assert s["density"].numpy().tolist() == [2.0] * 3 and "velocity" in s
    assert s.numpy("density").tolist() == [2.0] * 3


def test_view_shares_memory_with_the_source():
    x = wp.array(np.arange(12, dtype=np.float32).reshape(4, 3), dtype=wp.vec3)
    v = ParticleSet.view("part", 3, {"position": x[1:3]})
    assert v.n == 2
    x.assign(np.zeros((4, 3), np.float32))
    assert not v.position.numpy().any()


@pytest.mark.parametrize("points", [np.zeros((3,)), np.zeros((3, 4)), np.array([[np.nan, 0.0]])])
def test_bad_positions_name_the_parameter(points):
    with pytest.raises(ParameterError, match="positions"):
        to_vec3(points)


def test_bad_field_length_dim_and_shape():
    s = ParticleSet("fluid", np.zeros((3, 2)), dim=2)
    with pytest.raises(ParameterError, match="fluid.density"):
        s.add("density", np.ones(4))
    with pytest.raises(ParameterError, match="dim"):
        ParticleSet("fluid", np.zeros((3, 2)), dim=4)
    with pytest.raises(ParameterError, match="fluid.positions"):
        ParticleSet("fluid", np.zeros((3, 2)), dim=1)
    with pytest.raises(ParameterError, match="fluid.position"):
        ParticleSet.view("fluid", 2, {"velocity": s.position})
    with pytest.raises(ParameterError, match="fluid.position"):
        s.load({"position": np.zeros((4, 3), np.float32)})
