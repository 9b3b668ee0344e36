"""Weakly-compressible SPH kernels (seed 004, chapter 5; Adami 2012 walls; Molteni–Colagrossi δ-SPH).

Precision: float32 (fluid SPH tolerates it; densities vary by ~1%, pressures are O(ρ0 c0²)).
Units: SI (m, s, kg; pressures in Pa, densities in kg/m³, accelerations in m/s²).

Particles live in combined arrays: fluid indices ``[0, nf)``, boundary indices ``[nf, n)``. Neighbours
come from candidate tables (fluid -> fluid, fluid -> boundary, boundary -> fluid) built from
``wp.HashGrid`` queries with a skin and rebuilt once a fluid particle moved more than half the skin;
every loop tests the true distance against the support. Every kernel is a gather: thread ``i``
writes only particle ``i``.

Equations (r_ij = x_i - x_j, v_ij = v_i - v_j, ∇W_ij = ∇_i W(r_ij, h)):

- Tait EOS (seed 4-39):         p = B[(ρ/ρ0)^γ - 1],  B = ρ0 c0²/γ, γ = 7
- continuity (seed 4-37):       dρ_i/dt = Σ_j m_j v_ij·∇W_ij + δ-SPH diffusion D_i
- δ-SPH (Molteni & Colagrossi 2009, hydrostatic correction in the style of Fourtakas 2019):
      D_i = δ h c0 Σ_{j fluid} V_j ψ_ij·∇W_ij,
      ψ_ij = 2[(ρ_j - ρ_i) - ρ0 g·(x_j - x_i)/c0²] (x_j - x_i)/(r² + 0.01h²)
- momentum (seed 4-38):         dv_i/dt = -Σ_j m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇W_ij + F^visc_i + g
- laminar viscosity (Morris 1997): F^visc_i = Σ_j m_j 2μ/(ρ_i ρ_j) (r_ij·∇W_ij)/(r² + 0.01h²) v_ij
- artificial viscosity (Monaghan 1992): Π_ij = -α c0 μ_ij/ρ̄_ij, μ_ij = h v_ij·r_ij/(r² + 0.01h²)
  when v_ij·r_ij < 0, else 0
- Lennard-Jones wall force (seed 5-6, with the printed condition corrected to r < r0):
      Γ_ig = D[(r0/r)^12 - (r0/r)^4] r_ig/r²
  With dynamic boundaries the same force, with r0 < dx, is a safety net that only acts on a fluid
  particle closer to a wall particle than any particle of a settled flow is.
- Adami et al. 2012 wall pressure (eq. 27) for dynamic boundary particles w:
      p_w = [Σ_f p_f W_wf + (g - a_w)·Σ_f ρ_f r_wf W_wf] / Σ_f W_wf,  ρ_w from the inverse EOS,
      ghost velocity for no-slip ṽ_w = 2 v_w - Σ_f v_f W_wf / Σ_f W_wf.
      In the fluid–wall pressure term both pressures enter as max(p, 0): walls push and never pull
      (with suction, free-surface particles running down a wall are glued to it and leak through).
- leapfrog (seed 5-3 to 5-5) in kick–drift–kick form with Monaghan's predictor for the rates.
"""

import warp as wp

from warpfree.kernels.smoothing import kernel_grad_coef, kernel_shape, kernel_sigma

# boundary models
BOUNDARY_DYNAMIC = wp.constant(0)
BOUNDARY_LENNARD_JONES = wp.constant(1)

# run status flags written per particle
STATUS_OK = wp.constant(0)
STATUS_NONFINITE = wp.constant(1)
STATUS_OUTSIDE = wp.constant(2)


@wp.func
def tait_pressure(rho: float, rho0: float, b: float, gamma: float) -> float:
    """Tait EOS p = B[(ρ/ρ0)^γ - 1] in Pa (γ = 7 by multiplications: pow costs ~10x more)."""
    r = rho / rho0
    if gamma == 7.0:
        r2 = r * r
        return b * (r2 * r2 * r2 * r - 1.0)
    return b * (wp.pow(r, gamma) - 1.0)


@wp.func
def tait_density(p: float, rho0: float, b: float, gamma: float) -> float:
    """Inverse Tait EOS ρ = ρ0 (1 + p/B)^(1/γ) in kg/m³."""
    return rho0 * wp.pow(1.0 + p / b, 1.0 / gamma)


@wp.func
def lennard_jones(rij: wp.vec3, r2: float, d: float, r0: float) -> wp.vec3:
    """Seed eq. 5-6: Γ = D[(r0/r)^12 - (r0/r)^4] r_ij/r² (m/s²), for r < r0 (the caller tests it)."""
    q2 = r0 * r0 / r2
    q4 = q2 * q2
    q12 = q4 * q4 * q4
    return (d * (q12 - q4) / r2) * rij


@wp.func
def status_of(x: wp.vec3, v: wp.vec3, rho: float, lo: wp.vec3, hi: wp.vec3) -> int:
    """0 if finite and inside the container box [lo, hi], 1 if non-finite, 2 if outside."""
    s = float(x[0] + x[1] + x[2] + v[0] + v[1] + v[2] + rho)
    if not wp.isfinite(s):
        return STATUS_NONFINITE
    if x[0] < lo[0] or x[1] < lo[1] or x[2] < lo[2] or x[0] > hi[0] or x[1] > hi[1] or x[2] > hi[2]:
        return STATUS_OUTSIDE
    return STATUS_OK


@wp.kernel
def equation_of_state(
    first: int,
    rho: wp.array(dtype=float),
    rho0: float,
    b: float,
    gamma: float,
    p: wp.array(dtype=float),
):
    """p_i = B[(ρ_i/ρ0)^γ - 1] for fluid particles."""
    i = first + wp.tid()
    p[i] = tait_pressure(rho[i], rho0, b, gamma)


@wp.kernel
def wall_pressure_adami(
    first: int,
    wf_counts: wp.array(dtype=wp.int32),
    wf_indices: wp.array(dtype=wp.int32),
    wf_cap: int,
    nf: int,
    x: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    rho: wp.array(dtype=float),
    p: wp.array(dtype=float),
    kind: int,
    dim: int,
    h: float,
    support: float,
    gravity: wp.vec3,
    rho0: float,
    b: float,
    gamma: float,
    wall_v: wp.array(dtype=wp.vec3),
    ghost_v: wp.array(dtype=wp.vec3),
):
    """Adami 2012 eq. 27: pressure, density and no-slip ghost velocity of boundary particle nf + tid.

    ``wf_*`` is the neighbour table of fluid candidates of each boundary particle (row k at
    k*wf_cap, built with a skin; the true distance is tested here).
    """
    k = first + wp.tid()
    i = nf + k
    xi = x[i]
    inv_h = 1.0 / h
    sup2 = support * support
    sw = float(0.0)
    spw = float(0.0)
    srw = wp.vec3(0.0, 0.0, 0.0)
    svw = wp.vec3(0.0, 0.0, 0.0)
    for c in range(k * wf_cap, k * wf_cap + wf_counts[k]):
        j = wf_indices[c]
        rij = xi - x[j]
        r2 = wp.dot(rij, rij)
        if r2 >= sup2:
            continue
        w = kernel_shape(kind, dim, wp.sqrt(r2) * inv_h)  # σ_d cancels in the ratios below
        sw += w
        spw += p[j] * w
        srw += rho[j] * w * rij
        svw += v[j] * w
    if sw > 0.0:
        pw = (spw + wp.dot(gravity, srw)) / sw
        p[i] = pw
        rho[i] = tait_density(pw, rho0, b, gamma)
        ghost_v[i] = 2.0 * wall_v[i] - svw / sw
    else:
        p[i] = 0.0
        rho[i] = rho0
        ghost_v[i] = wall_v[i]


@wp.func
def pair_terms(
    vi: wp.vec3, rhoi: float, inv_rhoi: float, pi_term: float, rij: wp.vec3, r2: float, vj: wp.vec3,
    rhoj: float, pj: float, mj: float, viscous: int, kind: int, dim: int, inv_h: float, gfac: float,
    eps: float, mu: float, avisc: float,
):
    """Pressure (+ artificial viscosity) and laminar-viscosity acceleration of one pair.

    ``pi_term`` = p_i/ρ_i². Returns (dv_i/dt contribution, ∇W_ij, 1/(r² + 0.01h²)); two divisions per
    pair (three when the pair approaches), which matters in this, the hottest loop.
    """
    gw = (gfac * kernel_grad_coef(kind, dim, wp.sqrt(r2) * inv_h)) * rij
    inv_r2e = 1.0 / (r2 + eps)
    inv_rhoj = 1.0 / rhoj
    coef = pi_term + pj * inv_rhoj * inv_rhoj
    a = wp.vec3(0.0, 0.0, 0.0)
    if viscous != 0:
        vij = vi - vj
        vr = wp.dot(vij, rij)
        if vr < 0.0:
            coef -= avisc * vr * inv_r2e / (0.5 * (rhoi + rhoj))
        if mu > 0.0:
            a = (mj * 2.0 * mu * inv_rhoi * inv_rhoj * wp.dot(rij, gw) * inv_r2e) * vij
    a -= (mj * coef) * gw
    return a, gw, inv_r2e


@wp.kernel
def fluid_rates(
    first: int,
    ff_counts: wp.array(dtype=wp.int32),
    ff_indices: wp.array(dtype=wp.int32),
    ff_cap: int,
    fw_counts: wp.array(dtype=wp.int32),
    fw_indices: wp.array(dtype=wp.int32),
    fw_cap: int,
    nf: int,
    nb: int,
    x: wp.array(dtype=wp.vec3),
    v_eval: wp.array(dtype=wp.vec3),
    rho_eval: wp.array(dtype=float),
    p: wp.array(dtype=float),
    mass: wp.array(dtype=float),
    wall_v: wp.array(dtype=wp.vec3),
    ghost_v: wp.array(dtype=wp.vec3),
    kind: int,
    dim: int,
    h: float,
    support: float,
    rho0: float,
    c0: float,
    mu: float,
    alpha: float,
    delta: float,
    gravity: wp.vec3,
    boundary_model: int,
    wall_viscous: int,
    lj_d: float,
    lj_r0: float,
    drho: wp.array(dtype=float),
    acc: wp.array(dtype=wp.vec3),
):
    """dρ/dt and dv/dt of fluid particle i (continuity 4-37, momentum 4-38; see module docstring).

    Two neighbour sweeps over candidate tables built with a skin (row i at i*cap): fluid neighbours
    ``ff_*`` (indices 0..nf-1) and boundary neighbours ``fw_*`` (indices 0..nb-1, i.e. particle nf + j).
    """
    i = first + wp.tid()
    xi = x[i]
    vi = v_eval[i]
    rhoi = rho_eval[i]
    inv_rhoi = 1.0 / rhoi
    pi_term = p[i] * inv_rhoi * inv_rhoi
    pi_plus_term = wp.max(p[i], 0.0) * inv_rhoi * inv_rhoi  # walls push, never pull
    inv_h = 1.0 / h
    gfac = kernel_sigma(kind, dim, h) * inv_h * inv_h  # ∇W = gfac · (f'(q)/q) · r_ij
    eps = 0.01 * h * h
    inv_c2 = 1.0 / (c0 * c0)
    sup2 = support * support
    avisc = alpha * c0 * h
    dr = float(0.0)
    diff = float(0.0)
    a = wp.vec3(0.0, 0.0, 0.0)
    for c in range(i * ff_cap, i * ff_cap + ff_counts[i]):
        j = ff_indices[c]
        rij = xi - x[j]
        r2 = wp.dot(rij, rij)
        if r2 >= sup2:
            continue
        mj = mass[j]
        rhoj = rho_eval[j]
        vj = v_eval[j]
        aj, gw, inv_r2e = pair_terms(vi, rhoi, inv_rhoi, pi_term, rij, r2, vj, rhoj, p[j], mj, 1, kind, dim,
                                     inv_h, gfac, eps, mu, avisc)
        a += aj
        dr += mj * wp.dot(vi - vj, gw)
        if delta > 0.0:
            drho_dyn = (rhoj - rhoi) + rho0 * wp.dot(gravity, rij) * inv_c2
            diff -= 2.0 * drho_dyn * (mj / rhoj) * wp.dot(rij, gw) * inv_r2e
    if nb > 0:
        for c in range(i * fw_cap, i * fw_cap + fw_counts[i]):
            j = nf + fw_indices[c]
            rij = xi - x[j]
            r2 = wp.dot(rij, rij)
            if r2 >= sup2:
                continue
            if boundary_model == BOUNDARY_DYNAMIC:
                # Adami p, ρ; prescribed velocity in continuity, no-slip ghost velocity in viscosity.
                # Walls push and never pull: both pressures enter this pair's term as max(p, 0).
                mj = mass[j]
                aj, gw, inv_r2e = pair_terms(vi, rhoi, inv_rhoi, pi_plus_term, rij, r2, ghost_v[j], rho_eval[j],
                                             wp.max(p[j], 0.0), mj, wall_viscous, kind, dim, inv_h, gfac, eps, mu,
                                             avisc)
                a += aj
                dr += mj * wp.dot(vi - wall_v[j], gw)
            # Lennard-Jones force (seed 5-6), acting only when r < r0: the whole wall model of
            # "lennard_jones" boundaries, a short-range safety net of dynamic ones (r0 < dx there)
            if r2 < lj_r0 * lj_r0:
                a += lennard_jones(rij, r2, lj_d, lj_r0)
    drho[i] = dr + delta * h * c0 * diff
    acc[i] = a + gravity


@wp.kernel
def leapfrog_drift(
    first: int,
    dt: float,
    x: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    rho: wp.array(dtype=float),
    acc: wp.array(dtype=wp.vec3),
    drho: wp.array(dtype=float),
    rho0: float,
    b: float,
    gamma: float,
    v_eval: wp.array(dtype=wp.vec3),
    rho_eval: wp.array(dtype=float),
    p: wp.array(dtype=float),
    lo: wp.vec3,
    hi: wp.vec3,
    status: wp.array(dtype=wp.int32),
    x_built: wp.array(dtype=wp.vec3),
    moved2: wp.array(dtype=float),
):
    """First half kick and drift (seed 5-3): v ← v + ½Δt a, ρ ← ρ + ½Δt dρ, x ← x + Δt v.

    Then the predictor for the rate evaluation (Monaghan 1994): v* = v + ½Δt a, ρ* = ρ + ½Δt dρ,
    p* = EOS(ρ*). The status flag marks non-finite values or a particle outside the container box;
    ``moved2`` is the squared displacement since the neighbour lists were built.
    """
    i = first + wp.tid()
    a = acc[i]
    d = drho[i]
    vh = v[i] + (0.5 * dt) * a
    rh = rho[i] + (0.5 * dt) * d
    xn = x[i] + dt * vh
    v[i] = vh
    rho[i] = rh
    x[i] = xn
    ve = vh + (0.5 * dt) * a
    re = rh + (0.5 * dt) * d
    v_eval[i] = ve
    rho_eval[i] = re
    p[i] = tait_pressure(re, rho0, b, gamma)
    status[i] = status_of(xn, vh, rh, lo, hi)
    disp = xn - x_built[i]
    moved2[i] = wp.dot(disp, disp)


@wp.kernel
def leapfrog_kick(
    first: int,
    dt: float,
    x: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    rho: wp.array(dtype=float),
    acc: wp.array(dtype=wp.vec3),
    drho: wp.array(dtype=float),
    lo: wp.vec3,
    hi: wp.vec3,
    status: wp.array(dtype=wp.int32),
):
    """Second half kick: v ← v + ½Δt a(t+Δt), ρ ← ρ + ½Δt dρ(t+Δt) (seed 5-3/5-4)."""
    i = first + wp.tid()
    vn = v[i] + (0.5 * dt) * acc[i]
    rn = rho[i] + (0.5 * dt) * drho[i]
    v[i] = vn
    rho[i] = rn
    status[i] = status_of(x[i], vn, rn, lo, hi)
