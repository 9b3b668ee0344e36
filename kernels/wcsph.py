"""Weakly-compressible SPH kernels (Monaghan 1992, 1994; Adami 2012 walls; Molteni–Colagrossi δ-SPH).

The scheme follows chapter 5 ("Implementação SPH") of a Portuguese thesis on SPH fluids, whose equations are cited
as "SPH-fluids thesis, eq. 5-n" (author unknown: docs/references.md).

Precision: float32 (fluid SPH tolerates it; densities vary by ~1%, pressures are O(ρ0 c0²)).
Units: SI (m, s, kg; pressures in Pa, densities in kg/m³, accelerations in m/s²).

Particles live in combined arrays: fluid indices ``[0, nf)``, boundary (wall) indices ``[nf, n)``;
per-fluid arrays (rates, predictors, the step report) have nf entries, per-wall ones nb. Neighbours
come as :class:`~warpfree.kernels.neighbours.NeighbourRows` (fluid → fluid, fluid → wall,
wall → fluid) holding candidates within support + skin; every loop tests the true distance. Every
kernel is a gather: thread ``i`` writes only particle ``i``. Displacements come from the shared
space function (periodic boxes work through the minimum image).

Optional physics is switched at compile time: :func:`make_kernels` builds the kernels of one
:class:`FluidTerms` (smoothing kernel, dimension, which viscosities, δ-SPH, wall model, periodic
axes), so a term a scene switches off is not in its compiled code.

Equations (r_ij = x_i - x_j, v_ij = v_i - v_j, ∇W_ij = ∇_i W(r_ij, h)):

- Tait EOS (Monaghan 1994):     p = B[(ρ/ρ0)^γ - 1],  B = ρ0 c0²/γ, γ = 7; for a fluid without tension
  p = max(B[(ρ/ρ0)^γ - 1], 0) (``FluidConstants.p_floor`` = 0), in the sensors too
- continuity (Monaghan 1992):   dρ_i/dt = Σ_j m_j v_ij·∇W_ij + δ-SPH diffusion D_i
- δ-SPH (Molteni & Colagrossi 2009, hydrostatic correction in the style of Fourtakas 2019):
      D_i = δ h c0 Σ_{j fluid} V_j ψ_ij·∇W_ij,
      ψ_ij = 2[(ρ_j - ρ_i) - ½(G_i + G_j)·(x_j - x_i)] (x_j - x_i)/(r² + 0.01h²),
  with G = ρ0 g/c0² (the hydrostatic density gradient) or, with ``delta_gradient`` (Antuono et al. 2010), the
  renormalised density gradient of a first pass over the fluid (exact for a linear density on any layout):
      G_i = B_i⁻¹ Σ_{j fluid} V_j (ρ_j - ρ_i) ∇W_ij,   B_i = Σ_{j fluid} V_j ∇W_ij ⊗ (x_j - x_i),
  taking ρ0 g/c0² where B_i is near singular (a particle with few neighbours: det B_i < ``GRADIENT_MIN_DET``,
  B ≈ I in a full support)
- momentum (Monaghan 1992):     dv_i/dt = -Σ_j m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇W_ij + F^visc_i + g
- or, with ``riemann`` (Zhang, Hu & Adams 2017), fluid pairs by the linearised Riemann problem along r_ij:
      dv_i/dt = -Σ_j m_j 2P*_ij/(ρ_i ρ_j) ∇W_ij + ...,
      P*_ij = (ρ_j p_i + ρ_i p_j)/(ρ_i + ρ_j) + β ρ_i ρ_j c0 ΔU/(ρ_i + ρ_j),
      ΔU = -v_ij·r_ij/r (> 0 where the pair approaches),
      β = min(η max(ΔU, 0)/c0, 1): dissipation only where particles approach, quadratic in ΔU below c0/η (their
      low-dissipation limiter, η = 3), in place of Monaghan's Π_ij, which is linear in ΔU and slows free-surface
      sheets (fluid-wall pairs keep Monaghan's pressure terms)
- laminar viscosity (Morris 1997): F^visc_i = Σ_j m_j 2μ'/(ρ_i ρ_j) (r_ij·∇W_ij)/(r² + 0.01h²) v_ij, with
  μ' = μ/S, S the term's lattice second moment (``warpfree/solvers/wcsph/model.py``), so that it is exact for
  a linear shear on the lattice
- artificial viscosity (Monaghan 1992): Π_ij = -α c0 μ_ij/ρ̄_ij, μ_ij = h v_ij·r_ij/(r² + 0.01h²)
  when v_ij·r_ij < 0, else 0
- Lennard-Jones wall force (Monaghan 1994; SPH-fluids thesis, eq. 5-6, its printed condition corrected to r < r0):
      Γ_ig = D[(r0/r)^12 - (r0/r)^4] r_ig/r²
  With dynamic boundaries the same force, with r0 < dx, is a safety net that only acts on a fluid
  particle closer to a wall particle than any particle of a settled flow is.
- Adami et al. 2012 wall pressure (eq. 27) for dynamic boundary particles w:
      p_w = [Σ_f p_f W_wf + (g - a_w)·Σ_f ρ_f r_wf W_wf] / Σ_f W_wf,  ρ_w from the inverse EOS,
      ghost velocity for no-slip ṽ_w = 2 v_w - Σ_f v_f W_wf / Σ_f W_wf.
      In the fluid–wall pressure term both pressures enter as max(p, 0): walls push and never pull
      (with suction, free-surface particles running down a wall are glued to it and leak through).
- leapfrog (SPH-fluids thesis, eqs 5-3 to 5-5) in kick–drift–kick form with Monaghan's predictor for the rates.
- particle shifting (Lind et al. 2012 with the anti-clumping term of Sun et al. 2017), as a shifting velocity
  δu_i added to the particle's motion, with the fields carried along it (an ALE form, so that shifting moves
  particles, not the fluid):
      δu_i = -A h U Σ_{j fluid, wall} V_j [1 + R (W_ij/W(dx))⁴] ∇W_ij,   R = 0.2
      dx_i/dt += δu_i,  dv_i/dt += (δu_i·∇)v_i,  dρ_i/dt += δu_i·∇ρ_i,  ∇φ_i = Σ_j V_j (φ_j - φ_i) ∇W_ij
  Near a free surface (∇·r_i = -Σ_j V_j r_ij·∇W_ij below ``surface_div``, i.e. the support is truncated)
  the component of δu_i along ∇C_i = Σ_j V_j ∇W_ij (the surface normal there) is removed: particles slide
  along the surface and are never pushed out of it.

Colour function (free surfaces): χ(x) = Σ_j V_j W(|x - x_j|, h), sampled on a grid (SPH-fluids thesis, eq. 5-7).
"""

from dataclasses import dataclass
from types import SimpleNamespace

import warp as wp

from .clock import LIMIT, SLOTS, STEP, TIME, advance, choose
from .neighbours import NeighbourRows, PairGrid, pair_in_reach
from .smoothing import kernel_grad_coef, kernel_shape, kernel_w
from .space import Box, displacement, displacement_function, image_displacement, wrap

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("rates",)

# run status of a fluid particle (the 4th component of the step report; the worst one wins a max)
STATUS_OK = wp.constant(0.0)
STATUS_OUTSIDE = wp.constant(1.0)
STATUS_NONFINITE = wp.constant(2.0)

#: the least det B_i of the renormalised density gradient (δ-SPH's ``delta_gradient``). On a lattice (Wendland C2,
#: h = 1.3 dx) det B is 0.95 in a full support, 0.37 (2D) and 0.29 (3D) on a flat free surface, 0.135 in a 2D corner,
#: 0.083 on a 3D edge and 0.023 in a 3D corner; a particle in a sheet one particle thick has det B = 0. Below this
#: value a particle takes the hydrostatic gradient
GRADIENT_MIN_DET = wp.constant(0.01)

#: R of shifting's anti-clumping factor 1 + R (W_ij/W(dx))⁴ (Sun et al. 2017, their n = 4)
SHIFT_ANTI_CLUMPING = wp.constant(0.2)


@wp.struct
class FluidConstants:
    """Constants of a WCSPH model (SI), derived once on the host (see WCSPHModel)."""

    h: float                 # smoothing length (m)
    inv_h: float
    support2: float          # (support radius)² (m²)
    grad_factor: float       # σ_d/h²: ∇W = grad_factor · (df/dq)/q · r_ij
    eps: float               # 0.01 h² (m²), keeps 1/(r² + eps) finite
    rho0: float              # reference density (kg/m³)
    c0: float                # numerical speed of sound (m/s)
    b: float                 # Tait stiffness B = ρ0 c0²/γ (Pa)
    p_floor: float           # the least pressure the fluid holds (Pa): 0 for a fluid without tension, else -3e38
    gamma: float             # Tait exponent
    mu: float                # dynamic viscosity divided by the lattice second moment, μ/S (Pa·s)
    avisc: float             # α c0 h (m²/s), artificial viscosity
    riemann_eta: float       # η/c0 (s/m) of the Riemann dissipation limiter β = min(η max(U_L - U_R, 0)/c0, 1)
    delta_coef: float        # δ h c0 (m²/s), δ-SPH
    inv_c2: float            # 1/c0²
    gravity: wp.vec3         # m/s²
    lj_d: float              # Lennard-Jones strength D (m²/s²)
    lj_r0: float             # Lennard-Jones range r0 (m)
    shift_coef: float        # A h U (m²/s), particle shifting
    inv_shape_dx: float      # 1/f(dx/h): W_ij/W(dx) = f(q_ij) · inv_shape_dx (shifting's anti-clumping term)
    surface_div: float       # ∇·r below which a particle's support is truncated by a free surface
    container_lo: wp.vec3    # fluid must stay in this box (m)
    container_hi: wp.vec3
    box: Box                 # the space (periodic axes)


@wp.struct
class FluidArrays:
    """The particle arrays every WCSPH kernel reads or writes (combined: fluid [0, nf), walls [nf, n))."""

    nf: int
    position: wp.array(dtype=wp.vec3)          # (n) m
    velocity: wp.array(dtype=wp.vec3)          # (n) m/s; walls: their prescribed velocity
    density: wp.array(dtype=float)             # (n) kg/m³; walls: from the inverse EOS of their pressure
    pressure: wp.array(dtype=float)            # (n) Pa
    mass: wp.array(dtype=float)                # (n) kg
    acceleration: wp.array(dtype=wp.vec3)      # (nf) dv/dt, m/s²
    density_rate: wp.array(dtype=float)        # (nf) dρ/dt, kg/(m³ s)
    velocity_eval: wp.array(dtype=wp.vec3)     # (nf) predictor v* = v + ½Δt a
    density_eval: wp.array(dtype=float)        # (nf) predictor ρ* = ρ + ½Δt dρ/dt
    ghost_velocity: wp.array(dtype=wp.vec3)    # (nb) no-slip ghost velocity of the walls
    position_at_build: wp.array(dtype=wp.vec3)  # (nf) positions when the neighbour tables were built
    report: wp.array(dtype=wp.vec4)            # (nf; nf + nb with bodies: their walls' rows after the fluid's)
                                               # |Δx since build|², |v|², |a|², status
    shift_velocity: wp.array(dtype=wp.vec3)    # (nf) δu, m/s (particle shifting; written by rates)
    shift_acceleration: wp.array(dtype=wp.vec3)  # (nf) (δu·∇)v, m/s²
    shift_density_rate: wp.array(dtype=float)  # (nf) δu·∇ρ, kg/(m³ s)
    density_gradient: wp.array(dtype=wp.vec3)  # (nf) renormalised ∇ρ at the predicted state, kg/m⁴ (δ-SPH's
                                               # ``delta_gradient``; one unused row otherwise)
    wall_acceleration: wp.array(dtype=wp.vec3)  # (nb) the walls' acceleration a_w, m/s² (moving walls; one unused
                                                # row otherwise)
    zone: wp.array(dtype=wp.int32)             # (nf) 0 in the domain, k + 1 in opening k's buffer (open boundaries,
                                               # ``kernels/wcsph_open.py``; one unused row otherwise)


@dataclass(frozen=True)
class FluidTerms:
    """What a WCSPH model compiles in (one set of kernels per distinct value)."""

    kernel: int = 1                  # smoothing kernel id (warpfree.kernels.smoothing)
    dim: int = 2
    laminar: bool = True             # Morris laminar viscosity (μ > 0)
    artificial: bool = False         # Monaghan artificial viscosity (α > 0)
    delta_sph: bool = False          # δ-SPH density diffusion (δ > 0)
    delta_gradient: bool = False     # δ-SPH corrected by the renormalised density gradient (Antuono et al. 2010)
    walls: str = "dynamic"           # "dynamic" (Adami), "lennard_jones" (Monaghan 1994) or "none"
    wall_safety: bool = False        # Lennard-Jones safety net of dynamic walls (r0 > 0)
    no_slip: bool = True             # walls enter the laminar viscous term with the ghost velocity
    wall_artificial: bool = False    # artificial viscosity on fluid-wall pairs too (with the ghost velocity)
    riemann: bool = False            # fluid pairs' pressure from a low-dissipation Riemann solver (Zhang et al. 2017)
    moving_walls: bool = False       # walls that accelerate (rigid bodies): a_w in their Adami pressure
    shifting: bool = False           # particle shifting (A > 0)
    open_boundaries: bool = False    # buffer particles (``FluidArrays.zone`` != 0) take no rates
    periodic: tuple = (False, False, False)
    fluid_pairs: str = "rows"        # fluid pairs from a table's rows, or "grid": from the moving grid, no rows stored


@wp.func
def tait_pressure(rho: float, rho0: float, b: float, gamma: float) -> float:
    """Tait EOS p = B[(ρ/ρ0)^γ - 1] in Pa (γ = 7 by multiplications: pow costs ~10x more)."""
    r = rho / rho0
    if gamma == 7.0:
        r2 = r * r
        return b * (r2 * r2 * r2 * r - 1.0)
    return b * (wp.pow(r, gamma) - 1.0)


@wp.func
def fluid_pressure(c: FluidConstants, rho: float) -> float:
    """The fluid's pressure (Pa) at density ρ: the Tait EOS, no lower than ``c.p_floor`` (0 without tension)."""
    return wp.max(tait_pressure(rho, c.rho0, c.b, c.gamma), c.p_floor)


@wp.func
def tait_density(p: float, rho0: float, b: float, gamma: float) -> float:
    """Inverse Tait EOS ρ = ρ0 (1 + p/B)^(1/γ) in kg/m³."""
    return rho0 * wp.pow(1.0 + p / b, 1.0 / gamma)


@wp.func
def lennard_jones(rij: wp.vec3, r2: float, d: float, r0: float) -> wp.vec3:
    """Lennard-Jones wall force (Monaghan 1994; SPH-fluids thesis, eq. 5-6): Γ = D[(r0/r)^12 - (r0/r)^4] r_ij/r²
    (m/s²), for r < r0 (the caller tests it)."""
    q2 = r0 * r0 / r2
    q4 = q2 * q2
    q12 = q4 * q4 * q4
    return (d * (q12 - q4) / r2) * rij


@wp.func
def particle_status(c: FluidConstants, x: wp.vec3, v: wp.vec3, a: wp.vec3, rho: float) -> float:
    """STATUS_NONFINITE if any value is not finite, STATUS_OUTSIDE outside the container box, else STATUS_OK."""
    s = float(x[0] + x[1] + x[2] + v[0] + v[1] + v[2] + a[0] + a[1] + a[2] + rho)
    if not wp.isfinite(s):
        return STATUS_NONFINITE
    lo = c.container_lo
    hi = c.container_hi
    if x[0] < lo[0] or x[1] < lo[1] or x[2] < lo[2] or x[0] > hi[0] or x[1] > hi[1] or x[2] > hi[2]:
        return STATUS_OUTSIDE
    return STATUS_OK


@wp.func
def fluid_report(c: FluidConstants, f: FluidArrays, i: int) -> wp.vec4:
    """The step report of fluid particle i: |x - x(at build)|² (m², minimum image), |v|², |a|², status."""
    x = f.position[i]
    v = f.velocity[i]
    a = f.acceleration[i]
    moved = displacement(c.box, x, f.position_at_build[i])
    return wp.vec4(wp.dot(moved, moved), wp.dot(v, v), wp.dot(a, a), particle_status(c, x, v, a, f.density[i]))



@wp.kernel
def equation_of_state(first: int, c: FluidConstants, density: wp.array(dtype=float), pressure: wp.array(dtype=float)):
    """p_i = B[(ρ_i/ρ0)^γ - 1], no lower than the floor (fluid particles)."""
    i = first + wp.tid()
    pressure[i] = fluid_pressure(c, density[i])


@wp.func
def table_value(times: wp.array(dtype=wp.float64), values: wp.array(dtype=float), t: wp.float64) -> float:
    """A function of time given as a table: linear between the points (``times`` increasing), the end values
    beyond them."""
    m = times.shape[0]
    if t <= times[0]:
        return values[0]
    if t >= times[m - 1]:
        return values[m - 1]
    k = int(1)
    while times[k] < t:
        k += 1
    w = float((t - times[k - 1]) / (times[k] - times[k - 1]))
    return (1.0 - w) * values[k - 1] + w * values[k]


@wp.kernel
def wall_motion(first: int, nf: int, clock: wp.array(dtype=wp.float64), at_step_end: int,
                times: wp.array(dtype=wp.float64), factors: wp.array(dtype=float),
                surface_velocity: wp.array(dtype=wp.vec3), velocity: wp.array(dtype=wp.vec3)):
    """The walls' velocity at the time of the rates: v_k(t) = f(t) v0_k for held wall k = first + tid (particle
    nf + k), f the walls' velocity factor (a table, :func:`table_value`), v0 their surface velocity (m/s); t the
    clock's time, plus its step with ``at_step_end`` (the rates after a drift are those at t + Δt)."""
    k = first + wp.tid()
    t = clock[TIME]
    if at_step_end != 0:
        t = t + clock[STEP]
    v0 = surface_velocity[k]
    if wp.dot(v0, v0) > 0.0:  # a wall with none (at rest, or moved by a rigid body) keeps its velocity
        velocity[nf + k] = table_value(times, factors, t) * v0


@wp.struct
class StepLimits:
    """The terms of the stable step (``WCSPHSolver.stable_dt``), float64 as the host computes them: ``cfl_h`` = C h,
    ``h``, ``c0``, and the constant limits of the viscosity (0.125 h² ρ0/μ) and of particle shifting
    (0.125 h/(A U)), +inf when the term is off."""

    cfl_h: wp.float64
    h: wp.float64
    c0: wp.float64
    viscous: wp.float64
    shifting: wp.float64


#: the clock slots after ``kernels/clock.py``'s own that hold the fluid's reduced step report: max |Δx|², |v|², |a|²,
#: status
REPORT_SLOTS = wp.constant(4)
#: the clock slot after the report that holds the settling damping γ (1/s): v ← v e^(-γΔt) every step while a fluid
#: settles (0: none); in the clock, so in the state: the model stays as it was made
DAMPING = wp.constant(int(SLOTS) + 4)


@wp.kernel
def finish_step(first: int, limits: StepLimits, report: wp.array(dtype=wp.vec4), clock: wp.array(dtype=wp.float64),
                end_of_step: int):
    """The reduced report into the clock's report slots (float64), the next step's stable Δt into its LIMIT and, at
    the ``end_of_step`` (not for the report at the start), the time moved on and the next step chosen:
    Δt = min(C h/(max|v| + c0), 0.25 sqrt(h/max|a|), viscous, shifting) (the CFL condition, SPH-fluids thesis,
    eq. 5-12; ``WCSPHSolver.stable_dt``, the same float64 operations; a min keeps the first operand unless the second
    is smaller, as Python's ``min``)."""
    r = report[0]
    v2 = wp.float64(r[1])
    a2 = wp.float64(r[2])
    for k in range(REPORT_SLOTS):
        clock[SLOTS + k] = wp.float64(r[k])
    dt = limits.cfl_h / (wp.sqrt(v2) + limits.c0)
    if a2 > wp.float64(0.0):
        other = wp.float64(0.25) * wp.sqrt(limits.h / wp.sqrt(a2))
        if other < dt:
            dt = other
    if limits.viscous < dt:
        dt = limits.viscous
    if limits.shifting < dt:
        dt = limits.shifting
    clock[LIMIT] = dt
    if end_of_step != 0:  # t += Δt, then the next step's Δt (``kernels/clock.py``), in this one launch
        advance(clock)
        choose(clock)


@wp.kernel
def step_report(first: int, c: FluidConstants, f: FluidArrays):
    """report[i] for fluid particle i (at the start, and after a checkpoint was loaded)."""
    i = first + wp.tid()
    f.report[i] = fluid_report(c, f, i)


@wp.kernel
def colour_function_grid(
    first: int,
    grid: wp.uint64,
    positions: wp.array(dtype=wp.vec3),
    volumes: wp.array(dtype=float),
    lower: wp.vec3,
    cell: float,
    ny: int,
    nz: int,
    support: float,
    kind: int,
    h: float,
    chi: wp.array(dtype=float),
):
    """χ at grid node i = Σ_j V_j W(|x_i - x_j|, h) (dimensionless, 3D); node i = (ix·ny + iy)·nz + iz lies at
    ``lower + cell · (ix, iy, iz)``."""
    i = first + wp.tid()
    iz = i % nz
    iy = (i // nz) % ny
    ix = i // (ny * nz)
    x = lower + wp.vec3(float(ix) * cell, float(iy) * cell, float(iz) * cell)
    s = float(0.0)
    for j in wp.hash_grid_query(grid, x, support):
        r = wp.length(image_displacement(x, positions[j]))
        if r < support:
            s += volumes[j] * kernel_w(kind, 3, r, h)
    chi[i] = s


@wp.struct
class ShiftingSums:
    """Neighbour sums of particle shifting for one fluid particle (see the module docstring)."""

    grad_concentration: wp.vec3    # Σ V_j [1 + R (W_ij/W(dx))⁴] ∇W_ij (1/m)
    normal: wp.vec3                # Σ V_j ∇W_ij = ∇C (1/m): into the fluid near a free surface
    div_position: float            # ∇·r = -Σ V_j r_ij·∇W_ij (dimensionless; the space dimension inside)
    grad_velocity: wp.mat33        # Σ V_j (v_j - v_i) ⊗ ∇W_ij: (∇v)ᵀ, so (δu·∇)v = grad_velocity δu (1/s)
    grad_density: wp.vec3          # Σ V_j (ρ_j - ρ_i) ∇W_ij (kg/m⁴)


@wp.struct
class RateSums:
    """A fluid particle's sums over its fluid neighbours in ``rates``: dv/dt (m/s²), dρ/dt (kg/m³/s), the δ-SPH
    diffusion sum and the shifting sums."""

    acceleration: wp.vec3
    density_rate: float
    diffusion: float
    shifting: ShiftingSums


@wp.func
def shifting_velocity(c: FluidConstants, s: ShiftingSums) -> wp.vec3:
    """δu = -A h U ∇C̃, with the component along the surface normal removed where the support is truncated."""
    g = s.grad_concentration
    if s.div_position < c.surface_div:
        n2 = wp.dot(s.normal, s.normal)
        if n2 > 0.0:
            g = g - (wp.dot(g, s.normal) / n2) * s.normal
    return -c.shift_coef * g


_made: dict = {}


def make_kernels(terms: FluidTerms) -> SimpleNamespace:
    """The kernels of one model: ``drift``, ``wall_pressure``, ``density_gradient`` (with ``delta_gradient``),
    ``rates``, ``kick``, ``wall_force`` (cached per ``terms``).

    Each takes ``(first, c: FluidConstants, f: FluidArrays, ...)``; see their docstrings.
    """
    if terms in _made:
        return _made[terms]
    disp = displacement_function(terms.periodic)
    kind, dim = terms.kernel, terms.dim
    periodic_any = any(terms.periodic)
    dynamic = terms.walls == "dynamic"
    lj_walls = terms.walls == "lennard_jones" or (dynamic and terms.wall_safety)
    grid_pairs = terms.fluid_pairs == "grid"
    # the fluid pairs: a table's rows, or the moving grid itself (no rows stored: the candidates found again at
    # every sweep, the same ones in the same order)
    FluidPairs = PairGrid if grid_pairs else NeighbourRows

    def make_pair(artificial: bool, laminar: bool, riemann: bool):
        @wp.func
        def pair_terms(c: FluidConstants, vi: wp.vec3, rhoi: float, inv_rhoi: float, pi_term: float, rij: wp.vec3,
                       r2: float, vj: wp.vec3, rhoj: float, pj: float, mj: float):
            """Pressure (+ artificial viscosity) and laminar-viscosity acceleration of one pair.

            ``pi_term`` = p_i/ρ_i². Returns (dv_i/dt contribution, ∇W_ij, 1/(r² + 0.01h²)).
            """
            gw = (c.grad_factor * kernel_grad_coef(wp.static(kind), wp.static(dim), wp.sqrt(r2) * c.inv_h)) * rij
            inv_r2e = 1.0 / (r2 + c.eps)
            inv_rhoj = 1.0 / rhoj
            coef = float(0.0)
            if wp.static(riemann):
                # P* = (ρ_j p_i + ρ_i p_j)/(ρ_i + ρ_j) + β ρ_i ρ_j c0 (U_L - U_R)/(ρ_i + ρ_j), U_L - U_R = -v_ij·r_ij/r
                pi = pi_term * rhoi * rhoi
                du = -wp.dot(vi - vj, rij) / wp.sqrt(r2 + c.eps)
                beta = wp.min(c.riemann_eta * wp.max(du, 0.0), 1.0)
                inv_sum = 1.0 / (rhoi + rhoj)
                pstar = (rhoj * pi + rhoi * pj) * inv_sum + beta * rhoi * rhoj * c.c0 * du * inv_sum
                coef = 2.0 * pstar * inv_rhoi * inv_rhoj
            else:
                coef = pi_term + pj * inv_rhoj * inv_rhoj
            a = wp.vec3(0.0, 0.0, 0.0)
            if wp.static(artificial or laminar):
                vij = vi - vj
                if wp.static(artificial):
                    vr = wp.dot(vij, rij)
                    if vr < 0.0:
                        coef -= c.avisc * vr * inv_r2e / (0.5 * (rhoi + rhoj))
                if wp.static(laminar):
                    a = (mj * 2.0 * c.mu * inv_rhoi * inv_rhoj * wp.dot(rij, gw) * inv_r2e) * vij
            a -= (mj * coef) * gw
            return a, gw, inv_r2e

        return pair_terms

    fluid_pair = make_pair(terms.artificial, terms.laminar, terms.riemann)
    wall_pair = make_pair(terms.artificial and terms.no_slip and terms.wall_artificial, terms.laminar and terms.no_slip,
                          False)

    @wp.func
    def shifting_sums(c: FluidConstants, s: ShiftingSums, vol: float, rij: wp.vec3, r2: float, gw: wp.vec3,
                      dv: wp.vec3, drho: float) -> ShiftingSums:
        """Add neighbour j (volume V_j = m_j/ρ_j, ∇W_ij, v_j - v_i, ρ_j - ρ_i) to the shifting sums of i."""
        w = kernel_shape(wp.static(kind), wp.static(dim), wp.sqrt(r2) * c.inv_h) * c.inv_shape_dx
        w2 = w * w
        vgw = vol * gw
        out = ShiftingSums()
        out.grad_concentration = s.grad_concentration + (1.0 + SHIFT_ANTI_CLUMPING * w2 * w2) * vgw
        out.normal = s.normal + vgw
        out.div_position = s.div_position - wp.dot(rij, vgw)
        out.grad_velocity = s.grad_velocity + wp.outer(dv, vgw)
        out.grad_density = s.grad_density + drho * vgw
        return out

    @wp.kernel(module="unique")
    def drift(first: int, c: FluidConstants, f: FluidArrays, clock: wp.array(dtype=wp.float64)):
        """First half kick and drift (SPH-fluids thesis, eq. 5-3): v ← v + ½Δt a, ρ ← ρ + ½Δt dρ/dt,
        x ← x + Δt v (wrapped into the periodic box); then the predictor for the rate evaluation (Monaghan 1994):
        v* = v + ½Δt a, ρ* = ρ + ½Δt dρ/dt, p* = EOS(ρ*). Δt from the device clock (``kernels/clock.py``)."""
        i = first + wp.tid()
        dt = float(clock[STEP])
        a = f.acceleration[i]
        d = f.density_rate[i]
        vh = f.velocity[i] + (0.5 * dt) * a
        rh = f.density[i] + (0.5 * dt) * d
        xn = f.position[i] + dt * vh
        if wp.static(periodic_any):
            xn = wrap(c.box, xn)
        f.velocity[i] = vh
        f.density[i] = rh
        f.position[i] = xn
        re = rh + (0.5 * dt) * d
        f.velocity_eval[i] = vh + (0.5 * dt) * a
        f.density_eval[i] = re
        f.pressure[i] = fluid_pressure(c, re)

    @wp.kernel(module="unique")
    def wall_pressure(first: int, c: FluidConstants, f: FluidArrays, wall_fluid: NeighbourRows,
                      order: wp.array(dtype=wp.int32)):
        """Adami 2012 eq. 27: pressure, density and no-slip ghost velocity of wall particle k = ``order[first +
        tid]`` (index nf + k), from the fluid candidates in row k of ``wall_fluid``. ``order``: a permutation of the
        walls (the launch's chunks get their share of the walls next to the water: ``distribution.dealt_blocks``)."""
        k = order[first + wp.tid()]
        i = f.nf + k
        xi = f.position[i]
        sw = float(0.0)
        spw = float(0.0)
        srw = wp.vec3(0.0, 0.0, 0.0)
        svw = wp.vec3(0.0, 0.0, 0.0)
        for n in range(wall_fluid.start[k], wall_fluid.start[k] + wall_fluid.count[k]):
            j = wall_fluid.index[n]
            rij = disp(c.box, xi, f.position[j])
            r2 = wp.dot(rij, rij)
            if r2 >= c.support2:
                continue
            w = kernel_shape(wp.static(kind), wp.static(dim), wp.sqrt(r2) * c.inv_h)  # σ_d cancels in the ratios
            sw += w
            spw += f.pressure[j] * w
            srw += f.density_eval[j] * w * rij
            svw += f.velocity_eval[j] * w
        if sw > 0.0:
            g = c.gravity
            if wp.static(terms.moving_walls):
                g = g - f.wall_acceleration[k]
            pw = (spw + wp.dot(g, srw)) / sw
            f.pressure[i] = pw
            f.density[i] = tait_density(pw, c.rho0, c.b, c.gamma)
            f.ghost_velocity[k] = 2.0 * f.velocity[i] - svw / sw
        else:
            f.pressure[i] = 0.0
            f.density[i] = c.rho0
            f.ghost_velocity[k] = f.velocity[i]

    @wp.func
    def gradient_pair(c: FluidConstants, f: FluidArrays, j: int, xi: wp.vec3, rhoi: float, b: wp.mat33, s: wp.vec3):
        """Fluid neighbour j's terms of the renormalised density gradient: (B - V_j ∇W_ij ⊗ r_ij,
        s + V_j (ρ_j - ρ_i) ∇W_ij); a candidate beyond the support adds nothing."""
        rij = disp(c.box, xi, f.position[j])
        r2 = wp.dot(rij, rij)
        if r2 >= c.support2:
            return b, s
        rhoj = f.density_eval[j]
        vol_gw = (f.mass[j] / rhoj * c.grad_factor * kernel_grad_coef(wp.static(kind), wp.static(dim),
                                                                      wp.sqrt(r2) * c.inv_h)) * rij
        return b - wp.outer(vol_gw, rij), s + (rhoj - rhoi) * vol_gw

    @wp.kernel(module="unique")
    def density_gradient(first: int, c: FluidConstants, f: FluidArrays, fluid_fluid: FluidPairs,
                         rows: wp.array(dtype=wp.int32)):
        """The renormalised density gradient G_i = B_i⁻¹ Σ_j V_j (ρ_j - ρ_i) ∇W_ij of fluid particle i = rows[tid]
        at the predicted state (Antuono et al. 2010; the module docstring), ρ0 g/c0² where det B_i is below
        ``GRADIENT_MIN_DET``. ``rows``: as in ``rates`` (a ghost's gradient comes from its owner)."""
        i = rows[first + wp.tid()]
        xi = f.position[i]
        rhoi = f.density_eval[i]
        b = wp.mat33(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        s = wp.vec3(0.0, 0.0, 0.0)
        if wp.static(grid_pairs):
            xb = f.position_at_build[i]
            for k in wp.hash_grid_query(fluid_fluid.grid, xb, fluid_fluid.reach):
                j = fluid_fluid.source_id[k]
                if j != i and pair_in_reach(fluid_fluid, xb, k):
                    b, s = gradient_pair(c, f, j, xi, rhoi, b, s)
        else:
            for n in range(fluid_fluid.start[i], fluid_fluid.start[i] + fluid_fluid.count[i]):
                b, s = gradient_pair(c, f, fluid_fluid.index[n], xi, rhoi, b, s)
        if wp.static(dim == 2):
            b[2, 2] = 1.0
        g = c.rho0 * c.inv_c2 * c.gravity
        if wp.determinant(b) >= GRADIENT_MIN_DET:
            g = wp.inverse(b) * s
        f.density_gradient[i] = g

    @wp.func
    def fluid_rates_pair(c: FluidConstants, f: FluidArrays, i: int, j: int, xi: wp.vec3, vi: wp.vec3, rhoi: float,
                         inv_rhoi: float, pi_term: float, s: RateSums) -> RateSums:
        """Fluid neighbour j's terms of particle i's rates (continuity, momentum, δ-SPH diffusion, shifting sums)
        added to ``s``; a candidate beyond the support adds nothing."""
        rij = disp(c.box, xi, f.position[j])
        r2 = wp.dot(rij, rij)
        if r2 >= c.support2:
            return s
        mj = f.mass[j]
        rhoj = f.density_eval[j]
        vj = f.velocity_eval[j]
        aj, gw, inv_r2e = fluid_pair(c, vi, rhoi, inv_rhoi, pi_term, rij, r2, vj, rhoj, f.pressure[j], mj)
        out = RateSums()
        out.acceleration = s.acceleration + aj
        out.density_rate = s.density_rate + mj * wp.dot(vi - vj, gw)
        out.diffusion = s.diffusion
        if wp.static(terms.delta_sph):
            drho_dyn = float(0.0)
            if wp.static(terms.delta_gradient):
                drho_dyn = (rhoj - rhoi) + 0.5 * wp.dot(f.density_gradient[i] + f.density_gradient[j], rij)
            else:
                drho_dyn = (rhoj - rhoi) + c.rho0 * wp.dot(c.gravity, rij) * c.inv_c2
            out.diffusion = s.diffusion - 2.0 * drho_dyn * (mj / rhoj) * wp.dot(rij, gw) * inv_r2e
        out.shifting = s.shifting
        if wp.static(terms.shifting):
            out.shifting = shifting_sums(c, s.shifting, mj / rhoj, rij, r2, gw, vj - vi, rhoj - rhoi)
        return out

    @wp.kernel(module="unique")
    def rates(first: int, c: FluidConstants, f: FluidArrays, fluid_fluid: FluidPairs, fluid_wall: NeighbourRows,
              rows: wp.array(dtype=wp.int32)):
        """dρ/dt and dv/dt of fluid particle i = rows[tid] (continuity 4-37, momentum 4-38; see the module
        docstring): one sweep over its fluid candidates, one over its wall candidates (wall j is particle nf + j).
        ``rows``: the fluid rows whose rates are needed (every row in one process; a rank's own, its ghosts taking
        their owners' after the kick)."""
        i = rows[first + wp.tid()]
        if wp.static(terms.open_boundaries):
            if f.zone[i] != 0:  # a buffer particle: it moves with its opening's values (kernels/wcsph_open.py)
                f.density_rate[i] = 0.0
                f.acceleration[i] = wp.vec3(0.0, 0.0, 0.0)
                if wp.static(terms.shifting):
                    f.shift_velocity[i] = wp.vec3(0.0, 0.0, 0.0)
                    f.shift_acceleration[i] = wp.vec3(0.0, 0.0, 0.0)
                    f.shift_density_rate[i] = 0.0
                return
        xi = f.position[i]
        vi = f.velocity_eval[i]
        rhoi = f.density_eval[i]
        inv_rhoi = 1.0 / rhoi
        pi_term = f.pressure[i] * inv_rhoi * inv_rhoi
        sums = RateSums()
        if wp.static(grid_pairs):
            xb = f.position_at_build[i]
            for k in wp.hash_grid_query(fluid_fluid.grid, xb, fluid_fluid.reach):
                j = fluid_fluid.source_id[k]
                if j != i and pair_in_reach(fluid_fluid, xb, k):
                    sums = fluid_rates_pair(c, f, i, j, xi, vi, rhoi, inv_rhoi, pi_term, sums)
        else:
            for n in range(fluid_fluid.start[i], fluid_fluid.start[i] + fluid_fluid.count[i]):
                sums = fluid_rates_pair(c, f, i, fluid_fluid.index[n], xi, vi, rhoi, inv_rhoi, pi_term, sums)
        a = sums.acceleration
        dr = sums.density_rate
        diff = sums.diffusion
        sh = sums.shifting
        if wp.static(terms.walls != "none"):
            pi_plus_term = wp.max(f.pressure[i], 0.0) * inv_rhoi * inv_rhoi  # walls push, never pull
            for n in range(fluid_wall.start[i], fluid_wall.start[i] + fluid_wall.count[i]):
                jw = fluid_wall.index[n]
                j = f.nf + jw
                rij = disp(c.box, xi, f.position[j])
                r2 = wp.dot(rij, rij)
                if r2 >= c.support2:
                    continue
                if wp.static(dynamic):
                    # Adami p, ρ; prescribed velocity in continuity, no-slip ghost velocity in viscosity.
                    mj = f.mass[j]
                    aj, gw, inv_r2e = wall_pair(c, vi, rhoi, inv_rhoi, pi_plus_term, rij, r2, f.ghost_velocity[jw],
                                                f.density[j], wp.max(f.pressure[j], 0.0), mj)
                    a += aj
                    dr += mj * wp.dot(vi - f.velocity[j], gw)
                    if wp.static(terms.shifting):
                        dvw = wp.vec3(0.0, 0.0, 0.0)  # free-slip walls add no shear to ∇v
                        if wp.static(terms.no_slip):
                            dvw = f.ghost_velocity[jw] - vi
                        sh = shifting_sums(c, sh, mj / f.density[j], rij, r2, gw, dvw, f.density[j] - rhoi)
                if wp.static(lj_walls):
                    # Monaghan 1994, only for r < r0: the whole wall model of Lennard-Jones walls, a short-range
                    # safety net of dynamic ones (r0 < dx there)
                    if r2 < c.lj_r0 * c.lj_r0:
                        a += lennard_jones(rij, r2, c.lj_d, c.lj_r0)
        if wp.static(terms.delta_sph):
            dr += c.delta_coef * diff
        f.density_rate[i] = dr
        f.acceleration[i] = a + c.gravity
        if wp.static(terms.shifting):
            du = shifting_velocity(c, sh)
            f.shift_velocity[i] = du
            f.shift_acceleration[i] = sh.grad_velocity * du
            f.shift_density_rate[i] = wp.dot(sh.grad_density, du)

    @wp.kernel(module="unique")
    def kick(first: int, c: FluidConstants, f: FluidArrays, clock: wp.array(dtype=wp.float64)):
        """Second half kick: v ← v + ½Δt a(t+Δt), ρ ← ρ + ½Δt dρ/dt(t+Δt) (SPH-fluids thesis, eqs 5-3/5-4); with
        shifting, the particle then moves by Δt δu carrying v and ρ along; then the step report of the particle
        (moved², |v|², |a|², status), reduced on the device. While a fluid settles, v ← v e^(-γΔt) after the kick."""
        i = first + wp.tid()
        dt = float(clock[STEP])
        f.velocity[i] = f.velocity[i] + (0.5 * dt) * f.acceleration[i]
        f.density[i] = f.density[i] + (0.5 * dt) * f.density_rate[i]
        if wp.static(terms.shifting):
            # the shift of this step, with the fields carried along it (first order in Δt)
            xn = f.position[i] + dt * f.shift_velocity[i]
            if wp.static(periodic_any):
                xn = wrap(c.box, xn)
            f.position[i] = xn
            f.velocity[i] = f.velocity[i] + dt * f.shift_acceleration[i]
            f.density[i] = f.density[i] + dt * f.shift_density_rate[i]
        damping = float(clock[DAMPING])
        if damping > 0.0:  # settling only (WCSPHSolver.settle)
            f.velocity[i] = wp.exp(-damping * dt) * f.velocity[i]
        f.report[i] = fluid_report(c, f, i)

    @wp.kernel(module="unique")
    def wall_force(first: int, c: FluidConstants, f: FluidArrays, wall_fluid: NeighbourRows,
                   walls: wp.array(dtype=wp.int32), force: wp.array(dtype=wp.vec3)):
        """The force (N; per metre of depth in 2D) of the fluid on wall particle k = ``walls[first + tid]``: the
        reaction to what ``rates`` gives its fluid neighbours from it, F_k = -Σ_j m_j a_(j←k) (the wall pair's pressure
        and viscous terms with the Adami wall values, and the Lennard-Jones net), at the values the last rates used."""
        k = walls[first + wp.tid()]
        b = f.nf + k
        xk = f.position[b]
        total = wp.vec3(0.0, 0.0, 0.0)
        for n in range(wall_fluid.start[k], wall_fluid.start[k] + wall_fluid.count[k]):
            j = wall_fluid.index[n]
            rjk = disp(c.box, f.position[j], xk)
            r2 = wp.dot(rjk, rjk)
            if r2 >= c.support2:
                continue
            a = wp.vec3(0.0, 0.0, 0.0)
            if wp.static(dynamic):
                rhoj = f.density_eval[j]
                inv_rhoj = 1.0 / rhoj
                pj_plus_term = wp.max(f.pressure[j], 0.0) * inv_rhoj * inv_rhoj
                aj, gw, inv_r2e = wall_pair(c, f.velocity_eval[j], rhoj, inv_rhoj, pj_plus_term, rjk, r2,
                                            f.ghost_velocity[k], f.density[b], wp.max(f.pressure[b], 0.0),
                                            f.mass[b])
                a += aj
            if wp.static(lj_walls):
                if r2 < c.lj_r0 * c.lj_r0:
                    a += lennard_jones(rjk, r2, c.lj_d, c.lj_r0)
            total -= f.mass[j] * a
        force[first + wp.tid()] = total

    kernels = SimpleNamespace(drift=drift, wall_pressure=wall_pressure, rates=rates, kick=kick, wall_force=wall_force,
                              density_gradient=density_gradient if terms.delta_gradient else None)
    _made[terms] = kernels
    return kernels
