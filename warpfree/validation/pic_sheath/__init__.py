"""The collisionless sheath between a plasma source and a floating wall (``scenes/pic_sheath.py``; sources in
README.md).

Normalised units: the source's ion density n0 = 1, T_e = 1, e = m_e = ε0 = 1 (lengths in λ_D, potentials in T_e/e,
speeds in v_te = sqrt(T_e/m_e)). The source (x = 0, φ = 0) emits a half-Maxwellian of electrons of density
parameter n_s (flux Γ_e0 = n_s / sqrt(2π)) and a cold ion beam at u0 = M c_s, c_s = sqrt(1/μ), μ = m_i/m_e (flux
Γ_i = u0). With the potential falling monotonically from the source to the wall (φ_w < φ < 0):

- electrons: the source's half-Maxwellian slowed by the potential, e^φ n_s/2, and the part the wall turns back
  (energy below its barrier φ - φ_w), e^φ (n_s/2) erf(sqrt(φ - φ_w)): n_e = (n_s/2) e^φ (1 + erf(sqrt(φ - φ_w)));
- ions: n_i = Γ_i / sqrt(u0² - 2φ/μ) (energy conserved, none turned back);
- the floating wall: Γ_i = Γ_e0 e^{φ_w}, φ_w = ln(Γ_i / Γ_e0): at u0 = c_s and n_s = 1, -½ ln(μ/2π), the
  classic floating-wall potential (Stangeby 2000, eq. 2.60; -2.85 for hydrogen);
- n_s is chosen so that the plasma is neutral at the source, n_e(0) = n_i(0) = 1 (no source sheath);
- the potential solves φ'' = n_e(φ) - n_i(φ), φ(0) = 0, φ(L) = φ_w, through its first integral.

float64.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq
from scipy.special import erf

__all__ = ["SheathModel"]


class SheathModel:
    """The model for ions of ``mass_ratio`` μ entering at ``ion_mach`` M times the Bohm speed."""

    def __init__(self, mass_ratio: float, ion_mach: float):
        self.mass_ratio = float(mass_ratio)
        #: u0 = M sqrt(1/μ), the ions' speed at the source (v_te)
        self.ion_speed = float(ion_mach) / math.sqrt(self.mass_ratio)
        #: Γ_i = n0 u0
        self.ion_flux = self.ion_speed
        #: n_s: the source's electron density parameter making the plasma neutral there
        self.source_electron_density = brentq(
            lambda n: self.electron_density(0.0, n, self._wall_of(n)) - 1.0, 0.5, 4.0, xtol=1e-15, rtol=1e-14)
        #: Γ_e0 = n_s / sqrt(2π), the source's electron flux
        self.electron_flux = self.source_electron_density / math.sqrt(2.0 * math.pi)
        #: φ_w = ln(Γ_i / Γ_e0)
        self.wall_potential = self._wall_of(self.source_electron_density)
        self._profiles = {}

    @property
    def monotone(self) -> bool:
        """A potential falling monotonically from the source to the wall exists: V(φ) > 0 on [φ_w, 0) (Bohm's
        criterion at the source, n_i'(0) < n_e'(0): ions entering at u0 ≥ 0.98 c_s for m_i/m_e = 100, between 0.99 and 1
        c_s for hydrogen)."""
        return bool(np.all(self._pseudo_potential(np.linspace(self.wall_potential, 0.0, 2001)[:-1]) > 0.0))

    def plateau_potential(self) -> float:
        """φ_p, the potential of the neutral plasma between the sheaths: where V is least on [φ_w, 0] (n_e = n_i
        there). 0 for ions entering at Bohm's speed or above (no source sheath); below it, the potential a source
        sheath would drop to for the ions to meet Bohm's criterion (u_p² = u0² - 2φ_p/μ ≥ c_s²) at the wall's sheath,
        were the sheaths steady (``README.md``: the simulation's plasma does not hold still there)."""
        grid = np.linspace(self.wall_potential, 0.0, 20001)
        values = self._pseudo_potential(grid)
        k = int(np.argmin(values))
        if k == grid.size - 1:
            return 0.0
        lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
        return float(brentq(lambda p: self.electron_density(p, self.source_electron_density, self.wall_potential)
                            - self.ion_density(p), lo, hi, xtol=1e-15))

    def _wall_of(self, source_density: float) -> float:
        return math.log(self.ion_flux * math.sqrt(2.0 * math.pi) / source_density)

    @staticmethod
    def electron_density(phi, source_density: float, wall: float):
        """n_e = (n_s/2) e^φ (1 + erf(sqrt(φ - φ_w)))."""
        phi = np.asarray(phi, dtype=np.float64)
        return 0.5 * source_density * np.exp(phi) * (1.0 + erf(np.sqrt(np.maximum(phi - wall, 0.0))))

    def ion_density(self, phi):
        """n_i = Γ_i / sqrt(u0² - 2φ/μ) (φ ≤ 0)."""
        phi = np.asarray(phi, dtype=np.float64)
        return self.ion_flux / np.sqrt(self.ion_speed ** 2 - 2.0 * np.minimum(phi, 0.0) / self.mass_ratio)

    def _pseudo_potential(self, phi):
        """V(φ) = ∫_0^φ (n_e - n_i) dφ' in closed form (≥ 0 between φ_w and 0 when the sheath is monotone): with
        F_e = (n_s/2) (e^φ (1 + erf(sqrt(φ - φ_w))) - 2 e^{φ_w} sqrt((φ - φ_w)/π)) and F_i = -Γ_i μ sqrt(u0² - 2φ/μ),
        V = F_e(φ) - F_e(0) - F_i(φ) + F_i(0)."""
        n_s, wall, mu, u0 = self.source_electron_density, self.wall_potential, self.mass_ratio, self.ion_speed

        def f_e(p):
            d = np.maximum(p - wall, 0.0)
            return 0.5 * n_s * (np.exp(p) * (1.0 + erf(np.sqrt(d))) - 2.0 * math.exp(wall) * np.sqrt(d / math.pi))

        def f_i(p):
            return -self.ion_flux * mu * np.sqrt(u0 ** 2 - 2.0 * p / mu)

        phi = np.asarray(phi, dtype=np.float64)
        return f_e(phi) - f_e(0.0) - f_i(phi) + f_i(0.0)

    def _distance(self, phi_grid: np.ndarray, slope: float) -> np.ndarray:
        """x(φ) = ∫_φ^0 dψ / sqrt(2 V(ψ) + s²) at each φ of ``phi_grid`` (increasing to 0), s = |φ'(0)| (the first
        integral of φ'' = n_e - n_i: ½ φ'² = V(φ) + ½ s²), by Gauss-Legendre on each interval of the grid."""
        nodes, weights = np.polynomial.legendre.leggauss(16)
        a, b = phi_grid[:-1], phi_grid[1:]
        half = 0.5 * (b - a)
        psi = 0.5 * (a + b)[:, None] + half[:, None] * nodes[None, :]
        integrand = 1.0 / np.sqrt(2.0 * np.maximum(self._pseudo_potential(psi), 0.0) + slope ** 2)
        pieces = half * (integrand @ weights)
        return np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])

    def potential(self, x, length: float) -> np.ndarray:
        """φ(x) on [0, length] with φ(0) = 0, φ(length) = φ_w: the first integral ½ φ'² = V(φ) + ½ s² integrated as
        x(φ) = ∫_φ^0 dψ / sqrt(2V + s²), the slope s at the source chosen (Brent's method on log s) so that x(φ_w)
        = length; φ(x) a cubic Hermite spline through (x(φ), φ) with φ' = -sqrt(2V + s²), on a grid of φ linear near
        the wall and geometric toward 0 (to 1e-14 |φ_w|)."""
        key = float(length)
        if key not in self._profiles:
            wall = self.wall_potential
            if not self.monotone:
                raise ValueError(f"no monotone sheath: the ions enter below Bohm's speed (ion_mach "
                                 f"{self.ion_speed * math.sqrt(self.mass_ratio):g})")
            grid = np.concatenate([wall * np.geomspace(1.0, 1e-14, 4000), [0.0]])
            grid = np.concatenate([np.linspace(wall, 0.5 * wall, 2000, endpoint=False), grid[grid > 0.5 * wall]])
            log_slope = brentq(lambda t: self._distance(grid, math.exp(t))[0] - key, -250.0, 10.0, xtol=1e-13)
            slope = math.exp(log_slope)
            distance = self._distance(grid, slope)
            derivative = -np.sqrt(2.0 * np.maximum(self._pseudo_potential(grid), 0.0) + slope ** 2)
            self._profiles[key] = CubicHermiteSpline(distance[::-1], grid[::-1], derivative[::-1])
        return self._profiles[key](np.asarray(x, dtype=np.float64))
