"""Cold two-stream instability: growth rates from the cold-beam dispersion relation (no data files, ``README.md``).

Two cold beams of equal density (each with plasma frequency ω_b, ω_b² = ω_p²/2 for the total ω_p) drifting at
±v0 along x; a perturbation e^{i(kx - ωt)} obeys

    1 = ω_b² / (ω - k v0)² + ω_b² / (ω + k v0)²

(Birdsall & Langdon §5-10; Chen, *Introduction to Plasma Physics* §6.8). With a = k v0 / ω_b the roots are
(ω/ω_b)² = a² + 1 ± sqrt(4a² + 1); the minus root is negative (growth) for a² < 2, with the largest growth
γ_max = ω_b / 2 = ω_p / (2√2) at a² = 3/4, i.e. k v0 = sqrt(3/8) ω_p = 0.612 ω_p.
"""

from __future__ import annotations

import math

__all__ = ["growth_rate", "GAMMA_MAX", "K_V0_FASTEST"]

#: γ_max / ω_p
GAMMA_MAX = 1.0 / (2.0 * math.sqrt(2.0))
#: k v0 / ω_p of the fastest-growing mode
K_V0_FASTEST = math.sqrt(3.0 / 8.0)


def growth_rate(k_v0: float, omega_p: float = 1.0) -> float:
    """γ (same units as ω_p) of the mode with k v0 = ``k_v0``; 0 for a stable mode (k v0 >= sqrt(2) ω_b)."""
    wb = omega_p / math.sqrt(2.0)
    a2 = (k_v0 / wb) ** 2
    root = a2 + 1.0 - math.sqrt(4.0 * a2 + 1.0)
    return wb * math.sqrt(-root) if root < 0 else 0.0
