"""Internally pressurised thick cylinder (Rocha 2012, §5.3, Table 5.3): the exact Lamé field; no data files.

Inner radius a, outer radius b, internal pressure p, outer surface free, quarter model (x, y >= 0) with
symmetry conditions u_y = 0 on y = 0 and u_x = 0 on x = 0; the thesis runs it in plane strain.
Lamé's solution (Timoshenko & Goodier, *Theory of Elasticity*, 3rd ed., §28 and §31; Sadd, *Elasticity*, §8.3.1),
with A = p a² / (b² - a²):

    σ_r = A (1 - b²/r²),   σ_θ = A (1 + b²/r²),   σ_z = 2 ν A (plane strain) or 0 (plane stress)
    u_r = (1 + ν) A / E [(1 - 2ν) r + b²/r]                      plane strain
    u_r = A / E [(1 - ν) r + (1 + ν) b²/r]                       plane stress = Rocha (2012), eq. 5.3 as printed

The thesis prints the plane-stress form (5.3) although it states plane strain: with Table 5.3 it gives
u_r(a) = 0.080815 against the plane-strain 0.079167 (u_r(b) = 0.045788 against 0.041667). Use
plane='strain' for the thesis's problem. Consistent units (stresses in the unit of p, lengths in that of a).
See ``README.md``.
"""

from __future__ import annotations

import numpy as np

from warpfree.validation.efg_timoshenko import energy_norm_of_strains

__all__ = ["DEFAULTS", "SHEAR_MODULUS", "PLANE", "lame_constant", "radial_displacement", "radial_stress",
           "hoop_stress", "axial_stress", "displacement", "strain", "stress", "traction_on", "strain_energy",
           "energy_norm"]

#: Table 5.3: G0 = 8000, ν = 0.3, E = 2 G0 (1 + ν).
SHEAR_MODULUS = 8000.0
#: a, b (length), p (stress), E = 2 G0 (1 + ν) = 20800 (stress), ν: Rocha (2012), §5.3 and Table 5.3.
DEFAULTS = {"a": 10.0, "b": 25.0, "p": 100.0, "E": 2.0 * SHEAR_MODULUS * 1.3, "nu": 0.3}
#: The thesis's hypothesis (§5.3 text); its eq 5.3 is the plane-stress form nonetheless.
PLANE = "strain"

_A, _B, _P, _E, _NU = (DEFAULTS[k] for k in ("a", "b", "p", "E", "nu"))


def lame_constant(a: float = _A, b: float = _B, p: float = _P) -> float:
    """A = p a² / (b² - a²) (unit of p): σ_r = A (1 - b²/r²), σ_θ = A (1 + b²/r²). 19.0476 for the defaults."""
    return p * a ** 2 / (b ** 2 - a ** 2)


def _radial_coefficients(a: float, b: float, p: float, E: float, nu: float, plane: str) -> tuple[float, float]:
    """(α, β) with u_r = α r + β / r (Lamé): plane strain α = (1+ν)(1-2ν) A/E, β = (1+ν) A b²/E;
    plane stress α = (1-ν) A/E, β = (1+ν) A b²/E (the latter is Rocha 2012, eq. 5.3)."""
    A = lame_constant(a, b, p)
    if plane == "strain":
        return (1.0 + nu) * (1.0 - 2.0 * nu) * A / E, (1.0 + nu) * A * b ** 2 / E
    if plane == "stress":
        return (1.0 - nu) * A / E, (1.0 + nu) * A * b ** 2 / E
    raise ValueError(f"plane must be 'stress' or 'strain', got {plane!r}")


def radial_displacement(r, a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
                        plane: str = PLANE) -> np.ndarray:
    """u_r(r) (unit of length).

    plane='strain': u_r = (1 + ν) p a² / (E (b² - a²)) [(1 - 2ν) r + b²/r]   (Lamé; Timoshenko & Goodier §31)
    plane='stress': u_r = p a² / (E (b² - a²) r) [(1 - ν) r² + (1 + ν) b²]    (Rocha 2012, eq. 5.3 as printed)
    """
    r = np.asarray(r, dtype=np.float64)
    alpha, beta = _radial_coefficients(a, b, p, E, nu, plane)
    return alpha * r + beta / r


def radial_stress(r, a: float = _A, b: float = _B, p: float = _P) -> np.ndarray:
    """σ_r = A (1 - b²/r²), A = p a²/(b² - a²) (unit of p); σ_r(a) = -p, σ_r(b) = 0. Either plane hypothesis."""
    r = np.asarray(r, dtype=np.float64)
    return lame_constant(a, b, p) * (1.0 - b ** 2 / r ** 2)


def hoop_stress(r, a: float = _A, b: float = _B, p: float = _P) -> np.ndarray:
    """σ_θ = A (1 + b²/r²), A = p a²/(b² - a²) (unit of p). Either plane hypothesis."""
    r = np.asarray(r, dtype=np.float64)
    return lame_constant(a, b, p) * (1.0 + b ** 2 / r ** 2)


def axial_stress(a: float = _A, b: float = _B, p: float = _P, nu: float = _NU, plane: str = PLANE) -> float:
    """σ_z = ν (σ_r + σ_θ) = 2 ν A in plane strain (uniform, 11.4286 for the defaults); 0 in plane stress."""
    return 2.0 * nu * lame_constant(a, b, p) if plane == "strain" else 0.0


def _polar(points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, cos θ, sin θ) of ``points`` (n, 2)."""
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    r = np.hypot(points[:, 0], points[:, 1])
    return r, points[:, 0] / r, points[:, 1] / r


def displacement(points, a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
                 plane: str = PLANE) -> np.ndarray:
    """Cartesian (u_x, u_y) = u_r(r) (cos θ, sin θ) at ``points`` (n, 2). -> (n, 2)."""
    r, c, s = _polar(points)
    ur = radial_displacement(r, a, b, p, E, nu, plane)
    return np.column_stack([ur * c, ur * s])


def strain(points, a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
           plane: str = PLANE) -> np.ndarray:
    """Engineering strains [ε_xx, ε_yy, γ_xy] (dimensionless) of the exact field. -> (n, 3).

    With u_r = α r + β/r: ε_r = du_r/dr = α - β/r², ε_θ = u_r/r = α + β/r², then
    ε_xx = ε_r cos²θ + ε_θ sin²θ, ε_yy = ε_r sin²θ + ε_θ cos²θ, γ_xy = 2 (ε_r - ε_θ) sin θ cos θ.
    """
    r, c, s = _polar(points)
    alpha, beta = _radial_coefficients(a, b, p, E, nu, plane)
    e_r, e_t = alpha - beta / r ** 2, alpha + beta / r ** 2
    return np.column_stack([e_r * c ** 2 + e_t * s ** 2, e_r * s ** 2 + e_t * c ** 2, 2.0 * (e_r - e_t) * s * c])


def stress(points, a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
           plane: str = PLANE) -> np.ndarray:
    """Cartesian in-plane stresses [σ_xx, σ_yy, σ_xy] (unit of p) of the Lamé field. -> (n, 3).

    σ_xx = σ_r cos²θ + σ_θ sin²θ, σ_yy = σ_r sin²θ + σ_θ cos²θ, σ_xy = (σ_r - σ_θ) sin θ cos θ.
    Independent of E, ν and the plane hypothesis (accepted so that ``**DEFAULTS`` works everywhere).
    """
    r, c, s = _polar(points)
    s_r, s_t = radial_stress(r, a, b, p), hoop_stress(r, a, b, p)
    return np.column_stack([s_r * c ** 2 + s_t * s ** 2, s_r * s ** 2 + s_t * c ** 2, (s_r - s_t) * s * c])


def traction_on(points, normal, a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
                plane: str = PLANE) -> np.ndarray:
    """t = σ·n (unit of p) for outward unit ``normal`` ((2,) or (n, 2)); on r = a (n = -r̂) it is p r̂. -> (n, 2)."""
    sig = stress(points, a, b, p, E, nu, plane)
    n = np.broadcast_to(np.asarray(normal, dtype=np.float64), (sig.shape[0], 2))
    return np.column_stack([sig[:, 0] * n[:, 0] + sig[:, 2] * n[:, 1], sig[:, 2] * n[:, 0] + sig[:, 1] * n[:, 1]])


def strain_energy(a: float = _A, b: float = _B, p: float = _P, E: float = _E, nu: float = _NU,
                  plane: str = PLANE, angle: float = np.pi / 2.0) -> float:
    """U = ½ ∫ σ:ε dΩ over a sector of ``angle`` (default the quarter model), per unit thickness.

    By Clapeyron's theorem U = ½ × the work of the load: U = ½ p u_r(a) a · angle (the outer surface is free
    and the symmetry planes do no work). 62.177 for the defaults in plane strain (quarter model).
    """
    return float(0.5 * p * radial_displacement(a, a, b, p, E, nu, plane) * a * angle)


def energy_norm(points, weights, strain_h, a: float = _A, b: float = _B, p: float = _P, E: float = _E,
                nu: float = _NU, plane: str = PLANE) -> tuple[float, float]:
    """Energy-norm error against the Lamé field: returns (||e||_E, ||u||_E).

    ||e||_E = sqrt(½ ∫ (σ_h - σ)·(ε_h - ε) dΩ), ||u||_E = sqrt(½ ∫ σ·ε dΩ), by the solver's quadrature
    (``points`` (n, 2), ``weights`` (n,), engineering strains ``strain_h`` (n, 3)); D is plane strain
    (Rocha 2012, eq. 3.38) for plane='strain', plane stress (eq 3.37) for plane='stress'. With an exact
    quadrature of the quarter annulus ||u||_E² = :func:`strain_energy`.
    """
    return energy_norm_of_strains(weights, strain_h, strain(points, a, b, p, E, nu, plane), E, nu, plane)
