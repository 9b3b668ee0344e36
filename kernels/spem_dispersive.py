"""SPEM's dispersive materials on the device: a Drude medium by an auxiliary current (ADE), a module of its own so that a
scene without one never compiles it.

ε∞ ε0 ∂E/∂t = curl H - J,   ∂J/∂t = -γ J + ε0 ωp² E            (Taflove & Hagness, §9.4; e^{iωt}: ε = ε∞ - ωp²/(ω² - iγω))

J lives with H at whole steps. After the E phase (E^{n+1/2} from H^n): E^{n+1/2} -= (Δt/ε) J^n, then
J^{n+1} = [(1 - γΔt/2) J^n + ε0 ωp² Δt E^{n+1/2}] / (1 + γΔt/2) (the trapezoid in γ, E at the interval's midpoint):
second order, and with the curl a leapfrog whose step limit the model lowers to 2/√(ρ + max ωp²/ε∞) (ρ the curl
operator's spectral radius). float32, SI; ``weight`` = ε0 ωp² (F/(m s²)), ``rate`` = γ (1/s).
"""

import warp as wp

from .clock import STEP


@wp.kernel
def drude_electric(
    first: int,
    particles: wp.array(dtype=wp.int32),
    clock: wp.array(dtype=wp.float64),
    inv_permittivity: wp.array(dtype=float),
    current: wp.array(dtype=float),
    ez: wp.array(dtype=float),
    ezx: wp.array(dtype=float),
):
    """E^{n+1/2} -= (Δt/ε) J^n on the Drude particles (its x part with it: a Drude medium lies outside the PML)."""
    i = particles[first + wp.tid()]
    change = float(clock[STEP]) * inv_permittivity[i] * current[i]
    ez[i] = ez[i] - change
    ezx[i] = ezx[i] - change


@wp.kernel
def drude_current(
    first: int,
    particles: wp.array(dtype=wp.int32),
    clock: wp.array(dtype=wp.float64),
    weight: wp.array(dtype=float),
    rate: wp.array(dtype=float),
    ez: wp.array(dtype=float),
    current: wp.array(dtype=float),
):
    """J^{n+1} = [(1 - γΔt/2) J^n + ε0 ωp² Δt E^{n+1/2}] / (1 + γΔt/2) on the Drude particles."""
    i = particles[first + wp.tid()]
    dt = float(clock[STEP])
    half = 0.5 * rate[i] * dt
    current[i] = ((1.0 - half) * current[i] + weight[i] * dt * ez[i]) / (1.0 + half)
