"""2D pulse in a circular dielectric cavity: SPEM against the exact Bessel series.

Mendes (2010), §4.3, the series (4.5).

A disk of radius r0 = 0.1 m centred at (0.1, 0.1) m, εr = 10, perfectly conducting wall (a ring of E particles
held at Ez = 0), Ez(r, 0) = 1 - r²/r0², H = 0. Writes ``cavity.png`` (Ez along the radial line x = 0.1 m against
the series with Ez − exact below, and both mean errors over time against their tolerances) and into
``summary.json`` the mean error over all E particles and along that line, as a fraction of the initial peak, at
every output and its largest value (``warpfree/validation/em_cavity_2d``), the largest values checked
(:func:`cavity_checks`).

Model: E particles at the nodes of a lattice of spacing Δ = r0/``cells_per_radius`` and on the wall ring, H in
Yee's staggering (Hx at the midpoints of the cell sides along y, Hy along x, each carrying its one component;
``warpfree/solvers/spem/layouts.py``); the conservative FPM pair (``warpfree/solvers/spem/conservative.py``: exact for linear fields
and energy-conserving, so the irregular neighbourhoods at the ring cannot make it grow), support 1.1 Δ (1.1 + 2
jitter on jittered particles, widened where fewer than 4 particles of the other set, or of an H component, are
inside). Errors by
resolution and jitter, and the thesis's schemes beside them: ``bench/results/scene_studies.md``.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Seed, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.spem import HStaggering, Scheme, SPEMModel, SPEMSolver, staggered_disk, support_for_jitter
from warpfree.solvers.spem.kronecker import NodalValues
from warpfree.solvers.spem.parameters import Courant, DerivativeScheme, EndTime, Jitter, OutputInterval
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.em_cavity_2d import cavity_field


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"cells_per_radius": 8, "t_end": 1.0e-9, "output_interval": 0.25e-9}
#: what the benchmarks run of this scene for its family (bench/common.py ``benchmarks``): bench/core/gpu_check.py's
#: throughput at three sizes (``parameter`` set to each of ``values``, ``steps`` timed per block) and
#: bench/core/scaling.py's n and 2n work items on one and two ranks (the settings of each, per sweep size)
BENCHMARK = {"parameter": "cells_per_radius", "values": [20, 40, 80], "steps": 100,
             "scaling": {"large": [{"cells_per_radius": 80}, {"cells_per_radius": 113}],
                         "small": [{"cells_per_radius": 40}, {"cells_per_radius": 57}]}}
#: ``warpfree validate --quick``: the default run (about 2 s, two periods of the fundamental; literal values only)
QUICK = {}

#: where the reference and the tolerances come from
SOURCE = "Bessel series (eq. 4.5), the case of Mendes (2010), §4.3 (warpfree/validation/em_cavity_2d/README.md)"


def cavity_checks(result: dict) -> dict:
    """The largest mean |Ez - exact| over the outputs, of the initial peak (1 V/m): over all E particles below 1 %
    (the accuracy required of FPM, uniform and jittered, at 20 cells per radius: tests/spem/test_spem.py), and along
    the radial line below the thesis's 5 % (its plain-SPH figure along that line, §4.3)."""
    return {"max_mean_error": tolerance_check(
                result["max_mean_error"], 1e-2, SOURCE,
                basis="the 1 % required of the FPM pair at 20 cells per radius, uniform or 30 %-jittered "
                      "(tests/spem/test_spem.py)"),
            "max_line_error": tolerance_check(
                result["max_line_error"], 5e-2, SOURCE,
                basis="the thesis's mean error along the radial line, about 5 % (plain SPH, §4.3, Fig. 4.7)")}


@checked_parameters
def build(radius: Annotated[float, Param("m", "radius r0 of the cavity", "(0, inf)")] = 0.1,
          eps_r: Annotated[float, Param("", "relative permittivity εr of the dielectric", "(0, inf)")] = 10.0,
          cells_per_radius: Annotated[int, Param("", "lattice spacings per radius (Δ = r0/cells_per_radius)",
                                                 "[1, inf)")] = 20,
          courant: Courant = 0.9, t_end: EndTime = 5.5e-9, output_interval: OutputInterval = 0.25e-9,
          scheme: DerivativeScheme = Scheme.FPM,
          support: Annotated[float, Param("Δ", "support radius of a particle (0: 1.1 + 2 jitter)", "[0, 4]")] = 0.0,
          jitter: Jitter = 0.0, seed: Seed = 0,
          conservative: Annotated[bool | None, Param("", "the energy-conserving operator pair (none: on for fpm)")]
          = None,
          kronecker: Annotated[bool, Param("", "impose the initial profile as the SPH interpolant's values (sph and "
                                               "cspm only)")] = False,
          h_staggering: Annotated[HStaggering | None, Param("", "where the H particles sit (none: edges for fpm, "
                                                                "centres for cspm and sph)")] = None,
          pair_order: Annotated[int, Param("", "moments the conservative pair keeps exact: 1 linear, 2 also quadratic "
                                               "(for jittered layouts)", "[1, 2]")] = 1,
          frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """Times in s, lengths in m; ``support`` 0: 1.1 + 2·jitter spacings (``support_for_jitter``);
    ``h_staggering``: "edges" (Yee's) or "centres" (None: Yee's for FPM, cell centres for the thesis's "cspm" and
    "sph", printed for that layout);
    ``conservative``: the model's option (None: on for FPM); ``pair_order``: the conservative pair's (2: also the
    quadratic moments, for jittered layouts); ``kronecker``: impose the initial profile as the
    SPH interpolant's values (nodal values solved once; "sph"/"cspm" only)."""
    params = dict(locals())
    spacing = radius / cells_per_radius
    centre = np.array([radius, radius])
    if h_staggering is None:
        h_staggering = HStaggering.EDGES if scheme is Scheme.FPM else HStaggering.CENTRES
    with reported_as(spacing="cells_per_radius"):
        layout = staggered_disk(centre, radius, spacing, jitter=jitter, seed=seed, h_staggering=h_staggering)
    model = SPEMModel(layout, scheme=scheme, support=support or support_for_jitter(jitter), eps_r=eps_r,
                      conservative=conservative, pair_order=pair_order)
    r_e = np.hypot(*(layout.e_position[:, :2] - centre).T)
    solver = SPEMSolver(model, ez=lambda p: 1.0 - np.sum((p[:, :2] - centre) ** 2, axis=1) / radius**2,
                        kronecker=kronecker, courant=courant)
    # with ``kronecker`` the particle values are nodal parameters: the field is their SPH interpolant
    field = NodalValues.from_set(model.electric, 2).field if kronecker else (lambda u: u)
    on_line = (np.abs(layout.e_position[:, 0] - centre[0]) < 0.5 * spacing) & (layout.e_position[:, 1] >= centre[1])

    def errors(s, t):
        ez = field(s.electric.numpy("ez"))
        exact = cavity_field(r_e, s.electric_time, radius, eps_r)
        return np.abs(ez - exact)

    def mean_error(s, t):
        return float(np.mean(errors(s, t))) if t > 0 else 0.0

    def line_error(s, t):
        return float(np.mean(errors(s, t)[on_line])) if t > 0 else 0.0

    def cavity_analysis(run, out_dir):
        s = run.solver
        t_e = s.electric_time
        ez = field(s.electric.numpy("ez"))
        result = {"mean_error": run.series["mean_error"][-1], "line_error": run.series["line_error"][-1],
                  "max_mean_error": max(run.series["mean_error"]), "max_line_error": max(run.series["line_error"]),
                  "spacing": spacing, "dt": s.run_step, "courant": s.run_step / s.stable_dt(),
                  "periods": t_e * 2.405 * 299_792_458.0 / (2 * math.pi * radius * math.sqrt(eps_r))}
        result["checks"] = cavity_checks(result)
        if out_dir is not None:
            order = np.argsort(r_e[on_line])
            rr = r_e[on_line][order]
            _plot(os.path.join(out_dir, "cavity.png"), rr, ez[on_line][order], cavity_field(rr, t_e, radius, eps_r),
                  t_e, run.series, result["checks"])
        return {"cavity": result}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="em_cavity_2d", params=params,
                    probes={"mean_error": mean_error, "line_error": line_error}, analyses=[cavity_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((0.0, 2 * radius), (0.0, 2 * radius)),
                                         frame_range={"ez": (-1.0, 1.0)}))  # the initial pulse's peak, 1 V/m
    return run


def _plot(path, r, ez, exact, t, series, checks):
    """Left: Ez along the radial line against the Bessel series at the end (above), Ez − exact with the line's
    tolerance on its mean |error| (below). Right: both mean errors at every output against their tolerances (the
    checks take their largest values); Ez's time is half a step before the output's, within the markers."""
    from warpfree.io.validation_plots import new_figure, save_figure
    from warpfree.solvers.spem.plots import draw_error, draw_profile, draw_series

    fig = new_figure(12.0, 5.6)
    grid = fig.add_gridspec(2, 2, height_ratios=(3, 2), width_ratios=(1.15, 1.0))
    top, bottom, right = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[:, 1])
    top.sharex(bottom)
    top.tick_params(labelbottom=False)
    line = checks["max_line_error"]
    draw_profile(top, r, ez, exact, "SPEM Ez (E particles on x = 0.1 m, y ≥ 0.1 m)", "Bessel series (4.5)",
                 "Ez (V/m)", f"Circular cavity (εr = 10): SPEM against the Bessel series, t = {t * 1e9:.2f} ns")
    mean_line = float(np.mean(np.abs(ez - exact)))
    draw_error(bottom, r, ez - exact, line["tolerance"], f"tolerance on the line's mean |error|: "
               f"{line['tolerance']:.0%} of the peak", "r (m)", "Ez − exact (V/m)", pointwise=False, measure=mean_line,
               measure_label=f"mean |error| on the line = {mean_line:.2g} V/m")
    t_ns = np.asarray(series["time"]) * 1e9
    keep = t_ns > 0  # the errors are 0 at the start
    mean = checks["max_mean_error"]
    draw_series(right, t_ns[keep], {"mean |error|, all E particles": np.asarray(series["mean_error"])[keep],
                                    "mean |error|, radial line": np.asarray(series["line_error"])[keep]},
                {f"tolerance, all particles: {mean['tolerance']:.0%} of the peak": mean["tolerance"],
                 f"tolerance, radial line: {line['tolerance']:.0%} of the peak": line["tolerance"]},
                "t (ns)", "mean |Ez − exact| (V/m, initial peak 1 V/m)",
                "Mean error against the series at every output", logy=True)
    save_figure(fig, path)
