"""WCSPH against analytic solutions: the Taylor–Green vortex (doubly periodic) and transient plane Poiseuille
flow driven by a body force (Morris, Fox & Zhu 1997), with the observed order of convergence between the two
test resolutions. Exact solutions: ``warpfree.validation.taylor_green_2d`` and ``.poiseuille_2d`` (READMEs there
give the sources and the measurements behind every tolerance below). Fine resolutions live in
``bench/core/speed_vs_error.py --case taylor_green`` and ``--case poiseuille``."""

import inspect
import json
import math

import numpy as np
import pytest

from warpfree import device
from warpfree.cli import main
from warpfree.scene_loader import load_scene
from warpfree.errors import ParameterError
from warpfree.geometry import lattice_box
from warpfree.solvers.wcsph.model import lattice_second_moment
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
from warpfree.validation import poiseuille_2d as pf
from warpfree.validation import taylor_green_2d as tg


# Taylor–Green: L = U = 1, Re = 100 (ν = 0.01), c0 = 10 U; t_e = 0.6333 s (exact kinetic energy down to e^-1)
NU_TG = 0.01
T_E = tg.time_for_energy_ratio(math.exp(-1.0), NU_TG, 1.0)


def scene(name):
    return load_scene(name)


@pytest.fixture(scope="module")
def taylor_green():
    return scene("taylor_green_2d")


@pytest.fixture(scope="module")
def poiseuille():
    return scene("poiseuille_2d")


def run(module, out, **params):
    """Run a scene without frames or VTU into ``out``; returns the summary."""
    device.use("cpu", 2)
    sim = module.build(frames=False, vtk=False, **params)
    summary = sim.run(str(out), progress=False)
    assert summary["status"] == "ok"
    return summary


def order(coarse: float, fine: float) -> float:
    """Observed order of convergence between a resolution and twice it: log2(e_coarse / e_fine)."""
    return math.log2(coarse / fine)


# -- Taylor–Green: the scheme itself against a NumPy re-implementation -------------------------------------------

def numpy_wcsph_periodic(x, v, rho, dx, L, c0, mu, alpha, delta, dt, steps, rho0=1000.0, h_factor=1.3, riemann=0.0,
                         tension=True, delta_gradient=False):
    """The WCSPH scheme of ``kernels/wcsph.py`` (continuity, Tait γ = 7, symmetric pressure or, with ``riemann`` = η,
    the low-dissipation Riemann pair pressure, Morris viscosity, Monaghan α, δ-SPH without gravity (with
    ``delta_gradient``, corrected by the renormalised density gradient of Antuono et al. 2010), Wendland C2,
    kick–drift–kick with the rate predictor; without ``tension`` p >= 0) in float64 NumPy with brute-force
    minimum-image pairs in a periodic L × L box. Returns positions, velocities, densities."""
    h = h_factor * dx
    m = rho0 * dx * dx
    b = rho0 * c0 ** 2 / 7.0
    eps = 0.01 * h * h
    sigma = 7.0 / (4.0 * np.pi * h * h)

    def rates(x, v, r):
        d = x[:, None, :] - x[None, :, :]
        d -= L * np.round(d / L)
        r2 = np.sum(d * d, -1)
        q = np.sqrt(r2) / h
        near = (q < 2.0) & (r2 > 0.0)
        gw = np.where(near, -5.0 * sigma / h ** 2 * np.clip(1.0 - 0.5 * q, 0.0, None) ** 3, 0.0)[..., None] * d
        p = b * ((r / rho0) ** 7 - 1.0)
        if not tension:
            p = np.maximum(p, 0.0)
        vij = v[:, None, :] - v[None, :, :]
        rgw = np.sum(d * gw, -1)
        vr = np.sum(vij * d, -1)
        if riemann > 0.0:
            ri, rj, rsum = r[:, None], r[None, :], r[:, None] + r[None, :]
            du = -vr / np.sqrt(r2 + eps)
            beta = np.minimum(riemann * np.maximum(du, 0.0) / c0, 1.0)
            pstar = (rj * p[:, None] + ri * p[None, :]) / rsum + beta * ri * rj * c0 * du / rsum
            coef = 2.0 * pstar / (ri * rj)
        else:
            coef = (p / r ** 2)[:, None] + (p / r ** 2)[None, :]
        coef = coef - np.where(vr < 0.0, alpha * c0 * h * vr / (r2 + eps) / (0.5 * (r[:, None] + r[None, :])), 0.0)
        acc = np.sum((m * 2.0 * mu / (r[:, None] * r[None, :]) * rgw / (r2 + eps))[..., None] * vij, 1)
        acc -= np.sum((m * coef)[..., None] * gw, 1)
        drho = np.sum(m * np.sum(vij * gw, -1), 1)
        psi = r[None, :] - r[:, None]
        if delta_gradient:  # G_i = B_i⁻¹ Σ_j V_j (ρ_j - ρ_i) ∇W_ij, B_i = Σ_j V_j ∇W_ij ⊗ (x_j - x_i)
            vol = m / r[None, :, None]
            bmat = -np.einsum("ija,ijb->iab", vol * gw, d)
            grad = np.linalg.solve(bmat, np.sum(vol * psi[..., None] * gw, 1)[..., None])[..., 0]
            psi = psi + 0.5 * np.sum((grad[:, None, :] + grad[None, :, :]) * d, -1)
        drho -= delta * h * c0 * np.sum(2.0 * psi * (m / r[None, :]) * rgw / (r2 + eps), 1)
        return acc, drho

    a, dr = rates(x, v, rho)
    for _ in range(steps):
        vh, rh = v + 0.5 * dt * a, rho + 0.5 * dt * dr
        x = np.mod(x + dt * vh, L)
        a, dr = rates(x, vh + 0.5 * dt * a, rh + 0.5 * dt * dr)
        v, rho = vh + 0.5 * dt * a, rh + 0.5 * dt * dr
    return x, v, rho


@pytest.mark.parametrize("alpha,delta,riemann,tension,delta_gradient", [
    (0.0, 0.0, 0.0, True, False), (0.1, 0.1, 0.0, True, False), (0.0, 0.1, 3.0, True, False),
    (0.0, 0.1, 3.0, False, False), (0.0, 0.1, 3.0, True, True)])
def test_periodic_wcsph_matches_a_numpy_reimplementation(alpha, delta, riemann, tension, delta_gradient):
    """The Taylor–Green start (n = 16, c0 = 10, Re = 100) stepped 80 times by warpfree and by a float64 NumPy
    re-implementation of the same equations with brute-force minimum-image pairs: the periodic pressure (Monaghan's
    or the Riemann pair pressure; with and without tension: the vortex's pressure is negative at its centres),
    viscous, artificial-viscosity and δ-SPH terms (plain and with the renormalised density gradient) and the leapfrog.
    Measured (n = 20, 300 steps, through the break-up of the
    vortex): |Δx| ≤ 1.6e-5 dx, |Δv| ≤ 2.1e-5 U, |Δρ| ≤ 1.8e-3 kg/m³ (float32 has 6e-5 kg/m³ per ulp at 1000);
    the bounds are 1e-4 dx, 1e-4 U and 1e-2 kg/m³, float32 rounding, far below any physical effect."""
    device.use("cpu", 2)
    n, L, c0, mu = 16, 1.0, 10.0, NU_TG * 1000.0
    dx = L / n
    x = lattice_box((0.0, 0.0), (L, L), dx)
    rho = tg.inverse_tait_density(tg.pressure(x[:, 0], x[:, 1], 0.0, 1.0, NU_TG, L, 1000.0), 1000.0, c0)
    v = tg.velocity(x[:, 0], x[:, 1], 0.0, 1.0, NU_TG, L)
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=mu, alpha=alpha, delta=delta, riemann=riemann, tension=tension,
                         delta_gradient=delta_gradient,
                         gravity=(0.0, 0.0, 0.0), container_lo=(0.0, 0.0, -1.0), container_hi=(L, L, 1.0),
                         periodic=(True, True, False))
    solver = WCSPHSolver(WCSPHModel(x, np.zeros((0, 2)), params), density=rho, velocity=v)
    dt, steps = 0.5 * solver.stable_dt(), 80
    for _ in range(steps):
        solver.step(dt)
        assert solver.problem() is None
    # the solver divides the laminar term by its lattice second moment S (warpfree.solvers.wcsph.model)
    mu_lattice = mu / lattice_second_moment("wendland_c2", 2, params.h_factor)
    xr, vr, rr = numpy_wcsph_periodic(x, v, rho, dx, L, c0, mu_lattice, alpha, delta, dt, steps,
                                      h_factor=params.h_factor, riemann=riemann, tension=tension,
                                      delta_gradient=delta_gradient)
    d = solver.fluid.numpy("position")[:, :2].astype(np.float64) - xr
    d -= L * np.round(d / L)
    assert np.abs(d).max() < 1e-4 * dx
    assert np.abs(solver.fluid.numpy("velocity")[:, :2] - vr).max() < 1e-4
    assert np.abs(solver.fluid.numpy("density") - rr).max() < 1e-2
    assert np.abs(vr - v).max() > 1e-3  # the flow did evolve


# -- Taylor–Green: against the exact decay --------------------------------------------------------------------

@pytest.fixture(scope="module")
def tg_early(taylor_green, tmp_path_factory):
    """Plain WCSPH (no shifting) at n = 25 and 50 to t_e/10 (the exact energy falls by 10 %), outputs every t_e/40."""
    out = tmp_path_factory.mktemp("tg")
    return {n: run(taylor_green, out / f"n{n}", n=n, shifting=0.0, t_end=0.1 * T_E, output_interval=T_E / 40.0)
            ["analysis"]["taylor_green"] for n in (25, 50)}


def test_taylor_green_decay_is_exact_before_the_lattice_strains(tg_early):
    """Up to t_e/10 = 0.063 s plain WCSPH follows exp(−4νk²t) in energy and the exact field in velocity.

    Measured (2026-11-23, h = 1.6 dx, the laminar term divided by its lattice moment S): energy error +0.23 %
    (n = 25), +0.07 % (n = 50); velocity L2 error 0.0116, 0.0121. (At h = 1.3 dx: −0.31 %, −0.43 %, −0.45 % at
    n = 100; L2 0.0091, 0.0089, 0.0088.) The L2 plateau does not shrink with n: pressure waves of the weakly
    compressible start (the particles carry the exact initial pressure with them while the exact pressure field
    stays put) and the spurious pressure of the straining lattice. Bounds: |energy error| < 0.6 % (a 5 % error in the
    decay rate over this window would be 0.5 %; artificial viscosity α = 0.1 costs 2–4 %) and L2 < 0.015; the L2
    order between n = 25 and 50 is recorded as |order| < 0.5 (measured −0.06): the error here is not dx's.
    """
    for n, res in tg_early.items():
        assert res["early"]["time"] == pytest.approx(0.1 * T_E, rel=1e-9) == pytest.approx(res["time"], rel=1e-9)
        assert abs(res["energy_error"]) < 6e-3, (n, res["energy_error"])
        assert res["velocity_l2_error"] < 0.015, (n, res["velocity_l2_error"])
        assert res["breakdown_time"] is None
    p = order(tg_early[25]["velocity_l2_error"], tg_early[50]["velocity_l2_error"])
    assert abs(p) < 0.5, p


@pytest.fixture(scope="module")
def tg_full(taylor_green, tmp_path_factory):
    """The scene's defaults (particle shifting A = 20) to t_e at n = 25 and 50."""
    out = tmp_path_factory.mktemp("tg_full")
    return {n: run(taylor_green, out / f"n{n}", n=n)["analysis"]["taylor_green"] for n in (25, 50)}


def test_taylor_green_with_shifting_converges_at_the_e_folding_time(tg_full):
    """At t_e (exact energy down to e^-1) with particle shifting (A = 20, U = 1 m/s, h = 1.6 dx).

    Measured 2026-11-23: energy error +2.35 % (n = 25), +0.87 % (n = 50), +0.45 % (n = 100); velocity L2 error
    2.04 %, 0.73 %, 0.33 % (orders 1.5 and 1.1). The shifting coefficient, n = 25 / n = 50: A = 2: −38 % (breaks up
    at 0.16 s), A = 4: −19 %, A = 8: −3.7 % / L2 7.5 %, A = 12: −0.2 % / +0.9 %, L2 4.1 % / 0.88 %, A = 20: as above,
    A = 40: +2.2 % / +0.84 %, L2 1.8 % / 0.70 % (the error no longer moves with A from 20 on). Plain WCSPH breaks
    the vortex up at t ≈ 0.11 s (−89 % at n = 25). Bounds: |energy error| < 3.5 % and 1.5 %, L2 < 3 % and 1.2 %,
    L2 order > 1.
    """
    for n, (energy, l2) in {25: (0.035, 0.03), 50: (0.015, 0.012)}.items():
        res = tg_full[n]
        assert res["time"] == pytest.approx(T_E)
        assert res["breakdown_time"] is None
        assert abs(res["energy_error"]) < energy, (n, res["energy_error"])
        assert res["velocity_l2_error"] < l2, (n, res["velocity_l2_error"])
    assert order(tg_full[25]["velocity_l2_error"], tg_full[50]["velocity_l2_error"]) > 1.0


def test_taylor_green_without_shifting_breaks_up(taylor_green, tmp_path):
    """Plain WCSPH: the particles strained along the stagnation-point streamlines form lines, the continuity density
    drifts and the spurious pressure breaks the vortices up (measured at n = 25: |energy error| > 5 % from
    t ≈ 0.11 s, −89 % at t_e). The scene reports the breakdown time; the test asserts it comes before t_e/2."""
    res = run(taylor_green, tmp_path, n=25, shifting=0.0, t_end=0.5 * T_E)["analysis"]["taylor_green"]
    assert res["breakdown_time"] is not None and res["breakdown_time"] < 0.5 * T_E, res


def test_artificial_viscosity_costs_energy_in_proportion_to_alpha_h_c0(taylor_green, tmp_path):
    """Monaghan's α acts on the Taylor–Green vortex as an extra viscosity ≈ C α h c0 (first order in h).

    Energy error at t_e/10, n = 25, plain WCSPH, measured 2026-11-23 at h = 1.6 dx: α = 0 +0.23 %, α = 0.02
    −0.66 %, α = 0.1 −4.1 %: an eddy viscosity ν_α = C α h c0/8 with C = 0.55 for both (at h = 1.3 dx:
    C = 0.62–0.63 at n = 25 and 50; C = 1 is Monaghan's continuum estimate). Asserted: 0.45 < C < 0.75 for α = 0.02
    and 0.1.
    """
    k = 2.0 * math.pi
    h = inspect.signature(taylor_green.build).parameters["h_factor"].default / 25.0
    c0, t = 10.0, 0.1 * T_E
    errors = {a: run(taylor_green, tmp_path / f"a{a}", n=25, alpha=a, shifting=0.0, t_end=t, output_interval=t)
              ["analysis"]["taylor_green"]["energy_error"] for a in (0.0, 0.02, 0.1)}
    assert errors[0.0] > errors[0.02] > errors[0.1]
    for a in (0.02, 0.1):
        estimate = math.exp(-4.0 * k * k * (a * h * c0 / 8.0) * t) - 1.0  # energy factor of ν_α alone
        c = math.log((1.0 + errors[a]) / (1.0 + errors[0.0])) / math.log(1.0 + estimate)
        assert 0.45 < c < 0.75, (a, c)


# -- Poiseuille: against the series ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def pf_runs(poiseuille, tmp_path_factory):
    """Runs at n = 20 and 40 particles across the channel to t = 0.225 s (Morris' parameters, the scene's defaults)."""
    out = tmp_path_factory.mktemp("pf")
    return {n: run(poiseuille, out / f"n{n}", n=n)["analysis"]["poiseuille"] for n in (20, 40)}


def test_poiseuille_profile_against_the_series_at_the_anchor_times(pf_runs):
    """Binned velocity profile against the series at t = 0.0225, 0.045, 0.1125, 0.225 s, relative to u_c = 2.5e-5 m/s.

    This case found that the Morris viscous sum on a lattice is S ν ∇²u, S = 0.9627 (Wendland C2, h = 1.3 dx) at
    every dx: the error stalled at 2.4 % of u_c (n = 20: 2.69e-2, n = 40: 2.50e-2, n = 80: 2.44e-2 at 0.225 s). The
    solver now divides the laminar term by S (``viscosity_factor``; 0.9828 at the 2D default h = 1.6 dx), and the
    error against the series converges. Measured (2026-11-23), largest bin error / u_c at the four times:
    h = 1.6 dx (the default): n = 20: 3.72e-3, 4.21e-3, 4.78e-3, 5.25e-3; n = 40: 9.19e-4, 1.03e-3, 1.16e-3,
    1.27e-3; orders 2.02, 2.03, 2.04, 2.05. (h = 1.3 dx: n = 20: 2.69e-3 .. 4.24e-3, n = 40: 7.61e-4 .. 1.36e-3,
    orders 1.82 .. 1.64.) Asserted: order > 1.6 at every anchor time, below 6e-3 at n = 20 and 2e-3 at n = 40.
    """
    for n, res in pf_runs.items():
        assert set(res["anchors"]) == {"t0225", "t045", "t1125", "t225"}
        assert res["viscosity_factor"] == pytest.approx(0.98282, abs=1e-5)
        for key, a in res["anchors"].items():
            assert a["error_max"] < (6e-3 if n == 20 else 2e-3), (n, key, a)
    for key in pf_runs[20]["anchors"]:
        coarse, fine = pf_runs[20]["anchors"][key], pf_runs[40]["anchors"][key]
        assert order(coarse["error_max"], fine["error_max"]) > 1.6, (key, coarse, fine)


def _steady_viscosity_fit(poiseuille, n, kernel, h_factor):
    """Run to t = 1 s (10 e-folding times of the slowest mode) and fit u = a g + b, g = y (L − y)/2: returns
    ν_fit/ν (a = F/ν_fit) and the offset d/dx of walls moved out by d (b = F L d/(2ν_fit))."""
    width, force, nu = 1e-3, 2e-4, 1e-6
    sim = poiseuille.build(n=n, kernel=kernel, h_factor=h_factor, t_end=1.0, output_interval=0.5, frames=False,
                           vtk=False)
    sim.run(None, progress=False)
    y = sim.solver.fluid.numpy("position")[:, 1].astype(np.float64)
    u = sim.solver.fluid.numpy("velocity")[:, 0].astype(np.float64)
    g = y * (width - y) / 2.0
    (a, b), *_ = np.linalg.lstsq(np.stack([g, np.ones_like(g)], 1), u, rcond=None)
    nu_fit = force / a
    # the transient is gone: the series at t = 1 s is the steady profile to 1e-4
    assert pf.velocity(width / 2, 1.0, force, nu, width) == pytest.approx(pf.centre_velocity(force, nu, width), rel=1e-4)
    return nu_fit / nu, 2.0 * b * nu_fit / (force * width) / (width / n)


@pytest.mark.parametrize("kernel", ["wendland_c2", "cubic_spline"])
def test_poiseuille_steady_state_is_the_parabola_of_the_true_viscosity(poiseuille, kernel):
    """At h = 1.3 dx the SPH steady profile is the parabola of the viscosity ν itself: the laminar term divided by
    its lattice moment S (0.9627 for Wendland C2, 0.9998 for the cubic spline) is exact for a shear on the lattice,
    and the walls act where they stand.

    Measured 2026-11-23 at n = 20: ν_fit/ν = 1.0004 (Wendland C2) and 1.0005 (cubic spline), d = 0.023 dx and
    0.027 dx. (Before the division by S: ν_fit/ν = 0.9630 for Wendland C2.) Bounds: |ν_fit/ν − 1| < 0.2 %,
    |d| < 0.1 dx."""
    device.use("cpu", 2)
    ratio, offset = _steady_viscosity_fit(poiseuille, 20, kernel, 1.3)
    assert ratio == pytest.approx(1.0, abs=2e-3), ratio
    assert abs(offset) < 0.1, offset


def test_poiseuille_steady_viscosity_at_the_default_h_converges(poiseuille):
    """At the 2D default h = 1.6 dx the wider support reaches further into the no-slip walls, whose ghost velocity
    (2 u_wall − the Shepard average of the fluid nearby) is exact only for a linear profile: the fitted viscosity
    is off by a wall-resolution error that converges. Measured 2026-11-23 (Wendland C2): ν_fit/ν − 1 = 2.0e-3 at
    n = 20, 6.1e-4 at n = 40 (order 1.7); d = 0.029 dx, 0.014 dx. Asserted: < 3e-3 and < 1e-3, order > 1.3,
    |d| < 0.1 dx."""
    device.use("cpu", 2)
    fits = {n: _steady_viscosity_fit(poiseuille, n, "wendland_c2", 1.6) for n in (20, 40)}
    assert abs(fits[20][0] - 1.0) < 3e-3 and abs(fits[40][0] - 1.0) < 1e-3, fits
    assert order(abs(fits[20][0] - 1.0), abs(fits[40][0] - 1.0)) > 1.3, fits
    assert all(abs(d) < 0.1 for _, d in fits.values()), fits


def test_poiseuille_series_gives_the_quoted_centre_velocities():
    """The series at y = L/2 against shared/reference/anchors.md §6 (L = 1e-3 m, ν = 1e-6 m²/s, F = 2e-4 m/s²).
    The anchors' first value, 4.466e-6, is the series' 4.46548e-6 rounded twice (to 4.4655e-6, then up): 1e-4 off."""
    u = [pf.velocity(5e-4, t, 2e-4, 1e-6, 1e-3) for t in (0.0225, 0.045, 0.1125, 0.225)]
    np.testing.assert_allclose(u, [4.466e-6, 8.469e-6, 1.650e-5, 2.220e-5], rtol=1.5e-4)
    assert pf.centre_velocity(2e-4, 1e-6, 1e-3) == pytest.approx(2.5e-5)
    assert abs(pf.velocity(np.array([0.0, 1e-3]), 0.05, 2e-4, 1e-6, 1e-3)).max() < 1e-12
    assert abs(pf.velocity(np.linspace(0, 1e-3, 11), 0.0, 2e-4, 1e-6, 1e-3)).max() < 1e-12


def test_taylor_green_exact_solution_is_consistent():
    """Energy of the exact field (midpoint sum on a lattice) against E(t), and the e^-1 time (anchors.md §1.4e)."""
    x = lattice_box((0.0, 0.0), (1.0, 1.0), 1.0 / 32)
    v = tg.velocity(x[:, 0], x[:, 1], 0.3, 1.0, NU_TG, 1.0)
    e = 0.5 * 1000.0 * np.sum(v * v) / len(x)
    assert e == pytest.approx(tg.kinetic_energy(0.3, 1.0, NU_TG, 1.0, 1000.0), rel=1e-12)
    assert 2.0 * tg.decay_rate(NU_TG, 1.0) == pytest.approx(1.5791367, rel=1e-7)
    assert T_E == pytest.approx(0.6332574, rel=1e-6)
    p = tg.pressure(x[:, 0], x[:, 1], 0.0, 1.0, NU_TG, 1.0, 1000.0)
    assert tg.inverse_tait_density(p, 1000.0, 10.0) == pytest.approx(
        1000.0 * (1.0 + p * 7.0 / (1000.0 * 100.0)) ** (1.0 / 7.0))


# -- the scenes: CLI smoke runs and bad parameters ---------------------------------------------------------------

@pytest.mark.parametrize("name,sets,plot,key", [
    ("taylor_green_2d", ["n=12", "t_end=0.02", "output_interval=0.01"], "taylor_green.png", "taylor_green"),
    ("poiseuille_2d", ["n=10", "t_end=0.045", "output_interval=0.0225"], "poiseuille.png", "poiseuille"),
])
def test_scene_runs_from_the_cli_and_writes_its_plot(name, sets, plot, key, tmp_path):
    out = tmp_path / name
    args = ["run", name, "--out", str(out), "--threads", "2", "--no-progress"]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and key in summary["analysis"]
    assert (out / plot).is_file() and len(list((out / "frames").glob("*.png"))) == 3
    assert len(list((out / "vtk").glob("fluid_*.vtu"))) == 3


@pytest.mark.parametrize("name,params,bad", [
    ("taylor_green_2d", {"n": 5}, "n"),
    ("taylor_green_2d", {"n": 20.5}, "n"),
    ("taylor_green_2d", {"reynolds": 0.0}, "reynolds"),
    ("taylor_green_2d", {"mach": 0.8}, "mach"),
    ("taylor_green_2d", {"alpha": -0.1}, "alpha"),
    ("taylor_green_2d", {"delta": -1.0}, "delta"),
    ("taylor_green_2d", {"kernel": "gauss"}, "kernel"),
    ("taylor_green_2d", {"t_end": -1.0}, "t_end"),
    ("poiseuille_2d", {"n": 0}, "n"),
    ("poiseuille_2d", {"channel_length": 1.01e-3}, "channel_length"),
    ("poiseuille_2d", {"channel_length": 1e-4}, "channel_length"),
    ("poiseuille_2d", {"bins": 50}, "bins"),
    ("poiseuille_2d", {"wall_layers": 2}, "wall_layers"),
    ("poiseuille_2d", {"kernel": "quintic_spline"}, "wall_layers"),  # support 3.9 dx needs 4 layers
    # dynamic walls thinner than the support (4.8 dx at h = 2.4 dx needs 5 layers), refused before relaxing
    ("standing_wave_2d", {"h_factor": 2.4, "wall_layers": 3, "dx": 0.05}, "wall_layers"),
    ("tank_at_rest_2d", {"h_factor": 2.4, "dx": 0.05}, "wall_layers"),
    ("dam_break_2d", {"h_factor": 2.4, "dx": 0.05}, "wall_layers"),
    ("poiseuille_2d", {"force": -2e-4}, "force"),
    ("poiseuille_2d", {"nu": float("nan")}, "nu"),
])
def test_bad_scene_parameters_are_named(name, params, bad):
    module = scene(name)
    with pytest.raises(ParameterError) as info:
        module.build(frames=False, vtk=False, **params)
    assert info.value.name == bad
