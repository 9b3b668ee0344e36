"""The space-charge-limited current of a cylindrical diode: Langmuir and Blodgett's β² function (no data files; see
``README.md``).

Between a cathode r = r_c emitting without limit and an anode r = r_a at V above it, the steady current per unit
length is (Langmuir & Blodgett 1923, Phys. Rev. 22, 347)

    I / L = (8π ε0 / 9) sqrt(2 |q| / m) V^{3/2} / (r_a β²),

β(γ), γ = ln(r / r_c), solving 3 β β'' + β'² + 4 β β' + β² = 1 with β(0) = 0, β'(0) = 1 (primes: d/dγ). β² → 1 for
r_a ≫ r_c; near r_c, β = γ - 2γ²/5 + 11γ³/120 - 47γ⁴/3300 + ... :func:`beta_squared` integrates the equation
(SciPy's DOP853, relative tolerance 1e-12) from the series at γ = 1e-3.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["beta_squared", "current_per_length", "SERIES"]

#: the coefficients of β's series in γ (Langmuir & Blodgett 1923, eq. 9)
SERIES = (1.0, -2.0 / 5.0, 11.0 / 120.0, -47.0 / 3300.0)


def _series(gamma: float) -> tuple[float, float]:
    b = sum(c * gamma ** (k + 1) for k, c in enumerate(SERIES))
    db = sum((k + 1) * c * gamma ** k for k, c in enumerate(SERIES))
    return b, db


def beta_squared(ratio: float) -> float:
    """β² at r_a / r_c = ``ratio`` (> 1; the anode outside the cathode)."""
    if not ratio > 1.0:
        raise ValueError(f"the anode must lie outside the cathode: r_a / r_c > 1, got {ratio}")
    end = math.log(ratio)
    start = min(1e-3, 0.5 * end)
    b0, db0 = _series(start)

    def rate(_, y):
        b, db = y
        return [db, (1.0 - db * db - 4.0 * b * db - b * b) / (3.0 * b)]

    sol = solve_ivp(rate, (start, end), [b0, db0], method="DOP853", rtol=1e-12, atol=1e-14)
    return float(sol.y[0, -1] ** 2)


def current_per_length(voltage: float, cathode_radius: float, anode_radius: float, charge_over_mass: float = 1.0,
                       permittivity: float = 1.0) -> float:
    """I / L = (8π ε0 / 9) sqrt(2 |q/m|) V^{3/2} / (r_a β²) (per unit length: the 2D problem's current per unit depth;
    the default units are the PIC's normalised ones, ε0 = 1, |q/m| = 1 for electrons)."""
    return (8.0 * math.pi * permittivity / 9.0 * math.sqrt(2.0 * abs(charge_over_mass)) * voltage ** 1.5
            / (anode_radius * beta_squared(anode_radius / cathode_radius)))
