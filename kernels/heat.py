"""SPH heat conduction (Brookshaw 1985; Cleary & Monaghan 1999): the example solver's kernels.

Precision: float32. Units: SI (m, s; temperature in K or any unit, the equation is linear).

For a constant diffusivity α (m²/s) on particles of volume V_j:

    dT_i/dt = 2α Σ_j V_j (T_i - T_j) F_ij / N_i,   F_ij = (r_ij·∇_i W_ij)/(r_ij² + η²) <= 0,  η² = 0.01 h²
    N_i = -(1/d) Σ_j V_j F_ij r_ij²                                                   (dimensionless)

Brookshaw's Laplacian (no second derivative of W) divided by its discrete second moment N_i, so that
it is exact for quadratic fields. Without N_i (N_i = 1 in the continuum) the sum's bias does not vanish
as dx → 0 at a fixed h/dx: measured -3.7% in the decay rate of a sine mode at 20, 40 and 80 particles
per wavelength (h = 1.3 dx, Wendland C2); with it the error is O((kh)²). On a lattice or in a periodic
box N_i is the same for every particle and the operator conserves Σ V T exactly; on irregular
particles N_i varies and conservation holds only to the truncation error.
Forward Euler, T ← T + Δt dT/dt, is stable for Δt <= 2/λ_max of the operator; Gershgorin's bound
λ_max <= 2 max_i D_i with D_i = 2α Σ_j V_j |F_ij| / N_i gives the step Δt = 1/max_i D_i.

Neighbours: a static list (particles do not move), displacements from the shared space function. Each launch runs
over ``order``: thread item ``first + tid`` computes particle ``order[first + tid]`` (a rank's own particles, in the
load distribution over threads, ``warpfree/distribution.py``); every particle writes only its own slots (a gather), so
the results do not depend on the order.
"""

import warp as wp

from .neighbours import NeighbourRows
from .smoothing import kernel_grad_coef
from .space import Box, displacement

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("temperature_rate",)


@wp.struct
class HeatConstants:
    """α (m²/s), h (m), 1/h, (support)² (m²), η² = 0.01 h² (m²), σ_d/h² (∇W = grad_factor (df/dq)/q r_ij),
    the smoothing kernel id and dimension, and the space."""

    alpha: float
    h: float
    inv_h: float
    support2: float
    eta2: float
    grad_factor: float
    kind: int
    dim: int
    box: Box


@wp.func
def brookshaw_factor(c: HeatConstants, rij: wp.vec3, r2: float) -> float:
    """F_ij = (r_ij·∇_i W_ij)/(r_ij² + η²) (1/m²; <= 0)."""
    coef = c.grad_factor * kernel_grad_coef(c.kind, c.dim, wp.sqrt(r2) * c.inv_h)  # ∇W = coef · r_ij
    return coef * r2 / (r2 + c.eta2)


@wp.kernel
def temperature_rate(
    first: int,
    order: wp.array(dtype=wp.int32),
    c: HeatConstants,
    rows: NeighbourRows,
    position: wp.array(dtype=wp.vec3),
    volume: wp.array(dtype=float),
    normalisation: wp.array(dtype=float),
    temperature: wp.array(dtype=float),
    rate: wp.array(dtype=float),
):
    """rate[i] = dT_i/dt = 2α Σ_j V_j (T_i - T_j) F_ij / N_i."""
    i = order[first + wp.tid()]
    xi = position[i]
    ti = temperature[i]
    s = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        j = rows.index[n]
        rij = displacement(c.box, xi, position[j])
        r2 = wp.dot(rij, rij)
        if r2 < c.support2:
            s += volume[j] * (ti - temperature[j]) * brookshaw_factor(c, rij, r2)
    rate[i] = 2.0 * c.alpha * s / normalisation[i]


@wp.kernel
def operator_geometry(
    first: int,
    order: wp.array(dtype=wp.int32),
    c: HeatConstants,
    rows: NeighbourRows,
    position: wp.array(dtype=wp.vec3),
    volume: wp.array(dtype=float),
    normalisation: wp.array(dtype=float),
    bound: wp.array(dtype=float),
):
    """Once (static particles): N_i = -(1/d) Σ_j V_j F_ij r_ij² and the Gershgorin diagonal
    D_i = 2α Σ_j V_j |F_ij| / N_i (1/s), with λ_max <= 2 max D_i."""
    i = order[first + wp.tid()]
    xi = position[i]
    moment = float(0.0)
    s = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        j = rows.index[n]
        rij = displacement(c.box, xi, position[j])
        r2 = wp.dot(rij, rij)
        if r2 < c.support2:
            f = brookshaw_factor(c, rij, r2)
            moment -= volume[j] * f * r2
            s += volume[j] * wp.abs(f)
    normalisation[i] = moment / float(c.dim)
    bound[i] = 2.0 * c.alpha * s / normalisation[i]


@wp.kernel
def euler_update(first: int, order: wp.array(dtype=wp.int32), dt: float, rate: wp.array(dtype=float),
                 temperature: wp.array(dtype=float)):
    """T_i ← T_i + Δt dT_i/dt."""
    i = order[first + wp.tid()]
    temperature[i] = temperature[i] + dt * rate[i]
