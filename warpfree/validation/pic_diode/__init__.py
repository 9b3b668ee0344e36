"""Planar vacuum diode with a cold injected electron beam: the steady space-charge-limited potential (no data files,
``README.md``).

Normalised units (ε0 = 1, electron charge -1, mass 1; ``warpfree.solvers.pic``). The cathode at y = 0 (potential
0) emits a cold beam of particle flux Γ at speed v0 towards the anode at y = d (potential V > 0). In the steady
state every electron's energy ½v² - φ = ½v0² is conserved and the flux is constant, so the density is n = Γ/v with
v(φ) = sqrt(v0² + 2φ), and Poisson's equation -φ'' = ρ = -n reads

    φ'' = Γ / sqrt(v0² + 2φ).

Multiplied by φ' and integrated from the cathode (φ'(0) = E0, the potential gradient there; the field is -E0):

    ½ φ'² = ½ E0² + Γ (sqrt(v0² + 2φ) - v0),   y(φ) = ∫_0^φ dψ / sqrt(E0² + 2Γ (sqrt(v0² + 2ψ) - v0)),

and E0 follows from y(V) = d. A monotone profile needs E0 >= 0; E0 = 0 is its limit, which for v0 = 0 is Child's
law (Child 1911, Phys. Rev. 32, 492; Langmuir 1913, Phys. Rev. 2, 450):

    Γ_CL = (4/9) sqrt(2) V^{3/2} / d²   (in SI: J = (4/9) ε0 sqrt(2e/m) V^{3/2} / d²),

with φ = V (y/d)^{4/3}. The integrals are evaluated with the substitution ψ = φ t² (which removes the endpoint
singularities) by Gauss–Legendre quadrature; E0 by Brent's method.

For v0 > 0 the beam still passes a little above E0 = 0, over a potential minimum φ_m = (v_m² - v0²)/2 inside the gap
(0 < v_m <= v0, the speed there; Fay, Samuel & Shockley 1938, Bell Syst. Tech. J. 17, 49; Jaffé 1944, Phys. Rev. 65,
91; Birdsall & Bridges 1966, Electron Dynamics of Diode Regions, ch. 3). The field vanishes at the minimum, so
½ φ'² = Γ (v - v_m) on both sides, and with dφ = v dv the distance from the minimum to where the speed is v is

    |y - y_m| = G(v - v_m) / sqrt(2Γ),   G(s) = (2/3) s^{3/2} + 2 v_m s^{1/2}.

The cathode (v = v0) and the anode (v = v_a = sqrt(v0² + 2V)) lie on either side, so

    d sqrt(2Γ) = F(v_m) = G(v0 - v_m) + G(v_a - v_m),   Γ(v_m) = F(v_m)² / (2 d²).

v_m = v0 is the monotone profile's limit E0 = 0; v_m -> 0 the two Child-law regions either side of a virtual
cathode, Γ(0) = (4/9) sqrt(2) ((v0²/2)^{3/4} + (V + v0²/2)^{3/4})² / d², the least flux at which a virtual cathode,
once formed, can persist. Between them Γ(v_m) peaks where F'(v_m) = Σ (s - v_m)/sqrt(s) = 0 (s = v0 - v_m, v_a -
v_m): that maximum is the largest flux with a steady beam-through state, above which part of the beam must turn
back (:func:`beam_through_limit`). All three depend on V, d and v0 through Γ/Γ_CL(V, d) = f(v0²/V) only.

With a steady virtual cathode (v = 0 and E = 0 at φ = -v0²/2, a distance d1 from the cathode) the injected Γ
splits into Γ_t transmitted and Γ - Γ_t returned; between cathode and virtual cathode both streams pass, so two
Child-law regions carry 2Γ - Γ_t over the drop v0²/2 and Γ_t over V + v0²/2 (Birdsall & Bridges 1966, ch. 3):

    sqrt(K) ((v0²/2)^{3/4} / sqrt(2Γ - Γ_t) + (V + v0²/2)^{3/4} / sqrt(Γ_t)) = d,   K = (4/9) sqrt(2),

whose left side falls monotonically in Γ_t on (0, Γ] (:func:`virtual_cathode_transmitted_flux`); a root exists
for Γ above Γ(0).

That steady state is not what a beam injected above Γ_max settles into: its virtual cathode oscillates, and the flux
it passes, averaged over many oscillations, lies above the steady Γ_t (3.9 % at V = 2.5, d = 1.5, v0 = 0.1, Γ = 3
Γ_CL; 1.9 % at v0 = 0.05, 0.7 % at v0 = 0.02: -> Γ_CL as v0 -> 0, the Child-Langmuir current being the mean
transmitted current for any injected one above it, Puri, Biswas & Kumar 2004, Phys. Plasmas 11, 1178). No closed
form is used for it: ``sheet_model.csv`` holds the one-dimensional sheet model's time average
(:mod:`.reference_sheet_model`: exact Gauss's-law field, no grid, converged in Δt and sheet weight) for tabulated
cases, read by :func:`sheet_model_transmitted_flux`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from warpfree.validation import read_csv

__all__ = ["child_langmuir_flux", "steady_potential", "cathode_gradient", "beam_through_limit",
           "beam_through_flux", "virtual_cathode_floor", "virtual_cathode_transmitted_flux",
           "sheet_model_transmitted_flux"]

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
    """E0 = φ'(0) >= 0 of the steady monotone profile; ValueError above its limit E0 = 0 (Γ(v0) below)."""
    if _distance(voltage, 0.0, flux, v0) < gap:
        raise ValueError(f"flux {flux:.6g} is above the space-charge limit of a monotone profile in this diode (E0 "
                         f"would be < 0; beam-through states, over a potential minimum, end at "
                         f"{beam_through_limit(v0, voltage, gap):.6g})")
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


def beam_through_flux(speed_at_minimum: float, v0: float, voltage: float, gap: float) -> float:
    """Γ(v_m) = F(v_m)² / (2 d²), F(v_m) = G(v0 - v_m) + G(v_a - v_m), G(s) = (2/3) s^{3/2} + 2 v_m s^{1/2}: the flux
    of the steady beam-through state whose potential minimum has speed v_m (0 <= v_m <= v0; v_a = sqrt(v0² + 2V))."""
    vm = float(speed_at_minimum)
    if not 0.0 <= vm <= v0:
        raise ValueError(f"speed_at_minimum must lie in [0, v0 = {v0:.6g}], got {vm!r}")
    va = math.sqrt(v0 ** 2 + 2.0 * voltage)
    f = sum(2.0 / 3.0 * s ** 1.5 + 2.0 * vm * math.sqrt(s) for s in (v0 - vm, va - vm))
    return f * f / (2.0 * gap ** 2)


def beam_through_limit(v0: float, voltage: float, gap: float) -> float:
    """Γ_max = max over 0 <= v_m <= v0 of Γ(v_m) (:func:`beam_through_flux`): the largest flux of a cold beam
    injected at v0 that a steady state carries through the diode; above it part of the beam turns back. Γ_max /
    Γ_CL = 1.1119 at v0² / V = 0.0025, 1.2361 at 0.01, -> 1 as v0² / V -> 0. The maximum, where F'(v_m) =
    (v_a - 2 v_m)/sqrt(v_a - v_m) + (v0 - 2 v_m)/sqrt(v0 - v_m) = 0, is bracketed on a grid v_m = v0 (1 - t²) and
    refined by Brent's method (F' > 0 at v_m = 0, -> -inf as v_m -> v0)."""
    if not (v0 > 0.0 and voltage > 0.0 and gap > 0.0):
        raise ValueError(f"v0, voltage and gap must be > 0, got {v0!r}, {voltage!r}, {gap!r}")
    va = math.sqrt(v0 ** 2 + 2.0 * voltage)

    def slope(vm):
        return (va - 2.0 * vm) / math.sqrt(va - vm) + (v0 - 2.0 * vm) / math.sqrt(v0 - vm)

    grid = v0 * (1.0 - np.linspace(0.0, 1.0, 401)[1:] ** 2)[::-1]          # v_m from 0 up to v0 (excluded)
    values = [beam_through_flux(vm, v0, voltage, gap) for vm in grid]
    k = int(np.argmax(values))
    best = [(values[k], grid[k])]
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    if slope(lo) > 0.0 > slope(hi):
        vm = brentq(slope, lo, hi, xtol=1e-15 * v0, rtol=1e-14)
        best.append((beam_through_flux(vm, v0, voltage, gap), vm))
    best.append((beam_through_flux(v0, v0, voltage, gap), v0))
    return max(best)[0]


def virtual_cathode_floor(v0: float, voltage: float, gap: float) -> float:
    """Γ(0) = (4/9) sqrt(2) ((v0²/2)^{3/4} + (V + v0²/2)^{3/4})² / d²: the two Child-law regions either side of a
    virtual cathode at φ = -v0²/2 (the least flux at which a steady state with a virtual cathode exists)."""
    return beam_through_flux(0.0, v0, voltage, gap)


def virtual_cathode_transmitted_flux(flux: float, v0: float, voltage: float, gap: float) -> float:
    """Γ_t of the steady virtual-cathode state at injected flux Γ > Γ(0) (:func:`virtual_cathode_floor`): the root
    of sqrt(K) ((v0²/2)^{3/4} / sqrt(2Γ - Γ_t) + (V + v0²/2)^{3/4} / sqrt(Γ_t)) = d, by Brent's method; ValueError
    at or below Γ(0), where no virtual cathode is steady."""
    floor = virtual_cathode_floor(v0, voltage, gap)
    if flux <= floor:
        raise ValueError(f"flux {flux:.6g} is at or below {floor:.6g}, the least flux of a steady virtual cathode")
    k = 4.0 / 9.0 * math.sqrt(2.0)
    drop = 0.5 * v0 ** 2

    def excess(transmitted):
        return math.sqrt(k) * (drop ** 0.75 / math.sqrt(2.0 * flux - transmitted)
                               + (voltage + drop) ** 0.75 / math.sqrt(transmitted)) - gap

    return brentq(excess, 1e-12 * flux, flux, xtol=1e-15 * flux, rtol=1e-13)


def sheet_model_transmitted_flux(flux: float, v0: float, voltage: float, gap: float) -> tuple[float, float] | None:
    """(Γ_t, its spread) of the oscillating virtual cathode at injected flux Γ, both over Γ_CL: the sheet model's
    anode flux averaged over t = 50..100 and its standard deviation over windows of 2 time units (``sheet_model.csv``,
    :mod:`.reference_sheet_model`), for a tabulated case (V, d, v0 and Γ / Γ_CL equal to 1e-9 relative); None for
    any other."""
    header, data = read_csv("pic_diode", "sheet_model.csv")
    col = {name: k for k, name in enumerate(header)}
    fraction = flux / child_langmuir_flux(voltage, gap)
    for row in data:
        if all(math.isclose(row[col[name]], value, rel_tol=1e-9) for name, value in
               (("voltage", voltage), ("gap", gap), ("injection_speed", v0), ("injected_fraction", fraction))):
            return float(row[col["transmitted_over_child_langmuir"]]), float(row[col["window_std"]])
    return None
