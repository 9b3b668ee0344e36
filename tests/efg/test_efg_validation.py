"""EFG validation references (warpfree/validation/efg_*): the Timoshenko beam and the Lamé cylinder are exact
elasticity solutions (checked here against the gradient, Hooke's law, equilibrium and the boundary conditions
with finite differences and quadrature); Cook's membrane ships a Q9 FEM reference whose CSV is checked for
convergence and whose script is run on a tiny mesh."""

from __future__ import annotations

import time

import numpy as np
import pytest

from warpfree.validation import efg_cook as cook
from warpfree.validation import efg_cylinder as cyl
from warpfree.validation import efg_plate_hole as hole
from warpfree.validation import efg_timoshenko as beam
from warpfree.validation.efg_cook import reference_fem


def fd_gradient(field, points: np.ndarray, step: float) -> np.ndarray:
    """Five-point central differences (exact for quartics) of a vector field (n, 2) -> (n, 2, 2) ∂f_i/∂x_j."""
    grads = []
    for j in range(2):
        h = np.zeros(2)
        h[j] = step
        near = field(points + h) - field(points - h)
        far = field(points + 2 * h) - field(points - 2 * h)
        grads.append((8.0 * near - far) / (12.0 * step))
    return np.stack(grads, axis=-1)


def engineering_strain(grad: np.ndarray) -> np.ndarray:
    """[u_x,x, u_y,y, u_x,y + u_y,x] of a displacement gradient (n, 2, 2)."""
    return np.column_stack([grad[:, 0, 0], grad[:, 1, 1], grad[:, 0, 1] + grad[:, 1, 0]])


def stress_divergence(stress_fn, points: np.ndarray, step: float) -> np.ndarray:
    """(∂σxx/∂x + ∂σxy/∂y, ∂σxy/∂x + ∂σyy/∂y) by central differences. -> (n, 2)."""
    dx = (stress_fn(points + [step, 0.0]) - stress_fn(points - [step, 0.0])) / (2.0 * step)
    dy = (stress_fn(points + [0.0, step]) - stress_fn(points - [0.0, step])) / (2.0 * step)
    return np.column_stack([dx[:, 0] + dy[:, 2], dx[:, 2] + dy[:, 1]])


def gauss_line(a: float, b: float, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (b - a) * (t + 1.0) + a, 0.5 * (b - a) * w


# ---------------------------------------------------------------- Timoshenko beam (Rocha (2012) §5.1)

E, NU, DEPTH, LENGTH, LOAD = (beam.DEFAULTS[k] for k in ("E", "nu", "D", "L", "P"))
RNG = np.random.default_rng(3)
BEAM_POINTS = np.column_stack([RNG.uniform(0.0, LENGTH, 50), RNG.uniform(-DEPTH / 2, DEPTH / 2, 50)])


def test_beam_displacements_match_the_note():
    pts = np.array([[48, 0], [12, 0], [24, 0], [36, 0], [0, 0], [48, 6], [48, -6], [24, 6], [0, 6], [0, -6]], float)
    u = beam.displacement(pts)
    assert beam.TIP_DEFLECTION == pytest.approx(8.900e-3, rel=1e-12)
    assert beam.TIP_POINT == (48.0, 0.0)
    np.testing.assert_allclose(u[:5, 1], [8.900e-3, 8.25e-4, 2.850e-3, 5.675e-3, 0.0], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(u[5:8, 0], [-1.600e-3, 1.600e-3, -1.200e-3], rtol=1e-12)
    np.testing.assert_allclose(u[8:, 1], [6.0e-5, 6.0e-5], rtol=1e-12)
    inertia = beam.second_moment(DEPTH)
    closed = LOAD * LENGTH ** 3 / (3 * E * inertia) + (4 + 5 * NU) * LOAD * LENGTH * DEPTH ** 2 / (24 * E * inertia)
    assert beam.TIP_DEFLECTION == pytest.approx(closed, rel=1e-13)
    assert beam.displacement(pts).shape == (10, 2) and beam.stress(pts).shape == (10, 3)
    with pytest.raises(ValueError):
        beam.displacement(np.zeros((3, 3)))


def test_beam_strain_is_the_gradient_and_stress_is_plane_stress_hooke():
    grad = fd_gradient(beam.displacement, BEAM_POINTS, 1e-3)
    eps = beam.strain(BEAM_POINTS)
    np.testing.assert_allclose(engineering_strain(grad), eps, rtol=0, atol=1e-9 * np.abs(eps).max())
    sig = beam.stress(BEAM_POINTS)
    hooke = eps @ beam.elasticity_matrix(E, NU, "stress").T
    np.testing.assert_allclose(hooke, sig, rtol=0, atol=1e-9 * np.abs(sig).max())
    assert np.all(sig[:, 1] == 0.0)


def test_beam_equilibrium_and_boundary_tractions():
    div = stress_divergence(beam.stress, BEAM_POINTS, 1e-3)
    assert np.abs(div).max() < 1e-8 * 2000.0
    x = np.linspace(0.0, LENGTH, 9)
    for side in (+1.0, -1.0):                                   # y = ±D/2 are traction free
        edge = np.column_stack([x, np.full_like(x, side * DEPTH / 2)])
        np.testing.assert_allclose(beam.traction_on(edge, (0.0, side)), 0.0, atol=1e-12)
    y, w = gauss_line(-DEPTH / 2, DEPTH / 2)
    end = np.column_stack([np.full_like(y, LENGTH), y])
    t_end = beam.traction_end(end)
    np.testing.assert_allclose(t_end[:, 1], LOAD / (2 * beam.second_moment(DEPTH)) * (DEPTH ** 2 / 4 - y ** 2))
    assert np.all(t_end[:, 0] == 0.0)
    assert w @ t_end[:, 1] == pytest.approx(LOAD, rel=1e-13)     # resultant +P
    assert w @ (t_end[:, 1] * y) == pytest.approx(0.0, abs=1e-9)
    root = np.column_stack([np.zeros_like(y), y])
    t_root = beam.traction_on(root, (-1.0, 0.0))
    assert w @ t_root[:, 1] == pytest.approx(-LOAD, rel=1e-13)  # the reaction balances P
    assert w @ (-t_root[:, 0] * y) == pytest.approx(-LOAD * LENGTH, rel=1e-13)  # and its moment about the origin
    # the normal may be given per point
    np.testing.assert_array_equal(beam.traction_on(end, np.tile([1.0, 0.0], (len(y), 1))), t_end)
    s = beam.stress(np.array([[0.0, 6.0], [0.0, -6.0], [17.0, 0.0]]))
    np.testing.assert_allclose([s[0, 0], s[1, 0], s[2, 2]], [-2000.0, 2000.0, 125.0], rtol=1e-13)


def test_beam_strain_energy_and_clapeyron():
    U = beam.strain_energy()
    assert U == pytest.approx(4.47467, abs=5e-6)
    assert np.sqrt(U) == pytest.approx(2.11534, abs=5e-6)
    closed = (LOAD ** 2 * LENGTH ** 3 / (6 * E * beam.second_moment(DEPTH))
              + LOAD ** 2 * (1 + NU) * LENGTH * DEPTH ** 5 / (120 * E * beam.second_moment(DEPTH) ** 2))
    assert U == pytest.approx(closed, rel=1e-13)
    # U = ½ (work of the end load + work of the reaction on the prescribed displacement at x = 0)
    y, w = gauss_line(-DEPTH / 2, DEPTH / 2)
    end = np.column_stack([np.full_like(y, LENGTH), y])
    root = np.column_stack([np.zeros_like(y), y])
    work_end = 0.5 * w @ np.sum(beam.traction_end(end) * beam.displacement(end), axis=1)
    work_root = 0.5 * w @ np.sum(beam.traction_on(root, (-1.0, 0.0)) * beam.displacement(root), axis=1)
    assert work_end == pytest.approx(4.45000, abs=5e-6)
    assert work_root == pytest.approx(0.02467, abs=5e-6)
    assert work_end + work_root == pytest.approx(U, rel=1e-12)


def test_beam_energy_norm():
    pts, w = beam.gauss_rectangle(0.0, LENGTH, -DEPTH / 2, DEPTH / 2, 4)
    exact = beam.strain(pts)
    err, norm = beam.energy_norm(pts, w, exact)
    assert err == 0.0 and norm == pytest.approx(np.sqrt(beam.strain_energy()), rel=1e-12)
    err, norm2 = beam.energy_norm(pts, w, 1.01 * exact)
    assert norm2 == norm and err == pytest.approx(0.01 * norm, rel=1e-10)
    # an error confined to γ_xy: ½ ∫ G δγ² dΩ
    delta = np.zeros_like(exact)
    delta[:, 2] = 1e-6
    err, _ = beam.energy_norm(pts, w, exact + delta)
    assert err == pytest.approx(np.sqrt(0.5 * E / (2 * (1 + NU)) * 1e-12 * LENGTH * DEPTH), rel=1e-10)
    with pytest.raises(ValueError):
        beam.energy_norm(pts, w, exact[:-1])
    with pytest.raises(ValueError):
        beam.elasticity_matrix(E, NU, "axisymmetric")


def test_elasticity_matrices_invert_hooke():
    """D (Rocha (2012) eq 3.37/3.38) against the compliance: plane stress ε = C σ with C the 2D compliance,
    plane strain the same with E' = E/(1-ν²), ν' = ν/(1-ν)."""
    def compliance(E_, nu_):
        return np.array([[1, -nu_, 0], [-nu_, 1, 0], [0, 0, 2 * (1 + nu_)]]) / E_

    np.testing.assert_allclose(beam.elasticity_matrix(E, NU, "stress") @ compliance(E, NU), np.eye(3), atol=1e-14)
    np.testing.assert_allclose(beam.elasticity_matrix(E, NU, "strain") @ compliance(E / (1 - NU ** 2), NU / (1 - NU)),
                               np.eye(3), atol=1e-14)


# ---------------------------------------------------------------- Lamé cylinder (Rocha (2012) §5.3)

A_IN, B_OUT = cyl.DEFAULTS["a"], cyl.DEFAULTS["b"]
_r = RNG.uniform(A_IN + 0.5, B_OUT - 0.5, 50)
_t = RNG.uniform(0.0, np.pi / 2, 50)
CYL_POINTS = np.column_stack([_r * np.cos(_t), _r * np.sin(_t)])


def test_cylinder_table_of_the_note():
    assert cyl.DEFAULTS["E"] == pytest.approx(20800.0, rel=1e-15)
    r = np.array([10.0, 15.0, 20.0, 25.0])
    np.testing.assert_allclose(cyl.radial_displacement(r), [0.079167, 0.056746, 0.046726, 0.041667], atol=6e-7)
    np.testing.assert_allclose(cyl.radial_displacement(r, plane="stress"), [0.080815, 0.059219, 0.050023, 0.045788],
                               atol=6e-7)
    # eq 5.3 as printed is the plane-stress formula
    E_, nu, a, b, p = (cyl.DEFAULTS[k] for k in ("E", "nu", "a", "b", "p"))
    eq53 = p * a ** 2 / (E_ * (b ** 2 - a ** 2) * r) * ((1 - nu) * r ** 2 + (1 + nu) * b ** 2)
    np.testing.assert_allclose(cyl.radial_displacement(r, plane="stress"), eq53, rtol=1e-14)
    assert cyl.lame_constant() == pytest.approx(19.0476, abs=5e-5)
    np.testing.assert_allclose(cyl.radial_stress([a, b]), [-100.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(cyl.hoop_stress([a, b]), [138.095, 38.095], atol=5e-4)
    assert cyl.axial_stress() == pytest.approx(11.4286, abs=5e-5) and cyl.axial_stress(plane="stress") == 0.0
    with pytest.raises(ValueError):
        cyl.radial_displacement(r, plane="axisymmetric")


@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_cylinder_strain_gradient_hooke_and_equilibrium(plane):
    grad = fd_gradient(lambda q: cyl.displacement(q, plane=plane), CYL_POINTS, 1e-4)
    eps = cyl.strain(CYL_POINTS, plane=plane)
    np.testing.assert_allclose(engineering_strain(grad), eps, rtol=0, atol=1e-8 * np.abs(eps).max())
    sig = cyl.stress(CYL_POINTS, plane=plane)
    hooke = eps @ beam.elasticity_matrix(cyl.DEFAULTS["E"], cyl.DEFAULTS["nu"], plane).T
    np.testing.assert_allclose(hooke, sig, rtol=0, atol=1e-10 * np.abs(sig).max())
    div = stress_divergence(cyl.stress, CYL_POINTS, 1e-4)
    assert np.abs(div).max() < 1e-5


def test_cylinder_cartesian_rotation_boundaries_and_symmetry():
    r = np.linspace(A_IN, B_OUT, 7)
    on_x = np.column_stack([r, np.zeros_like(r)])
    on_y = np.column_stack([np.zeros_like(r), r])
    s_x, s_y = cyl.stress(on_x), cyl.stress(on_y)
    np.testing.assert_allclose(s_x[:, 0], cyl.radial_stress(r), rtol=1e-14)
    np.testing.assert_allclose(s_x[:, 1], cyl.hoop_stress(r), rtol=1e-14)
    np.testing.assert_allclose(s_y[:, 1], cyl.radial_stress(r), rtol=1e-14, atol=1e-12)
    assert np.abs(s_x[:, 2]).max() < 1e-12 and np.abs(s_y[:, 2]).max() < 1e-12
    assert np.abs(cyl.displacement(on_x)[:, 1]).max() == 0.0          # u_y = 0 on y = 0
    assert np.abs(cyl.displacement(on_y)[:, 0]).max() < 1e-17         # u_x = 0 on x = 0
    theta = np.linspace(0.0, np.pi / 2, 9)
    rhat = np.column_stack([np.cos(theta), np.sin(theta)])
    inner, outer = A_IN * rhat, B_OUT * rhat
    np.testing.assert_allclose(cyl.traction_on(inner, -rhat), cyl.DEFAULTS["p"] * rhat, atol=1e-12)
    np.testing.assert_allclose(cyl.traction_on(outer, rhat), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(cyl.displacement(inner), axis=1), cyl.radial_displacement(A_IN))


def annulus_gauss(a: float, b: float, n_r: int = 12, n_t: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Gauss rule on the quarter annulus in (r, θ): weights include the Jacobian r."""
    r, wr = gauss_line(a, b, n_r)
    t, wt = gauss_line(0.0, np.pi / 2, n_t)
    R, T = np.meshgrid(r, t, indexing="ij")
    W = np.outer(wr * r, wt)
    return np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()]), W.ravel()


@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_cylinder_strain_energy_and_energy_norm(plane):
    pts, w = annulus_gauss(A_IN, B_OUT)
    sig, eps = cyl.stress(pts), cyl.strain(pts, plane=plane)
    U = 0.5 * w @ np.sum(sig * eps, axis=1)
    assert U == pytest.approx(cyl.strain_energy(plane=plane), rel=1e-10)
    err, norm = cyl.energy_norm(pts, w, eps, plane=plane)
    assert err == 0.0 and norm ** 2 == pytest.approx(U, rel=1e-12)
    err, _ = cyl.energy_norm(pts, w, 0.98 * eps, plane=plane)
    assert err == pytest.approx(0.02 * norm, rel=1e-10)
    assert cyl.strain_energy() == pytest.approx(62.1774, abs=5e-5)


# ---------------------------------------------------------------- Cook's membrane (Rocha (2012) §5.2)

def test_cook_csv_converges_and_matches_the_note():
    header, data = cook.convergence_table()
    assert len(header) == 5 and header[0].startswith("elements_per_side") and "uy_48_60" in header[1]
    meshes, limit = data[:-1], data[-1]
    assert limit[0] == 0 and meshes.shape[0] >= 4
    n = meshes[:, 0]
    np.testing.assert_array_equal(n[1:], 2 * n[:-1])
    for col in range(1, 5):
        q = meshes[:, col]
        steps = np.diff(q)
        assert np.all(np.sign(steps) == np.sign(steps[0])), header[col]          # monotone
        assert np.all(np.abs(steps[1:]) < np.abs(steps[:-1])), header[col]       # contracting
        assert np.sign(limit[col] - q[-1]) == np.sign(steps[0]), header[col]     # limit beyond the finest
        assert abs(limit[col] - q[-1]) <= abs(steps[-1]), header[col]            # within the finest change
        order = np.log2(steps[-2] / steps[-1])                                # observed, finest three
        assert 0.9 < order < 2.0, (header[col], order)
    ref = cook.reference()
    assert ref["uy_48_60"] == pytest.approx(0.09584, rel=1e-3)
    assert ref["uy_48_52"] == pytest.approx(0.09122, rel=1e-3)
    assert ref["ux_48_60"] == pytest.approx(-0.0716, rel=2e-3)
    # the note's own 256² Q9 value, 0.095819
    assert meshes[n == 256, 1][0] == pytest.approx(0.095819, abs=1e-6)


def test_cook_reference_scaling():
    base = cook.reference()
    scaled = cook.reference(F=3.0, E=2 * cook.DEFAULTS["E"])
    for key in ("uy_48_60", "uy_48_52", "ux_48_60"):
        assert scaled[key] == pytest.approx(1.5 * base[key], rel=1e-14)
    assert scaled["strain_energy"] == pytest.approx(4.5 * base["strain_energy"], rel=1e-14)
    np.testing.assert_array_equal(cook.edge_traction(32.0), [0.0, 2.0])
    assert cook.CORNERS.shape == (4, 2) and cook.DEFAULTS == {"E": 240.565, "nu": 0.3, "F": 1.0}


def test_cook_fem_script_runs_on_a_tiny_mesh():
    start = time.perf_counter()
    coarse = reference_fem.solve_cook(4)
    fine = reference_fem.solve_cook(8)
    assert time.perf_counter() - start < 5.0
    ref = cook.reference()
    for row in (coarse, fine):
        assert row["uy_corner"] == pytest.approx(ref["uy_48_60"], rel=0.03)
        assert row["uy_middle"] == pytest.approx(ref["uy_48_52"], rel=0.03)
    # the CSV's rows come from this script: its 16² value is reproduced
    header, data = cook.convergence_table()
    row16 = reference_fem.solve_cook(16)
    assert row16["uy_corner"] == pytest.approx(data[data[:, 0] == 16, 1][0], rel=1e-9)
    assert row16["energy"] == pytest.approx(data[data[:, 0] == 16, 4][0], rel=1e-9)
    # u scales as F/E
    scaled = reference_fem.solve_cook(4, E=2 * cook.DEFAULTS["E"], F=5.0)
    assert scaled["uy_corner"] == pytest.approx(2.5 * coarse["uy_corner"], rel=1e-12)


def test_readmes_name_their_sources_and_the_thesis_errors():
    from importlib import resources

    needles = {
        "efg_timoshenko": ("Timoshenko & Goodier", "§21", "5.1a", "4.47467", "8.900e-3"),
        "efg_cylinder": ("Lamé", "§28", "eq 5.3", "plane-stress", "0.079167", "0.080815"),
        "efg_cook": ("Cook 1974", "240,565", "reference_fem", "32.27", "Richardson", "23.96"),
        "efg_plate_hole": ("Muskhelishvili", "§81", "Inglis", "Kirsch"),
    }
    for case, words in needles.items():
        text = resources.files(f"warpfree.validation.{case}").joinpath("README.md").read_text(encoding="utf-8")
        for word in words:
            assert word in text, (case, word)


def test_cook_fem_pieces():
    nodes, elements, grid = reference_fem.structured_q9_mesh(3)
    assert nodes.shape == (49, 2) and elements.shape == (9, 9)
    # element areas sum to the membrane's (shoelace: 48 · (44 + 16)/2 = 1440)
    dN, w = reference_fem.q9_reference_gradients(3)
    J = np.einsum("gak,eai->egik", dN, nodes[elements])
    assert np.sum(w * np.linalg.det(J)) == pytest.approx(1440.0, rel=1e-13)
    # rigid motions are in the kernel of K; the consistent load of the edge sums to F with zero moment
    K = reference_fem.assemble_stiffness(nodes, elements, reference_fem.elasticity_matrix(1.0, 0.3, "strain"))
    x, y = nodes[:, 0], nodes[:, 1]
    for mode in (np.column_stack([np.ones_like(x), 0 * x]), np.column_stack([0 * x, np.ones_like(x)]),
                 np.column_stack([-y, x])):
        assert np.abs(K @ mode.ravel()).max() < 1e-12
    right = np.flatnonzero(grid[:, 0] == 6)
    right = right[np.argsort(grid[right, 1])]
    f = reference_fem.edge_load(nodes, np.stack([right[0:-1:2], right[1::2], right[2::2]], axis=1),
                                np.array([0.0, 1.0 / 16]))
    assert f[1::2].sum() == pytest.approx(1.0, rel=1e-14) and f[0::2].sum() == 0.0
    assert f[1::2] @ (y - 52.0) == pytest.approx(0.0, abs=1e-13)
    # Richardson on q = 1 + h^1.5 recovers 1 and the order
    h = np.array([1.0, 0.5, 0.25])
    limit, order = reference_fem.richardson(*(1 + h ** 1.5))
    assert limit == pytest.approx(1.0, abs=1e-14) and order == pytest.approx(1.5, rel=1e-12)


# ---------------------------------------------------------------- plate with an elliptical hole (Muskhelishvili)


def _kirsch(points: np.ndarray, a: float, p: float) -> np.ndarray:
    """Kirsch's stresses (σ_xx, σ_yy, σ_xy) around a circular hole of radius a under a tension p along x."""
    r, t = np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0])
    q2, q4 = (a / r) ** 2, (a / r) ** 4
    srr = 0.5 * p * (1 - q2) + 0.5 * p * (1 - 4 * q2 + 3 * q4) * np.cos(2 * t)
    stt = 0.5 * p * (1 + q2) - 0.5 * p * (1 + 3 * q4) * np.cos(2 * t)
    srt = -0.5 * p * (1 + 2 * q2 - 3 * q4) * np.sin(2 * t)
    c, s = np.cos(t), np.sin(t)
    return np.column_stack([srr * c * c + stt * s * s - 2 * srt * s * c, srr * s * s + stt * c * c + 2 * srt * s * c,
                            (srr - stt) * s * c + srt * (c * c - s * s)])


@pytest.mark.parametrize("a,b", [(0.25, 0.5), (0.5, 0.25), (1.0, 0.1), (0.3, 0.3)])
def test_plate_hole_stresses_free_the_hole_balance_and_tend_to_the_tension(a, b):
    """Muskhelishvili's stresses: no traction on the ellipse, σ_xx = p (1 + 2b/a) at its tip (Inglis), -p at (a, 0),
    divergence-free, and the remote tension p far away (the perturbation falls as 1/r²)."""
    p = 2.5
    t = np.linspace(0.0, 2.0 * np.pi, 37)[:-1]
    edge = np.column_stack([a * np.cos(t), b * np.sin(t)])
    normal = np.column_stack([np.cos(t) / a, np.sin(t) / b])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    s = hole.stresses(edge, a, b, p)
    traction = np.column_stack([s[:, 0] * normal[:, 0] + s[:, 2] * normal[:, 1],
                                s[:, 2] * normal[:, 0] + s[:, 1] * normal[:, 1]])
    assert np.abs(traction).max() < 1e-12 * p
    assert hole.stresses(np.array([[0.0, b]]), a, b, p)[0, 0] == pytest.approx(hole.tip_stress(a, b, p), rel=1e-12)
    assert hole.tip_stress(a, b, p) == pytest.approx(p * (1 + 2 * b / a))
    assert hole.stresses(np.array([[a, 0.0]]), a, b, p)[0, 1] == pytest.approx(-p, rel=1e-12)
    rng = np.random.default_rng(5)
    angle = rng.uniform(0, 2 * np.pi, 40)
    outside = (1.3 + rng.uniform(0, 2, 40))[:, None] * np.column_stack([a * np.cos(angle), b * np.sin(angle)])
    assert np.abs(stress_divergence(lambda x: hole.stresses(x, a, b, p), outside, 1e-5)).max() < 1e-6 * p / min(a, b)
    far = 1e3 * max(a, b) * np.column_stack([np.cos(angle), np.sin(angle)])
    assert np.abs(hole.stresses(far, a, b, p) - [p, 0.0, 0.0]).max() < 1e-5 * p


def test_plate_hole_stresses_of_a_circle_are_kirsch_s():
    """a = b: the circular hole's Kirsch solution (σ_θθ = 3p at (0, a))."""
    rng = np.random.default_rng(6)
    angle, radius = rng.uniform(0, 2 * np.pi, 50), rng.uniform(1.0, 4.0, 50)
    points = radius[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    assert np.abs(hole.stresses(points, 1.0, 1.0, 1.0) - _kirsch(points, 1.0, 1.0)).max() < 1e-12
    assert hole.stresses(np.array([[0.0, 1.0]]), 1.0, 1.0, 1.0)[0, 0] == pytest.approx(3.0, rel=1e-12)
