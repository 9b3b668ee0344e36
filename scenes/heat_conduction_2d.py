"""Heat conduction in a doubly periodic square (the example solver, ``warpfree/solvers/heat.py``).

T(x, 0) = T0 + A sin(2π m x/L) relaxes as T0 + A exp(-α k² t) sin(k x), k = 2π m/L: the run writes the
amplitude against time beside the exact decay (``decay.png``) and the relative error of the decay
rate into ``summary.json``. The particles sit on a lattice (spacing L/n), h = 1.3 dx, Wendland C2.
"""

import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as, require_integer
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.geometry import lattice_box
from warpfree.run import OutputOptions
from warpfree.solvers.heat import HeatModel, HeatSolver
from warpfree.space import Space
from warpfree.time_loop import TimeLoop


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"n": 16, "t_end": 2.0, "output_interval": 0.25}
#: what the benchmarks run of this scene for its family (bench/common.py ``benchmarks``): bench/core/gpu_check.py's
#: throughput at three sizes (``parameter`` set to each of ``values``, ``steps`` timed per block) and
#: bench/core/scaling.py's n and 2n work items on one and two ranks (the settings of each, per sweep size: n² particles,
#: about 100 steps of the larger, the stable step falling as dx²)
BENCHMARK = {"parameter": "n", "values": [40, 160, 640], "steps": 100,
             "scaling": {"large": [{"n": 160, "t_end": 0.07, "output_interval": 0.07},
                                   {"n": 226, "t_end": 0.07, "output_interval": 0.07}],
                         "small": [{"n": 80, "t_end": 0.28, "output_interval": 0.28},
                                   {"n": 113, "t_end": 0.28, "output_interval": 0.28}]}}

#: ``warpfree validate --quick``: 20 particles per wavelength (the tolerance's basis: ``rate_tolerance``)
QUICK = {"n": 20}


@checked_parameters
def build(n: Annotated[int, Param("", "particles per side of the periodic box (two supports of 2.6 dx need 6)",
                                  "[6, inf)")] = 40,
          length: Annotated[float, Param("m", "side L of the periodic box", "(0, inf)")] = 1.0,
          alpha: Annotated[float, Param("m²/s", "thermal diffusivity α", "(0, inf)")] = 0.01,
          mode: Annotated[int, Param("", "sine mode m of the initial temperature, below n/2", "[1, inf)")] = 1,
          amplitude: Annotated[float, Param("K", "amplitude A of the initial sine (not 0)", "(-inf, inf)")] = 1.0,
          t_end: Annotated[float, Param("s", "simulated time at which the run ends", "(0, inf)")] = 2.5,
          output_interval: Annotated[float, Param("s", "simulated time between outputs", "(0, inf)")] = 0.05,
          frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """``n`` particles per side of the L × L box (m), diffusivity α (m²/s), sine mode ``mode``, T0 = 300 K."""
    params = dict(locals())
    require_integer("mode", mode, minimum=1, maximum=(n - 1) // 2)  # below n/2
    if amplitude == 0.0:
        raise ParameterError("amplitude", "must not be 0 (the decay of a zero mode is not measurable)")
    dx = length / n
    space = Space(2, (0.0, 0.0, 0.0), (length, length, 0.0), (True, True, False))
    with reported_as(dx="n"):
        model = HeatModel(lattice_box((0.0, 0.0), (length, length), dx), dx, alpha, space)
    k = 2.0 * np.pi * mode / length
    x = model.particles.numpy("position")[:, 0]
    solver = HeatSolver(model, 300.0 + amplitude * np.sin(k * x))
    basis = np.sin(k * x) / np.sum(np.sin(k * x) ** 2)

    def sine_amplitude(s, t):
        """Projection of T - T0 on sin(kx): the mode's amplitude (K)."""
        return float(np.dot(s.temperature().astype(np.float64) - 300.0, basis))

    def decay_analysis(run, out_dir):
        t = np.asarray(run.series["time"])
        a = np.asarray(run.series["amplitude"])
        exact = amplitude * np.exp(-alpha * k * k * t)
        rate = -np.polyfit(t, np.log(a), 1)[0]
        heat = np.asarray(run.diag_series["heat_content"], dtype=np.float64)
        res = {"rate": rate, "exact_rate": alpha * k * k, "rate_rel_error": rate / (alpha * k * k) - 1.0,
               "max_amplitude_error": float(np.max(np.abs(a - exact)) / amplitude),
               "heat_content_drift": float(np.max(np.abs(heat / heat[0] - 1.0)))}
        rate_tol = rate_tolerance(n / mode)
        amp_tol = rate_tol * float(np.max(alpha * k * k * t * np.exp(-alpha * k * k * t)))
        res["checks"] = decay_checks(res, rate_tol, amp_tol, n / mode)
        if out_dir is not None:
            _plot(os.path.join(out_dir, "decay.png"), t, a, exact, amplitude, amp_tol)
        return {"decay": res}

    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="heat_conduction_2d", params=params,
                    probes={"amplitude": sine_amplitude}, analyses=[decay_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((0, length), (0, length)),
                                         frame_range={"temperature": (300.0 - abs(amplitude), 300.0 + abs(amplitude))}))


SOURCE = "the exact decay T0 + A exp(-α k² t) sin(kx) of the heat equation; warpfree/validation/heat_conduction_2d/README.md"


def rate_tolerance(per_wavelength: float) -> float:
    """The check's bound on the decay rate's relative error: 0.2 % at 40 particles per wavelength, second order in the
    spacing, 2e-3 (40 / per_wavelength)²."""
    return 2.0e-3 * (40.0 / per_wavelength) ** 2


def decay_checks(res: dict, rate_tol: float, amp_tol: float, per_wavelength: float) -> dict:
    """The decay rate's relative error, the largest amplitude error (of A) and the heat content's drift."""
    from warpfree.validation import tolerance_check

    return {
        "rate_rel_error": tolerance_check(
            res["rate_rel_error"], rate_tol, SOURCE,
            basis=f"0.2 % at 40 particles per wavelength (4x the measured +0.05 %), second order in the spacing (the "
                  f"amplitude error falls 4.0x per halving): {rate_tol:.3g} at {per_wavelength:g} per wavelength"),
        "amplitude_error_max": tolerance_check(
            res["max_amplitude_error"], amp_tol, SOURCE, unit="A",
            basis="the amplitude error a decay rate off by the rate check's tolerance ε makes over the run: "
                  "max_t ε α k² t exp(-α k² t) (<= ε/e)"),
        "heat_content_drift": tolerance_check(
            res["heat_content_drift"], 1.0e-6, "conservation of heat, Σ V T (exact: the pair exchange is antisymmetric)",
            basis="float32 round-off of T ≈ 300 K summed over the particles and steps (measured < 1e-6)"),
    }


def _plot(path, t, a, exact, amplitude, amp_tol):
    from warpfree.io.validation_plots import plot_series_check

    plot_series_check(path, t, a, exact, (a - exact) / amplitude, amp_tol, computed_label="warpfree SPH",
                      reference_label="exact A exp(-α k² t)", xlabel="t (s)", ylabel="sine-mode amplitude (K)",
                      error_label="(computed − exact) / A", title="Heat conduction: decay of a sine mode against the "
                      "exact decay", tolerance_label=f"tolerance ±{amp_tol:.3g} A")
