"""Device reductions (max, min, sum, any flag) against NumPy, bitwise the same for any thread count."""

import numpy as np
import pytest
import warp as wp

from warpfree.reduce import BLOCK, Reduction, reduce


@pytest.mark.parametrize("n", [0, 1, 7, BLOCK, BLOCK + 1, 5 * BLOCK + 3, BLOCK ** 2 + 1, BLOCK ** 3 + 7])
def test_max_min_sum_of_float32_against_numpy(launcher, n):
    x = np.random.default_rng(n).standard_normal(n).astype(np.float32)
    a = wp.array(x, dtype=float)
    if n:
        assert reduce(launcher, a, "max") == x.max() and reduce(launcher, a, "min") == x.min()
    s = reduce(launcher, a, "sum")
    assert s.dtype == np.float64  # float32 sums accumulate in float64
    assert s == pytest.approx(x.astype(np.float64).sum(), abs=1e-9 * max(1, n))


def test_vector_max_is_componentwise_and_partial_lengths_work(launcher):
    v = np.random.default_rng(2).random((3000, 4)).astype(np.float32)
    r = Reduction(launcher, wp.vec4, "max")
    arr = wp.array(v, dtype=wp.vec4)
    r.launch(arr)
    np.testing.assert_array_equal(r.value(), v.max(axis=0))
    r.launch(arr, 100)  # the first 100 items only; the result is read again after a new launch
    np.testing.assert_array_equal(r.value(), v[:100].max(axis=0))


def test_sums_bitwise_identical_for_1_2_3_threads(make_launcher):
    x = wp.array(np.random.default_rng(3).standard_normal(50_000).astype(np.float32), dtype=float)
    sums = [reduce(make_launcher(threads=t), x, "sum") for t in (1, 2, 3)]
    assert sums[0] == sums[1] == sums[2]


def test_every_pass_has_work_for_a_gpu(launcher):
    """A tree of passes over blocks of BLOCK items: each pass runs n/BLOCK^k threads, never one thread over a long
    list (262 144 items: 8 192, 256, 8 and 1 threads)."""
    r = Reduction(launcher, wp.float32, "max")
    assert r._passes(262_144) == [8192, 256, 8, 1]
    assert r._passes(0) == [1] and r._passes(BLOCK) == [1] and r._passes(BLOCK + 1) == [2, 1]
