"""Smoothing kernels (kernels/smoothing.py): normalisation, positivity, compact support, continuity,
dW/dr and gradient against finite differences, gradient antisymmetry, and discrete lattice sums.

The ``@wp.func`` kernels are evaluated through the test kernels in ``kernels_for_tests.py`` (float32);
the checks run in NumPy (float64).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from helpers import kernels_for_tests as kt
from warpfree.kernels import smoothing as sm
from warpfree.neighbours import NeighbourGrid
from warpfree.space import Space

NAMES = ["cubic_spline", "wendland_c2", "quintic_spline"]
DIMS = [1, 2, 3]
CASES = [(name, dim) for name in NAMES for dim in DIMS]
IDS = [f"{name}-{dim}d" for name, dim in CASES]


# --- NumPy reference (float64) from the formulas in the module docstring ------------------------------

SIGMA = {
    "cubic_spline": {1: 2.0 / 3.0, 2: 10.0 / (7.0 * math.pi), 3: 1.0 / math.pi},
    "wendland_c2": {1: 5.0 / 8.0, 2: 7.0 / (4.0 * math.pi), 3: 21.0 / (16.0 * math.pi)},
    "quintic_spline": {1: 1.0 / 120.0, 2: 7.0 / (478.0 * math.pi), 3: 1.0 / (120.0 * math.pi)},
}


def shape_ref(name: str, dim: int, q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    if name == "cubic_spline":
        return np.where(q < 1.0, 1.0 - 1.5 * q**2 + 0.75 * q**3, 0.25 * np.clip(2.0 - q, 0.0, None) ** 3)
    if name == "wendland_c2":
        t = np.clip(1.0 - 0.5 * q, 0.0, None)
        return t**3 * (1.5 * q + 1.0) if dim == 1 else t**4 * (2.0 * q + 1.0)

    def p(a):
        return np.clip(a - q, 0.0, None) ** 5

    return p(3.0) - 6.0 * p(2.0) + 15.0 * p(1.0)


def w_ref(name: str, dim: int, r: np.ndarray, h: float) -> np.ndarray:
    return SIGMA[name][dim] / h**dim * shape_ref(name, dim, np.asarray(r) / h)


# --- Warp evaluation helpers -------------------------------------------------------------------------


def eval_w(launcher, name: str, dim: int, r, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(W, dW/dr) at float32 radii ``r`` as float64 arrays."""
    r32 = np.ascontiguousarray(np.asarray(r, dtype=np.float32).ravel())
    n = r32.shape[0]
    r_wp = wp.array(r32, dtype=float, device="cpu")
    w = wp.zeros(n, dtype=float, device="cpu")
    dw = wp.zeros(n, dtype=float, device="cpu")
    launcher.launch(kt.eval_w_dwdr, n, [sm.kernel_id(name), dim, r_wp, float(h), w, dw])
    return w.numpy().astype(np.float64), dw.numpy().astype(np.float64)


def eval_point(launcher, name: str, dim: int, x, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(W(|x|), ∇W(x)) for float32 points ``x`` (N, 3)."""
    x32 = np.ascontiguousarray(np.asarray(x, dtype=np.float32).reshape(-1, 3))
    n = x32.shape[0]
    x_wp = wp.array(x32, dtype=wp.vec3, device="cpu")
    w = wp.zeros(n, dtype=float, device="cpu")
    g = wp.zeros(n, dtype=wp.vec3, device="cpu")
    launcher.launch(kt.eval_point, n, [sm.kernel_id(name), dim, x_wp, float(h), w, g])
    return w.numpy().astype(np.float64), g.numpy().astype(np.float64)


def support_radius_f32(name: str, h: float) -> np.float32:
    """Smallest float32 r with r >= kappa*h32 in exact arithmetic (so r/h rounds to >= kappa)."""
    kappa = sm.support_factor(name)
    h32 = float(np.float32(h))
    r = np.float32(kappa * h32)
    while float(r) < kappa * h32:
        r = np.nextafter(r, np.float32(np.inf))
    return r


def breakpoints(name: str) -> list[float]:
    kappa = sm.support_factor(name)
    return [b for b in (1.0, 2.0, 3.0) if b <= kappa]


def fd4(values: np.ndarray, step: float) -> np.ndarray:
    """Fourth-order central difference from values at offsets (-2, -1, +1, +2) * step (axis 0)."""
    m2, m1, p1, p2 = values
    return (m2 - 8.0 * m1 + 8.0 * p1 - p2) / (12.0 * step)


# --- API ---------------------------------------------------------------------------------------------


def test_names_ids_and_support_factors():
    assert [sm.kernel_id(n) for n in NAMES] == [int(sm.CUBIC_SPLINE), int(sm.WENDLAND_C2), int(sm.QUINTIC_SPLINE)]
    assert [sm.support_factor(n) for n in NAMES] == [2.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="kernel"):
        sm.kernel_id("gaussian")
    with pytest.raises(ValueError, match="kernel"):
        sm.support_factor("gaussian")


# --- per kernel and dimension --------------------------------------------------------------------------


@pytest.mark.parametrize("h", [0.7, 0.013])
@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_normalisation(launcher, name, dim, h):
    """∫ W dV = 1 by radial Gauss-Legendre quadrature, exact on each polynomial piece."""
    nodes, weights = np.polynomial.legendre.leggauss(12)
    q_all, wq_all = [], []
    edges = [0.0] + breakpoints(name)
    for a, b in zip(edges[:-1], edges[1:]):
        q_all.append(0.5 * (b - a) * nodes + 0.5 * (a + b))
        wq_all.append(0.5 * (b - a) * weights)
    q = np.concatenate(q_all)
    wq = np.concatenate(wq_all)
    r = (q * h).astype(np.float32).astype(np.float64)  # the radii Warp actually sees
    w, _ = eval_w(launcher, name, dim, r, h)
    radial = {1: 2.0 * np.ones_like(r), 2: 2.0 * np.pi * r, 3: 4.0 * np.pi * r**2}[dim]
    integral = float(np.sum(wq * h * w * radial))
    assert integral == pytest.approx(1.0, rel=1e-5)


@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_values_match_documented_formula(launcher, name, dim):
    h = 0.37
    kappa = sm.support_factor(name)
    q = np.linspace(0.0, kappa + 0.5, 3001)
    r = (q * h).astype(np.float32).astype(np.float64)
    w, _ = eval_w(launcher, name, dim, r, h)
    ref = w_ref(name, dim, r, h)
    w0 = SIGMA[name][dim] / h**dim * float(shape_ref(name, dim, 0.0))
    np.testing.assert_allclose(w, ref, rtol=1e-5, atol=1e-6 * w0)
    # W(0) = sigma_d * f(0): 1 (cubic), 1 (Wendland C2), 66 (quintic)
    assert w[0] == pytest.approx(w0, rel=1e-6)


@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_nonnegative_and_compact_support(launcher, name, dim):
    h = 0.7
    kappa = sm.support_factor(name)
    r_sup = support_radius_f32(name, h)
    q = np.linspace(0.0, kappa + 1.0, 4001)
    w, _ = eval_w(launcher, name, dim, q * h, h)
    assert np.all(w >= 0.0)
    assert np.all(w[q < kappa * (1 - 1e-3)] > 0.0), "W must be positive inside its support"

    # at and beyond r = kappa*h: exactly zero value and derivative
    beyond = np.concatenate([[r_sup], r_sup * np.linspace(1.0, 3.0, 200)[1:], [1.0e3 * h]])
    w, dw = eval_w(launcher, name, dim, beyond, h)
    assert np.all(w == 0.0) and np.all(dw == 0.0)
    # the gradient vector vanishes there too (any direction)
    rng = np.random.default_rng(1)
    d = rng.normal(size=(len(beyond), 3))
    if dim == 1:
        d[:, 1:] = 0.0
    elif dim == 2:
        d[:, 2] = 0.0
    d /= np.linalg.norm(d, axis=1)[:, None]
    x = d * (beyond[:, None] * (1 + 1e-5))  # 1e-5 margin: |x| in float32 must stay >= kappa*h
    _, g = eval_point(launcher, name, dim, x, h)
    assert np.all(g == 0.0)


@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_continuity_at_breakpoints(launcher, name, dim):
    """W and dW/dr are continuous at q = 1, 2 (and 3) and tend to zero at the support radius."""
    h = 0.5
    eps = 1e-5
    w0 = SIGMA[name][dim] / h**dim * float(shape_ref(name, dim, 0.0))
    q_dense = np.linspace(0.0, sm.support_factor(name), 2001)
    _, dw_dense = eval_w(launcher, name, dim, q_dense * h, h)
    dmax = np.max(np.abs(dw_dense))
    for b in (1.0, 2.0):
        q = np.array([b * (1 - eps), b, b * (1 + eps)])
        w, dw = eval_w(launcher, name, dim, q * h, h)
        assert abs(w[2] - w[0]) <= 1e-4 * w0, f"W jumps at q={b}: {w}"
        assert abs(w[1] - w[0]) <= 1e-4 * w0 and abs(w[2] - w[1]) <= 1e-4 * w0
        assert abs(dw[2] - dw[0]) <= 1e-3 * dmax, f"dW/dr jumps at q={b}: {dw}"
        assert abs(dw[1] - dw[0]) <= 1e-3 * dmax and abs(dw[2] - dw[1]) <= 1e-3 * dmax
    kappa = sm.support_factor(name)
    w, dw = eval_w(launcher, name, dim, [kappa * (1 - eps) * h], h)
    assert 0.0 <= w[0] <= 1e-4 * w0
    assert abs(dw[0]) <= 1e-3 * dmax


@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_dwdr_against_finite_differences(launcher, name, dim):
    h = 0.5
    kappa = sm.support_factor(name)
    grid_step = 2.0**-10  # radii on an exact float32 lattice: r +- k*step are exact
    step = h / 64.0  # 2**-7, a multiple of grid_step
    r = np.arange(1, int(round(kappa * h / grid_step))) * grid_step
    q = r / h
    far_from_kinks = np.all(np.abs(q[:, None] - np.array([0.0] + breakpoints(name))[None, :]) > 2.5 * step / h,
                            axis=1)
    r = r[far_from_kinks]
    offsets = np.array([-2.0, -1.0, 1.0, 2.0])
    w_st, _ = eval_w(launcher, name, dim, (r[None, :] + offsets[:, None] * step).ravel(), h)
    fd = fd4(w_st.reshape(4, -1), step)
    _, dw = eval_w(launcher, name, dim, r, h)
    dmax = np.max(np.abs(dw))
    assert dmax > 0.0
    big = np.abs(dw) > 0.05 * dmax
    assert big.sum() > 0.5 * len(r)
    rel = np.abs(fd[big] - dw[big]) / np.abs(dw[big])
    assert rel.max() < 1e-3, f"max relative error {rel.max():.2e} at r={r[big][np.argmax(rel)]}"
    assert np.max(np.abs(fd[~big] - dw[~big])) < 1e-3 * dmax
    # dW/dr <= 0 (monotone kernels) and exactly 0 at r = 0
    assert np.all(dw <= 0.0)
    _, dw0 = eval_w(launcher, name, dim, [0.0], h)
    assert dw0[0] == 0.0


@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_gradient_antisymmetric_and_zero_at_origin(launcher, name, dim):
    h = 0.3
    kappa = sm.support_factor(name)
    rng = np.random.default_rng(7)
    rij = rng.uniform(-1.0, 1.0, size=(500, 3))
    if dim < 3:
        rij[:, dim:] = 0.0
    rij *= (kappa * h * rng.uniform(0.0, 1.1, size=500) / np.linalg.norm(rij, axis=1))[:, None]
    rij = rij.astype(np.float32)
    _, g_ij = eval_point(launcher, name, dim, rij, h)
    _, g_ji = eval_point(launcher, name, dim, -rij, h)
    assert np.array_equal(g_ij, -g_ji)
    # pointing from j to i: ∇_i W = (dW/dr) r_ij / r with dW/dr <= 0, so g . r_ij <= 0
    assert np.all(np.sum(g_ij * rij, axis=1) <= 0.0)
    assert np.any(np.sum(g_ij * rij, axis=1) < 0.0)
    if dim < 3:
        assert np.all(g_ij[:, dim:] == 0.0)
    w, g0 = eval_point(launcher, name, dim, np.zeros((1, 3)), h)
    assert np.all(g0 == 0.0) and np.all(np.isfinite(w)) and w[0] > 0.0
    # close to (but not at) r = 0 the gradient is still dW/dr r_ij/r: no dead zone around the origin
    q_small = np.array([1e-4, 1e-3, 1e-2, 3e-2])
    e = np.zeros(3)
    e[:dim] = 1.0 / np.sqrt(dim)
    x_small = (q_small[:, None] * h) * e[None, :]
    _, g_small = eval_point(launcher, name, dim, x_small, h)
    _, dw_small = eval_w(launcher, name, dim, np.linalg.norm(x_small.astype(np.float32), axis=1), h)
    assert np.all(dw_small < 0.0)
    np.testing.assert_allclose(g_small, dw_small[:, None] * e[None, :], rtol=1e-4, atol=0.0)


@pytest.mark.parametrize("name,dim", [c for c in CASES if c[1] > 1], ids=[i for c, i in zip(CASES, IDS) if c[1] > 1])
def test_gradient_vector_against_finite_differences(launcher, name, dim):
    """Each component of ∇W(x) against a 4th-order difference of W(|x|) in x, y (and z)."""
    h = 0.5
    kappa = sm.support_factor(name)
    step = h / 64.0
    rng = np.random.default_rng(3)
    # points on an exact float32 lattice (multiples of 2**-12), so x +- k*step is exact
    x = rng.integers(-int(kappa * h * 4096), int(kappa * h * 4096), size=(6000, 3)) / 4096.0
    if dim == 2:
        x[:, 2] = 0.0
    q = np.linalg.norm(x, axis=1) / h
    kinks = np.array([0.0] + breakpoints(name))
    keep = (q < kappa) & np.all(np.abs(q[:, None] - kinks[None, :]) > 2.5 * step / h + 1e-3, axis=1)
    x = x[keep][:1500]
    w, g = eval_point(launcher, name, dim, x, h)
    _, dw = eval_w(launcher, name, dim, np.linalg.norm(x, axis=1), h)
    dmax = np.max(np.abs(dw))
    fd = np.zeros_like(g)
    offsets = np.array([-2.0, -1.0, 1.0, 2.0])
    for k in range(dim):
        shifted = np.repeat(x[None, :, :], 4, axis=0)
        shifted[:, :, k] += offsets[:, None] * step
        w_st, _ = eval_point(launcher, name, dim, shifted.reshape(-1, 3), h)
        fd[:, k] = fd4(w_st.reshape(4, -1), step)
    err = np.linalg.norm(fd - g, axis=1)
    gnorm = np.linalg.norm(g, axis=1)
    big = gnorm > 0.05 * dmax
    assert big.sum() > 0.25 * len(x)
    assert np.max(err[big] / gnorm[big]) < 1e-3
    assert np.max(err[~big]) < 1e-3 * dmax
    # |∇W| = |dW/dr|
    np.testing.assert_allclose(gnorm, np.abs(dw), rtol=1e-5, atol=1e-6 * dmax)
    if dim == 2:
        assert np.all(g[:, 2] == 0.0)


# --- discrete lattice sums -----------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", NAMES)
def test_lattice_partition_of_unity(launcher, name, dim):
    """Σ_j V_j W_ij ≈ 1 (2 %) and Σ_j V_j ∇W_ij ≈ 0 for interior particles of a lattice, h = 1.3 dx."""
    dx = 0.02
    h = 1.3 * dx
    radius = sm.support_factor(name) * h
    layers = int(math.ceil(radius / dx)) + 1  # particles this many layers in see a full support
    m = 2 * layers + 3
    idx = np.stack(np.meshgrid(*[np.arange(m)] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    pts = np.zeros((idx.shape[0], 3))
    pts[:, :dim] = -0.37 + idx * dx  # negative coordinates, not aligned with the hash cells
    x = wp.array(pts.astype(np.float32), dtype=wp.vec3, device="cpu")
    grid = NeighbourGrid(launcher, radius, Space.free(dim), x)
    n = idx.shape[0]
    vol = wp.array(np.full(n, dx**dim, dtype=np.float32), dtype=float, device="cpu")
    sum_w = wp.zeros(n, dtype=float, device="cpu")
    sum_g = wp.zeros(n, dtype=wp.vec3, device="cpu")
    launcher.launch(kt.kernel_sums, n, [sm.kernel_id(name), dim, grid.id, x, grid.radius, h, radius,
                                        vol, sum_w, sum_g])
    interior = np.all((idx >= layers) & (idx < m - layers), axis=1)
    assert interior.sum() >= 3**dim
    s = sum_w.numpy()[interior]
    g = sum_g.numpy()[interior]
    assert np.all(np.abs(s - 1.0) < 0.02), f"Σ V W in [{s.min():.4f}, {s.max():.4f}]"
    # the gradient sum cancels by symmetry; scale: Σ V |∇W| ~ 1/h
    assert np.max(np.linalg.norm(g, axis=1)) * h < 1e-4
    # and boundary particles are visibly deficient (the sums really are local)
    corner = np.all(idx == 0, axis=1)
    assert sum_w.numpy()[corner][0] < 0.8


# --- kernel_grad_coef (fast gradient form), when present -----------------------------------------------

needs_grad_coef = pytest.mark.skipif(not hasattr(kt, "eval_grad_coef"), reason="no kernel_grad_coef")


def eval_grad_coef(launcher, name: str, dim: int, x, h: float) -> tuple[np.ndarray, np.ndarray]:
    x32 = np.ascontiguousarray(np.asarray(x, dtype=np.float32).reshape(-1, 3))
    n = x32.shape[0]
    coef = wp.zeros(n, dtype=float, device="cpu")
    g = wp.zeros(n, dtype=wp.vec3, device="cpu")
    launcher.launch(kt.eval_grad_coef, n, [sm.kernel_id(name), dim, wp.array(x32, dtype=wp.vec3, device="cpu"),
                                           float(h), coef, g])
    return coef.numpy().astype(np.float64), g.numpy().astype(np.float64)


@needs_grad_coef
@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_grad_coef_matches_kernel_grad(launcher, name, dim):
    """(σ_d/h²) (df/dq)/q · r_ij equals kernel_grad, vanishes beyond the support and is continuous."""
    h = 0.4
    kappa = sm.support_factor(name)
    rng = np.random.default_rng(17)
    d = rng.normal(size=(3000, 3))
    d[:, dim:] = 0.0
    d /= np.linalg.norm(d, axis=1)[:, None]
    q = np.concatenate([rng.uniform(0.01, kappa + 1.0, size=2990), [0.0, 1.0, 2.0, 3.0, kappa * 1.001, 5.0,
                                                                    0.999, 1.001, 1.999, 2.001]])
    x = d * (q * h)[:, None]
    coef, g_fast = eval_grad_coef(launcher, name, dim, x, h)
    _, g = eval_point(launcher, name, dim, x, h)
    gmax = np.max(np.linalg.norm(g, axis=1))
    # atol: near q = 0 the quintic f'(q) cancels (405, 480, 75 -> O(q)), ~1e-6 of the gradient scale in float32
    np.testing.assert_allclose(g_fast, g, rtol=1e-5, atol=1e-5 * gmax)
    assert np.all(coef[q > kappa] == 0.0) and np.all(g_fast[q > kappa] == 0.0)
    assert np.all(coef[(q > 0.0) & (q < kappa * 0.999)] < 0.0)  # q = 0: see test_grad_coef_limit_at_origin
    for b in breakpoints(name):
        if b < kappa:
            c = eval_grad_coef(launcher, name, dim, np.array([[b * (1 - 1e-5), 0, 0], [b * (1 + 1e-5), 0, 0]]) * h,
                               h)[0]
            assert abs(c[1] - c[0]) <= 1e-3 * np.max(np.abs(coef)), f"(df/dq)/q jumps at q={b}: {c}"


@needs_grad_coef
@pytest.mark.parametrize("name,dim", CASES, ids=IDS)
def test_grad_coef_limit_at_origin(launcher, name, dim):
    """(df/dq)/q at q = 0 is its limit f''(0) (-3 cubic, -5 / -3 (1D) Wendland C2, -120 quintic), and
    small q stays accurate in float32."""
    limit = {"cubic_spline": -3.0, "wendland_c2": -3.0 if dim == 1 else -5.0, "quintic_spline": -120.0}[name]
    q = np.array([0.0, 1e-6, 1e-4, 1e-3])
    x = np.zeros((len(q), 3))
    x[:, 0] = q * 0.5
    coef, _ = eval_grad_coef(launcher, name, dim, x, 0.5)
    np.testing.assert_allclose(coef, limit, rtol=1e-2)
