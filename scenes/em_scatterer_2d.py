"""A TMz plane wave scattered by a circular cylinder: SPEM against the exact Bessel series (the 2D Mie solution).

A plane wave of frequency f travels along +x through vacuum (total-field/scattered-field box, PML around) and meets a
cylinder of radius a (k0 a = ``k0a``) at the origin: a dielectric of relative permittivity ``eps_r`` or a perfect
conductor (``cylinder``). The cylinder is an object of the scene (``warpfree/solvers/spem/materials.py``): a dielectric
particle takes the mean permittivity of its cell (``interface="average"``, second order) or the one at its centre
(``"centre"``, the staircase); a conductor is cut out with a held row on its surface (``"average"``) or its lattice
particles inside held (``"centre"``). After
``periods`` periods (the wave's transient in the cylinder has decayed: the field moves by less than 1e-3 of its
amplitude from 30 to 70 periods at 20 particles per wavelength), a running DFT over the last ``window`` whole periods
gives the complex amplitude of Ez (``warpfree/solvers/spem/monitors.py``) on a ring of radius 1.5 a and on the two lines
through the centre (along and across the wave, inside the total-field box), compared with the series
(``warpfree/validation/em_scatterer_2d``) at the same points.

A flux monitor on a square in the scattered-field region gives the scattered power, over the incident intensity the
scattering width (``scattering_width``, against (4/k0) Σ|a_n|²).

Writes ``monitors/near_field.csv`` (the DFT at every point: real, imaginary, amplitude, phase),
``monitors/scattered_power.csv``, ``scatterer.png``
(amplitude and phase on the ring and along the line of the wave against the series) and into ``summary.json``, relative
to the series' largest |Ez| on each set of points, ``ring_error`` and ``line_error`` (‖Ez - Ez_exact‖₂ / ‖Ez_exact‖₂,
amplitude and phase together), ``ring_amplitude_error`` (largest |(|Ez| - |Ez_exact|)| / max |Ez_exact|) and
``ring_phase_error`` (largest phase difference, rad, where |Ez_exact| is at least half its mean on the ring: near a
null the phase means little), checked (:func:`scatterer_checks`).

Model: E on a uniform lattice, H in Yee's staggering, PML 12 spacings; the interior difference of ``order`` 4 (Fang's
(2,4), ``warpfree/solvers/spem/fourth_order.py``: the bulk's phase error 3(kΔ)⁴/640, the interface's second order
left) or 2 (the conservative FPM pair, Yee's difference); a conductor runs at order 2 with the order-2 pair.
Resolution: Δ = λ0 / (``particles_per_wavelength`` √εr), the wavelength counted in the densest medium. Errors by
resolution, averaged and staircased: ``warpfree/validation/em_scatterer_2d/README.md``.
"""

import dataclasses
import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as, require_memory
from warpfree.parameters import Choice, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.shapes import Disc
from warpfree.solvers.spem import C0, EPS0, MU0, PML, PlaneWave, SPEMModel, SPEMSolver, Waveform, staggered_box
from warpfree.solvers.spem.materials import PEC, EMObject, Material
from warpfree.solvers.spem.monitors import DFTMonitor, FluxMonitor, window_amplitude
from warpfree.solvers.spem.parameters import Courant, DifferenceOrder, Frequency, Ramp
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.em_scatterer_2d import scattering_width, total_field

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"particles_per_wavelength": 8, "periods": 6, "window": 2}
#: ``warpfree validate --quick``: the default run (literal values only)
QUICK = {}

#: where the reference and the tolerances come from
SOURCE = ("exact Bessel series of a circular cylinder, dielectric or perfectly conducting, in a TMz plane wave "
          "(Balanis 2012, §11.5; warpfree/validation/em_scatterer_2d/README.md)")

#: the accuracy required of the near field (amplitude and phase together, relative L2): 1 %, the figure a user of a
#: photonics code reads as converged (Meep's subpixel-averaged runs reach it near 40 pixels per wavelength in the
#: densest medium, Farjadpour et al. 2006, Fig. 2)
NEAR_FIELD_TOLERANCE = 1e-2


class Interface(Choice):
    """How the particles meet the cylinder's surface."""

    AVERAGE = "average", ("a dielectric: each particle takes the mean permittivity over its cell (subpixel averaging); "
                          "a conductor: cut out, a row of held particles on its surface (both second order)")
    CENTRE = "centre", ("a dielectric: each particle takes the permittivity at its centre; a conductor: the lattice's E "
                        "particles inside held at 0 (both staircases: erratic with resolution)")


class Cylinder(Choice):
    """What the cylinder is made of."""

    DIELECTRIC = "dielectric", "a dielectric of relative permittivity eps_r"
    CONDUCTOR = "conductor", "a perfect electric conductor"


def scatterer_checks(result: dict) -> dict:
    """The near field on the ring and on the lines, and the scattering width, within :data:`NEAR_FIELD_TOLERANCE` of
    the series."""
    basis = ("1 %: a converged near field (amplitude and phase together, relative L2) for a user's scatterer; the "
             "averaged interface converges at second order (warpfree/validation/em_scatterer_2d/README.md)")
    return {"ring_error": tolerance_check(result["ring_error"], NEAR_FIELD_TOLERANCE, SOURCE, basis=basis),
            "line_error": tolerance_check(result["line_error"], NEAR_FIELD_TOLERANCE, SOURCE, basis=basis),
            "scattering_width": tolerance_check(result["scattering_width"], NEAR_FIELD_TOLERANCE * result[
                "scattering_width_scale"], SOURCE, reference=result["scattering_width_exact"], unit="m",
                basis="1 % of the series' width (4/k0) Σ|a_n|² (of 2a where nothing scatters), the scattered power "
                      "through a square in the scattered-field region over the incident intensity")}


@checked_parameters
def build(cylinder: Annotated[Cylinder, Param("", "what the cylinder is made of")] = Cylinder.DIELECTRIC,
          eps_r: Annotated[float, Param("", "relative permittivity of the cylinder", "(0, inf)")] = 4.0,
          k0a: Annotated[float, Param("", "size parameter k0 a of the cylinder (vacuum wavenumber times radius)",
                                      "(0, inf)")] = 2.5,
          frequency: Frequency = 1.0e9,
          particles_per_wavelength: Annotated[float, Param("", "resolution: the wavelength in the densest medium "
                                                               "(a dielectric cylinder's, else vacuum) in particle "
                                                               "spacings",
                                                           "[4, inf)")] = 20.0,
          order: DifferenceOrder = 4,
          interface: Annotated[Interface, Param("", "how the particles meet the cylinder's surface")] = Interface.AVERAGE,
          pml_cells: Annotated[int, Param("Δ", "thickness of the PML, in particle spacings", "[2, inf)")] = 12,
          periods: Annotated[int, Param("periods", "length of the run, in periods of the wave", "[2, inf)")] = 30,
          window: Annotated[int, Param("periods", "whole periods at the run's end over which the DFT is taken",
                                       "[1, inf)")] = 4,
          ramp: Ramp = 2.0, courant: Courant = 0.95,
          ring_points: Annotated[int, Param("", "points on the ring of radius 1.5 a", "[8, inf)")] = 180,
          frames: Frames = True, vtk: Vtk = True) -> TimeLoop:
    """``eps_r``, ``k0a``: the cylinder; ``particles_per_wavelength``: λ/Δ in the densest medium; ``order``: the interior
    difference's (a conductor runs at 2: its surface row is off the lattice); ``interface``: average or
    centre; ``periods``, ``window``: the run's length and the DFT's window (periods)."""
    params = dict(locals())
    if window >= periods:
        raise ParameterError("window", f"must be shorter than the run ({periods} periods), got {window}")
    wavelength = C0 / frequency
    k0 = 2.0 * math.pi / wavelength
    radius = k0a / k0
    conductor = cylinder is Cylinder.CONDUCTOR
    index = 1.0 if conductor else math.sqrt(max(eps_r, 1.0))
    spacing = wavelength / (index * particles_per_wavelength)
    ring = 1.5 * radius
    # the total-field box holds the ring with a quarter wavelength to spare; a quarter more of scattered field to the PML
    half_box = ring + 0.25 * wavelength
    half = math.ceil((half_box + 0.25 * wavelength) / spacing) * spacing
    pml = pml_cells * spacing
    require_memory("ring_points", ring_points, 1024.0, "monitor points")  # their interpolation rows, set up on the host
    with reported_as(spacing="particles_per_wavelength, k0a, eps_r, frequency, pml_cells"):
        layout = staggered_box((-half - pml, -half - pml), (half + pml, half + pml), spacing)
    disc = Disc((0.0, 0.0), radius)
    objects, background = [], 1.0
    if interface is Interface.AVERAGE:
        objects = [EMObject(disc, PEC if conductor else Material(eps_r=eps_r), name="cylinder")]
    elif conductor:  # the staircase: the lattice's E particles inside the cylinder held at 0
        layout = dataclasses.replace(layout, on_wall=layout.on_wall | ~(disc.signed_distance(layout.e_position) > 0))
    else:
        background = lambda p: np.where(disc.contains(p), eps_r, 1.0)  # noqa: E731
    # a conductor's surface row breaks the lattice only along the surface: there the order-2 pair (quadratic moments,
    # :mod:`warpfree.solvers.spem.conservative`) sets up as fast as the order-1 one (8 s at 80 particles per wavelength)
    # and lowers the error (0.996 % against 1.13 % at 20, 0.161 % against 0.230 % at 80)
    pair_order = 2 if conductor and interface is Interface.AVERAGE else 1
    # a conductor's surface row (or its held staircase) lies off the lattice's faces: it runs at order 2
    difference_order = 2 if conductor else order
    model = SPEMModel(layout, eps_r=background, objects=objects, pml=PML(pml), interior=((-half, -half), (half, half)),
                      pair_order=pair_order, order=difference_order)
    wave = PlaneWave(Waveform(frequency, ramp=ramp), lower=(-half_box, -half_box), upper=(half_box, half_box),
                     direction=(1.0, 0.0))
    angle = 2.0 * math.pi * np.arange(ring_points) / ring_points
    ring_xy = ring * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    # the lines through the centre along and across the wave: on the lattice's E particles (read without interpolation)
    reach = math.floor((half_box - spacing) / spacing)
    steps = np.arange(-reach, reach + 1) * spacing
    if conductor:  # outside the conductor, on lattice particles it left in place
        steps = steps[np.abs(steps) >= radius + spacing]
    along = np.stack([steps, np.zeros_like(steps)], axis=1)
    across = np.stack([np.zeros_like(steps), steps], axis=1)
    points = np.vstack([ring_xy, along, across])
    period = 1.0 / frequency
    t_end = periods * period
    start = t_end - window * period
    monitor = DFTMonitor("near_field", points, (frequency,), ("ez",), start=start, stop=t_end)
    # the scattered power through a square in the scattered-field region, midway between the total-field box and the PML
    side = 0.5 * (half_box + half)
    contour = FluxMonitor("scattered_power", [[-side, -side], [side, -side], [side, side], [-side, side]],
                          (frequency,), start=start, stop=t_end, closed=True)
    solver = SPEMSolver(model, [wave], courant=courant, monitors=[monitor, contour])
    incident_intensity = 0.5 * wave.amplitude ** 2 * math.sqrt(EPS0 / MU0)  # W/m², ½ E0²/η0
    exact_width = scattering_width(k0, radius, None if conductor else eps_r)
    exact = total_field(points, (0.0, 0.0), radius, k0, None if conductor else eps_r)
    n_ring, n_line = ring_points, steps.size
    sets = {"ring": slice(0, n_ring), "along": slice(n_ring, n_ring + n_line),
            "across": slice(n_ring + n_line, n_ring + 2 * n_line)}

    def near_field(s):
        """Ez's complex amplitude at the monitor's points, in the series' convention (phase 0 at the centre)."""
        transform = s.dft("near_field")["ez"][:, 0]
        amplitude, phase = window_amplitude(transform, s.dft_window("near_field", "ez"))
        # the wave is A sin(2πf t - k0 (x - s0)): a phasor e^{-i k0 x} of phase -π/2 + k0 s0 in the DFT's convention
        value = amplitude * np.exp(1j * phase)
        return value * np.exp(-1j * k0 * wave.front_start(2))

    def scatterer_analysis(run, out_dir):
        s = run.solver
        field = near_field(s)
        error = {k: float(np.linalg.norm(field[v] - exact[v]) / np.linalg.norm(exact[v])) for k, v in sets.items()}
        line = np.r_[field[sets["along"]], field[sets["across"]]]
        line_exact = np.r_[exact[sets["along"]], exact[sets["across"]]]
        r = sets["ring"]
        strong = np.abs(exact[r]) >= 0.5 * np.mean(np.abs(exact[r]))  # the phase where the field is not near a null
        result = {"ring_error": error["ring"],
                  "line_error": float(np.linalg.norm(line - line_exact) / np.linalg.norm(line_exact)),
                  "ring_amplitude_error": float(np.max(np.abs(np.abs(field[r]) - np.abs(exact[r])))
                                                / np.max(np.abs(exact[r]))),
                  "ring_phase_error": float(np.max(np.abs(np.angle(field[r] / exact[r]))[strong])),
                  "spacing": layout.spacing, "particles_per_wavelength": particles_per_wavelength,
                  "vacuum_particles_per_wavelength": wavelength / layout.spacing, "radius": radius,
                  "window": s.dft_window("near_field", "ez"), "dt": s.run_step, "interface": str(interface), "cylinder": str(cylinder),
                  "order": difference_order,
                  "particles_on_interface": model.materials.e_on_interface if model.materials else None}
        result["scattering_width"] = float(s.flux("scattered_power")["power"][0] / incident_intensity)
        result["scattering_width_exact"] = exact_width
        # relative to the series' width, or to the geometric width 2a where nothing scatters (εr = 1)
        result["scattering_width_scale"] = exact_width if exact_width > 0 else 2.0 * radius
        result["scattering_width_error"] = (result["scattering_width"] - exact_width) / result["scattering_width_scale"]
        result["checks"] = scatterer_checks(result)
        if out_dir is not None:
            _plot(os.path.join(out_dir, "scatterer.png"), angle, field[r], exact[r], steps,
                  field[sets["along"]], exact[sets["along"]], radius, result)
        return {"scatterer": result}

    # a frame every window: the DFT's window is whole periods whatever the step (the steps at its ends are cut), so
    # the transform of a steady sine holds no leakage from a partial period
    return TimeLoop(solver, t_end=t_end, output_interval=window * period,
                    name="em_scatterer_2d", params=params, analyses=[scatterer_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((-half - pml, half + pml),
                                                                                (-half - pml, half + pml)),
                                         frame_range={"ez": (-2.0, 2.0)}))


def _plot(path, angle, ring, ring_exact, x, line, line_exact, radius, result):
    """Left: |Ez| and its phase on the ring against the series. Right: |Ez| along the line of the wave through the
    cylinder (its surface marked) against the series."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(13.0, 5.2)
    grid = fig.add_gridspec(2, 2, height_ratios=(3, 2))
    amp, ph, line_ax, diff = (fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[0, 1]),
                              fig.add_subplot(grid[1, 1]))
    deg = np.degrees(angle)
    amp.plot(deg, np.abs(ring_exact), "k-", lw=1.2, label="Bessel series")
    amp.plot(deg, np.abs(ring), "o", ms=2.5, mfc="none", color="C0", label="SPEM (DFT)")
    amp.set_ylabel("|Ez| / E0")
    amp.set_title(f"Ring r = 1.5 a: relative L2 error {result['ring_error']:.2%} "
                  f"(tolerance {result['checks']['ring_error']['tolerance']:.0%})", fontsize=10)
    amp.legend(fontsize=8)
    ph.plot(deg, np.degrees(np.angle(ring / ring_exact)), ".", ms=3, color="C0")
    ph.set_xlabel("angle from the direction of travel (°)")
    ph.set_ylabel("phase − series (°)")
    for ax in (amp, ph, line_ax, diff):
        ax.grid(True, alpha=0.3)
    for k, side in enumerate((x < 0, x >= 0)):  # apart: a conductor leaves a gap between the sides
        line_ax.plot(x[side] / radius, np.abs(line_exact[side]), "k-", lw=1.2, label="Bessel series" if k else None)
    line_ax.plot(x / radius, np.abs(line), "o", ms=2.5, mfc="none", color="C0", label="SPEM (DFT)")
    for side in (-1, 1):
        line_ax.axvline(side, color="0.5", lw=0.8, ls="--")
        diff.axvline(side, color="0.5", lw=0.8, ls="--")
    line_ax.set_ylabel("|Ez| / E0")
    line_ax.set_title(f"Line of the wave through the cylinder: lines' error {result['line_error']:.2%}", fontsize=10)
    line_ax.legend(fontsize=8)
    diff.plot(x / radius, np.abs(line - line_exact), ".", ms=3, color="C0")
    diff.set_xlabel("x / a")
    diff.set_ylabel("|Ez − series| / E0")
    save_figure(fig, path)
