"""A dielectric slab's reflection and transmission over a band, from one broadband pulse, against the Airy formulas.

A Gaussian pulse (centre frequency f0, most of its energy within ``band`` f0 of it) enters a vacuum line by
total-field/scattered-field from the left and meets a slab of relative permittivity ``eps_r`` and thickness
``thickness`` (in vacuum wavelengths at f0), its faces between particles (the slab is an object: each particle
takes the mean permittivity of its cell, ``warpfree/solvers/spem/materials.py``). Running DFTs
(``warpfree/solvers/spem/monitors.py``) at ``frequencies`` frequencies across the band read the reflected wave in the
scattered-field region before the slab and the transmitted wave behind it; the incident spectrum is the pulse's own
(its Fourier transform in closed form), so R(f) = |E_r/E_inc|² and T(f) = |E_t/E_inc|² need no second run.

Writes ``monitors/reflected.csv`` and ``monitors/transmitted.csv`` (the transforms), ``slab.png`` (R and T against the
Airy formulas, with the differences) and into ``summary.json`` the largest |R - R_exact| and |T - T_exact| over the
band and the largest difference of the absorbed fraction 1 - R - T from Airy's (0 for a lossless slab), checked
(:func:`slab_checks`). ``plasma_frequency`` > 0 makes the slab a Drude plasma, ε(ω) = εr - ωp²/(ω² - iγω).

Model: the interior difference of ``order`` 4 (Fang's (2,4), ``warpfree/solvers/spem/fourth_order.py``) or 2 (Yee's).

Reference (``warpfree/validation/em_slab_1d``): a slab of complex index n = √ε(ω), thickness d, normal incidence from
vacuum, r12 = (1 - n)/(1 + n), P = e^{-i n k0 d}: r = r12 (1 - P²)/(1 - r12² P²), t = (1 - r12²) P/(1 - r12² P²),
R = |r|², T = |t|² (Born & Wolf, Principles of Optics, §7.6.1; for a real n, R = 4 r12² sin²δ / ((1 - r12²)² +
4 r12² sin²δ), T = 1 - R).
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.shapes import Interval
from warpfree.solvers.spem import (C0, PML, DFTMonitor, EMObject, GaussianPulse, Material, PlaneWave, SPEMModel,
                                   SPEMSolver, staggered_line)
from warpfree.solvers.spem.parameters import Courant, DifferenceOrder, Frequency
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.em_slab_1d import gaussian_pulse_spectrum, slab_coefficients

#: the smallest run of this scene worth making (literal values only)
SMALLEST = {"particles_per_wavelength": 10, "frequencies": 11}
#: ``warpfree validate --quick``: the default run (literal values only)
QUICK = {}

SOURCE = ("Airy's formulas for a slab at normal incidence (Born & Wolf, Principles of Optics, §7.6.1; "
          "warpfree/validation/em_slab_1d/README.md)")

#: the accuracy required of R and T over the band: 0.005 of the incident power (half a percent)
POWER_TOLERANCE = 5e-3


def slab_checks(result: dict) -> dict:
    """R and T within :data:`POWER_TOLERANCE` of Airy's over the band."""
    basis = "half a percent of the incident power at every frequency of the band"
    return {"reflectance": tolerance_check(result["reflectance_error"], POWER_TOLERANCE, SOURCE, basis=basis),
            "transmittance": tolerance_check(result["transmittance_error"], POWER_TOLERANCE, SOURCE, basis=basis)}


#: the pulse's spectrum at the band's edges, a fraction of its peak: R and T there are the monitors' transforms over
#: it squared, so the float32 fields' rounding in the DFT sums (~1e-7 of the peak) weighs (1e-7/EDGE_AMPLITUDE)²-ish
#: relatively; at 1e-3 the Drude slab's largest error at 80 particles per wavelength moved between 9e-5 and 2.8e-4
#: with 0.1 % changes of the step (at the band's top edge), while inside the band it was 8.6e-5 for all
EDGE_AMPLITUDE = 1e-2


@checked_parameters
def build(eps_r: Annotated[float, Param("", "relative permittivity of the slab", "(0, inf)")] = 4.0,
          thickness: Annotated[float, Param("λ0", "thickness of the slab, in vacuum wavelengths at f0",
                                            "(0, inf)")] = 0.5,
          frequency: Frequency = 1.0e9,
          band: Annotated[float, Param("", "half-width of the band, a fraction of f0: f0 (1 ± band)", "(0, 1)")] = 0.5,
          plasma_frequency: Annotated[float, Param("Hz", "the slab's Drude plasma frequency ωp/2π (0: a plain "
                                                         "dielectric)", "[0, inf)")] = 0.0,
          collision_rate: Annotated[float, Param("1/s", "the slab's Drude collision rate γ", "[0, inf)")] = 0.0,
          particles_per_wavelength: Annotated[float, Param("", "resolution: the shortest wavelength of the band in "
                                                               "the slab, in particle spacings", "[4, inf)")] = 40.0,
          order: DifferenceOrder = 4,
          frequencies: Annotated[int, Param("", "frequencies across the band the DFT monitors record",
                                            "[2, inf)")] = 101,
          pml_cells: Annotated[int, Param("Δ", "thickness of each PML, in particle spacings", "[2, inf)")] = 20,
          courant: Courant = 0.95, frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """``eps_r``, ``thickness``: the slab; ``frequency``, ``band``: the band f0 (1 ± band) the pulse covers and the
    monitors record; ``particles_per_wavelength``: the resolution at the band's top in the slab."""
    params = dict(locals())
    if frequencies > 100_000:
        raise ParameterError("frequencies", f"at most 100 000 frequencies a monitor, got {frequencies}")
    wavelength = C0 / frequency
    index = math.sqrt(max(eps_r, 1.0))
    top = frequency * (1.0 + band)
    spacing = C0 / (top * index * particles_per_wavelength)
    width = thickness * wavelength
    # the line: PML, a quarter wavelength of scattered field, the total-field box (a wavelength before the slab, the
    # slab, a wavelength after it), a quarter wavelength, PML
    pml = pml_cells * spacing
    box = (-wavelength, width + wavelength)
    lower, upper = box[0] - 0.5 * wavelength, box[1] + 0.5 * wavelength
    with reported_as(spacing="particles_per_wavelength, frequency, band, eps_r, thickness, pml_cells"):
        layout = staggered_line(lower - pml, upper + pml, spacing)
    medium = Material(eps_r=eps_r, plasma_frequency=2.0 * math.pi * plasma_frequency, collision_rate=collision_rate)
    slab = EMObject(Interval(0.0, width), medium, name="slab")
    model = SPEMModel(layout, pml=PML(pml, sides=("x-", "x+")), interior=((lower,), (upper,)), objects=[slab],
                      order=order)
    # the pulse: its spectrum e^{-(πτ(f - f0))²} falls to EDGE_AMPLITUDE at the band's edges
    tau = math.sqrt(-math.log(EDGE_AMPLITUDE)) / (math.pi * band * frequency)
    pulse = GaussianPulse(frequency, tau, 4.0 * tau)
    wave = PlaneWave(pulse, lower=(box[0],), upper=(box[1],), direction=(1.0,))
    f = np.linspace(frequency * (1.0 - band), top, frequencies)
    reflected = DFTMonitor("reflected", [[0.5 * (lower + box[0])]], tuple(f), ("ez",))
    transmitted = DFTMonitor("transmitted", [[0.5 * (width + box[1])]], tuple(f), ("ez",))
    solver = SPEMSolver(model, [wave], courant=courant, monitors=[reflected, transmitted])
    # the run: the pulse (8 τ) crosses the line, then the slab's echoes (each round trip keeps r12² of the wave) fall
    # below 1e-6 of it
    r12 = (1.0 - index) / (1.0 + index)
    if plasma_frequency > 0:  # a plasma slab rings longer: its largest reflection over the band, and γ's damping
        n_band = np.sqrt(medium.permittivity(np.linspace(frequency * (1.0 - band), top, 64)).astype(complex))
        r12 = float(np.max(np.abs((1.0 - n_band) / (1.0 + n_band))))
    echoes = min(200, math.ceil(math.log(1e-6) / math.log(max(min(r12 * r12, 0.99), 1e-12))))
    t_end = 8.0 * tau + (upper - lower) / C0 + echoes * 2.0 * index * width / C0
    spectrum = gaussian_pulse_spectrum(f, frequency, tau)

    def slab_analysis(run, out_dir):
        s = run.solver
        incident = np.abs(spectrum) ** 2
        r_power = np.abs(s.dft("reflected")["ez"][0]) ** 2 / incident
        t_power = np.abs(s.dft("transmitted")["ez"][0]) ** 2 / incident
        exact_r, exact_t = slab_coefficients(f, medium.permittivity(f), width)
        result = {"reflectance_error": float(np.max(np.abs(r_power - exact_r))),
                  "transmittance_error": float(np.max(np.abs(t_power - exact_t))),
                  "absorption_error": float(np.max(np.abs((1.0 - r_power - t_power) - (1.0 - exact_r - exact_t)))),
                  "band_hz": [float(f[0]), float(f[-1])], "frequencies": int(f.size), "spacing": layout.spacing,
                  "particles_per_wavelength": particles_per_wavelength, "order": order, "dt": s.run_step}
        result["checks"] = slab_checks(result)
        if out_dir is not None:
            _plot(os.path.join(out_dir, "slab.png"), f, r_power, t_power, exact_r, exact_t, result)
        return {"slab": result}

    output_interval = t_end / 4.0
    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="em_slab_1d", params=params,
                    analyses=[slab_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((lower - pml, upper + pml),),
                                         frame_range={"ez": (-1.5, 1.5)}))


def _plot(path, f, r_power, t_power, exact, exact_t, result):
    """Above: R and T against Airy's over the band. Below: the differences with the tolerance."""
    from warpfree.io.validation_plots import draw_bound, new_figure, save_figure

    fig = new_figure(9.0, 6.0)
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2, sharex=None)
    g = f / 1e9
    top.plot(g, exact, "k-", lw=1.2, label="Airy: R")
    top.plot(g, exact_t, "k--", lw=1.2, label="Airy: T")
    top.plot(g, r_power, "o", ms=3, mfc="none", color="C0", label="SPEM: R")
    top.plot(g, t_power, "s", ms=3, mfc="none", color="C1", label="SPEM: T")
    top.set_ylabel("fraction of the incident power")
    top.set_title("Slab from one pulse: reflectance and transmittance against Airy's formulas", fontsize=10)
    top.legend(fontsize=8, ncol=2)
    bottom.plot(g, r_power - exact, ".", color="C0", label="R − R_Airy")
    bottom.plot(g, t_power - exact_t, ".", color="C1", label="T − T_Airy")
    draw_bound(bottom, result["checks"]["reflectance"]["tolerance"], "tolerance")
    draw_bound(bottom, -result["checks"]["reflectance"]["tolerance"], None)
    bottom.set_xlabel("frequency (GHz)")
    bottom.set_ylabel("difference")
    bottom.legend(fontsize=8)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    save_figure(fig, path)
