"""Plasma sheath at a floating wall: the wall's potential and the potential profile against the collisionless
kinetic model.

A strip [0, L] x [0, W] of a region: on its left side x = 0 a plasma source held at potential 0 emits electrons as a
half-Maxwellian flux (temperature T_e) and ions as a cold beam at ``ion_mach`` times the Bohm speed c_s =
sqrt(T_e / m_i); on its right side x = L a wall floats (its charge is what it has absorbed, its potential follows);
the strip's top and bottom reflect the particles (symmetry: a slab of a one-dimensional plasma). Both electrodes
absorb what reaches them. The strip starts full of plasma at density n0 (electrons Maxwellian, ions drifting at the
source speed).

Steady, the wall charges until it draws as many electrons as ions: the electrons that reach it are the source's with
energy enough to climb its potential, so Γ_i = Γ_e0 exp(e φ_w / T_e), φ_w = (T_e / e) ln(Γ_i / Γ_e0)
(Γ_e0 = n_e,src v_te / sqrt(2π), the source's electron flux), -½ ln(m_i / (2π m_e)) T_e/e for ions at the Bohm speed
and equal source densities, the classic floating-wall potential (Stangeby, *The Plasma Boundary of Magnetic Fusion
Devices*, 2000, eq. 2.60). Between, the potential solves Poisson's equation with the densities of the collisionless
kinetic model (``warpfree.validation.pic_sheath``): the source's half-Maxwellian and the part of it the wall turns
back, and the cold ion beam accelerated by the potential; the source's electron density is chosen so that the plasma
is neutral at the source, and the ions reach the sheath at ``ion_mach`` c_s (Bohm's criterion).

Normalised units: n0 = 1, T_e = 1, e = m_e = ε0 = 1: lengths in λ_D, times in 1/ω_pe, potentials in T_e/e.
Measured over the second half of the run: the floating wall's mean potential (and its fluctuation: σ and the
exponential mean ln⟨exp φ_w⟩), the mean potential along the strip against the model's, and the fluxes to the wall.
Writes ``history.csv``, ``energy.png`` (with the charge balance), ``profile.png`` (mean potential and the model's
along x, and their difference), particle frames and VTU.
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, SupportScale
from warpfree.galerkin.region import Region
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.pic import PICSolver, Species
from warpfree.solvers.pic.electrodes import Electrode, ElectrodeField
from warpfree.solvers.pic.emission import Emission, SurfaceSource
from warpfree.solvers.pic.parameters import Density, ElectronTemperature, OutputEvery
from warpfree.solvers.pic.scene_tools import POTENTIAL_FRAMES, plot_history, plot_profile, write_history
from warpfree.solvers.pic.species import load_in_region, region_positions
from warpfree.solvers.pic.units import plasma_units
from warpfree.time_loop import TimeLoop
from warpfree.validation import tolerance_check
from warpfree.validation.pic_sheath import SheathModel

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"length": 8.0, "node_spacing": 1.0, "particles_per_cell": 4, "t_end": 2.0, "output_every": 5}

#: ``warpfree validate --quick``: half the default run (t = 300: the ions have crossed the strip 1.5 times)
QUICK = {"t_end": 300.0}

#: the units of the outputs: n0 = T_e = e = m_e = ε0 = 1
UNITS = {"position": "λ_D", "velocity": "v_te", "speed": "v_te", "e_field": "T_e/(e λ_D)", "potential": "T_e/e",
         "charge": "e n0 λ_D²"}
TIME_UNIT = "1/ω_pe"
#: the charge in the strip = loaded + emitted - absorbed, to round-off
BALANCE_TOLERANCE = 1e-11
#: the floating wall's mean potential against the model's, in T_e/e
WALL_TOLERANCE = 0.05
#: the mean potential's largest difference from the model's over the sheath (the last SHEATH_WIDTH before the wall),
#: in T_e/e
PROFILE_TOLERANCE = 0.05
#: the sheath's width checked against the model (λ_D)
SHEATH_WIDTH = 5.0


@checked_parameters
def build(mass_ratio: Annotated[float, Param("", "ion to electron mass ratio m_i/m_e", "(0, inf)")] = 100.0,
          ion_mach: Annotated[float, Param("", "ion speed at the source over the Bohm speed sqrt(T_e/m_i)",
                                           "(0, inf)")] = 1.0,
          length: Annotated[float, Param("λ_D", "distance L from the source to the floating wall", "(0, inf)")] = 20.0,
          width: Annotated[float, Param("λ_D", "width W of the strip (its sides reflect)", "(0, inf)")] = 2.0,
          node_spacing: Annotated[float, Param("λ_D", "spacing of the EFG nodes", "(0, inf)")] = 0.5,
          basis: Basis = MLSBasis.QUADRATIC, d_max: SupportScale = 3.0,
          particles_per_cell: Annotated[int, Param("", "macro-particles of each species per λ_D² at density n0",
                                                   "[1, inf)")] = 100,
          dt: Annotated[float, Param("1/ω_pe", "time step Δt of the leapfrog", "(0, inf)")] = 0.1,
          t_end: Annotated[float, Param("1/ω_pe", "time at which the run ends", "(0, inf)")] = 600.0,
          seed: Annotated[int, Param("", "seed of the random number generator", "[0, inf)")] = 0,
          output_every: OutputEvery = 500, frames: Frames = True, vtk: Vtk = True, density: Density = None,
          electron_temperature: ElectronTemperature = None) -> TimeLoop:
    """A plasma source at x = 0 (potential 0), a floating wall at x = ``length``, ions of ``mass_ratio`` entering at
    ``ion_mach`` times the Bohm speed; ``particles_per_cell`` per λ_D² of each species; the wall's potential and the
    profile averaged over the second half. ``density`` (m⁻³) and ``electron_temperature`` (eV): the results also in
    SI (:mod:`warpfree.solvers.pic.units`)."""
    params = dict(locals())
    units = plasma_units(density, electron_temperature)
    if node_spacing > 0.5 * min(length, width):
        raise ParameterError("node_spacing", f"must be at most half the strip's width and length "
                                             f"({0.5 * min(length, width):g}), got {node_spacing:g}")
    model_of = SheathModel(mass_ratio, ion_mach)
    if not model_of.monotone:
        raise ParameterError("ion_mach", f"the ions must enter at Bohm's speed or above for the sheath model (no "
                                         f"monotone sheath at {ion_mach:g}; Bohm's criterion for these electrons: about 0.98 to 1)")
    with reported_as(spacing="node_spacing", support="node_spacing, d_max"):
        region = Region.rectangle((0.0, 0.0), (length, width), ["side", "wall", "side", "source"])
        nodes = region.nodes(node_spacing)
        model = MLSModel(nodes.position, MLSSettings(basis=basis, d_max=d_max))
        field = ElectrodeField(model, region, nodes, [Electrode("source", 0.0), Electrode("wall", None, charge=0.0)])
    rng = np.random.default_rng(seed)
    count = max(1, int(round(particles_per_cell * length * width)))
    ions = Species("ions", 1.0, mass_ratio, 1.0, drift=(model_of.ion_speed, 0.0))
    electrons = Species("electrons", -1.0, 1.0, 1.0, temperature=1.0)
    with reported_as(count="particles_per_cell, length, width"):
        loads = [load_in_region(electrons, region, region_positions(region, count, rng), rng),
                 load_in_region(ions, region, region_positions(region, count, rng), rng)]
    weight = length * width / count  # real particles (per unit depth) a loaded macro-particle carries
    source_electrons = Species("source_electrons", -1.0, 1.0, model_of.source_electron_density, temperature=1.0)
    source_ions = Species("source_ions", 1.0, mass_ratio, 1.0)
    sources = [SurfaceSource(source_electrons, "source", Emission.BEAM,
                             particles_per_step=model_of.electron_flux * width * dt / weight, seed=seed + 1),
               SurfaceSource(source_ions, "source", Emission.BEAM, speed=model_of.ion_speed,
                             particles_per_step=model_of.ion_flux * width * dt / weight, seed=seed + 2)]
    n_steps = int(math.ceil(t_end / dt))
    solver = PICSolver(field, loads, dt, background_density=0.0, gather="energy", surface_sources=sources,
                       average_from=0.5 * n_steps * dt)
    solver.time_unit = TIME_UNIT

    def sheath_analysis(run, out_dir):
        s = run.solver
        h = s.history
        t = np.asarray(h["time"])
        late = t >= 0.5 * t[-1]
        wall_series = np.asarray(h["potential_wall"])[late]
        wall = float(np.mean(wall_series))
        x = np.linspace(0.0, length, 161)
        points = np.column_stack([x, np.full_like(x, 0.5 * width)])
        mean = model.evaluate(s.mean_potential(), model.shape_at(points))[0][:, 0]
        reference = model_of.potential(x, length)
        wall_current = -np.polyfit(t[late], np.asarray(h["absorbed_charge_wall"])[late], 1)[0] / width
        absorbed = sum(np.asarray(h[k]) for k in h if k.startswith("absorbed_charge_"))
        loaded = length * width  # the electrons' (and the ions') charge at the start, n0 L W
        balance = (np.asarray(h["deposited_charge"]) - np.asarray(h["deposited_charge"])[0]
                   - np.asarray(h["injected_charge"]) + absorbed) / loaded
        result = {"wall_potential": wall, "model_wall_potential": model_of.wall_potential,
                  "wall_potential_error": wall - model_of.wall_potential,
                  # the electrons the wall draws go as exp(φ_w(t)): were its oscillation slow, the flux balance would
                  # fix the exponential mean ln⟨exp φ_w⟩, the plain mean about σ²/2 below it (README)
                  "wall_potential_std": float(np.std(wall_series)),
                  "wall_flux_potential": float(np.log(np.mean(np.exp(wall_series)))),
                  "bohm_wall_potential": -0.5 * math.log(mass_ratio / (2 * math.pi)),
                  "profile_max_error": float(np.max(np.abs(mean - reference))),
                  "sheath_profile_max_error": float(np.max(np.abs(mean - reference)[x >= length - SHEATH_WIDTH])),
                  "potential_max": float(np.max(mean)), "potential_max_at": float(x[np.argmax(mean)]),
                  "wall_net_current": float(wall_current), "ion_flux": model_of.ion_flux,
                  "charge_balance_error": float(np.max(np.abs(balance))),
                  "particles": s.n, "nodes": model.node_count}
        result["checks"] = sheath_checks(result)
        if units is not None:
            result["si"] = units.describe({
                "wall_potential": (wall, "potential"), "model_wall_potential": (model_of.wall_potential, "potential"),
                "ion_current_density": (model_of.ion_flux, "current_density"),
                "wall_net_current_density": (wall_current, "current_density"), "length": (length, "length"),
                "sheath_checked_over": (SHEATH_WIDTH, "length")})
        if out_dir is not None:
            write_history(os.path.join(out_dir, "history.csv"), h)
            plot_history(out_dir, h, s, BALANCE_TOLERANCE, f"± {BALANCE_TOLERANCE:g} (round-off)", units=UNITS,
                         below={"values": balance, "label": "(Q_region - Q_start - Q_emitted + Q_absorbed) / (e n0 L W)",
                                "ylabel": "charge balance error", "title": "the charge balance (an open plasma: the "
                                                                          "source and the wall exchange particles)",
                                "xlabel": f"t ({TIME_UNIT})"})
            plot_profile(os.path.join(out_dir, "profile.png"), x, mean, reference, 1.0, PROFILE_TOLERANCE,
                         f"± {PROFILE_TOLERANCE:g} T_e/e, checked over the last {SHEATH_WIDTH:g} λ_D",
                         "sheath at a floating wall: mean potential against the kinetic model", xlabel="x (λ_D)",
                         ylabel="potential φ (T_e/e)", reference_label="collisionless kinetic model",
                         scale_label="", checked_from=length - SHEATH_WIDTH)
        return {"sheath": result}

    return TimeLoop(solver, t_end=n_steps * dt, output_interval=output_every * dt, name="pic_sheath",
                    params=params, analyses=[sheath_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field="speed", extra_frames=POTENTIAL_FRAMES,
                                         units=UNITS))


def sheath_checks(result: dict) -> dict:
    """The wall's mean potential within 0.05 T_e/e of the model's; the mean potential over the sheath's last 5 λ_D
    within 0.05 T_e/e of the model's."""
    source = "collisionless sheath model (warpfree/validation/pic_sheath/README.md)"
    return {"wall_potential_error": tolerance_check(result["wall_potential_error"], WALL_TOLERANCE, source,
                                                    reference=0.0, basis="measured -0.014 at t = 300, -0.015 and "
                                                                        "+0.013 at the defaults (seeds 0, 1)"),
            "sheath_profile_max_error": tolerance_check(result["sheath_profile_max_error"], PROFILE_TOLERANCE, source,
                                                        reference=0.0, basis="measured 0.016 at t = 300, 0.015 and "
                                                                             "0.021 at the defaults")}
