"""Operations per item read from Warp's generated C++ (``bench/core/operations.py``, the roofline's arithmetic side):
kernels whose operations are known by hand, with loops whose trips come from constants, launch integers, neighbour
rows and hash-grid queries, a called function, float64 apart and special functions apart."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import warp as wp

from helpers import ROOT

sys.path.insert(0, str(ROOT / "bench" / "core"))
import operations  # noqa: E402
from warpfree.kernels.neighbours import NeighbourRows  # noqa: E402


@wp.func
def _axpy(a: float, x: float, y: float) -> float:
    return a * x + y  # 2


@wp.kernel
def _straight(first: int, a: wp.array(dtype=float), b: wp.array(dtype=wp.vec3), out: wp.array(dtype=float)):
    i = first + wp.tid()
    v = b[i] * a[i]                               # 3
    out[i] = wp.length(v) + _axpy(a[i], 2.0, 1.0)  # 6 (one sqrt) + 1 + 2


@wp.kernel
def _loops(first: int, steps: int, rows: NeighbourRows, w: wp.array(dtype=float), d: wp.array(dtype=wp.float64),
           out: wp.array(dtype=float)):
    i = first + wp.tid()
    s = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        s += w[rows.index[n]] * 2.0               # 2 a pair
    for _k in range(steps):
        s = s * 0.5                               # 1 a trip of the launch's integer
    for _k in range(40):
        s = s + 1.0                               # 1 a trip, 40 trips (a constant range Warp does not unroll)
    x = d[i] * d[i] + wp.float64(1.0)             # 2 in float64
    out[i] = s + float(wp.exp(x))                 # 1 float32, 1 float64 special


@wp.kernel
def _query(first: int, grid: wp.uint64, points: wp.array(dtype=wp.vec3), radius: float,
           out: wp.array(dtype=float)):
    i = first + wp.tid()
    s = float(0.0)
    for k in wp.hash_grid_query(grid, points[i], radius):
        d = points[k] - points[i]                 # 3
        s += wp.dot(d, d)                         # 5 + 1
    out[i] = s


def _launch(kernel, n, inputs):
    wp.launch(kernel, dim=n, inputs=[0, *inputs], device="cpu")
    return operations.kernel_operations(kernel, inputs, n)


def test_straight_code_and_a_called_function():
    n = 5
    ops = _launch(_straight, n, [wp.ones(n, dtype=float, device="cpu"), wp.ones(n, dtype=wp.vec3, device="cpu"),
                                 wp.zeros(n, dtype=float, device="cpu")])
    assert ops["f32"] == 3 + 6 + 1 + 2 and ops["f64"] == 0 and ops["special"] == 1 and ops["unresolved"] == []


def test_loop_trips_from_rows_integers_and_constants_float64_apart():
    counts = np.array([3, 0, 5, 2], dtype=np.int32)
    rows = NeighbourRows()
    rows.count = wp.array(counts, dtype=wp.int32, device="cpu")
    rows.start = wp.array(np.r_[0, np.cumsum(counts)[:-1]].astype(np.int32), dtype=wp.int32, device="cpu")
    rows.index = wp.zeros(int(counts.sum()), dtype=wp.int32, device="cpu")
    n, steps = counts.size, 7
    ops = _launch(_loops, n, [steps, rows, wp.ones(4, dtype=float, device="cpu"),
                              wp.ones(n, dtype=wp.float64, device="cpu"), wp.zeros(n, dtype=float, device="cpu")])
    assert ops["f32"] == pytest.approx(2 * counts.mean() + steps + 40 + 1)
    assert ops["f64"] == 3 and ops["special"] == 1 and ops["unresolved"] == []


def test_a_hash_grid_loop_counts_every_candidate():
    rng = np.random.default_rng(0)
    pts = rng.uniform(0.0, 1.0, (400, 3)).astype(np.float32)
    points = wp.array(pts, dtype=wp.vec3, device="cpu")
    grid = wp.HashGrid(8, 8, 8, device="cpu")
    radius = 0.15
    grid.build(points, radius)
    ops = _launch(_query, len(pts), [grid.id, points, radius, wp.zeros(len(pts), dtype=float, device="cpu")])
    counts = wp.zeros(len(pts), dtype=wp.int32, device="cpu")
    wp.launch(operations.count_candidates, dim=len(pts), inputs=[grid.id, points, radius, counts], device="cpu")
    within = (np.linalg.norm(pts[:, None] - pts[None], axis=-1) < radius).sum(axis=1).mean()
    candidates = counts.numpy().mean()
    assert candidates >= within  # the query's candidates hold every point within the radius
    assert ops["f32"] == pytest.approx(9 * candidates) and ops["unresolved"] == []


def test_statement_rules():
    vec3, mat33, f = operations.Type(3, 32, 3, 1), operations.Type(9, 32, 3, 3), operations.Type(1, 32)
    assert operations.statement_operations("mul", vec3, [mat33, vec3]) == (15, False)
    assert operations.statement_operations("mul", mat33, [mat33, mat33]) == (45, False)
    assert operations.statement_operations("cross", vec3, [vec3, vec3]) == (9, False)
    assert operations.statement_operations("dot", f, [vec3, vec3]) == (5, False)
    assert operations.statement_operations("sqrt", f, [f]) == (1, True)
    assert operations.parse_type("wp::mat_t<3, 2, wp::float64>") == operations.Type(6, 64, 3, 2)
    assert operations.parse_type("wp::int32").bits == 0
