"""Timoshenko cantilever beam (Rocha 2012, §5.1, Table 5.1): the exact plane-stress field; no data files.

A beam of length L and depth D (0 <= x <= L, -D/2 <= y <= D/2), unit thickness, plane stress, loaded at
x = L by a parabolic shear traction of resultant P in +y (the thesis's sign convention, so the tip rises).
Timoshenko & Goodier, *Theory of Elasticity*, 3rd ed., §21; Rocha (2012), eqs 5.1a, 5.1b, 5.2:

    u_x = -P y / (6 E I) [(6 L - 3 x) x + (2 + ν)(y² - D²/4)]                   (5.1a)
    u_y =  P / (6 E I) [3 ν y² (L - x) + (4 + 5 ν) D² x / 4 + (3 L - x) x²]     (5.1b)
    I   = D³ / 12                                                            (5.2)

    σ_xx = -P (L - x) y / I,   σ_yy = 0,   σ_xy = P / (2 I) (D²/4 - y²)

The exact u is not zero on x = 0: a solver must prescribe it along the whole clamped edge. Units are any
consistent set (the thesis: Pa, m, N; displacements in m, stresses in Pa, energies in J per unit thickness).
See ``README.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULTS", "TIP_POINT", "TIP_DEFLECTION", "second_moment", "displacement", "strain", "stress",
           "traction_on", "traction_end", "strain_energy", "energy_norm", "elasticity_matrix",
           "energy_norm_of_strains", "gauss_rectangle"]

#: Table 5.1 of the thesis: E (Pa), ν, depth D (m), length L (m), end load P (N).
DEFAULTS = {"E": 3.0e7, "nu": 0.3, "D": 12.0, "L": 48.0, "P": 1000.0}


def second_moment(D: float) -> float:
    """I = D³/12 (m⁴ per unit thickness), Rocha (2012), eq. 5.2."""
    return D ** 3 / 12.0


def _xy(points) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    return points[:, 0], points[:, 1]


def displacement(points, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
                 L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> np.ndarray:
    """Exact (u_x, u_y) (m) at ``points`` (n, 2), Rocha (2012), eqs 5.1a/5.1b (Timoshenko & Goodier §21). -> (n, 2)."""
    x, y = _xy(points)
    c = P / (6.0 * E * second_moment(D))
    ux = -c * y * ((6.0 * L - 3.0 * x) * x + (2.0 + nu) * (y ** 2 - D ** 2 / 4.0))
    uy = c * (3.0 * nu * y ** 2 * (L - x) + (4.0 + 5.0 * nu) * D ** 2 * x / 4.0 + (3.0 * L - x) * x ** 2)
    return np.column_stack([ux, uy])


def strain(points, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
           L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> np.ndarray:
    """Exact engineering strains [ε_xx, ε_yy, γ_xy] (dimensionless), the gradient of (5.1a/b). -> (n, 3).

    ε_xx = ∂u_x/∂x = -P (L - x) y / (E I),  ε_yy = ∂u_y/∂y = -ν ε_xx,
    γ_xy = ∂u_x/∂y + ∂u_y/∂x = P (1 + ν) / (E I) (D²/4 - y²).
    """
    x, y = _xy(points)
    inertia = second_moment(D)
    exx = -P * (L - x) * y / (E * inertia)
    gxy = P * (1.0 + nu) / (E * inertia) * (D ** 2 / 4.0 - y ** 2)
    return np.column_stack([exx, -nu * exx, gxy])


def stress(points, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
           L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> np.ndarray:
    """Exact stresses [σ_xx, σ_yy, σ_xy] (Pa) consistent with (5.1): plane-stress Hooke's law of :func:`strain`.

    σ_xx = -P (L - x) y / I,  σ_yy = 0,  σ_xy = P / (2 I) (D²/4 - y²)   (Timoshenko & Goodier §21).
    They do not depend on E or ν (accepted so that ``**DEFAULTS`` works everywhere). -> (n, 3).
    """
    x, y = _xy(points)
    inertia = second_moment(D)
    sxx = -P * (L - x) * y / inertia
    sxy = P / (2.0 * inertia) * (D ** 2 / 4.0 - y ** 2)
    return np.column_stack([sxx, np.zeros_like(sxx), sxy])


def traction_on(points, normal, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
                L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> np.ndarray:
    """Traction t = σ·n (Pa) of the exact field at ``points`` for outward unit ``normal`` ((2,) or (n, 2)). -> (n, 2).

    t_x = σ_xx n_x + σ_xy n_y,  t_y = σ_xy n_x + σ_yy n_y.
    """
    s = stress(points, E, nu, D, L, P)
    n = np.broadcast_to(np.asarray(normal, dtype=np.float64), (s.shape[0], 2))
    return np.column_stack([s[:, 0] * n[:, 0] + s[:, 2] * n[:, 1], s[:, 2] * n[:, 0] + s[:, 1] * n[:, 1]])


def traction_end(points, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
                 L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> np.ndarray:
    """The end load on x = L (outward normal +x): t = (0, P/(2I)(D²/4 - y²)) (Pa), resultant +P. -> (n, 2)."""
    return traction_on(points, (1.0, 0.0), E, nu, D, L, P)


def elasticity_matrix(E: float, nu: float, plane: str = "stress") -> np.ndarray:
    """The 3x3 D of σ = D ε for engineering strains [ε_xx, ε_yy, γ_xy] (Pa).

    plane='stress':  D = E/(1-ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1-ν)/2]]                        (Rocha 2012, eq. 3.37)
    plane='strain':  D = E/((1+ν)(1-2ν)) [[1-ν, ν, 0], [ν, 1-ν, 0], [0, 0, 1/2-ν]]               (Rocha 2012, eq. 3.38)
    """
    if plane == "stress":
        return E / (1.0 - nu ** 2) * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, (1.0 - nu) / 2.0]])
    if plane == "strain":
        return E / ((1.0 + nu) * (1.0 - 2.0 * nu)) * np.array(
            [[1.0 - nu, nu, 0.0], [nu, 1.0 - nu, 0.0], [0.0, 0.0, 0.5 - nu]])
    raise ValueError(f"plane must be 'stress' or 'strain', got {plane!r}")


def energy_norm_of_strains(weights, strain_h, strain_exact, E: float, nu: float,
                           plane: str = "stress") -> tuple[float, float]:
    """(||e||_E, ||u||_E) by quadrature: ||e||_E = sqrt(½ Σ_g w_g (ε_h - ε)ᵀ D (ε_h - ε)) and
    ||u||_E = sqrt(½ Σ_g w_g εᵀ D ε) (J^½ per unit thickness), with σ_h - σ = D (ε_h - ε) so that
    (σ_h - σ)·(ε_h - ε) is the integrand; D from :func:`elasticity_matrix`.

    weights (n,) are the quadrature weights (area, m²); strain_h and strain_exact (n, 3) engineering strains.
    """
    w = np.asarray(weights, dtype=np.float64)
    eps_h = np.asarray(strain_h, dtype=np.float64)
    eps = np.asarray(strain_exact, dtype=np.float64)
    if eps_h.shape != eps.shape or eps.shape != (w.shape[0], 3):
        raise ValueError(f"weights {w.shape}, strain_h {eps_h.shape} and exact strains {eps.shape} do not match")
    Dm = elasticity_matrix(E, nu, plane)
    err = eps_h - eps
    err_density = np.einsum("gi,ij,gj->g", err, Dm, err)
    exact_density = np.einsum("gi,ij,gj->g", eps, Dm, eps)
    return float(np.sqrt(0.5 * w @ err_density)), float(np.sqrt(0.5 * w @ exact_density))


def energy_norm(points, weights, strain_h, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"],
                D: float = DEFAULTS["D"], L: float = DEFAULTS["L"], P: float = DEFAULTS["P"],
                plane: str = "stress") -> tuple[float, float]:
    """Energy-norm error of computed strains against the exact beam: returns (||e||_E, ||u||_E).

    ||e||_E = sqrt(½ ∫ (σ_h - σ)·(ε_h - ε) dΩ) and ||u||_E = sqrt(½ ∫ σ·ε dΩ), both by the quadrature
    (``points`` (n, 2), ``weights`` (n,)) the solver used; ``strain_h`` (n, 3) its engineering strains.
    D is plane stress (Rocha 2012, eq. 3.37), the hypothesis of (5.1); with exact points and weights the second
    value is sqrt(:func:`strain_energy`) = 2.11534 for the defaults.
    """
    return energy_norm_of_strains(weights, strain_h, strain(points, E, nu, D, L, P), E, nu, plane)


def gauss_rectangle(x0: float, x1: float, y0: float, y1: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor n x n Gauss-Legendre rule on [x0, x1] x [y0, y1]: (points (n², 2), weights (n²,)).

    Exact for polynomials of degree <= 2n - 1 in each of x and y.
    """
    t, w = np.polynomial.legendre.leggauss(n)
    xs = 0.5 * (x1 - x0) * (t + 1.0) + x0
    ys = 0.5 * (y1 - y0) * (t + 1.0) + y0
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    W = np.outer(w, w) * 0.25 * (x1 - x0) * (y1 - y0)
    return np.column_stack([X.ravel(), Y.ravel()]), W.ravel()


def strain_energy(E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], D: float = DEFAULTS["D"],
                  L: float = DEFAULTS["L"], P: float = DEFAULTS["P"]) -> float:
    """U = ½ ∫_Ω σ:ε dΩ (J per unit thickness) of the exact field over the whole beam.

    The integrand is a polynomial of degree 4 in y and 2 in x, so a 4 x 4 Gauss-Legendre rule is exact;
    8 x 8 is used. Closed form: U = P² L³ / (6 E I) + P² (1 + ν) L D⁵ / (120 E I²) = 4.47467 for the defaults.
    It includes the work of the exact displacement on x = 0 against the reaction there (0.02467), besides that of
    the end load (4.45000).
    """
    points, weights = gauss_rectangle(0.0, L, -D / 2.0, D / 2.0, 8)
    s = stress(points, E, nu, D, L, P)
    e = strain(points, E, nu, D, L, P)
    return float(0.5 * weights @ np.einsum("gi,gi->g", s, e))


#: The monitored point Q = (L, 0) of the thesis (the neutral axis at the loaded end).
TIP_POINT = (DEFAULTS["L"], 0.0)
#: u_y(L, 0) (m) for :data:`DEFAULTS`: P L³/(3 E I) + (4 + 5ν) P L D²/(24 E I) = 8.900e-3.
TIP_DEFLECTION = float(displacement(np.array([TIP_POINT]))[0, 1])
