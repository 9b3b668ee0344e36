"""A plane wave on a circular cylinder: the exact Bessel series (``warpfree.validation.em_scatterer_2d``) checked
against its own boundary conditions and the optical theorem, and the scene ``em_scatterer_2d`` against it: second
order with the averaged interface."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from warpfree.scene_loader import load_scene
from warpfree.validation.em_scatterer_2d import extinction_width, scattering_width, total_field


@pytest.mark.parametrize("eps_r,k0a", [(4.0, 2.5), (2.25, 6.0), (10.0, 0.7)])
def test_the_series_is_continuous_at_the_surface_with_its_normal_derivative(eps_r, k0a):
    """Ez and ∂Ez/∂r (μr = 1) on both sides of r = a agree to 1e-6 of the field (one-sided differences of 1e-6 a)."""
    angle = np.linspace(0.0, 2.0 * math.pi, 13)
    k0, a = 1.0, k0a

    def at(r):
        return total_field(np.stack([r * np.cos(angle), r * np.sin(angle)], axis=1), (0.0, 0.0), a, k0, eps_r)

    h = 1e-6 * a
    scale = np.abs(at(a * (1 + 1e-9))).max()
    assert np.abs(at(a * (1 - 1e-12)) - at(a * (1 + 1e-12))).max() < 1e-6 * scale
    inner, outer = (at(a - h) - at(a - 2 * h)) / h, (at(a + 2 * h) - at(a + h)) / h
    assert np.abs(inner - outer).max() < 1e-4 * np.abs(inner).max() + 1e-5 * scale


@pytest.mark.parametrize("eps_r", [4.0, 2.25, None])
def test_the_optical_theorem_holds(eps_r):
    """A lossless cylinder's scattering width equals its extinction width (the forward amplitude's), to 1e-12."""
    assert scattering_width(1.0, 2.5, eps_r) == pytest.approx(extinction_width(1.0, 2.5, eps_r), rel=1e-12)


def test_a_conductor_carries_no_field_on_its_surface():
    angle = np.linspace(0.0, 2.0 * math.pi, 17)
    surface = np.stack([np.cos(angle), np.sin(angle)], axis=1) * 1.7
    assert np.abs(total_field(surface, (0.0, 0.0), 1.7, 2.0, None)).max() < 1e-9


def test_the_dielectric_cylinder_converges_at_second_order_with_the_averaged_interface():
    """εr = 4, k0 a = 2.5 at 10 and 20 particles per wavelength in the dielectric with Yee's difference (order 2): the
    near field's error against the Bessel series and the scattering width's fall by 3.5x or more (order >= 1.8;
    measured 10.4 % -> 2.6 %), the ring, the lines and the width alike."""
    errors = {}
    for n in (10, 20):
        run = load_scene("em_scatterer_2d").build(particles_per_wavelength=n, order=2, frames=False, vtk=False)
        result = run.run(None)["analysis"]["scatterer"]
        errors[n] = result
        assert result["particles_on_interface"] > 0
    for key in ("ring_error", "line_error", "scattering_width_error"):
        order = math.log2(abs(errors[10][key] / errors[20][key]))
        assert order >= 1.8, (key, errors[10][key], errors[20][key])
        assert abs(errors[20][key]) < 0.03


def test_the_fourth_order_difference_meets_the_series_within_one_percent_at_twenty_per_wavelength():
    """The scene's defaults (Fang's (2,4) difference, 20 particles per wavelength in the dielectric): the ring, the
    lines and the scattering width within 1 % of the series (measured 0.94 %, 0.87 %, +0.57 %; Yee's difference at 20:
    2.6 %, 2.6 %, -2.4 %), then second order (the interface's: order 1.83, 1.84, 1.95 to 28 per wavelength)."""
    results = {n: load_scene("em_scatterer_2d").build(particles_per_wavelength=n, frames=False, vtk=False)
               .run(None)["analysis"]["scatterer"] for n in (20, 28)}
    assert results[20]["order"] == 4 and all(c["passed"] for c in results[20]["checks"].values())
    for key in ("ring_error", "line_error", "scattering_width_error"):
        order = math.log(abs(results[20][key] / results[28][key])) / math.log(28 / 20)
        assert order > 1.7, (key, order)


def test_a_conducting_cylinder_meets_the_series_within_one_percent():
    """A perfect conductor (cut out, its surface held; Yee's difference) at 40 particles per wavelength: the near field
    on the ring and the lines and the scattering width within 1 % of the series (measured 0.50 %, 0.50 %, -0.49 %;
    at 20: 1.0 %, 0.94 %, -0.92 %); its staircase (the lattice's particles inside held) is off by more than 5 %."""
    run = load_scene("em_scatterer_2d").build(cylinder="conductor", particles_per_wavelength=40, frames=False,
                                              vtk=False)
    result = run.run(None)["analysis"]["scatterer"]
    assert result["order"] == 2
    assert result["checks"]["ring_error"]["passed"] and result["checks"]["line_error"]["passed"]
    assert result["checks"]["scattering_width"]["passed"]
    staircase = load_scene("em_scatterer_2d").build(cylinder="conductor", interface="centre", frames=False, vtk=False,
                                                    particles_per_wavelength=40)
    assert staircase.run(None)["analysis"]["scatterer"]["ring_error"] > 0.05


@pytest.mark.parametrize("order,measured", [(4, "0.0066 and 0.0016"), (2, "0.0128 and 0.0032")])
def test_the_slab_reflects_and_transmits_as_airy_says_at_second_order(order, measured):
    """One pulse over 0.5-1.5 GHz on a slab (εr = 4, half a wavelength thick at 1 GHz): R and T within 0.005 of
    Airy's at 40 particles per wavelength, the error falling by 3.5x or more from 20 (the interfaces' second order;
    measured at 20 and 40: see ``measured``), and R + T = 1 within 1e-3 (lossless)."""
    errors = {}
    for n in (20, 40):
        run = load_scene("em_slab_1d").build(particles_per_wavelength=n, order=order, frames=False, vtk=False)
        errors[n] = run.run(None)["analysis"]["slab"]
    assert errors[40]["checks"]["reflectance"]["passed"] and errors[40]["checks"]["transmittance"]["passed"]
    for key in ("reflectance_error", "transmittance_error"):
        assert math.log2(errors[20][key] / errors[40][key]) >= 1.8
    assert max(e["absorption_error"] for e in errors.values()) < 1e-3


DRUDE = {"eps_r": 1.0, "plasma_frequency": 1.0e9, "collision_rate": 6.283e8, "thickness": 0.1}


def test_a_drude_slab_reflects_transmits_and_absorbs_as_airy_says():
    """A Drude plasma slab (fp = 1 GHz, γ = 0.1 GHz·2π, 0.1 λ0 thick: a metal below 1 GHz, lossy above) over
    0.5-1.5 GHz: R, T and the absorbed 1 - R - T against Airy's formulas with ε(ω) = 1 - ωp²/(ω² - iγω), within
    0.005 at 40 particles per wavelength (measured 0.00036, 0.00058, 0.00040), three times closer or more at 80
    (measured 0.000093, 0.00015, 0.00011)."""
    results = {n: load_scene("em_slab_1d").build(particles_per_wavelength=n, frames=False, vtk=False, **DRUDE)
               .run(None)["analysis"]["slab"] for n in (40, 80)}
    assert all(c["passed"] for c in results[40]["checks"].values())
    for key in ("reflectance_error", "transmittance_error", "absorption_error"):
        assert results[80][key] < results[40][key] / 3.0, key
    assert results[40]["absorption_error"] < 5e-3


def test_a_dense_plasma_lowers_the_step_and_stays_stable():
    """fp = 100 GHz (ωp Δt at the curl's limit would be 8.5: the E-J leapfrog would grow): the step limit falls below
    2/ωp and the run reflects the band as Airy says (R within 0.005)."""
    run = load_scene("em_slab_1d").build(eps_r=1.0, plasma_frequency=1.0e11, thickness=0.1, frames=False, vtk=False)
    assert run.solver.stable_dt() < 2.0 / (2.0 * math.pi * 1.0e11)
    result = run.run(None)["analysis"]["slab"]
    assert all(c["passed"] for c in result["checks"].values())


def test_the_drude_current_continues_bitwise_after_a_resume(tmp_path):
    """The Drude slab's smallest run, uninterrupted and resumed from its first checkpoint: the same transforms."""
    from warpfree.cli import main

    whole, resumed = tmp_path / "whole", tmp_path / "resumed"
    args = ["run", "em_slab_1d", "--no-frames", "--set", "vtk=false", "--set", "particles_per_wavelength=10",
            "--set", "frequencies=11"] + [x for k, v in DRUDE.items() for x in ("--set", f"{k}={v}")]
    assert main(args + ["--out", str(whole)]) == 0
    steps = json.loads((whole / "summary.json").read_text())["steps"]
    assert main(args + ["--out", str(resumed), "--checkpoint-every", str(steps // 2)]) == 0
    checkpoints = sorted((resumed / "checkpoints").glob("step_*"), key=lambda p: int(p.stem.split("_")[1]))
    with np.load(checkpoints[0]) as saved:
        assert np.abs(saved["state__current"]).max() > 0
    for later in checkpoints[1:]:
        later.unlink()
    assert main(["run", "--resume", str(resumed), "--no-frames"]) == 0
    for name in ("reflected", "transmitted"):
        assert (whole / "monitors" / f"{name}.csv").read_text() == (resumed / "monitors" / f"{name}.csv").read_text()
