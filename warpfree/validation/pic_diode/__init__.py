"""Planar vacuum diode with a cold injected electron beam: the steady space-charge-limited potential (no data files,
``README.md``).

Normalised units (ε0 = 1, electron charge -1, mass 1; ``warpfree.solvers.pic``). The cathode at y = 0 (potential
0) emits a cold beam of particle flux Γ at speed v0 towards the anode at y = d (potential V > 0). In the steady
state every electron's energy ½v² - φ = ½v0² is conserved and the flux is constant, so the density is n = Γ/v with
v(φ) = sqrt(v0² + 2φ), and Poisson's equation -φ'' = ρ = -n reads

    φ'' = Γ / sqrt(v0² + 2φ).

Multiplied by φ' and integrated from the cathode (φ'(0) = E0, the potential gradient there; the field is -E0):

    ½ φ'² = ½ E0² + Γ (sqrt(v0² + 2φ) - v0),   y(φ) = ∫_0^φ dψ / sqrt(E0² + 2Γ (sqrt(v0² + 2ψ) - v0)),

and E0 follows from y(V) = d. A monotone profile needs E0 >= 0; E0 = 0 is the space-charge limit, which for v0 = 0
is Child's law (Child 1911, Phys. Rev. 32, 492; Langmuir 1913, Phys. Rev. 2, 450):

    Γ_CL = (4/9) sqrt(2) V^{3/2} / d²   (in SI: J = (4/9) ε0 sqrt(2e/m) V^{3/2} / d²),

with φ = V (y/d)^{4/3}. For v0 > 0 the limit rises a little (Jaffé 1944, Phys. Rev. 65, 91); above it a virtual
cathode forms and part of the beam returns to the cathode. The integrals are evaluated with the substitution ψ =
φ t² (which removes the endpoint singularities) by Gauss–Legendre quadrature; E0 by Brent's method.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["child_langmuir_flux", "steady_potential", "cathode_gradient"]

_T, _W = np.polynomial.legendre.leggauss(200)
_T = 0.5 * (_T + 1.0)
_W = 0.5 * _W


def child_langmuir_flux(voltage: float, gap: float) -> float:
    """Γ_CL = (4/9) sqrt(2) V^{3/2} / d² (particles per unit area and time; ε0 = e = m = 1)."""
    return 4.0 / 9.0 * math.sqrt(2.0) * voltage ** 1.5 / gap ** 2


def _distance(phi: float, e0: float, flux: float, v0: float) -> float:
    """y(φ) for the cathode gradient ``e0``."""
    if phi <= 0.0:
        return 0.0
    psi = phi * _T ** 2
    slope2 = e0 ** 2 + 2.0 * flux * (np.sqrt(v0 ** 2 + 2.0 * psi) - v0)
    return float(np.sum(_W * 2.0 * phi * _T / np.sqrt(slope2)))


def cathode_gradient(flux: float, v0: float, voltage: float, gap: float) -> float:
    """E0 = φ'(0) >= 0 of the steady profile; ValueError above the space-charge limit (no monotone profile)."""
    if _distance(voltage, 0.0, flux, v0) < gap:
        raise ValueError(f"flux {flux:.6g} is above the space-charge limit of this diode (E0 would be < 0)")
    hi = 2.0 * voltage / gap + 1.0
    return brentq(lambda e0: _distance(voltage, e0, flux, v0) - gap, 0.0, hi, xtol=1e-14, rtol=1e-13)


def steady_potential(y, flux: float, v0: float, voltage: float, gap: float) -> np.ndarray:
    """φ(y) of the steady beam (y in [0, d]): y(φ) inverted by Brent's method at each point."""
    e0 = cathode_gradient(flux, v0, voltage, gap)
    out = []
    for yy in np.atleast_1d(np.asarray(y, dtype=np.float64)):
        if yy <= 0.0:
            out.append(0.0)
        elif yy >= gap:
            out.append(voltage)
        else:
            out.append(brentq(lambda p: _distance(p, e0, flux, v0) - yy, 0.0, voltage, xtol=1e-14, rtol=1e-13))
    return np.asarray(out)
