"""Parallel-plate waveguide with a PML: SPEM against the exact TM1 signalling solution.

Mendes (2010), §4.4.

Plates (PEC, held E particles) at x = 0 and x = a = 0.5 m, the wave driven from y = 0 and absorbed by a PML of
0.1 m beyond y = 0.4 m (backed by PEC). The source imposes Ez = E0 sin(πx/a) s(t) on the E particles of the line
y = 0, s(t) = sin(2π f t) with f = 1.2 × the TM1 cutoff (359.8 MHz), switched on over ``ramp`` periods (0: at
once, as the thesis). The thesis drove the line uniformly (its profile is not given); the TM1 profile makes the
exact solution a single mode, Ez = E0 sin(πx/a) u(y, t), u evaluated by Fourier transform
(``warpfree/validation/em_waveguide_2d``). Compared at t = 4.1 ns along the column nearest x = 0.244 m, outside
the PML (the thesis: mean error 0.39 % at 80 particles per wavelength). Writes ``waveguide.png`` (Ez over the
exact field, and below it Ez − exact with the tolerance) and the mean and largest error, relative to E0, into
``summary.json``, the mean checked against the thesis's 0.39 % (:func:`waveguide_checks`).

Model: E at the lattice nodes, H in Yee's staggering (Hx and Hy at the midpoints of the cell sides,
``warpfree/solvers/spem/layouts.py``), Δ = λ0/``particles_per_wavelength`` (λ0 = c/f = 0.833 m), the
conservative FPM pair over each component's nearest particles (``warpfree/solvers/spem/conservative.py``; on
this uniform layout it is Yee's difference up to small off-axis terms, with Yee's step limit of about
Δ/(c√2)); PML graded with n = 3 from ψ = 1e-6. Errors against resolution
and time: ``bench/results/scene_studies.md``.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.distribution import Distribution
from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.spem import C0, PML, HStaggering, Source, SPEMModel, SPEMSolver, Waveform, staggered_box
from warpfree.solvers.spem.parameters import (Courant, EndTime, HLayout, LoadDistribution, OutputInterval,
                                              ParticlesPerWavelength, Ramp)
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.em_waveguide_2d import cutoff_frequency, tm1_field


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"particles_per_wavelength": 20, "t_end": 1.64e-9}
#: ``warpfree validate --quick``: the default run (about 2 s) at half the thesis's density (literal values only)
QUICK = {}

#: where the reference and the tolerance come from
SOURCE = "exact TM1 signalling solution, the case of Mendes (2010), §4.4 (warpfree/validation/em_waveguide_2d/README.md)"


def waveguide_checks(result: dict) -> dict:
    """The thesis's accuracy (§4.4): mean |Ez - exact| / E0 along the line outside the PML below 0.39 %, which it
    reached at 80 particles per wavelength, required here at the scene's 40 and above. The largest error is
    reported, not checked (the thesis states none)."""
    basis = ("the thesis's mean error 0.39 % at 80 particles per wavelength, required at 40 "
             "(tests/spem/test_spem.py)")
    return {"mean_error": tolerance_check(result["mean_error"], 3.9e-3, SOURCE, basis=basis)}


@checked_parameters
def build(width: Annotated[float, Param("m", "distance a between the plates", "(0, inf)")] = 0.5,
          length: Annotated[float, Param("m", "length of the guide from the source to the PML", "(0, inf)")] = 0.4,
          pml_thickness: Annotated[float, Param("m", "thickness δ of the PML beyond the guide (two spacings or more)",
                                                "(0, inf)")] = 0.1,
          frequency_ratio: Annotated[float, Param("", "source frequency over the TM1 cutoff, f/f_c (> 1: propagating)",
                                                  "(1, inf)")] = 1.2,
          amplitude: Annotated[float, Param("V/m", "amplitude E0 of the source's TM1 profile", "(-inf, inf)")] = 0.2,
          particles_per_wavelength: ParticlesPerWavelength = 40.0, courant: Courant = 0.95, ramp: Ramp = 0.0,
          t_end: EndTime = 4.1e-9, output_interval: OutputInterval = 0.41e-9,
          line_x: Annotated[float, Param("m", "x of the column compared with the exact field (between the plates)",
                                         "(0, inf)")] = 0.244,
          pml_order: Annotated[int, Param("", "grading order n of the PML's conductivity σ = σm (ρ/δ)^n", "[1, 6]")]
          = 3,
          pml_reflection: Annotated[float, Param("", "the PML's reflection ψ at normal incidence (sets σm, eq. 3.26)",
                                                 "(0, 1)")] = 1e-6,
          distribution: LoadDistribution = Distribution.BLOCKS, h_staggering: HLayout = HStaggering.EDGES,
          frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """Lengths in m, times in s; ``frequency_ratio``: f/f_c of TM1 (> 1: propagating); ``distribution``: the
    load distribution over threads (``warpfree/distribution.py``); ``h_staggering``: "edges" (Yee's) or "centres"
    (``warpfree/solvers/spem/layouts.py``)."""
    params = dict(locals())
    if not line_x < width:
        raise ParameterError("line_x", f"must lie between the plates (0, {width}), got {line_x}")
    frequency = frequency_ratio * cutoff_frequency(width)
    spacing = C0 / frequency / particles_per_wavelength
    with reported_as(spacing="particles_per_wavelength, width, length, pml_thickness, frequency_ratio",
                     **{"pml.thickness": "pml_thickness", "pml.order": "pml_order", "pml.reflection": "pml_reflection"}):
        layout = staggered_box((0.0, 0.0), (width, length + pml_thickness), spacing, h_staggering=h_staggering)
        pml = PML(pml_thickness, sides=("y+",), order=pml_order, reflection=pml_reflection)
        model = SPEMModel(layout, pml=pml, interior=((0.0, 0.0), (width, length)))
    e = layout.e_position
    dy = (length + pml_thickness) / round((length + pml_thickness) / spacing)
    line = np.flatnonzero(np.abs(e[:, 1]) < 0.25 * dy)
    profile = np.sin(np.pi * e[line, 0] / width)
    driven = line[np.abs(profile) > 1e-12]  # the plate particles stay PEC (profile 0 there)
    waveform = Waveform(frequency, ramp=ramp)
    solver = SPEMSolver(model, [Source(driven, waveform, amplitude * np.sin(np.pi * e[driven, 0] / width))],
                        distribution=distribution, courant=courant)
    column_x = e[np.argmin(np.abs(e[:, 0] - line_x)), 0]
    column = np.flatnonzero((np.abs(e[:, 0] - column_x) < 1e-9 * width) & (e[:, 1] <= length + 1e-9 * length))
    column = column[np.argsort(e[column, 1])]

    def waveguide_analysis(run, out_dir):
        s = run.solver
        t_e = s.electric_time
        ez = s.electric.numpy("ez")[column]
        y = e[column, 1]
        exact = amplitude * math.sin(math.pi * column_x / width) * tm1_field(y, t_e, width, waveform, frequency)
        err = np.abs(ez - exact) / amplitude
        result = {"mean_error": float(np.mean(err)), "max_error": float(np.max(err)),
                  "line_x": float(column_x), "frequency": frequency, "spacing": spacing,
                  "particles_per_wavelength": C0 / frequency / spacing, "dt": s.run_step,
                  "courant": s.run_step / s.stable_dt(), "time_of_ez": t_e}
        result["checks"] = waveguide_checks(result)
        if out_dir is not None:
            _plot(os.path.join(out_dir, "waveguide.png"), y, ez, exact, column_x, t_e, amplitude,
                  result["checks"]["mean_error"])
        return {"waveguide": result}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="em_waveguide_2d", params=params,
                    analyses=[waveguide_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames,
                                         frame_bounds=((0.0, width), (0.0, length + pml_thickness)),
                                         frame_range={"ez": (-abs(amplitude), abs(amplitude))} if amplitude else None))
    return run


def _plot(path, y, ez, exact, x, t, amplitude, check):
    """Ez and the exact TM1 field along the column (above), Ez − exact with the tolerance on its mean |error|,
    the check's fraction of E0 in V/m (below)."""
    from warpfree.solvers.spem.plots import plot_profile_check

    tolerance, mean = check["tolerance"] * amplitude, check["value"] * amplitude
    plot_profile_check(path, y, ez, exact, xlabel="y (m)", ylabel="Ez (V/m)", error_ylabel="Ez − exact (V/m)",
                       title=f"Parallel-plate waveguide, TM1: SPEM against the exact field along x = {x:.3f} m, "
                             f"t = {t * 1e9:.2f} ns",
                       computed_label="SPEM Ez (E particles)", exact_label="exact TM1 (Fourier integral)",
                       tolerance=tolerance,
                       tolerance_label=f"tolerance on the mean |error|: {check['tolerance']:.2%} of E0 "
                                       f"= {tolerance:.2g} V/m",
                       pointwise=False, measure=mean,
                       measure_label=f"mean |error| = {check['value']:.3%} of E0 = {mean:.2g} V/m")
