"""The threaded CPU launcher (warpfree/device.py): chunking, argument checks, determinism, errors."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from helpers import kernels_for_tests as kt
from warpfree.device import Launcher, default_threads, resolve_device
from warpfree.errors import ParameterError
from warpfree.kernels import smoothing as sm
from warpfree.neighbours import NeighbourGrid, NeighbourList, empty_rows
from warpfree.space import Space

# --- chunks --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("threads", [1, 2, 3, 4, 7, 16])
@pytest.mark.parametrize("n", [0, 1, 2, 3, 5, 6, 7, 15, 16, 17, 100, 1001, 123457])
def test_chunks_cover_range_exactly_once(make_launcher, n, threads):
    launcher = make_launcher(threads=threads)
    chunks = launcher.chunks(n)
    assert chunks == launcher.chunks(n)  # deterministic
    assert len(chunks) == min(n, threads)
    covered = np.zeros(n, dtype=np.int64)
    expected_first = 0
    for first, count in chunks:
        assert isinstance(first, int) and isinstance(count, int)
        assert first == expected_first, "chunks must be contiguous and in order"
        assert count >= 1
        covered[first:first + count] += 1
        expected_first = first + count
    assert expected_first == n
    assert np.all(covered == 1)


def test_launch_of_zero_items_is_a_no_op(make_launcher):
    launcher = make_launcher(threads=3)
    r = wp.zeros(0, dtype=float, device="cpu")
    w = wp.zeros(0, dtype=float, device="cpu")
    launcher.launch(kt.eval_w_dwdr, 0, [0, 3, r, 1.0, w, w])


@pytest.mark.parametrize("threads", [1, 2, 3, 5])
def test_every_item_launched_once(make_launcher, threads):
    """Each index i = first + tid is computed exactly once, whatever the thread count (n < threads too)."""
    launcher = make_launcher(threads=threads)
    for n in (1, 2, 3, 4, 11, 1000):
        r_np = np.linspace(0.0, 3.0, n).astype(np.float32)
        r = wp.array(r_np, dtype=float, device="cpu")
        w = wp.array(np.full(n, -1.0, dtype=np.float32), dtype=float, device="cpu")
        dw = wp.array(np.full(n, -1.0, dtype=np.float32), dtype=float, device="cpu")
        launcher.launch(kt.eval_w_dwdr, n, [sm.kernel_id("cubic_spline"), 3, r, 1.0, w, dw])
        ref = wp.array(np.full(n, -1.0, dtype=np.float32), dtype=float, device="cpu")
        dref = wp.array(np.full(n, -1.0, dtype=np.float32), dtype=float, device="cpu")
        wp.launch(kt.eval_w_dwdr, dim=n, inputs=[0, sm.kernel_id("cubic_spline"), 3, r, 1.0, ref, dref],
                  device="cpu")
        assert np.array_equal(w.numpy(), ref.numpy())
        assert np.array_equal(dw.numpy(), dref.numpy())
        assert np.all(w.numpy() >= 0.0)


# --- parameters ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, False, -0.5])
def test_bad_threads(threads):
    with pytest.raises(ParameterError, match="threads"):
        Launcher(device="cpu", threads=threads)


@pytest.mark.parametrize("threads", [float("inf"), float("nan"), "four"])
def test_bad_threads_non_integral_values_name_threads(threads):
    with pytest.raises(ParameterError, match="threads"):
        Launcher(device="cpu", threads=threads)


def test_threads_default_and_a_float_refused(make_launcher):
    launcher = make_launcher(threads=None)
    assert launcher.threads == default_threads() >= 1 and isinstance(launcher.threads, int)
    assert launcher.is_cpu and launcher.device == "cpu"
    with pytest.raises(ParameterError, match="threads: must be an integer"):
        make_launcher(threads=2.0)  # an integer is asked for: a float is refused, not read as one


def test_cuda_without_cuda_names_device():
    if wp.is_cuda_available():
        pytest.skip("a CUDA device is present")
    for name in ("cuda", "cuda:0"):
        with pytest.raises(ParameterError, match="device"):
            Launcher(device=name, threads=1)
        with pytest.raises(ParameterError, match="device"):
            resolve_device(name)


@pytest.mark.parametrize("name", ["gpu", "metal", "cpu0"])
def test_unknown_device_names_device(name):
    with pytest.raises(ParameterError, match="device"):
        Launcher(device=name, threads=1)


def test_default_device_is_cpu():
    assert resolve_device(None) == "cpu"
    assert resolve_device("") == "cpu"
    assert resolve_device("cpu") == "cpu"


# --- determinism ---------------------------------------------------------------------------------------


def _jittered_lattice(m: int, dx: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    k = np.arange(m)
    idx = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3)
    return (-0.5 + idx * dx + rng.uniform(-0.3 * dx, 0.3 * dx, size=idx.shape)).astype(np.float32)


def _density(launcher, grid, x, mass, h, radius):
    n = x.shape[0]
    rho = wp.zeros(n, dtype=float, device="cpu")
    grad = wp.zeros(n, dtype=wp.vec3, device="cpu")
    launcher.launch(kt.kernel_sums, n, [sm.kernel_id("cubic_spline"), 3, grid.id, x, grid.radius, h,
                                        radius, mass, rho, grad])
    return rho.numpy(), grad.numpy()


def test_gather_bitwise_identical_across_thread_counts(make_launcher):
    """An SPH density sum ρ_i = Σ_j m_j W_ij over HashGrid neighbours gives the same bits on 1, 2, 3 threads."""
    dx = 0.05
    h = 1.3 * dx
    radius = sm.support_factor("cubic_spline") * h
    p = _jittered_lattice(20, dx, seed=21)
    n = p.shape[0]
    x = wp.array(p, dtype=wp.vec3, device="cpu")
    rng = np.random.default_rng(22)
    mass_np = (1000.0 * dx**3 * rng.uniform(0.9, 1.1, size=n)).astype(np.float32)
    mass = wp.array(mass_np, dtype=float, device="cpu")
    grid = NeighbourGrid(Launcher("cpu", 1), radius, Space.free(3), x)

    results = {}
    for threads in (1, 2, 3):
        launcher = make_launcher(threads=threads)
        assert len(launcher.chunks(n)) == threads
        results[threads] = _density(launcher, grid, x, mass, h, radius)
    rho1, g1 = results[1]
    assert rho1.dtype == np.float32
    for threads in (2, 3):
        rho, g = results[threads]
        assert np.array_equal(rho, rho1) and np.array_equal(g, g1)
        assert np.array_equal(rho.view(np.uint32), rho1.view(np.uint32))  # bitwise, signed zeros included
        assert np.array_equal(g.view(np.uint32), g1.view(np.uint32))
    # sanity: a real computation (interior density near the rest density of 1000)
    inner = np.all((p > -0.5 + 4 * dx) & (p < -0.5 + 15 * dx), axis=1)
    assert inner.sum() > 100
    assert np.all(np.abs(rho1[inner] / 1000.0 - 1.0) < 0.3)
    assert abs(np.mean(rho1[inner]) / 1000.0 - 1.0) < 0.05
    # repeated runs on the same launcher are bitwise identical too
    launcher = make_launcher(threads=3)
    again = _density(launcher, grid, x, mass, h, radius)
    assert np.array_equal(again[0].view(np.uint32), rho1.view(np.uint32))


def test_neighbour_lists_identical_across_thread_counts(make_launcher):
    p = _jittered_lattice(12, 0.1, seed=23)
    x = wp.array(p, dtype=wp.vec3, device="cpu")
    ref = NeighbourList(NeighbourGrid(make_launcher(threads=1), 0.26, Space.free(3), x), x)
    for threads in (2, 3):
        lst = NeighbourList(NeighbourGrid(make_launcher(threads=threads), 0.26, Space.free(3), x), x)
        assert np.array_equal(lst.offsets(), ref.offsets())
        assert np.array_equal(lst.indices(), ref.indices())


# --- errors --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_launch_error_propagates(make_launcher, threads):
    """A bad argument fails inside wp.launch (in a worker when threads > 1) and reaches the caller."""
    launcher = make_launcher(threads=threads)
    n = 10
    bad_r = wp.zeros(n, dtype=wp.vec3, device="cpu")  # the kernel expects a float array
    w = wp.zeros(n, dtype=float, device="cpu")
    with pytest.raises(RuntimeError, match="'r'"):
        launcher.launch(kt.eval_w_dwdr, n, [0, 3, bad_r, 1.0, w, w])
    # the launcher is still usable afterwards
    r = wp.array(np.linspace(0.0, 1.0, n).astype(np.float32), dtype=float, device="cpu")
    dw = wp.zeros(n, dtype=float, device="cpu")
    launcher.launch(kt.eval_w_dwdr, n, [0, 3, r, 1.0, w, dw])
    assert np.all(w.numpy() > 0.0) and np.all(dw.numpy() <= 0.0)


def test_exception_in_one_worker_propagates(make_launcher, monkeypatch):
    """Only the last chunk's worker raises; the caller still sees that exception (not a silent partial result)."""
    launcher = make_launcher(threads=3)
    n = 30
    last_first = launcher.chunks(n)[-1][0]
    assert last_first > 0
    real_run = launcher._run
    seen = []

    def flaky_run(kernel, first, count, inputs):
        seen.append(first)
        if first == last_first:
            raise ValueError("boom in worker")
        return real_run(kernel, first, count, inputs)

    r = wp.array(np.linspace(0.0, 1.0, n).astype(np.float32), dtype=float, device="cpu")
    w = wp.zeros(n, dtype=float, device="cpu")
    launcher.launch(kt.eval_w_dwdr, n, [0, 3, r, 1.0, w, w])  # compile/load before patching
    monkeypatch.setattr(launcher, "_run", flaky_run)
    with pytest.raises(ValueError, match="boom in worker"):
        launcher.launch(kt.eval_w_dwdr, n, [0, 3, r, 1.0, w, w])
    assert sorted(seen) == [c[0] for c in launcher.chunks(n)]


def test_close_is_idempotent():
    launcher = Launcher(device="cpu", threads=2, min_items_per_thread=1)
    launcher.close()
    launcher.close()
    assert "threads=2" in repr(launcher)


def test_split_from_measured_time():
    """Measured splitting: a first launch runs whole; a split is tried (over a burst of TRIAL launches) when the
    whole launch is long against the pool's hand-over; then the faster way is taken, the other re-timed every
    RETRY launches; a launch of more than ALWAYS_SPLIT hand-overs is always split; the result is bitwise the
    same either way."""
    from warpfree.device import _Timing

    launcher = Launcher(device="cpu", threads=2)
    try:
        assert launcher.min_items_per_thread is None and launcher.handover_s > 0
        n = 200_000
        r = wp.array(np.linspace(0.0, 3.0, n).astype(np.float32), dtype=float, device="cpu")
        w, dw = wp.zeros(n, dtype=float, device="cpu"), wp.zeros(n, dtype=float, device="cpu")
        args = [sm.kernel_id("cubic_spline"), 3, r, 1.0, w, dw]
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 1  # never timed yet
        launcher.launch(kt.eval_w_dwdr, n, args)
        whole = w.numpy().copy()
        key = Launcher.site(kt.eval_w_dwdr, n, args)
        assert launcher._timings[key].whole is None  # a kernel's first launch is cold: not counted
        for _ in range(Launcher.TRIAL - 1):
            launcher.launch(kt.eval_w_dwdr, n, args)
        assert launcher._timings[key].whole > 0  # then timed: the warm whole launches
        timing = _Timing()
        launcher._timings[key] = timing
        mid = 5.0 * launcher.handover_s / n     # times are kept per item
        timing.add(mid, split=False)             # long against the hand-over: try a split ...
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 2
        assert timing.trial_split and timing.trial_left == Launcher.TRIAL  # ... over a burst of launches
        for _ in range(Launcher.TRIAL):
            launcher.launch(kt.eval_w_dwdr, n, args)
        assert np.array_equal(w.numpy(), whole) and timing.split is not None and timing.trial_left == 0
        timing.split, timing.whole, timing.launches = 2 * mid, mid, 5   # splitting measured slower: run whole
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 1
        timing.launches = Launcher.RETRY          # ... but time the split again now and then
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 2
        timing.trial_left, timing.split, timing.launches = 0, 0.4 * mid, 7
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 2
        timing.split, timing.whole = 2.0 / n, 1.0 / n   # a launch of many hand-overs is split whatever was measured
        assert timing.whole * n > Launcher.ALWAYS_SPLIT * launcher.handover_s
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 2
        timing.split, timing.whole = 0.4 * mid, mid
        short = _Timing()
        short.add(0.5 * launcher.handover_s / n, split=False)  # too short to be worth a try
        launcher._timings[key] = short
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 1
        # a kernel is timed per size class of the item count and per arrays: another power of two or another
        # output array starts untimed; a count in the same class (an open system's, changing every step) shares it
        assert launcher.split_count(kt.eval_w_dwdr, n // 2, args) == 1
        launcher._timings[key] = timing
        assert launcher.split_count(kt.eval_w_dwdr, n, args) == 2
        assert Launcher.site(kt.eval_w_dwdr, n - 1000, args) == key
        assert launcher.split_count(kt.eval_w_dwdr, n - 1000, args) == 2
        assert launcher.split_count(kt.eval_w_dwdr, n, [*args[:4], wp.zeros_like(w), dw]) == 1
    finally:
        launcher.close()


def test_recorded_launches_see_new_arguments(make_launcher):
    """Replayed commands: a changed scalar, a new array and a struct field assigned after recording all reach the
    kernel (the results equal fresh ``wp.launch`` calls)."""
    launcher = make_launcher(threads=2)
    n = 40

    def fresh(args):
        w = wp.zeros(n, dtype=float, device="cpu")
        dw = wp.zeros(n, dtype=float, device="cpu")
        wp.launch(kt.eval_w_dwdr, dim=n, inputs=[0, *args[:4], w, dw], device="cpu")
        return w.numpy(), dw.numpy()

    r = wp.array(np.linspace(0.0, 2.0, n).astype(np.float32), dtype=float, device="cpu")
    w, dw = wp.zeros(n, dtype=float, device="cpu"), wp.zeros(n, dtype=float, device="cpu")
    kid = sm.kernel_id("cubic_spline")
    for args in ([kid, 3, r, 1.0, w, dw], [kid, 3, r, 0.7, w, dw], [kid, 2, r, 0.7, w, dw],
                 [kid, 2, wp.array(np.linspace(0.0, 1.0, n).astype(np.float32), dtype=float, device="cpu"), 0.7, w, dw],
                 [sm.kernel_id("wendland_c2"), 2, r, 1.3, w, dw]):
        launcher.launch(kt.eval_w_dwdr, n, args)
        ref_w, ref_dw = fresh(args)
        assert np.array_equal(w.numpy(), ref_w) and np.array_equal(dw.numpy(), ref_dw)
    # a struct argument: a field assigned after the command was recorded is seen by the replay
    counts = wp.zeros(n, dtype=wp.int32, device="cpu")
    rows = empty_rows(n, "cpu")
    launcher.launch(kt.copy_row_counts, n, [rows, counts])
    assert np.all(counts.numpy() == 0)
    rows.count = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device="cpu")
    launcher.launch(kt.copy_row_counts, n, [rows, counts])
    assert np.array_equal(counts.numpy(), np.arange(n))


def test_recorded_launches_keep_only_the_latest_arrays_alive(make_launcher):
    """A kernel launched over ever new counts and new arrays: the recorded commands (each holding its arguments) stay
    at most ``RECORDED_PER_KERNEL`` for the kernel, so the arrays of older launches are freed (counted by Warp's
    allocation tracker), and the newest still replays."""
    import gc

    from warp._src.context import runtime

    launcher = make_launcher(threads=2)
    core = runtime.core
    gc.collect()
    core.wp_alloc_tracker_enable(1)
    core.wp_alloc_tracker_reset()
    try:
        kid = sm.kernel_id("cubic_spline")
        launches = 4 * launcher.RECORDED_PER_KERNEL
        for k in range(launches):
            n = 100 + k  # a new count: new keys for every chunk
            args = [kid, 2, wp.zeros(n, dtype=float, device="cpu"), 1.0, wp.zeros(n, dtype=float, device="cpu"),
                    wp.zeros(n, dtype=float, device="cpu")]
            launcher.launch(kt.eval_w_dwdr, n, args)
            launcher.launch(kt.eval_w_dwdr, n, args)  # the second launch with these arrays records its commands
            del args
        gc.collect()
        live = core.wp_alloc_tracker_get_current_bytes()
        kept = len(launcher._recorded[kt.eval_w_dwdr])
        assert kept <= launcher.RECORDED_PER_KERNEL
        # each recorded command holds one launch's three arrays of about 4 (100 + k) bytes
        assert live < (launcher.RECORDED_PER_KERNEL + 1) * 3 * 4 * (100 + launches) < 0.5 * 3 * 4 * 100 * launches
    finally:
        core.wp_alloc_tracker_enable(0)


def test_fixed_split_rule():
    """``min_items_per_thread`` = m: at least m items per chunk, at most one chunk per thread."""
    launcher = Launcher(device="cpu", threads=2, min_items_per_thread=2048)
    try:
        assert launcher.chunks(4000) == [(0, 4000)]
        assert launcher.chunks(4096) == [(0, 2048), (2048, 2048)]
        assert launcher.split_count(kt.eval_w_dwdr, 4000) == 1
        assert launcher.split_count(kt.eval_w_dwdr, 4096) == 2
    finally:
        launcher.close()
