"""Standing wave in a rectangular tank (2D): WCSPH against linear theory, ω² = g k tanh(k d).

Water of depth d in a tank of length L, settled at rest (relaxed particles, then settled in the solver's own
discretisation: ``scene_tools.still_water_2d``), is given at t = 0 the velocity of the first standing mode at its
flat-surface phase (``warpfree.validation.standing_wave_2d``): η = A cos(kx) sin(ωt), k = π/L. The water's
horizontal centre of mass then swings as x_cm - L/2 = -(2AL/(π²d)) sin(ωt); every output records it (probe
``centre_of_mass_x``), and the analysis fits c + B e^(-βt) sin(ω't + ϕ) to the record: ``frequency_error`` =
ω'/ω - 1 against linear theory, ``decay_rate`` β (1/s) and ``amplitude_ratio`` B over the linear amplitude.
It writes ``standing_wave.png`` (the record, the fit and linear theory) and the figures into
``summary["analysis"]["standing_wave"]``.

Linear theory's own error at A/d = 0.02 (the default): the second-order frequency correction is of order
(kA)² ≈ 1e-3. Viscous damping β of water (ν = 1e-6 m²/s) in a 1 m tank is ~1e-3 1/s; what the run measures
beyond that is numerical (artificial viscosity ``alpha``, the particle discretisation).

The kernel reaches h = 2.8 dx (``h_factor``; the other fluid scenes use 1.6 dx). At a fixed reach the frequency
converges as dx falls to the particle sums' own error at that reach, which depends on h/dx (the neighbour count) and
not on dx: +0.13 % at 2.8 dx (-0.62, -0.36, -0.04, +0.12, +0.13 % at dx = 0.04, 0.033, 0.025, 0.02, 0.01, the
kernel's smoothing lowering it at coarse dx), +0.56 % at 2.4 dx (+0.03, -0.14, +0.27, +0.52, +0.56 %), 0.9-1.3 % at
1.6 dx; a wave whose surface moves less than a particle spacing feels it fully
(``warpfree/validation/standing_wave_2d/README.md``). Walls need ``wall_layers`` >= 2h/dx - 1/2 layers (6 at 2.8 dx).
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.smoothing import SmoothingKernel
from warpfree.solvers.wcsph import FluidField
from warpfree.solvers.wcsph.parameters import (ArtificialViscosity, Courant, DensityDiffusion, DynamicViscosity,
                                                FrameField, Gravity, HFactor, Kernel, RestDensity, SettlePeriods,
                                                Spacing, WallLayers)
from warpfree.solvers.wcsph.scene_tools import box_2d, still_water_2d
from warpfree.time_loop import TimeLoop
from warpfree.validation import standing_wave_2d as linear


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"dx": 0.05, "periods": 0.25, "settle_periods": 0.25, "outputs_per_period": 20}

#: ``warpfree validate --quick``: dx = 0.025 (20 particles over the depth), as the tests: the coarsest spacing at which
#: the kernel's smoothing (h = 2.8 dx = 0.07 m) no longer lowers the frequency by tenths of a per cent (-0.04 %;
#: -0.36 % at dx = 0.033); about 35 s with its set-up on 2 threads (the default dx = 0.02 spends about 100 s relaxing
#: and settling before the first step)
QUICK = {"dx": 0.025}


@checked_parameters
def build(length: Annotated[float, Param("m", "length of the tank (the wavelength is twice it)", "(0, inf)")] = 1.0,
          depth: Annotated[float, Param("m", "water depth (the tank is twice as high)", "(0, inf)")] = 0.5,
          amplitude: Annotated[float, Param("m", "amplitude A of the surface wave (A < 0.2 depth)", "(0, inf)")] = 0.01,
          dx: Spacing = 0.02,
          periods: Annotated[float, Param("", "length of the run, in periods of linear theory", "(0, inf)")] = 3.0,
          h_factor: HFactor = 2.8, kernel: Kernel = SmoothingKernel.WENDLAND_C2, alpha: ArtificialViscosity = 0.02,
          delta: DensityDiffusion = 0.1, mu: DynamicViscosity = 1.0e-3, cfl: Courant = 0.1, g: Gravity = 9.81,
          rho0: RestDensity = 1000.0, wall_layers: WallLayers = 6, settle_periods: SettlePeriods = 3.0,
          outputs_per_period: Annotated[int, Param("", "outputs per period of linear theory", "[1, inf)")] = 40,
          checkpoint_every: CheckpointEvery = 0, frames: Frames = True, frame_field: FrameField = FluidField.SPEED,
          vtk: Vtk = True) -> TimeLoop:
    """Tank ``length`` × 2 ``depth`` (m), water ``depth`` deep, wave ``amplitude`` A (m, A ≪ depth); the run lasts
    ``periods`` periods of linear theory. c0 = 10 sqrt(2 g d) as in the other tanks."""
    params = dict(locals())
    if amplitude >= 0.2 * depth:
        raise ParameterError("amplitude", f"must be < 0.2 depth = {0.2 * depth:g} m (a linear wave), got {amplitude}")
    omega = linear.frequency(g, length, depth)
    period = 2.0 * math.pi / omega
    c0 = 10.0 * math.sqrt(2.0 * g * depth)
    tank = box_2d(length, 2.0 * depth)
    with reported_as(layers="wall_layers"):
        solver, _, settled = still_water_2d(
            tank, depth, dx, dict(h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, alpha=alpha, delta=delta,
                                  gravity=(0.0, -g, 0.0), cfl=cfl, lj_d=2.0 * g * depth, lj_r0=0.75 * dx),
            wall_layers=wall_layers, settle_periods=settle_periods)
    x = solver.fluid.numpy("position").astype(np.float64)
    v = linear.initial_velocity(x[:, 0], x[:, 1], amplitude, g, length, depth)
    solver.fluid.load({"velocity": np.column_stack([v, np.zeros(len(v))]).astype(np.float32)})
    solver.initialise()
    mass = solver.fluid.numpy("mass").astype(np.float64)
    expected = linear.centre_of_mass_amplitude(amplitude, length, depth)

    def centre_of_mass_x(s, t):
        """Horizontal centre of mass of the water (m)."""
        return float(np.sum(mass * s.fluid.numpy("position")[:, 0]) / np.sum(mass))

    def wave_analysis(run: TimeLoop, out_dir: str) -> dict:
        try:
            res = standing_wave_errors(run.series["time"], run.series["centre_of_mass_x"], omega, expected)
        except ValueError as exc:  # too short a record to fit
            return {"standing_wave": {"fit_error": str(exc), "omega_linear": omega, "period_linear": period,
                                      "settling": settled}}
        res.update({"omega_linear": omega, "period_linear": period, "settling": settled})
        res["checks"] = wave_checks(res)
        if out_dir is not None:
            plot_wave(os.path.join(out_dir, "standing_wave.png"), run.series, res, length, expected,
                      f"L = {length:g} m, d = {depth:g} m, A = {amplitude:g} m, dx = {dx:g} m, α = {alpha:g}")
        return {"standing_wave": res}

    return TimeLoop(solver, t_end=periods * period, output_interval=period / outputs_per_period,
                    name="standing_wave_2d", params=params, probes={"centre_of_mass_x": centre_of_mass_x},
                    analyses=[wave_analysis], checkpoint_every=checkpoint_every,
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                         frame_bounds=((-0.05 * length, 1.05 * length), (-0.05 * depth, 1.5 * depth)),
                                         # linear theory's largest speed, A ω coth(k d) at the surface (k = π/L)
                                         frame_range={"speed": (0.0, amplitude * omega / math.tanh(math.pi * depth
                                                                                                    / length)),
                                                      "pressure": (0.0, rho0 * g * (depth + amplitude))}))


def standing_wave_errors(time, centre_x, omega: float, expected_amplitude: float) -> dict:
    """Fit of the centre-of-mass record against linear theory: frequency error ω'/ω - 1, decay rate β (1/s),
    amplitude ratio B/(2AL/(π²d)) and the fit's relative rms residual."""
    fit = linear.fit_damped_oscillation(time, centre_x, omega)
    return {"omega": fit["omega"], "frequency_error": fit["omega"] / omega - 1.0, "decay_rate": fit["beta"],
            "amplitude_ratio": fit["amplitude"] / expected_amplitude, "fit_residual": fit["relative_residual"],
            "fit": fit}


#: the checks' tolerances: frequency (relative), amplitude ratio, decay rate (1/s), the fit's rms residual
FREQUENCY_TOLERANCE, AMPLITUDE_TOLERANCE, DECAY_TOLERANCE, RESIDUAL_TOLERANCE = 0.005, 0.05, 0.2, 0.05

SOURCE = ("linear water-wave theory, ω² = g k tanh(k d) (Lamb 1932, §227-228); "
          "warpfree/validation/standing_wave_2d/README.md")


def wave_checks(res: dict) -> dict:
    """The fit's figures against linear theory (:func:`warpfree.validation.tolerance_check`)."""
    from warpfree.validation import tolerance_check

    return {
        "frequency_error": tolerance_check(
            res["frequency_error"], FREQUENCY_TOLERANCE, SOURCE,
            basis="linear theory's own error (kA)² ≈ 0.1 % plus the discretisation's at h = 2.8 dx, converged as dx "
                  "falls: -0.04 % at dx = 0.025, +0.12 % at 0.02, +0.13 % at 0.01 (coarser, the kernel's smoothing "
                  "lowers it: -0.36 % at 0.033); at 2.4 dx it converges to +0.56 %, past this tolerance"),
        "amplitude_ratio": tolerance_check(
            res["amplitude_ratio"], AMPLITUDE_TOLERANCE, SOURCE, reference=1.0,
            basis="the start's velocity is linear theory's; measured 0.992-0.994 from dx = 0.025 to 0.02"),
        "decay_rate": tolerance_check(
            res["decay_rate"], DECAY_TOLERANCE, SOURCE + " (inviscid: no decay; water's own ~1e-3 1/s)", unit="1/s",
            basis="the numerical damping allowed: e^(-0.2 x 3 periods) keeps half the amplitude; measured 0.048-0.059 "
                  "1/s from dx = 0.02 to 0.025 (artificial viscosity α = 0.02)"),
        "fit_residual": tolerance_check(
            res["fit_residual"], RESIDUAL_TOLERANCE, "the record against its fitted damped sine",
            basis="the record is a damped sine to 5 % rms, or the fitted frequency and amplitude mean little; "
                  "measured 0.23-0.24 % from dx = 0.025 to 0.02"),
    }


def plot_wave(path: str, series: dict, res: dict, length: float, expected: float, label: str) -> None:
    """Above: x_cm - L/2 against t, the run, its fitted damped sine and linear theory. Below: the run minus its fit,
    over the fitted amplitude, with its rms (checked against 5 %), and every check in ``res["checks"]``."""
    from warpfree.io.validation_plots import (COMPUTED, REFERENCE, annotate_checks, comparison_axes, draw_bound,
                                              save_figure)

    t = np.asarray(series["time"])
    xc = np.asarray(series["centre_of_mass_x"]) - 0.5 * length
    f = res["fit"]

    def fitted(time):
        return f["offset"] - 0.5 * length + f["amplitude"] * np.exp(-f["beta"] * time) * np.sin(f["omega"] * time
                                                                                                  + f["phase"])

    tt = np.linspace(0.0, max(t.max(), 1e-12), 400)
    fig, top, bottom = comparison_axes(8.0, 6.0, title=f"Standing wave ({label}) against linear theory:\nfrequency "
                                                       f"error {100 * res['frequency_error']:+.2f} %, decay "
                                                       f"{res['decay_rate']:.3g} 1/s")
    top.plot(tt, -expected * np.sin(res["omega_linear"] * tt), "-", color=REFERENCE, lw=1.2,
             label="linear theory, −(2AL/(π²d)) sin(ωt)")
    top.plot(t, xc, "o", ms=3, color=COMPUTED, label="warpfree WCSPH")
    top.plot(tt, fitted(tt), "--", color="C1", lw=1, label="damped sine fitted to the run")
    top.set_ylabel("x_cm − L/2 (m)")
    top.margins(y=0.3)  # room for the legend above the crests
    top.legend(fontsize=7, loc="upper right")
    residual = (xc - fitted(t)) / f["amplitude"]
    bottom.plot(t, residual, "o-", ms=2.5, lw=0.8, color=COMPUTED, label="(run − fit) / fitted amplitude")
    bottom.axhline(res["fit_residual"], color=COMPUTED, ls="--", lw=1.0,
                   label=f"its rms = {100 * res['fit_residual']:.2f} %")
    draw_bound(bottom, RESIDUAL_TOLERANCE, f"tolerance on the rms: {100 * RESIDUAL_TOLERANCE:g} %")
    bottom.axhline(0.0, color="0.5", lw=0.6)
    bottom.set_xlabel("t (s)")
    bottom.set_ylabel("residual / amplitude")
    bottom.legend(fontsize=7, loc="upper right")
    annotate_checks(bottom, res["checks"])
    save_figure(fig, path)
