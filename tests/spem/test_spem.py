"""SPEM (Mendes (2010)): derivative coefficients against NumPy and exact linear fields, the stable step against Yee's
limit, the 1D line against the exact wave, a PEC box's resonance against the analytic TM11 frequency, thread
independence and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from warpfree import device
from warpfree.cli import main
from warpfree.scene_loader import load_scene
from warpfree.errors import ParameterError
from warpfree.solvers.spem import (C0, PML, Source, SPEMModel, SPEMSolver, Waveform, staggered_box, staggered_disk,
                                   staggered_line, support_for_jitter)
from warpfree.time_loop import TimeLoop


def rows_of(rows_list):
    start, count, index = (a.numpy() for a in (rows_list.rows.start, rows_list.rows.count, rows_list.rows.index))
    return start, count, index


def apply(model, which, values):
    """Σ_j g_ij u_j for every particle of set ``which`` ("e": over H values, "h": over E values), in NumPy."""
    rows = model.e_rows if which == "e" else model.h_rows
    coef = (model.e_coefficient if which == "e" else model.h_coefficient).numpy()
    start, count, index = rows_of(rows)
    out = np.zeros((count.size, 2))
    for i in range(count.size):
        sl = slice(start[i], start[i] + count[i])
        out[i] = coef[sl, :2].T @ values[index[sl]]
    return out


@pytest.mark.parametrize("staggering", ["centres", "edges"])
@pytest.mark.parametrize("jitter,conservative", [(0.0, False), (0.3, False), (0.0, True), (0.3, True)])
def test_fpm_derivative_reproduces_linear_fields_on_any_layout(jitter, conservative, staggering):
    """FPM (seed eqs 2.30-2.35) and the conservative pair made from it are exact for u = a + b·x on uniform and
    jittered (30 %) layouts, walls included: measured error ~1e-6 relative (float32 coefficients). Under Yee's
    staggering an H particle takes the one derivative its component needs (Hx: ∂/∂y, Hy: ∂/∂x) and none other."""
    device.use("cpu", 2)
    lay = staggered_box((0, 0), (1.0, 0.6), 0.05, jitter=jitter, seed=3, h_staggering=staggering)
    model = SPEMModel(lay, support=support_for_jitter(jitter), conservative=conservative)
    grad = np.array([0.7, -1.3])
    served = np.zeros((lay.n_h, 2), bool)  # H particle k takes the derivative along axis a
    for axis, sub in enumerate(lay.h_subsets()):
        served[sub, axis] = True
    assert np.all(served.sum(axis=1) == (1 if staggering == "edges" else 2))
    for which, pts, held in (("e", lay.h_position, model.held), ("h", lay.e_position, np.zeros(lay.n_h, bool))):
        u = 2.0 + pts[:, :2] @ grad
        expected = np.broadcast_to(grad, (held.size, 2)) if which == "e" else np.where(served, grad, 0.0)
        g = apply(model, which, u)
        assert np.max(np.abs(g - expected)[~held]) < 2e-5 * np.abs(grad).max() * 10


def test_cspm_is_exact_and_plain_sph_is_not_on_a_uniform_interior():
    """The diagonal CSPM (eq. 3.6, u_i by Shepard) is exact for linear fields where the neighbourhood is symmetric.
    Plain SPH is not consistent (2.21/2.22 fail at the particle level): on the nearest shell its gradient is 2.70x
    the true one (measured), and it approaches it only with many neighbours (1.015 at 2 spacings, 0.994 at 3)."""
    device.use("cpu", 1)
    lay = staggered_box((0, 0), (1.0, 1.0), 0.05, h_staggering="centres")  # the thesis's schemes' layout
    grad = np.array([0.4, 0.9])
    u = lay.h_position[:, :2] @ grad
    inner = np.all((lay.e_position[:, :2] > 0.3) & (lay.e_position[:, :2] < 0.7), axis=1)
    g = apply(SPEMModel(lay, scheme="cspm"), "e", u)[inner]
    assert np.max(np.abs(g - grad)) < 1e-5
    ratio = {sup: apply(SPEMModel(lay, scheme="sph", support=sup), "e", u)[inner] / grad for sup in (1.1, 3.0)}
    assert np.all(np.abs(ratio[1.1] - 1.0) > 0.5)
    assert np.all(np.abs(ratio[3.0] - 1.0) < 0.02)


def test_coefficients_equal_a_numpy_fpm_solve():
    """Kernel against NumPy: the (d+1) moment system of FPM assembled and solved in float64 for every E particle
    of a jittered box (support 1.7 spacings, several shells) gives the same coefficients."""
    device.use("cpu", 1)
    lay = staggered_box((0, 0), (0.5, 0.4), 0.05, jitter=0.3, seed=1, h_staggering="centres")  # one H set, 2D fits
    model = SPEMModel(lay, support=1.7, conservative=False)
    coef = model.e_coefficient.numpy()
    start, count, index = rows_of(model.e_rows)
    vol = model.magnetic.numpy("volume")
    checked = 0
    for i in np.flatnonzero(~model.held):
        radius = 1.7 * lay.spacing
        sl = slice(start[i], start[i] + count[i])
        d = (lay.h_position[index[sl], :2] - lay.e_position[i, :2]) / radius
        q = np.hypot(d[:, 0], d[:, 1])
        w = np.where(q <= 0.5, 2 / 3 - 4 * q**2 + 4 * q**3, np.where(q < 1, 4 / 3 - 4 * q + 4 * q**2 - 4 / 3 * q**3, 0))
        s = np.where(q <= 0.5, -8 * q + 12 * q**2, np.where(q < 1, -4 + 8 * q - 4 * q**2, 0)) / np.where(q > 0, q, 1)
        rows = np.stack([w, s * d[:, 0], s * d[:, 1]]) * vol[index[sl]]       # (3, n): W, ∂xW, ∂yW times ω
        basis = np.stack([np.ones_like(q), d[:, 0], d[:, 1]])                 # 1, Δx, Δy
        m = rows @ basis.T
        expected = (np.linalg.solve(m, rows)[1:] / radius).T
        assert np.allclose(coef[sl, :2], expected, rtol=2e-4, atol=2e-4 * np.abs(expected).max())
        checked += 1
    assert checked > 20


def operator_matrices(model):
    """Per axis: D_E (n_e x n_h) and D_H (n_h x n_e) as dense arrays, from the model's rows."""
    out = []
    for rows, coef, shape in ((model.e_rows, model.e_coefficient, (model.layout.n_e, model.layout.n_h)),
                              (model.h_rows, model.h_coefficient, (model.layout.n_h, model.layout.n_e))):
        start, count, index = rows_of(rows)
        c = coef.numpy()
        m = np.zeros((2,) + shape)
        for i in range(shape[0]):
            sl = slice(start[i], start[i] + count[i])
            m[:, i, index[sl]] = c[sl, :2].T
        out.append(m)
    return out


def test_conservative_pair_is_skew_adjoint_on_a_jittered_disk():
    """Summation by parts, V_E D_E^a = -(V_H D_H^a)^T on the free E particles (module docstring of
    ``conservative.py``, eq. 1), holds to float32 rounding on a 30 %-jittered disk with its PEC ring (measured
    2026-11-23: 3e-8 of the largest entry, float32 rounding); plain FPM misses it by 4.6 % (asserted > 1 %), enough for its
    energy to grow by ~100x a period."""
    device.use("cpu", 1)
    lay = staggered_disk((0.1, 0.1), 0.1, 0.01, jitter=0.3, seed=5)
    for conservative, bound in ((True, 1e-4), (False, None)):
        model = SPEMModel(lay, support=support_for_jitter(0.3), conservative=conservative)
        (de, dh), free = operator_matrices(model), ~model.held
        ve, vh = lay.quadrature_volumes()
        scale = np.abs(de).max() * ve.max()
        defect = max(np.abs(ve[free, None] * de[a][free] + (vh[:, None] * dh[a][:, free]).T).max() for a in range(2))
        if bound is None:
            assert defect / scale > 1e-2
        else:
            assert defect / scale < bound


def test_order_two_pair_cuts_the_jittered_cavity_error_and_stays_conservative_and_linear(tmp_path):
    """The order-2 pair (``pair_order=2``: the quadratic moments of ``conservative.py`` eq. 2 in least squares, eq. 1
    and the linear ones exact). Measured on the PEC disk (20 cells per radius, 30 % jitter, to 5.5 ns, the step 0.9 of
    the limit), largest mean |Ez| error against the TM mode, seed 0: order 1 0.587 %, order 2 0.353 % (ratio 0.60;
    at 0.5 of the limit 0.776 and 0.455 %, 0.59: the leapfrog's time error offsets some of the space error; uniform
    layout 0.219 %). Asserted: summation by parts to float32 rounding, linear fields exact, the quadratic moments'
    residual well below order 1's, and the error below 0.65x order 1's and 0.45 %."""
    device.use("cpu", 2)
    lay = staggered_disk((0.1, 0.1), 0.1, 0.01, jitter=0.3, seed=5)
    quadratic = {}
    for order in (1, 2):
        model = SPEMModel(lay, support=support_for_jitter(0.3), pair_order=order)
        (de, dh), free = operator_matrices(model), ~model.held
        ve, vh = lay.quadrature_volumes()
        scale = np.abs(de).max() * ve.max()
        assert max(np.abs(ve[free, None] * de[a][free] + (vh[:, None] * dh[a][:, free]).T).max()
                   for a in range(2)) / scale < 1e-4
        x = lay.h_position[:, :2]
        assert np.abs(de[0][free] @ (2.0 + x @ [0.7, -1.3]) - 0.7).max() < 1e-3
        # d/dx of (x - x_i)² at x_i is 0: what each row gives instead, in units of the spacing
        sq = np.array([float(np.abs((de[0][i] * (x[:, 0] - lay.e_position[i, 0]) ** 2).sum()) / 0.01)
                       for i in np.flatnonzero(free)])
        quadratic[order] = float(np.median(sq))
    assert quadratic[2] < 0.3 * quadratic[1]
    scene = load_scene("em_cavity_2d")
    errors = {order: scene.build(jitter=0.3, pair_order=order, frames=False, vtk=False).run(
        str(tmp_path / str(order)), progress=False)["analysis"]["cavity"]["max_mean_error"] for order in (1, 2)}
    assert errors[2] < 0.65 * errors[1] and errors[2] < 4.5e-3


def test_conservative_pair_keeps_yee_on_a_long_uniform_line():
    """A uniform line 1 500 spacings long (the 1D scene at 80 particles per wavelength): its float32 positions
    round by up to 1e-4 of a spacing. The pair's volumes are measured on those same positions, so FPM (Yee's
    difference there) already satisfies the constraints and is kept: measured 2026-11-23, largest change 5e-4
    per spacing, step limit Δ/c. With volumes from the float64 layout the solve changed entries by 0.23 per
    spacing and the limit fell to 0.76 Δ/c."""
    device.use("cpu", 1)
    line = staggered_line(0.0, math.pi, C0 / 1.8e9 / 80)
    model = SPEMModel(line)
    assert model.conservation["largest_change_per_spacing"] < 1e-2
    assert model.stable_dt() == pytest.approx(line.spacing / C0, rel=1e-3)


def test_stable_step_on_uniform_layouts():
    """1D: Δ/c, Yee's limit. 2D, cell-centred H: the nearest-shell derivative is the central difference along the
    cell diagonals, symbol (2/Δ) sin(k_xΔ/2) cos(k_yΔ/2), whose largest eigenvalue 4c²/Δ² gives Δ/c, √2 above Yee's
    Δ/(c√2): the conservative pair's computed spectral limit finds it (a finite box's modes stay just below the
    lattice's sup), the Gershgorin bound of the plain FPM pair gives the safe Δ/(c√2). 2D, Yee's staggering (the
    default): Yee's Δ/(c√2) (measured 0.708 Δ/c computed, a finite box's modes just below the lattice's sup;
    asserted within 0.70-0.75), the plain pair's Gershgorin bound at or below it (0.7071)."""
    device.use("cpu", 1)
    line = staggered_line(0.0, 1.0, 0.01)
    for conservative in (True, False):
        dt = SPEMSolver(SPEMModel(line, conservative=conservative)).stable_dt()
        assert dt == pytest.approx(line.spacing / C0, rel=1e-3)
    box = staggered_box((0, 0), (0.4, 0.3), 0.01, h_staggering="centres")
    assert SPEMSolver(SPEMModel(box)).stable_dt() == pytest.approx(box.spacing / C0, rel=1e-2)
    plain = SPEMSolver(SPEMModel(box, conservative=False)).stable_dt()
    assert plain == pytest.approx(box.spacing / (C0 * math.sqrt(2)), rel=1e-5)
    yee = staggered_box((0, 0), (0.4, 0.3), 0.01)
    computed = SPEMSolver(SPEMModel(yee)).stable_dt() * C0 / yee.spacing
    assert 0.70 < computed < 0.75
    assert SPEMSolver(SPEMModel(yee, conservative=False)).stable_dt() * C0 / yee.spacing <= computed


def test_line_1d_matches_the_exact_wave(tmp_path):
    """Mendes (2010) §4.2 at 20 particles per wavelength (the thesis needed 40): mean error 5.5e-3 against the exact
    wave on (0.5, 1.5) at t = 4.75 ns (measured 2026-11-23), wavelength error < 0.1 %. Asserted: the required
    1e-2 and 0.1 %."""
    device.use("cpu", 2)
    run = load_scene("em_line_1d").build(frames=False, vtk=False)
    line = run.run(str(tmp_path / "line"), progress=False)["analysis"]["line"]
    assert line["particles_per_wavelength"] == pytest.approx(20.0, rel=0.01)
    assert line["mean_error"] < 1e-2
    assert abs(line["wavelength_rel_error"]) < 1e-3


@pytest.mark.parametrize("steps_per_output", [2.5, 0.4])
def test_outputs_fall_at_the_first_step_at_or_after_their_times_and_never_shorten_the_step(steps_per_output):
    """SPEM's constant step is ``courant`` x the stable limit whatever the output interval: each output falls at the
    first step at or after its time (recording that time) and the run ends at the first step at or after t_end; an
    interval shorter than the step gives an output every step. The same step and the same fields as a run with one
    output at the end."""
    device.use("cpu", 1)
    scene = load_scene("em_line_1d")
    step = scene.build(particles_per_wavelength=10, frames=False, vtk=False).step_size
    interval, t_end = steps_per_output * step, 10.3 * step
    run = scene.build(particles_per_wavelength=10, frames=False, vtk=False, output_interval=interval, t_end=t_end)
    assert run.step_size == step == pytest.approx(0.95 * run.solver.stable_dt(), rel=1e-12)
    run.run(None, progress=False)
    times = np.asarray(run.series["time"])
    assert run.step_count == 11 and times[-1] == pytest.approx(11 * step, rel=1e-12)
    steps_at = np.round(times / step).astype(int)
    assert np.allclose(times / step, steps_at, atol=1e-6) and np.all(np.diff(steps_at) > 0)  # on steps, once each
    due = np.arange(math.floor(t_end / interval) + 1) * interval  # the output times up to the end
    first_at_or_after = np.ceil(due / step - 1e-9).astype(int)
    assert set(steps_at) == set(first_at_or_after) | {11}  # each at its first step, and the end's step
    once = scene.build(particles_per_wavelength=10, frames=False, vtk=False, output_interval=t_end, t_end=t_end)
    once.run(None, progress=False)
    assert once.step_count == 11 and np.array_equal(once.solver.electric.numpy("ez"), run.solver.electric.numpy("ez"))


def pec_box(spacing: float, jitter: float = 0.0, conservative: bool = True, grading: float = 1.0,
            staggering: str = "edges"):
    """A 1 m x 0.8 m PEC box started in its TM11 mode Ez = sin(πx/a) sin(πy/b), H = 0."""
    a, b = 1.0, 0.8
    lay = staggered_box((0, 0), (a, b), spacing, jitter=jitter, seed=2, grading=grading, h_staggering=staggering)
    shape = lambda p: np.sin(np.pi * p[:, 0] / a) * np.sin(np.pi * p[:, 1] / b)  # noqa: E731
    solver = SPEMSolver(SPEMModel(lay, support=support_for_jitter(jitter), conservative=conservative), ez=shape)
    return solver, shape(lay.e_position), C0 * math.pi * math.hypot(1 / a, 1 / b)


def cavity_frequency(spacing: float, jitter: float = 0.0, conservative: bool = True, periods: float = 3.0,
                     grading: float = 1.0, staggering: str = "edges"):
    """Relative error of the TM11 frequency, from the zero crossings of the mode's projection, against
    ω = cπ sqrt(1/a² + 1/b²), and the energy sampled once a period (8 periods)."""
    solver, basis, omega = pec_box(spacing, jitter, conservative, grading, staggering)
    dt = 0.9 * solver.stable_dt()
    per_period = int(2 * math.pi / omega / dt)
    proj, energy = [], []
    for n in range(8 * per_period):
        solver.step(dt)
        if n < periods * per_period:
            proj.append(float(basis @ solver.electric.numpy("ez")))
        if (n + 1) % per_period == 0:
            e = solver.energy()
            energy.append(e["electric_energy"] + e["magnetic_energy"])
    p = np.asarray(proj)
    if p.size < per_period:
        return float("nan"), np.asarray(energy)
    t = (np.arange(p.size) + 0.5) * dt
    k = np.flatnonzero(np.sign(p[:-1]) * np.sign(p[1:]) < 0)
    tc = t[k] - p[k] * dt / (p[k + 1] - p[k])
    return math.pi / np.mean(np.diff(tc)) / omega - 1.0, np.asarray(energy)


def test_pec_box_resonates_at_the_tm11_frequency_with_second_order_convergence():
    """Measured (conservative pair, Yee's staggering): frequency error -0.141 % at Δ = 0.05 m (~18 particles per
    wavelength of the mode) and -0.022 % at 0.025 m (ratio 6.4; cell-centred H: -0.31 %, -0.077 %, ratio 4.0).
    Asserted: below 1 % and a ratio above 3."""
    device.use("cpu", 2)
    coarse, fine = cavity_frequency(0.05)[0], cavity_frequency(0.025)[0]
    assert abs(coarse) < 1e-2 and abs(fine) < 0.3e-2
    assert abs(coarse) / abs(fine) > 3.0


def test_jittered_particles_conserve_energy_and_keep_the_uniform_accuracy():
    """30 %-jittered particles (both sets). Plain FPM on both sides is exact for linear fields but not
    skew-adjoint there: measured, its energy grows ~100x a period. The conservative pair (the default:
    ``warpfree/solvers/spem/conservative.py``) is both. TM11 frequency error at Δ = 0.05 / 0.025 m, measured:
    cell-centred H uniform -0.31 %, jittered -0.37 % / -0.095 %; Yee's staggering uniform -0.141 %, jittered
    -0.49 % / -0.11 % (second order on both; jittered 3.4x its uniform error, which is half the cell-centred one).
    Asserted: the invariant (``SPEMSolver.energy``) constant to 1e-5 over 8 periods; with cell-centred H jittered
    within 2x of uniform; with Yee's staggering second-order convergence on jittered particles (ratio > 3) below
    1 %; FPM's growth above 1e3."""
    device.use("cpu", 2)
    uniform, _ = cavity_frequency(0.05, staggering="centres")
    jittered, energy = cavity_frequency(0.05, jitter=0.3, staggering="centres")
    assert abs(jittered) < 2 * abs(uniform)
    assert energy.max() / energy.min() - 1 < 1e-5
    coarse, energy = cavity_frequency(0.05, jitter=0.3, periods=3.0)
    fine, _ = cavity_frequency(0.025, jitter=0.3, periods=1.5)
    assert abs(coarse) < 1e-2 and abs(coarse) / abs(fine) > 3.0
    assert energy.max() / energy.min() - 1 < 1e-5
    _, grows = cavity_frequency(0.05, jitter=0.3, conservative=False, periods=0)
    assert grows[-1] / grows[0] > 1e3


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_reported_energy_is_the_conserved_one_for_a_white_noise_start(jitter):
    """A closed PEC box started from white noise in Ez (every mode up to the layout's shortest) through a time loop:
    ``SPEMSolver.energy`` reports the leapfrog invariant ½ΣεV Ez^{n-1/2}Ez^{n+1/2} + ½ΣμV|H^n|², constant to
    round-off of the float32 state (measured 3e-7 over 400 steps), where the plain sum of the staggered values
    swings by more than 50 %. Asserted: the invariant within 2e-6, the plain sum off by more than 10 %."""
    device.use("cpu", 2)
    lay = staggered_box((0, 0), (1.0, 0.8), 0.05, jitter=jitter, seed=2)
    solver = SPEMSolver(SPEMModel(lay, support=support_for_jitter(jitter)),
                        ez=np.random.default_rng(1).standard_normal(lay.n_e))
    interval = 5 * solver.stable_dt()
    loop = TimeLoop(solver, t_end=40 * interval, output_interval=interval)
    loop.run(None, progress=False)
    total = np.asarray(loop.diag_series["electric_energy"]) + np.asarray(loop.diag_series["magnetic_energy"])
    assert total.size > 30
    assert np.ptp(total) / total[0] < 2e-6
    e = solver.electric
    plain = 0.5 * np.sum(e.numpy("permittivity") * e.numpy("ez").astype(float) ** 2 * e.numpy("cell_volume")) \
        + solver.energy()["magnetic_energy"]
    assert abs(plain / total[0] - 1) > 0.1


def test_graded_layout_keeps_energy_and_accuracy():
    """Graded particles (``staggered_box(grading=2)``: spacing from 0.67 to 1.33 of the mean along each axis,
    so cells of different sizes and aspect ratios meet). Measured (conservative pair, Yee's staggering): TM11
    frequency error -0.47 % at a mean spacing of 0.05 m and -0.19 % at 0.025 m (cell-centred H: -0.54 %,
    -0.22 %; the coarsest cells are 1.33x the mean, and 1.33² = 1.8), the invariant constant to 2e-7.
    Asserted: below 1 %, converging, the leapfrog invariant constant to 1e-5."""
    device.use("cpu", 2)
    coarse, energy = cavity_frequency(0.05, grading=2.0)
    fine, _ = cavity_frequency(0.025, grading=2.0)
    assert abs(coarse) < 1e-2 and abs(fine) < 0.5 * abs(coarse)
    assert energy.max() / energy.min() - 1 < 1e-5
    with pytest.raises(ParameterError, match="^grading"):
        staggered_box((0, 0), (1, 1), 0.1, grading=5.0)


def test_cavity_series_reproduces_the_initial_profile():
    from warpfree.validation.em_cavity_2d import cavity_field

    r = np.linspace(0.0, 0.1, 41)
    assert np.max(np.abs(cavity_field(r, 0.0, 0.1, 10.0) - (1.0 - (r / 0.1) ** 2))) < 1e-6


def test_circular_cavity_against_the_bessel_series(tmp_path):
    """Mendes (2010) §4.3 (εr = 10, r0 = 0.1 m) to t = 5.5 ns, 20 cells per radius, largest mean error over the outputs
    (of the peak, over all E particles). Measured: Yee's staggering (the default) 0.25 %, 30 %-jittered 0.63 %;
    cell-centred H 0.38 %, jittered 0.68 %; CSPM 1.9 % (support 1.5, cell-centred), plain SPH 88 % (the thesis:
    about 5 % with plain SPH). The jittered error is 2.6x the uniform one with Yee's staggering (1.8x with
    cell-centred H, whose uniform error is 1.5x as large). Asserted: the required 1 % uniform and jittered, Yee's
    staggering below 0.8x the cell-centred error uniform and below it jittered, and FPM at least twice as accurate
    as CSPM."""
    device.use("cpu", 2)
    scene = load_scene("em_cavity_2d")
    err = {}
    for name, kw in (("fpm", {}), ("jittered", {"jitter": 0.3}), ("centres", {"h_staggering": "centres"}),
                     ("jittered_centres", {"jitter": 0.3, "h_staggering": "centres"}),
                     ("cspm", {"scheme": "cspm", "support": 1.5})):
        run = scene.build(frames=False, vtk=False, **kw)
        err[name] = run.run(str(tmp_path / name), progress=False)["analysis"]["cavity"]["max_mean_error"]
    assert err["fpm"] < 1e-2 and err["jittered"] < 1e-2
    assert err["fpm"] < 0.8 * err["centres"]
    assert err["jittered"] < err["jittered_centres"]
    assert err["cspm"] > 2 * err["fpm"]


def test_results_are_bitwise_identical_for_any_thread_count_and_load_distribution(make_launcher):
    """The four load distributions of seed §3.2.2 change which thread updates a particle, not the result."""
    lay = staggered_box((0, 0), (0.5, 0.5), 0.05, jitter=0.3, seed=4)
    out = []
    for threads, distribution in ((1, "blocks"), (2, "blocks"), (2, "alternating"), (3, "random"), (2, "neighbours")):
        launcher = make_launcher(threads=threads)
        model = SPEMModel(lay, support=support_for_jitter(0.3), launcher=launcher,
                          pml=PML(0.15, sides=("x+", "y+")), interior=((0, 0), (0.35, 0.35)))
        solver = SPEMSolver(model, ez=lambda p: np.exp(-((p[:, 0] - 0.2) ** 2 + (p[:, 1] - 0.2) ** 2) / 0.01),
                            launcher=launcher, distribution=distribution)
        assert solver.describe()["distribution"] == distribution
        for _ in range(40):
            solver.step(0.9 * solver.stable_dt())
        out.append([a.numpy().copy() for a in (solver.state.ez, solver.state.hx, solver.state.hy)])
    for other in out[1:]:
        for a, b in zip(out[0], other):
            assert np.array_equal(a, b)
    with pytest.raises(ParameterError, match="^distribution"):
        SPEMSolver(model, launcher=launcher, distribution="cyclic")


def test_kronecker_option_imposes_the_field_through_the_sph_interpolant():
    """Seed §3.1.5: with ``kronecker`` the initial particle values are the nodal values whose interpolant
    (3.31) takes the imposed profile at every free particle; PEC particles stay 0. Measured 2026-11-23 on the
    cavity (20 cells per radius, to 5.5 ns): CSPM at support 2.5 largest mean error 3.46 % -> 3.35 %, at 1.5
    unchanged (1.87 %), plain SPH at 2.5 55.6 % -> 54.4 %: the missing Kronecker delta is not what limits
    those schemes."""
    device.use("cpu", 1)
    from warpfree.solvers.spem.kronecker import NodalValues

    lay = staggered_disk((0.1, 0.1), 0.1, 0.01, h_staggering="centres")  # the thesis's schemes' layout
    model = SPEMModel(lay, scheme="cspm", support=2.5)
    profile = 1.0 - np.sum((lay.e_position[:, :2] - 0.1) ** 2, axis=1) / 0.01
    raw = SPEMSolver(model, ez=profile).state.ez.numpy().astype(np.float64)
    nodal = SPEMSolver(model, ez=profile, kronecker=True).state.ez.numpy().astype(np.float64)
    interpolant = NodalValues.from_set(model.electric, 2).field
    free = ~model.held
    assert np.all(nodal[model.held] == 0.0)
    assert np.max(np.abs(interpolant(nodal) - profile)[free]) < 1e-5
    assert np.max(np.abs(interpolant(raw) - profile)[free]) > 1e-3  # without it the interpolant misses the profile
    with pytest.raises(ParameterError, match="^kronecker"):
        SPEMSolver(SPEMModel(lay), ez=profile, kronecker=True)


def test_bad_input_names_the_parameter():
    device.use("cpu", 1)
    from warpfree.solvers.spem import StaggeredLayout

    e = np.array([[0.0, 0.0, 0.0], [0.1, 0.05, 0.0], [0.2, 0.0, 0.0]])
    h = np.array([[0.05, 0.0, 0.0], [0.15, 0.0, 0.0], [0.25, 0.0, 0.0], [-0.05, 0.0, 0.0]])  # all on y = 0
    collinear = StaggeredLayout(2, e, h, np.full(3, 0.1), np.full(4, 0.1), np.zeros(3, bool), 0.1)
    with pytest.raises(ParameterError, match=r"^support: .*particle 0 at \[0.0, 0.0\] with 4 magnetic"):
        SPEMModel(collinear)  # H particles on one line: no y derivative at any E particle
    box = staggered_box((0, 0), (0.5, 0.5), 0.05)
    with pytest.raises(ParameterError, match="^pml.thickness"):
        SPEMModel(box, pml=PML(0.05), interior=((0.05, 0.05), (0.45, 0.45)))
    with pytest.raises(ParameterError, match="^eps_r"):
        SPEMModel(box, eps_r=lambda p: np.where(p[:, 0] > 0.3, -1.0, 1.0))
    with pytest.raises(ParameterError, match="^scheme"):
        SPEMModel(box, scheme="fdtd")
    with pytest.raises(ParameterError, match="^pml.sides"):
        PML(0.15, sides=("z+",))
    with pytest.raises(ParameterError, match="^source.kind"):
        Source([0], Waveform(1e9), kind="sticky")
    with pytest.raises(ParameterError, match="^jitter"):
        staggered_box((0, 0), (0.5, 0.5), 0.05, jitter=0.6)
    with pytest.raises(ParameterError, match="^pml.reflection"):
        SPEMModel(box, pml=PML(0.15, reflection=2.0), interior=((0.15, 0.15), (0.35, 0.35)))
    solver = SPEMSolver(SPEMModel(box))
    with pytest.raises(ParameterError, match="^dt"):
        TimeLoop(solver, t_end=1e-9, output_interval=1e-10, dt=1.01 * solver.stable_dt())


def pml_line_record(lo: float, hi: float, delta: float, spacing: float, length: float, frequency: float,
                    steps: int, order: int = 3):
    """Ez at x = length/2 from a soft Gaussian pulse at x = length/4, interior [lo, hi], PML of thickness δ on both
    ends (backed by PEC particles)."""
    lay = staggered_line(lo - delta, hi + delta, spacing)
    model = SPEMModel(lay, pml=PML(delta, sides=("x-", "x+"), order=order), interior=((lo, 0, 0), (hi, 0, 0)))
    x = lay.e_position[:, 0]
    source, probe = int(np.argmin(np.abs(x - 0.25 * length))), int(np.argmin(np.abs(x - 0.5 * length)))
    from warpfree.solvers.spem import GaussianPulse, Source

    solver = SPEMSolver(model, [Source([source], GaussianPulse(frequency, 0.5 / frequency, 2.5 / frequency), kind="soft")])
    dt = 0.95 * spacing / C0
    record = np.empty(steps)
    for n in range(steps):
        solver.step(dt)
        record[n] = solver.state.ez.numpy()[probe]
    return record, x[source], x[probe]


@pytest.mark.parametrize("cells,limit_db", [(5, -40.0), (10, -40.0)])
def test_pml_reflection_at_normal_incidence_meep_style(cells, limit_db):
    """Reflection of a graded (n = 3, ψ = 1e-6) PML of 5 and 10 particles at 20 per wavelength, measured as Meep's
    tests do: the same run in a domain 7x longer with a layer twice as thick is the reflection-free reference
    (its reflections arrive after the window); R = max|Ez - Ez_ref| / max|Ez_ref| at the probe. Measured
    2026-11-23: -69.9 dB (5) and -92.5 dB (10). Asserted: the required -40 dB. (The exponential update had lost
    its Δt/ε for a particle a rounding error inside the layer, which reflected everything at some
    thicknesses: tested at 10.)"""
    device.use("cpu", 1)
    f = 1.0e9
    lam = C0 / f
    dx, length = lam / 20, 4 * lam
    steps = int((5.0 / f + 2.5 * length / C0) / (0.95 * dx / C0))
    a, s1, p1 = pml_line_record(0.0, length, cells * dx, dx, length, f, steps)
    b, s2, p2 = pml_line_record(-3 * length, 4 * length, 2 * cells * dx, dx, length, f, steps)
    assert abs(s1 - s2) < 1e-9 and abs(p1 - p2) < 1e-9
    assert np.abs(b).max() > 0.3
    assert 20 * np.log10(np.abs(a - b).max() / np.abs(b).max()) < limit_db


def test_long_run_with_pml_stays_bounded():
    """20 000 steps of a sine source between two PMLs: the field stays at the source's level (measured max |Ez|
    over the last 2 000 steps ~ 1.0 x the amplitude; asserted below 1.5, and the run not decaying to nothing)."""
    device.use("cpu", 1)
    f = 1.0e9
    lam = C0 / f
    dx = lam / 20
    lay = staggered_line(-0.5 * lam, 2.5 * lam, dx)
    model = SPEMModel(lay, pml=PML(0.5 * lam, sides=("x-", "x+")), interior=((0.0, 0, 0), (2 * lam, 0, 0)))
    from warpfree.solvers.spem import Source, Waveform

    source = int(np.argmin(np.abs(lay.e_position[:, 0] - lam)))
    solver = SPEMSolver(model, [Source([source], Waveform(f, ramp=2.0))])
    dt = 0.95 * solver.stable_dt()
    late = 0.0
    for n in range(20_000):
        solver.step(dt)
        if n >= 18_000 and n % 10 == 0:
            late = max(late, float(np.abs(solver.state.ez.numpy()).max()))
    assert 0.5 < late < 1.5


def test_waveguide_reference_is_the_causal_tm1_solution():
    import math as m

    from warpfree.solvers.spem import Waveform
    from warpfree.validation.em_waveguide_2d import cutoff_frequency, tm1_field

    a = 0.5
    f = 1.2 * cutoff_frequency(a)
    beta = m.sqrt((2 * m.pi * f) ** 2 - (C0 * m.pi / a) ** 2) / C0
    source = lambda t: m.sin(2 * m.pi * f * t) * m.sin(0.5 * m.pi * min(1.0, t * f / 2.0)) ** 2  # noqa: E731
    y = np.linspace(0.0, 0.4, 9)
    t = 200 / f
    u = tm1_field(y, t, a, source, f)
    assert abs(u[0] - source(t)) < 1e-9                                     # the boundary condition
    sudden = Waveform(f)  # switched on at once: a kink at t = 0, the hardest case for the sampled spectrum
    at_4ns = tm1_field(y, 4.08e-9, a, sudden, f)
    assert np.max(np.abs(at_4ns - tm1_field(y, 4.08e-9, a, sudden, f, window_periods=4096, samples_per_period=2048))) < 2e-5
    assert np.max(np.abs(u - np.sin(2 * m.pi * f * t - beta * y))) < 5e-4   # the steady wave after 200 periods
    assert abs(tm1_field(np.array([0.3]), 0.5e-9, a, source, f)[0]) < 1e-6  # before the front (c t = 0.15 m < 0.3 m)


def test_waveguide_matches_the_exact_tm1_wave_with_half_the_thesis_density(tmp_path):
    """Mendes (2010) §4.4 at 40 particles per wavelength (the thesis: 80), t = 4.1 ns: measured mean error 0.073 % of E0
    along x = 0.25 m outside the PML (largest 0.29 %; cell-centred H 0.11 %, 0.31 %). Asserted: the thesis's
    0.39 %."""
    device.use("cpu", 2)
    run = load_scene("em_waveguide_2d").build(frames=False, vtk=False)
    wg = run.run(str(tmp_path / "wg"), progress=False)["analysis"]["waveguide"]
    assert wg["particles_per_wavelength"] == pytest.approx(40.0)
    assert wg["mean_error"] < 3.9e-3


def plane_wave(tmp_path, **kw):
    device.use("cpu", 2)
    run = load_scene("em_plane_wave_2d").build(frames=False, vtk=False, size=0.2,
                                                                              margin=0.03, **kw)
    return run.run(str(tmp_path / "pw"), progress=False)["analysis"]["plane_wave"]


@pytest.mark.parametrize("angle", [0.0, 30.0])
def test_plane_wave_has_no_stripes_and_matches_the_analytic_wave(tmp_path, angle):
    """Mendes (2010) §4.5 (3.6 GHz, 40 particles per wavelength, PML on all sides), on a 0.2 m square to 2 ns:
    measured (Yee's staggering), mean (largest) |Ez - Ez_inc| / A in the total-field box 0.17 % (0.68 %) at 0°,
    0.061 % (0.25 %) at 30°; amplitude spread between neighbouring lines 1e-4 and 4e-5; largest field in the
    scattered region 0.74 % and 0.27 %: Yee's phase lag over the 1.68 wavelengths (0°; 1.94 along the longest chord
    at 30°) the wave crosses, 2 sin(δφ/2) = 0.61 % and 0.25 % of A. Asserted: the required 1 % between lines, and the
    box error and the leakage within the scene's tolerance, 1.5 x that lag (the checks the run reports)."""
    pw = plane_wave(tmp_path, angle=angle)
    assert pw["lines"] > 60
    assert pw["line_amplitude_spread"] < 1e-2
    tolerance = 1.5 * pw["predicted_lag_error"]
    assert pw["checks"]["max_leakage"]["tolerance"] == pytest.approx(tolerance, rel=1e-12)
    assert pw["max_error"] < tolerance
    assert pw["max_leakage"] < tolerance
    assert all(c["passed"] for c in pw["checks"].values())


@pytest.mark.parametrize("settings,travel", [({"particles_per_wavelength": 20.0}, 1.68),
                                             ({"size": 0.3, "margin": 0.04}, 2.64)])
def test_plane_wave_leakage_is_the_predicted_phase_lag(tmp_path, settings, travel):
    """What leaks into the scattered region is the discrete wave's phase lag behind the analytic one at the exit
    (Yee's dispersion, ``warpfree/solvers/spem/dispersion.py``), raised by the diffraction of the box's side edges:
    measured 1.07-1.22 times the predicted 2 sin(δφ/2) from 1.7 to 7.2 wavelengths of travel and 20 to 80 particles
    per wavelength (a paraxial model of the edges gives 1.08-1.18); at the quick size's 40 per wavelength 1.22.
    Here at half the density (4x the lag: predicted 2.44 %, measured 2.92 %) and on a 0.3 m square (2.64
    wavelengths: 0.95 %, 1.09 %). Asserted: the leakage between 1.0 and 1.3 times the prediction, and so within
    the scene's tolerance of 1.5 times it."""
    kw = {"size": 0.2, "margin": 0.03, **settings}
    device.use("cpu", 2)
    run = load_scene("em_plane_wave_2d").build(frames=False, vtk=False, **kw)
    pw = run.run(None, progress=False)["analysis"]["plane_wave"]
    assert pw["travel_wavelengths"] == pytest.approx(travel, abs=0.01)
    ratio = pw["max_leakage"] / pw["predicted_lag_error"]
    assert 1.0 <= ratio <= 1.3, ratio
    assert pw["checks"]["max_leakage"]["passed"] and pw["checks"]["max_error"]["passed"]


def test_plane_wave_on_jittered_particles_has_no_stripes(tmp_path):
    """The same at 30° on 30 %-jittered particles: measured mean error 0.73 % (11x the uniform layout's at 30°),
    largest 3.3 %, spread between lines 0.34 %, scattered region 2.7 % (cell-centred H: 0.82 %, 7.9 %, 0.44 %,
    3.1 %). Asserted: no stripes (1 %) and a mean error below 2 %."""
    pw = plane_wave(tmp_path, angle=30.0, jitter=0.3, seed=1)
    assert pw["line_amplitude_spread"] < 1e-2
    assert pw["mean_error"] < 2e-2


def test_plane_wave_box_must_lie_in_the_lossless_interior():
    device.use("cpu", 1)
    from warpfree.solvers.spem import PlaneWave, Waveform

    model = SPEMModel(staggered_box((0, 0), (0.5, 0.5), 0.025), pml=PML(0.1), interior=((0.1, 0.1), (0.4, 0.4)))
    with pytest.raises(ParameterError, match="^plane_wave.lower: .*PML"):
        SPEMSolver(model, [PlaneWave(Waveform(1e9), lower=(0.05, 0.15), upper=(0.35, 0.35))])
    with pytest.raises(ParameterError, match="^plane_wave.upper"):
        SPEMSolver(model, [PlaneWave(Waveform(1e9), lower=(0.3, 0.15), upper=(0.2, 0.35))])
    with pytest.raises(ParameterError, match="^plane_wave.direction"):
        SPEMSolver(model, [PlaneWave(Waveform(1e9), lower=(0.15, 0.15), upper=(0.35, 0.35), direction=(0, 0))])


@pytest.mark.parametrize("scene,settings,plot", [
    ("em_line_1d", ["particles_per_wavelength=10", "t_end=0.95e-9"], "line.png"),
    ("em_cavity_2d", ["cells_per_radius=8", "t_end=0.5e-9"], "cavity.png"),
    ("em_waveguide_2d", ["particles_per_wavelength=20", "t_end=0.82e-9"], "waveguide.png"),
    ("em_plane_wave_2d", ["particles_per_wavelength=20", "size=0.2", "margin=0.03", "t_end=0.5e-9"],
     "plane_wave.png"),
])
def test_em_scenes_write_frames_vtu_plot_and_their_error(tmp_path, scene, settings, plot):
    out = tmp_path / "em"
    args = [a for s in settings for a in ("--set", s)]
    assert main(["run", scene, *args, "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["throughput"]["value"] > 0
    assert "mean_error" in next(iter(summary["analysis"].values()))
    frames = list((out / "frames").glob("*.png"))
    assert frames and len(frames) == len(list((out / "vtk").glob("electric_*.vtu")))
    assert (out / "electric.pvd").is_file() and (out / "magnetic.pvd").is_file()
    assert (out / plot).is_file()
