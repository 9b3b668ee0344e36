"""Heat conduction in a doubly periodic square (the example solver, ``warpfree/solvers/heat.py``).

T(x, 0) = T0 + A sin(2π m x/L) relaxes as T0 + A exp(-α k² t) sin(k x), k = 2π m/L: the run writes the
amplitude against time beside the exact decay (``decay.png``) and the relative error of the decay
rate into ``summary.json``. The particles sit on a lattice (spacing L/n), h = 1.3 dx, Wendland C2.
"""

import os

import numpy as np

from warpfree.errors import ParameterError, reported_as, require_finite, require_integer, require_positive
from warpfree.geometry import lattice_box
from warpfree.run import OutputOptions
from warpfree.solvers.heat import HeatModel, HeatSolver
from warpfree.space import Space
from warpfree.time_loop import TimeLoop


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"n": 16, "t_end": 2.0, "output_interval": 0.25}


def build(n: int = 40, length: float = 1.0, alpha: float = 0.01, mode: int = 1, amplitude: float = 1.0,
          t_end: float = 2.5, output_interval: float = 0.05, frames: bool = True, vtk: bool = True) -> TimeLoop:
    """``n`` particles per side of the L × L box (m), diffusivity α (m²/s), sine mode ``mode``, T0 = 300 K."""
    params = dict(locals())
    if require_integer("n", n) < 6:
        raise ParameterError("n", f"must be an integer >= 6 (the box must hold two supports of 2.6 dx), got {n!r}")
    require_integer("mode", mode, minimum=1, maximum=(n - 1) // 2)  # below n/2
    require_positive("length", length)
    if require_finite("amplitude", amplitude) == 0.0:
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
        return float(np.dot(s.model.particles.numpy("temperature").astype(np.float64) - 300.0, basis))

    def decay_analysis(run, out_dir):
        t = np.asarray(run.series["time"])
        a = np.asarray(run.series["amplitude"])
        exact = amplitude * np.exp(-alpha * k * k * t)
        rate = -np.polyfit(t, np.log(a), 1)[0]
        _plot(os.path.join(out_dir, "decay.png"), t, a, exact)
        return {"decay": {"rate": rate, "exact_rate": alpha * k * k,
                          "rate_rel_error": rate / (alpha * k * k) - 1.0,
                          "max_amplitude_error": float(np.max(np.abs(a - exact)) / amplitude)}}

    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="heat_conduction_2d", params=params,
                    probes={"amplitude": sine_amplitude}, analyses=[decay_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((0, length), (0, length))))


def _plot(path, t, a, exact):
    from warpfree.io.frames import plot_series

    plot_series(path, t, {"warpfree SPH": a}, xlabel="t (s)", ylabel="amplitude (K)",
                title="Heat conduction: decay of a sine mode", reference={"exp(-α k² t)": (t, exact)})
