"""1D wave from a sine source in the middle of a line: SPEM against the exact wave.

Mendes (2010), §4.2.

Ω = [0, π] m, perfectly conducting ends (E particles held at 0), a hard source Ez = sin(2π f t), f = 1.8 GHz,
on the E particle nearest the centre, compared at t = 4.75 ns with sin(ω(t - |x - x_s|/c)) on x in (0.5, 1.5)
(``warpfree/validation/em_line_1d``). Writes ``line.png`` (Ez over the exact wave, and below it Ez − exact with
the tolerance) and into ``summary.json`` the mean error and the wavelength error, each checked against the thesis's
accuracy (:func:`line_checks`).

Model: E at x = kΔ, H at the midpoints, Δ = λ/``particles_per_wavelength`` (20 by default: one E and one H
particle per Δ, as FDTD counts cells; the thesis needed 40 E particles per λ); FPM derivatives over the
nearest particles of the other set (support 1.1 Δ). On this layout the scheme is Yee's, so its dispersion
is Yee's: the phase error vanishes at the stable limit Δt = Δ/c and grows as the step shrinks. The error
against the Courant number: ``bench/results/scene_studies.md``.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import Frames, Param, Seed, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.spem import C0, Scheme, Source, SPEMModel, SPEMSolver, Waveform, staggered_line
from warpfree.solvers.spem.parameters import (Courant, DerivativeScheme, EndTime, Frequency, Jitter, OutputInterval,
                                              ParticlesPerWavelength)
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.em_line_1d import line_wave, mean_error, wavelength_from_crossings


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"particles_per_wavelength": 10, "t_end": 9.5e-10}
#: ``warpfree validate --quick``: the default run (about 1 s), whose accuracy the thesis states (literal values only)
QUICK = {}

#: where the reference and the tolerances come from
SOURCE = "exact wave, the case of Mendes (2010), §4.2 (warpfree/validation/em_line_1d/README.md)"


def line_checks(result: dict) -> dict:
    """The thesis's accuracy (§4.2, at about 40 E particles per wavelength), required here at 20 and above: mean
    |Ez - exact| below 1e-2 V/m on the window (unit amplitude), and the wavelength from the zero crossings within
    0.1 % of c/f (NaN, failing, when the window holds too few crossings)."""
    basis = "the thesis's stated accuracy at 40 particles per wavelength, required at 20 (tests/spem/test_spem.py)"
    return {"mean_error": tolerance_check(result["mean_error"], 1e-2, SOURCE, unit="V/m", basis=basis),
            "wavelength_rel_error": tolerance_check(result.get("wavelength_rel_error", float("nan")), 1e-3, SOURCE,
                                                    basis=basis)}


@checked_parameters
def build(frequency: Frequency = 1.8e9,
          length: Annotated[float, Param("m", "length of the line (at least 4 wavelengths)", "(0, inf)")] = math.pi,
          particles_per_wavelength: ParticlesPerWavelength = 20.0, courant: Courant = 0.95, t_end: EndTime = 4.75e-9,
          output_interval: OutputInterval = 0.475e-9, scheme: DerivativeScheme = Scheme.FPM,
          support: Annotated[float, Param("Δ", "support radius of a particle", "[0.75, 4]")] = 1.1,
          jitter: Jitter = 0.0, seed: Seed = 0, frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """``particles_per_wavelength`` = λ/Δ; ``courant``: the step as a fraction of the stable limit; times in s."""
    params = dict(locals())
    wavelength = C0 / frequency
    if length < 4 * wavelength:
        raise ParameterError("length", f"must hold at least 4 wavelengths ({4 * wavelength:.4g} m), got {length}")
    with reported_as(spacing="particles_per_wavelength, length, frequency"):
        layout = staggered_line(0.0, length, wavelength / particles_per_wavelength, jitter=jitter, seed=seed)
    model = SPEMModel(layout, scheme=scheme, support=support)
    x = layout.e_position[:, 0]
    source = int(np.argmin(np.abs(x - 0.5 * length)))
    solver = SPEMSolver(model, [Source([source], Waveform(frequency))], courant=courant)
    window = (0.5, 1.5) if length == math.pi else (0.5 * length - 0.32 * length, 0.5 * length + 0.32 * length)

    def line_analysis(run, out_dir):
        s = run.solver
        t_e = s.electric_time  # Ez is half a step behind H
        ez = s.electric.numpy("ez")
        err = mean_error(x, ez, t_e, x[source], frequency, window)
        result = {"mean_error": err, "window": list(window), "particles_per_wavelength": wavelength / layout.spacing,
                  "dt": s.run_step, "courant": s.run_step / s.stable_dt(), "time_of_ez": t_e}
        try:
            lam = wavelength_from_crossings(x, ez, window)
            result.update(wavelength=lam, wavelength_rel_error=lam / wavelength - 1.0)
        except ValueError as exc:
            result["wavelength_error"] = str(exc)
        result["checks"] = line_checks(result)
        if out_dir is not None:
            _plot(os.path.join(out_dir, "line.png"), x, ez, line_wave(x, t_e, x[source], frequency), window, t_e,
                  result["checks"]["mean_error"])
        return {"line": result}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="em_line_1d", params=params,
                    analyses=[line_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((0.0, length),),
                                         frame_range={"ez": (-1.0, 1.0)}))  # the source's amplitude, 1 V/m
    return run


def _plot(path, x, ez, exact, window, t, check):
    """Ez and the exact wave on the window (above), Ez − exact with the tolerance on its mean |error| (below)."""
    from warpfree.solvers.spem.plots import plot_profile_check

    sel = (x > window[0]) & (x < window[1])
    order = np.argsort(x[sel])
    plot_profile_check(path, x[sel][order], ez[sel][order], exact[sel][order], xlabel="x (m)", ylabel="Ez (V/m)",
                       error_ylabel="Ez − exact (V/m)",
                       title=f"1D line, hard sine source at the centre: SPEM against the exact wave, t = {t * 1e9:.2f} ns",
                       computed_label="SPEM Ez (E particles)", exact_label="exact sin(ω(t − |x − x_s|/c))",
                       tolerance=check["tolerance"],
                       tolerance_label=f"tolerance on the mean |error|: ±{check['tolerance']:.2g} V/m",
                       pointwise=False, measure=check["value"], measure_label=f"mean |error| = {check['value']:.2g} V/m")
