"""Periodic space: minimum-image displacements (run-time and compiled forms) and wrapping, against NumPy."""

import numpy as np
import pytest
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels.space import Box, displacement, displacement_function, wrap
from warpfree.space import Space

_compiled = {}


def compiled_kernel(periodic):
    """A kernel calling the displacement compiled for one pattern of periodic axes."""
    key = tuple(periodic)
    if key not in _compiled:
        disp = displacement_function(key)

        @wp.kernel(module="unique")
        def pair_displacements_compiled(box: Box, a: wp.array(dtype=wp.vec3), b: wp.array(dtype=wp.vec3),
                                        out: wp.array(dtype=wp.vec3)):
            i = wp.tid()
            out[i] = disp(box, a[i], b[i])

        _compiled[key] = pair_displacements_compiled
    return _compiled[key]


@wp.kernel
def pair_displacements(box: Box, a: wp.array(dtype=wp.vec3), b: wp.array(dtype=wp.vec3),
                       out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out[i] = displacement(box, a[i], b[i])


@wp.kernel
def wrap_points(box: Box, a: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out[i] = wrap(box, a[i])


PATTERNS = [(False, False, False), (True, False, False), (True, True, False), (True, True, True), (False, True, True)]


@pytest.mark.parametrize("periodic", PATTERNS)
def test_displacement_is_the_minimum_image(periodic):
    sp = Space(3, (-1.0, 0.0, 2.0), (1.0, 0.5, 5.0), periodic)
    rng = np.random.default_rng(1)
    a = sp.lower + rng.uniform(0, 1, (2000, 3)) * sp.length
    b = sp.lower + rng.uniform(0, 1, (2000, 3)) * sp.length
    b[:10] = sp.lower  # points exactly on the lower faces
    a[10:20] = sp.upper
    ref = sp.displacement(a.astype(np.float32), b.astype(np.float32))
    for kernel in (pair_displacements, compiled_kernel(periodic)):
        out = wp.zeros(2000, dtype=wp.vec3)
        wp.launch(kernel, 2000, [sp.box, wp.array(a.astype(np.float32), dtype=wp.vec3),
                                 wp.array(b.astype(np.float32), dtype=wp.vec3), out])
        got = out.numpy()
        np.testing.assert_allclose(got, ref, atol=2e-6)
        for axis in range(3):
            if periodic[axis]:
                assert np.all(np.abs(got[:, axis]) <= 0.5 * sp.length[axis] + 1e-6)
    if not any(periodic):  # free space: exactly x_i - x_j
        assert np.array_equal(got, (a.astype(np.float32) - b.astype(np.float32)))


def test_wrap_brings_points_into_the_box():
    sp = Space(2, (0.0, -1.0, 0.0), (2.0, 1.0, 0.0), (True, False, False))
    pts = np.array([[-0.1, 5.0, 0], [2.0, 0, 0], [4.3, 0.2, 0], [0.0, 0, 0], [-1e-9, 0, 0]], dtype=np.float32)
    out = wp.zeros(5, dtype=wp.vec3)
    wp.launch(wrap_points, 5, [sp.box, wp.array(pts, dtype=wp.vec3), out])
    got = out.numpy()
    assert np.all((got[:, 0] >= 0.0) & (got[:, 0] < 2.0))
    np.testing.assert_allclose(got[:3, 0], [1.9, 0.0, 0.3], atol=1e-6)
    assert got[0, 1] == 5.0  # y is not periodic: untouched
    np.testing.assert_allclose(sp.wrap(pts)[:, 0], [1.9, 0.0, 0.3, 0.0, 2.0 - 1e-9], atol=1e-6)


def test_bad_spaces_name_the_parameter():
    with pytest.raises(ParameterError, match="dim"):
        Space(4)
    with pytest.raises(ParameterError, match="periodic"):
        Space(2, (0, 0, 0), (1, 1, 1), (False, False, True))
    with pytest.raises(ParameterError, match="periodic"):
        Space(2, periodic=(True, False, False))
    with pytest.raises(ParameterError, match="upper"):
        Space(2, (0, 0, 0), (1, -1, 0), (True, False, False))
    with pytest.raises(ParameterError, match="lower"):
        Space(2, (0, np.nan, 0), (1, 1, 0))
    with pytest.raises(ParameterError, match="radius"):
        Space(2, (0, 0, 0), (1, 1, 0), (True, True, False)).require_room(0.6)
