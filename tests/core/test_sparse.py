"""Sparse assembly and solves (warpfree/sparse.py, kernels/assembly.py).

The test problem is -u'' = f on [0, 1], f = f0 + f1 x, linear finite elements on a non-uniform node set,
2-point Gauss rule: per Gauss point q of element e (length h, Jacobian h/2, weight 1)

    K[e+a, e+c] += (h/2) dN_a/dx dN_c/dx,   dN/dx = (-1/h, 1/h)
    b[e+a]      += (h/2) f(x_q) N_a(x_q)

assembled by a Warp kernel into per-Gauss-point slots (4 triplets, 2 loads) and by NumPy densely.
Linear FEM is nodally exact for constant f: u = a + (b - a) x + f0 x (1 - x) / 2.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import warp as wp

import warpfree.sparse as wsp
from warpfree.errors import ParameterError
from warpfree.kernels.assembly import Loads, Triplets, write_load, write_triplet

GAUSS_XI = 0.5773502691896257645  # 1/sqrt(3)


@wp.kernel
def assemble_laplacian_1d(first: int, x: wp.array(dtype=wp.float64), f0: wp.float64, f1: wp.float64,
                          K: Triplets, b: Loads):
    g = first + wp.tid()  # Gauss point: element g // 2, point g % 2
    e = g // 2
    xi = wp.float64(GAUSS_XI)
    if g % 2 == 0:
        xi = -xi
    h = x[e + 1] - x[e]
    jac = h / wp.float64(2.0)
    n = wp.vector(wp.float64(0.5) * (wp.float64(1.0) - xi), wp.float64(0.5) * (wp.float64(1.0) + xi))
    dn = wp.vector(wp.float64(-1.0) / h, wp.float64(1.0) / h)
    f = f0 + f1 * (x[e] + jac * (xi + wp.float64(1.0)))
    for a in range(2):
        write_load(b, 2 * g + a, e + a, jac * f * n[a])
        for c in range(2):
            write_triplet(K, 4 * g + 2 * a + c, e + a, e + c, jac * dn[a] * dn[c])


def nodes(n_elements: int = 30, seed: int = 1) -> np.ndarray:
    """Non-uniform nodes on [0, 1] (float64), ends included."""
    x = np.sort(np.random.default_rng(seed).uniform(0.0, 1.0, n_elements - 1))
    return np.concatenate([[0.0], x, [1.0]])


def dense_assembly(x: np.ndarray, f0: float, f1: float) -> tuple[np.ndarray, np.ndarray]:
    n = len(x)
    K, b = np.zeros((n, n)), np.zeros(n)
    for e in range(n - 1):
        h = x[e + 1] - x[e]
        for xi in (-GAUSS_XI, GAUSS_XI):
            shape = np.array([0.5 * (1 - xi), 0.5 * (1 + xi)])
            grad = np.array([-1.0, 1.0]) / h
            xq = x[e] + 0.5 * h * (xi + 1)
            K[e:e + 2, e:e + 2] += 0.5 * h * np.outer(grad, grad)
            b[e:e + 2] += 0.5 * h * (f0 + f1 * xq) * shape
    return K, b


def warp_assembly(launcher, x: np.ndarray, f0: float, f1: float):
    n_gauss = 2 * (len(x) - 1)
    K, b = wsp.TripletBuffer(4 * n_gauss, "cpu"), wsp.LoadBuffer(2 * n_gauss, "cpu")
    launcher.launch(assemble_laplacian_1d, n_gauss,
                    inputs=[wp.array(x, dtype=wp.float64, device="cpu"), f0, f1, K.triplets, b.loads])
    return K, b


def analytic(x, f0, a, b):
    return a + (b - a) * x + 0.5 * f0 * x * (1 - x)


def ends(n: int, a: float, b: float) -> wsp.PrescribedValues:
    return wsp.PrescribedValues([0, n - 1], [a, b], n)


def dense_reduced_solve(K, b, prescribed: wsp.PrescribedValues) -> np.ndarray:
    f, p = prescribed.free, prescribed.indices
    u = np.empty(len(b))
    u[p] = prescribed.values
    u[f] = np.linalg.solve(K[np.ix_(f, f)], b[f] - K[np.ix_(f, p)] @ prescribed.values)
    return u


# --- assembly ----------------------------------------------------------------------------------------


def test_assembly_matches_numpy_and_is_bitwise_identical_across_threads(make_launcher):
    x = nodes()
    K_ref, b_ref = dense_assembly(x, 2.0, -3.0)
    results = []
    for threads in (1, 2, 3):
        K_slots, b_slots = warp_assembly(make_launcher(threads), x, 2.0, -3.0)
        K = wsp.to_csr(K_slots, (len(x), len(x)))
        b = wsp.load_vector(b_slots, len(x))
        assert K.dtype == np.float64 and b.dtype == np.float64
        np.testing.assert_allclose(K.toarray(), K_ref, rtol=0, atol=1e-12 * np.abs(K_ref).max())
        np.testing.assert_allclose(b, b_ref, rtol=0, atol=1e-12 * np.abs(b_ref).max())
        results.append((K_slots.numpy(), b_slots.numpy(), K, b))
    for slots_K, slots_b, K, b in results[1:]:
        for got, want in zip((*slots_K, *slots_b), (*results[0][0], *results[0][1])):
            assert np.array_equal(got, want)
        assert np.array_equal(K.indptr, results[0][2].indptr) and np.array_equal(K.indices, results[0][2].indices)
        assert np.array_equal(K.data, results[0][2].data) and np.array_equal(b, results[0][3])


def test_buffers_start_unused_and_convert_to_empty():
    K, b = wsp.TripletBuffer(5), wsp.LoadBuffer(3)
    assert np.all(K.rows.numpy() == -1) and np.all(b.rows.numpy() == -1)
    assert wsp.to_csr(K, (4, 4)).nnz == 0
    assert np.array_equal(wsp.load_vector(b, 4), np.zeros(4))
    with pytest.raises(ParameterError, match="n_slots"):
        wsp.TripletBuffer(-1)


def test_to_csr_sums_duplicates_and_drops_unused_slots():
    rows = np.array([0, 1, -1, 0, 2, 1, -1], dtype=np.int32)
    cols = np.array([0, 2, 5, 0, 1, 2, -7], dtype=np.int32)
    vals = np.array([1.0, 2.0, 99.0, 0.5, -4.0, 0.25, np.nan])
    K = wsp.to_csr((rows, cols, vals), (3, 3))
    assert isinstance(K, sp.csr_matrix) and K.dtype == np.float64
    assert np.array_equal(K.toarray(), [[1.5, 0, 0], [0, 0, 2.25], [0, -4.0, 0]])
    K_warp = wsp.to_csr(tuple(wp.array(a, device="cpu") for a in (rows, cols, vals)), (3, 3))
    assert np.array_equal(K_warp.toarray(), K.toarray())
    b = wsp.load_vector((rows, vals), 3)
    assert np.array_equal(b, [1.5, 2.25, -4.0])


@pytest.mark.parametrize(
    "rows, cols, values, name",
    [
        ([0, -2], [0, 0], [1.0, 1.0], "rows"),
        ([0, 3], [0, 0], [1.0, 1.0], "rows"),
        ([0, 1], [0, 3], [1.0, 1.0], "cols"),
        ([0, 1], [-1, 0], [1.0, 1.0], "cols"),
        ([0, 1], [0, 0], [1.0, np.inf], "values"),
        ([0, 1], [0], [1.0, 1.0], "triplets"),
    ],
)
def test_to_csr_rejects_bad_indices_naming_the_array(rows, cols, values, name):
    with pytest.raises(ParameterError, match=f"^{name}:"):
        wsp.to_csr((np.array(rows), np.array(cols), np.array(values)), (3, 3))


def test_load_vector_rejects_bad_rows():
    with pytest.raises(ParameterError, match="^rows:"):
        wsp.load_vector((np.array([0, 4]), np.array([1.0, 1.0])), 4)


# --- prescribed values and the factorised direct solve ----------------------------------------------


@pytest.mark.parametrize(
    "indices, values, name",
    [([0, 0], [1.0, 2.0], "indices"), ([0, 10], [1.0, 2.0], "indices"), ([-1], [1.0], "indices"),
     ([0.5], [1.0], "indices"), ([0, 9], [1.0, np.nan], "values"), ([0, 9], [1.0], "values")],
)
def test_prescribed_values_validation(indices, values, name):
    with pytest.raises(ParameterError, match=f"^{name}:"):
        wsp.PrescribedValues(indices, values, 10)


def test_elimination_solve_matches_dense_and_analytic(launcher):
    x = nodes()
    n, f0, a, b = len(x), 3.0, 0.5, -1.25
    K_slots, b_slots = warp_assembly(launcher, x, f0, 0.0)
    K, load = wsp.to_csr(K_slots, (n, n)), wsp.load_vector(b_slots, n)
    prescribed = ends(n, a, b)
    u = wsp.FactorisedSystem(K, prescribed).solve(load)
    assert u[0] == a and u[-1] == b
    np.testing.assert_allclose(u, dense_reduced_solve(K.toarray(), load, prescribed), rtol=0, atol=1e-10)
    np.testing.assert_allclose(u, analytic(x, f0, a, b), rtol=0, atol=1e-10)
    # the reduced system alone: K_ff u_f = b_f - K_fp u_p
    K_ff, rhs = prescribed.reduce(K, load)
    np.testing.assert_allclose(K_ff @ u[prescribed.free], rhs, rtol=0, atol=1e-10)


def test_many_right_hand_sides_one_factorisation(launcher, monkeypatch):
    calls = []
    splu = wsp.spla.splu
    monkeypatch.setattr(wsp.spla, "splu", lambda A: calls.append(A.shape) or splu(A))
    x = nodes(40, seed=2)
    n = len(x)
    K = wsp.to_csr(warp_assembly(launcher, x, 0.0, 0.0)[0], (n, n))
    system = wsp.FactorisedSystem(K, ends(n, 0.0, 0.0))
    cases = [(1.0, 0.0, 0.0), (-2.0, 1.0, 3.0), (0.0, -0.5, 0.5), (7.5, 2.0, -1.0)]
    for f0, a, b in cases:
        load = wsp.load_vector(warp_assembly(launcher, x, f0, 0.0)[1], n)
        u = system.solve(load, [a, b])
        np.testing.assert_allclose(u, analytic(x, f0, a, b), rtol=0, atol=1e-10)
    assert len(calls) == 1 and system.counts == {"factorise": 1, "solve": len(cases)}
    assert system.timings["factorise"] > 0 and system.timings["solve"] >= system.timings["last_solve"] > 0
    np.testing.assert_array_equal(system.prescribed.values, [0.0, 0.0])  # solve(values=...) left them
    with pytest.raises(ParameterError, match="^values:"):
        system.solve(load, [1.0, 2.0, 3.0])
    with pytest.raises(ParameterError, match="^b:"):
        system.solve(load[:-1])


def test_all_unknowns_prescribed():
    K = sp.identity(3, format="csr")
    u = wsp.FactorisedSystem(K, wsp.PrescribedValues([2, 0, 1], [3.0, 1.0, 2.0], 3)).solve(np.zeros(3))
    assert np.array_equal(u, [1.0, 2.0, 3.0])


def test_pure_neumann_problem_is_reported_as_singular(launcher):
    x = nodes()
    n = len(x)
    K = wsp.to_csr(warp_assembly(launcher, x, 0.0, 0.0)[0], (n, n))
    with pytest.raises(ParameterError, match="singular.*prescribe at least one value"):
        wsp.FactorisedSystem(K, wsp.PrescribedValues([], [], n))
    exactly_singular = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 2.0]]))
    with pytest.raises(ParameterError, match="singular"):
        wsp.FactorisedSystem(exactly_singular, wsp.PrescribedValues([], [], 3))


def test_symmetric_pattern_factorisation_solves_a_saddle_point_and_still_detects_singularity():
    """The ordering for symmetric patterns with threshold pivoting: a KKT system [[K, G], [Gᵀ, 0]] (zero diagonal
    block) solved as by the default COLAMD factorisation; a singular matrix is still refused."""
    rng = np.random.default_rng(3)
    a = sp.random(60, 60, density=0.1, random_state=4)
    K = (a @ a.T + 60 * sp.identity(60)).tocsr()
    G = sp.random(60, 8, density=0.3, random_state=5).tocsr() + sp.eye(60, 8)
    kkt = sp.bmat([[K, G], [G.T, None]]).tocsr()
    b = rng.standard_normal(68)
    none = wsp.PrescribedValues([], [], 68)
    x_sym = wsp.FactorisedSystem(kkt, none, symmetric_pattern=True).solve(b)
    x_ref = wsp.FactorisedSystem(kkt, none).solve(b)
    assert np.abs(x_sym - x_ref).max() < 1e-10 * np.abs(x_ref).max()
    assert np.abs(kkt @ x_sym - b).max() < 1e-10 * np.abs(b).max()
    singular = sp.bmat([[K, G], [G.T, None]]).tolil()
    singular[:, 60] = 0.0
    singular[60, :] = 0.0
    with pytest.raises(ParameterError) as err:
        wsp.FactorisedSystem(singular.tocsr(), none, symmetric_pattern=True)
    assert err.value.name == "K"
