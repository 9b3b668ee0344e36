"""SPEM (Mendes 2010): time-domain Maxwell on two static particle sets, as Warp kernels.

Equations (Mendes 2010, TMz, SI units: E in V/m, H in A/m, x in m, t in s):

    ε ∂Ez/∂t = ∂Hy/∂x - ∂Hx/∂y          (3.3)        μ ∂Hx/∂t = -∂Ez/∂y     (3.4)
                                                     μ ∂Hy/∂t =  ∂Ez/∂x     (3.5)

The 1D system of §4.2 (Ex, Hy along z) is the same pair with one axis: Ez(x), Hy(x) here.

Two particle sets, E (Ez) and H (Hx, Hy), interleaved in space and staggered in time: Ez at n+1/2, H at n
(leapfrog, 3.13-3.15). A particle's neighbours are the particles of the *other* set. The derivatives are
linear in the neighbours' values, ∂u/∂x_a (x_i) ≈ Σ_j g_ij,a u_j, with per-pair coefficients g_ij
computed once (the particles do not move) by :func:`gradient_coefficients`, three ways:

- ``FPM`` (default): the finite particle method (Mendes 2010, eqs 2.30-2.35; Liu & Liu 2006): the (d+1) moment
  equations Σ_j u_j [W_ij, ∂_a W_ij] ω_j = u*_i Σ_j [W_ij, ∂_a W_ij] ω_j + ∂_b u Σ_j (x_j - x_i)_b [W_ij,
  ∂_a W_ij] ω_j solved for (u*_i, ∇u). It needs only the other set's values (the thesis's undefined
  "u_i of the other field", erratum 14, is one of the unknowns) and reproduces constant and linear
  fields exactly on any layout, including the cross terms the diagonal CSPM drops.
- ``CSPM``: the diagonal CSPM ratio of eq. 3.6, ∂u/∂x = Σ_j (u_j - u_i) W_i,x ω_j / Σ_j (x_j - x_i)
  W_i,x ω_j (denominator with the matching coordinate difference, erratum 2), with u_i, which particle i
  does not hold, interpolated from the other set by Shepard's formula (2.26).
- ``SPH``: the uncorrected SPH derivative Σ_j u_j ∇_i W(x_i - x_j) ω_j (the thesis's cavity run, §4.3).

Kernel: the cubic spline of eq. 2.9 in d̄ = r/d_W (d_W: the particle's support radius); it needs no
normalisation, since every value is paired with the volume ω_j = 1/Σ_k W(x_j - x_k) of eq. 2.15 (summed
over particle j's own set) and the corrected forms are ratios.

Berenger's split-field PML (3.17-3.20) with the standard pairing (Hx damped by σy*, Hy by σx*: erratum 4)
and damping loss terms (erratum 5), stepped exponentially so that it is stable for any σ:
ε ∂u/∂t + σ u = f  →  u ← a u + b f, a = exp(-σΔt/ε), b = (1 - a)/σ (b = Δt/ε when σ = 0). Each particle
holds its loss rates κ = (σx/ε, σy/ε) (1/s); on H particles the matched σ*/μ = σ/ε (3.21).

Precision: float32 fields and coefficients (the coefficients are solved in float64, the fields are
O(1) and the operator is well conditioned for the supports the model admits).

Arguments: the field updates (:func:`update_electric`, :func:`update_magnetic` and the plane-wave corrections) take
their arrays one by one, not in ``@wp.struct`` bundles. Warp compiles the indexing of a contiguous array passed to a
kernel without its strides; the same arrays inside structs cost the step 5-9 % (``bench/results/kernel_arguments.md``),
and these kernels are the whole SPEM step.
"""

import warp as wp

from .clock import STEP, TIME
from .neighbours import NeighbourRows
from .smoothing import unit_cubic_spline
from .space import Box, displacement

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("update_electric", "update_magnetic")

FPM = wp.constant(0)
CSPM = wp.constant(1)
SPH = wp.constant(2)

SCHEMES = {"fpm": 0, "cspm": 1, "sph": 2}


@wp.kernel
def own_set_volume(
    first: int,
    box: Box,
    rows: NeighbourRows,
    position: wp.array(dtype=wp.vec3),
    support: wp.array(dtype=float),
    volume: wp.array(dtype=float),
):
    """ω_i = 1/Σ_k W(|x_k - x_i|/d_W,i) over particle i's own set, i included (eq. 2.15; dimensionless here, as
    W is unnormalised: only ratios of ω enter the derivatives)."""
    i = first + wp.tid()
    xi = position[i]
    inv_r = 1.0 / support[i]
    s, ds = unit_cubic_spline(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        k = rows.index[n]
        if k != i:
            w, dw = unit_cubic_spline(wp.length(displacement(box, position[k], xi)) * inv_r)
            s += w
    volume[i] = 1.0 / s


@wp.kernel
def gradient_coefficients(
    first: int,
    scheme: int,
    dim: int,
    axis: int,
    box: Box,
    rows: NeighbourRows,
    position: wp.array(dtype=wp.vec3),
    support: wp.array(dtype=float),
    other_position: wp.array(dtype=wp.vec3),
    other_volume: wp.array(dtype=float),
    coefficient: wp.array(dtype=wp.vec3),
    condition: wp.array(dtype=float),
):
    """Per pair (i, j) of row i: g_ij with ∂u/∂x_a (x_i) ≈ Σ_j g_ij,a u_j (1/m), by ``scheme`` (module
    docstring); ``condition[i]``: the Frobenius condition number of the scaled moment matrix (FPM), or
    the inverse of the smallest relative denominator (CSPM, SPH: 1/min_a |D_a|/Σ|terms|), inf when singular.
    ``axis`` >= 0 (FPM, Yee's staggering: only ∂/∂x_axis is wanted): where the neighbours lie on the line through
    x_i along that axis (the other axis's moment below 1e-9 of this one's), the fit is the 1D one along it, as in 1D
    (on a uniform lattice: Yee's two-point difference); -1: the full gradient."""
    i = first + wp.tid()
    xi = position[i]
    radius = support[i]
    inv_r = 1.0 / radius
    start = rows.start[i]
    end = start + rows.count[i]
    # moments in units of the support radius, float64
    m = wp.mat33d()
    shepard = wp.float64(0.0)
    sx = wp.float64(0.0)
    sy = wp.float64(0.0)
    dxx = wp.float64(0.0)
    dyy = wp.float64(0.0)
    axx = wp.float64(0.0)
    ayy = wp.float64(0.0)
    for n in range(start, end):
        j = rows.index[n]
        d = displacement(box, other_position[j], xi) * inv_r  # (x_j - x_i)/d_W
        q = wp.length(d)
        if q < 1.0:
            wq, dwq = unit_cubic_spline(q)
            w = wp.float64(wq * other_volume[j])
            slope = float(0.0)
            if q > 0.0:
                slope = dwq / q
            wx = wp.float64(slope * d[0] * other_volume[j])  # ∂W/∂x_j ω_j (per unit d_W)
            wy = wp.float64(slope * d[1] * other_volume[j])
            dx = wp.float64(d[0])
            dy = wp.float64(d[1])
            m[0, 0] += w
            m[0, 1] += dx * w
            m[0, 2] += dy * w
            m[1, 0] += wx
            m[1, 1] += dx * wx
            m[1, 2] += dy * wx
            m[2, 0] += wy
            m[2, 1] += dx * wy
            m[2, 2] += dy * wy
            shepard += w
            sx += wx
            sy += wy
            axx += wp.abs(dx * wx)
            ayy += wp.abs(dy * wy)
    along = 0  # 1: the fit is the 1D one along ``axis`` (collinear neighbours)
    if dim == 2 and axis == 0 and ayy < wp.float64(1.0e-9) * axx:
        along = 1
    if dim == 2 and axis == 1 and axx < wp.float64(1.0e-9) * ayy:
        along = 1
    if dim == 1 or along == 1:  # drop the axis the neighbours do not span: its row and column become the identity's
        p = 2
        if dim == 2 and axis == 1:
            p = 1
        for k in range(3):
            m[p, k] = wp.float64(0.0)
            m[k, p] = wp.float64(0.0)
        m[p, p] = wp.float64(1.0)
        if p == 2:
            ayy = wp.float64(1.0)
        else:
            axx = wp.float64(1.0)
    dxx = m[1, 1]
    dyy = m[2, 2]
    inv = wp.mat33d()
    cond = float(1.0e30)
    det = wp.determinant(m)
    if scheme == FPM:
        if det != wp.float64(0.0):
            inv = wp.inverse(m)
            cond = float(wp.sqrt(wp.ddot(m, m) * wp.ddot(inv, inv)))
    else:
        if shepard > wp.float64(0.0) and dxx != wp.float64(0.0) and dyy != wp.float64(0.0):
            cond = float(wp.max(axx / wp.abs(dxx), ayy / wp.abs(dyy)))
    condition[i] = cond
    for n in range(start, end):
        j = rows.index[n]
        d = displacement(box, other_position[j], xi) * inv_r
        q = wp.length(d)
        g = wp.vec3(0.0, 0.0, 0.0)
        if q < 1.0 and cond < 1.0e29:
            wq, dwq = unit_cubic_spline(q)
            w = wp.float64(wq * other_volume[j])
            slope = float(0.0)
            if q > 0.0:
                slope = dwq / q
            wx = wp.float64(slope * d[0] * other_volume[j])
            wy = wp.float64(slope * d[1] * other_volume[j])
            if dim == 1 or (along == 1 and axis == 0):
                wy = wp.float64(0.0)
            if along == 1 and axis == 1:
                wx = wp.float64(0.0)
            if scheme == FPM:
                c = inv * wp.vec3d(w, wx, wy)
                g = wp.vec3(float(c[1]), float(c[2]), 0.0)
            elif scheme == CSPM:
                phi = w / shepard  # Shepard weight of j in the interpolated u_i (2.26)
                gx = (wx - sx * phi) / dxx
                gy = wp.float64(0.0)
                if dim > 1:
                    gy = (wy - sy * phi) / dyy
                g = wp.vec3(float(gx), float(gy), 0.0)
            else:
                # ∇_i W(x_i - x_j) ω_j = -∂W/∂x_j ω_j, normalised by Σ_j W ω_j (= 1 for a normalised kernel)
                g = wp.vec3(float(-wx / shepard), float(-wy / shepard), 0.0)
        coefficient[n] = g * inv_r


@wp.func
def exponential_step(kappa: float, dt: float, inv_material: float) -> wp.vec2:
    """(a, b) of u ← a u + b f for m ∂u/∂t + σ u = f with κ = σ/m (1/s): a = exp(-κΔt), b = (Δt/m)(1 - a)/(κΔt)
    (Δt/m when κ = 0); ``inv_material`` = 1/m (1/ε or 1/μ). (1 - a)/(κΔt) by its series below κΔt = 1e-3: in
    float32, 1 - exp(-κΔt) loses every digit for a tiny κ (a particle a rounding error inside the layer)."""
    x = kappa * dt
    phi = float(1.0)
    a = float(1.0)
    if x < 1.0e-3:
        a = 1.0 - x * (1.0 - 0.5 * x)
        phi = 1.0 - x * (0.5 - x / 6.0)
    else:
        a = wp.exp(-x)
        phi = (1.0 - a) / x
    return wp.vec2(a, dt * inv_material * phi)


@wp.kernel
def update_electric(
    first: int,
    order: wp.array(dtype=wp.int32),
    clock: wp.array(dtype=wp.float64),
    rows: NeighbourRows,
    coefficient: wp.array(dtype=wp.vec3),
    hx: wp.array(dtype=float),
    hy: wp.array(dtype=float),
    inv_permittivity: wp.array(dtype=float),
    loss: wp.array(dtype=wp.vec2),
    held: wp.array(dtype=wp.int32),
    ez: wp.array(dtype=float),
    ezx: wp.array(dtype=float),
):
    """Ez^{n+1/2} from Ez^{n-1/2} and H^n (3.13; split field 3.17/3.18 with exponential loss):
    Ezx ← a_x Ezx + b_x ∂Hy/∂x, Ezy ← a_y Ezy - b_y ∂Hx/∂y, Ez = Ezx + Ezy. Held particles (PEC walls,
    hard sources) keep their value. Thread item ``first + tid`` updates particle ``order[first + tid]`` (the
    load distribution, ``warpfree/distribution.py``). Δt from the device clock (``kernels/clock.py``)."""
    i = order[first + wp.tid()]
    if held[i] != 0:
        return
    dt = float(clock[STEP])
    dhy_dx = float(0.0)
    dhx_dy = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        j = rows.index[n]
        g = coefficient[n]
        dhy_dx += g[0] * hy[j]
        dhx_dy += g[1] * hx[j]
    k = loss[i]
    inv_eps = inv_permittivity[i]
    px = exponential_step(k[0], dt, inv_eps)
    py = exponential_step(k[1], dt, inv_eps)
    e_x = ezx[i]
    e_y = ez[i] - e_x
    e_x = px[0] * e_x + px[1] * dhy_dx
    e_y = py[0] * e_y - py[1] * dhx_dy
    ezx[i] = e_x
    ez[i] = e_x + e_y


@wp.kernel
def update_magnetic(
    first: int,
    order: wp.array(dtype=wp.int32),
    clock: wp.array(dtype=wp.float64),
    rows: NeighbourRows,
    coefficient: wp.array(dtype=wp.vec3),
    ez: wp.array(dtype=float),
    inv_permeability: wp.array(dtype=float),
    loss: wp.array(dtype=wp.vec2),
    hx: wp.array(dtype=float),
    hy: wp.array(dtype=float),
):
    """H^{n+1} from H^n and Ez^{n+1/2} (3.14/3.15; PML 3.19/3.20 with Hx damped by σy*, Hy by σx*):
    Hx ← a_y Hx - b_y ∂Ez/∂y, Hy ← a_x Hy + b_x ∂Ez/∂x; particle ``order[first + tid]``; Δt from the clock."""
    i = order[first + wp.tid()]
    dt = float(clock[STEP])
    dez_dx = float(0.0)
    dez_dy = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        j = rows.index[n]
        g = coefficient[n]
        e = ez[j]
        dez_dx += g[0] * e
        dez_dy += g[1] * e
    k = loss[i]
    inv_mu = inv_permeability[i]
    px = exponential_step(k[0], dt, inv_mu)
    py = exponential_step(k[1], dt, inv_mu)
    hx[i] = py[0] * hx[i] - py[1] * dez_dy
    hy[i] = px[0] * hy[i] + px[1] * dez_dx


@wp.struct
class SourceSignal:
    """A source's waveform f(t) (float64, evaluated on the device at the step's half time): ``kind`` 0 a sine
    sin(2π f t + φ) with a sin² ramp over ``ramp`` periods (0: none), 1 a Gaussian pulse
    sin(2π f (t - delay)) exp(-((t - delay)/width)²). Units: Hz, rad, periods, s."""

    kind: int
    frequency: wp.float64
    phase: wp.float64
    ramp: wp.float64
    width: wp.float64
    delay: wp.float64


@wp.func
def source_signal(w: SourceSignal, t: wp.float64) -> wp.float64:
    """f(t) of :class:`SourceSignal`, as ``warpfree.solvers.spem.solver.Waveform`` / ``GaussianPulse`` compute it on
    the host (the same float64 operations)."""
    two_pi = wp.float64(6.283185307179586)
    if w.kind == 0:
        envelope = wp.float64(1.0)
        if w.ramp > wp.float64(0.0):
            s = wp.min(wp.float64(1.0), t * w.frequency / w.ramp)
            r = wp.sin(wp.float64(1.5707963267948966) * s)
            envelope = r * r
        return envelope * wp.sin(two_pi * w.frequency * t + w.phase)
    u = (t - w.delay) / w.width
    return wp.exp(-u * u) * wp.sin(two_pi * w.frequency * (t - w.delay))


@wp.kernel
def set_source(
    first: int,
    particles: wp.array(dtype=wp.int32),
    amplitude: wp.array(dtype=float),
    signal: SourceSignal,
    clock: wp.array(dtype=wp.float64),
    additive: int,
    ez: wp.array(dtype=float),
    ezx: wp.array(dtype=float),
):
    """Source on E particles at the step's half time t + Δt/2 (the clock's): hard (Ez = A_p f(t), the split parts
    set to Ez and 0) or soft (Ez += A_p f(t), added to the x part). Source particles are distinct, so the kernel is
    race-free."""
    s = first + wp.tid()
    i = particles[s]
    value = float(source_signal(signal, clock[TIME] + wp.float64(0.5) * clock[STEP]))
    v = amplitude[s] * value
    if additive != 0:
        ez[i] = ez[i] + v
        ezx[i] = ezx[i] + v
    else:
        ez[i] = v
        ezx[i] = v


@wp.kernel
def row_abs_sums(
    first: int,
    rows: NeighbourRows,
    coefficient: wp.array(dtype=wp.vec3),
    inv_material: wp.array(dtype=float),
    electric: int,
    out: wp.array(dtype=float),
):
    """A row's absolute sum of the update operator (1/(m · material)): E rows (Σ|g_x| + Σ|g_y|)/ε,
    H rows max(Σ|g_x|, Σ|g_y|)/μ; their maxima bound the leapfrog's stable step (Gershgorin)."""
    i = first + wp.tid()
    sx = float(0.0)
    sy = float(0.0)
    for n in range(rows.start[i], rows.start[i] + rows.count[i]):
        g = coefficient[n]
        sx += wp.abs(g[0])
        sy += wp.abs(g[1])
    s = wp.max(sx, sy)
    if electric != 0:
        s = sx + sy
    out[i] = s * inv_material[i]


@wp.struct
class IncidentWave:
    """A plane wave Ez = A f(τ), H = (A/η) f(τ) (d_y, -d_x), τ = t - (d·x - s0)/v, f(τ) = 0 for τ < 0 (causal):
    ``kind`` 0 a sine sin(2π f τ + φ) with a sin² ramp over ``ramp`` periods, 1 a Gaussian pulse
    sin(2π f (τ - delay)) exp(-((τ - delay)/width)²). Units: V/m, A/m, m, s."""

    direction: wp.vec3  # unit d
    start: float  # s0 (m): d·x where the wave front is at t = 0
    speed: float  # v (m/s)
    amplitude: float  # A (V/m)
    admittance: float  # 1/η (S)
    kind: int
    frequency: float
    phase: float
    ramp: float
    width: float
    delay: float


@wp.func
def incident_signal(w: IncidentWave, x: wp.vec3, t: float) -> float:
    """f(τ) of :class:`IncidentWave` at x and t (dimensionless)."""
    tau = t - (wp.dot(w.direction, x) - w.start) / w.speed
    value = float(0.0)
    if tau >= 0.0:
        if w.kind == 0:
            envelope = float(1.0)
            if w.ramp > 0.0:
                s = wp.min(1.0, tau * w.frequency / w.ramp)
                envelope = wp.sin(0.5 * wp.pi * s) * wp.sin(0.5 * wp.pi * s)
            value = envelope * wp.sin(2.0 * wp.pi * w.frequency * tau + w.phase)
        else:
            u = (tau - w.delay) / w.width
            value = wp.exp(-u * u) * wp.sin(2.0 * wp.pi * w.frequency * (tau - w.delay))
    return value


@wp.func
def incident_sums(wave: IncidentWave, rows: NeighbourRows, s: int, coefficient: wp.array(dtype=wp.vec3),
                  partner_position: wp.array(dtype=wp.vec3), t: float) -> wp.vec2:
    """(Σ_j g_x f_j, Σ_j g_y f_j) over crossing row ``s``: f_j the incident signal at partner j at time t."""
    sx = float(0.0)
    sy = float(0.0)
    for n in range(rows.start[s], rows.start[s] + rows.count[s]):
        f = incident_signal(wave, partner_position[rows.index[n]], t)
        g = coefficient[n]
        sx += g[0] * f
        sy += g[1] * f
    return wp.vec2(sx, sy)


@wp.kernel
def plane_wave_electric(
    first: int,
    clock: wp.array(dtype=wp.float64),
    wave: IncidentWave,
    targets: wp.array(dtype=wp.int32),
    rows: NeighbourRows,
    coefficient: wp.array(dtype=wp.vec3),
    h_position: wp.array(dtype=wp.vec3),
    inv_permittivity: wp.array(dtype=float),
    loss: wp.array(dtype=wp.vec2),
    held: wp.array(dtype=wp.int32),
    ez: wp.array(dtype=float),
    ezx: wp.array(dtype=float),
):
    """Total-field/scattered-field correction of the E phase: E particle ``targets[s]`` whose row crosses the
    TF/SF boundary adds the incident H^n (the clock's time t) of its partners across it, with the sign folded into
    the coefficients (+ seen from the total side, - from the scattered side): Ezx += b_x Σ g_x Hy_inc,
    Ezy -= b_y Σ g_y Hx_inc. Targets are distinct: race-free."""
    s = first + wp.tid()
    i = targets[s]
    if held[i] != 0:
        return
    dt = float(clock[STEP])
    t = float(clock[TIME])
    sums = incident_sums(wave, rows, s, coefficient, h_position, t)
    h0 = wave.amplitude * wave.admittance  # Hx_inc = h0 f d_y, Hy_inc = -h0 f d_x
    dhy_dx = -h0 * wave.direction[0] * sums[0]
    dhx_dy = h0 * wave.direction[1] * sums[1]
    k = loss[i]
    px = exponential_step(k[0], dt, inv_permittivity[i])
    py = exponential_step(k[1], dt, inv_permittivity[i])
    ezx[i] = ezx[i] + px[1] * dhy_dx
    ez[i] = ez[i] + px[1] * dhy_dx - py[1] * dhx_dy


@wp.kernel
def plane_wave_magnetic(
    first: int,
    clock: wp.array(dtype=wp.float64),
    wave: IncidentWave,
    targets: wp.array(dtype=wp.int32),
    rows: NeighbourRows,
    coefficient: wp.array(dtype=wp.vec3),
    e_position: wp.array(dtype=wp.vec3),
    inv_permeability: wp.array(dtype=float),
    loss: wp.array(dtype=wp.vec2),
    hx: wp.array(dtype=float),
    hy: wp.array(dtype=float),
):
    """TF/SF correction of the H phase with the incident Ez at t^{n+1/2} = t + Δt/2 (the clock's): Hx -= b_y Σ g_y
    Ez_inc, Hy += b_x Σ g_x Ez_inc over the row's partners across the boundary (signed coefficients)."""
    s = first + wp.tid()
    dt = float(clock[STEP])
    t = float(clock[TIME] + wp.float64(0.5) * clock[STEP])
    k = targets[s]
    sums = incident_sums(wave, rows, s, coefficient, e_position, t)
    dez_dx = wave.amplitude * sums[0]
    dez_dy = wave.amplitude * sums[1]
    kk = loss[k]
    px = exponential_step(kk[0], dt, inv_permeability[k])
    py = exponential_step(kk[1], dt, inv_permeability[k])
    hx[k] = hx[k] - py[1] * dez_dy
    hy[k] = hy[k] + px[1] * dez_dx

