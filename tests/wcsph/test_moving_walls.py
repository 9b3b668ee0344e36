"""Walls that move along their surface (``WCSPHModel(wall_velocity=...)``): plane Couette flow against its series
solution, bad wall velocities named, and the lid-driven cavity against Ghia, Ghia & Shin (1982)."""

import json

import numpy as np
import pytest

from warpfree import device
from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.geometry import lattice_box
from warpfree.scene_loader import load_scene
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
from warpfree.validation import lid_driven_cavity_2d as ghia


def couette_velocity(y, t, speed, nu, width, terms=200):
    """Plane Couette flow started from rest by the wall y = ``width`` sliding at ``speed`` (the wall y = 0 at rest):
    u = U y/L - Σ_k 2U (-1)^(k+1)/(kπ) sin(kπy/L) exp(-k²π²νt/L²)."""
    k = np.arange(1, terms + 1)[:, None]
    decay = np.exp(-(k * np.pi / width) ** 2 * nu * t)
    series = 2.0 * speed * (-1.0) ** (k + 1) / (k * np.pi) * np.sin(k * np.pi * y[None, :] / width) * decay
    return speed * y / width - series.sum(0)


def test_couette_series_starts_at_rest_and_ends_linear():
    y = np.linspace(0.05, 0.95, 19)
    assert np.abs(couette_velocity(y, 0.0, 1.0, 1.0, 1.0, terms=20000)).max() < 2e-3
    np.testing.assert_allclose(couette_velocity(y, 5.0, 1.0, 1.0, 1.0), y, atol=1e-12)


def couette_run(n: int, times: list[float]):
    """A periodic channel L = 1 mm wide, ν = 1e-6 m²/s (L²/ν = 1 s), its top wall sliding at U = 1 mm/s, run to each
    of ``times`` (in L²/ν): the water's y and u at each."""
    device.use("cpu", 2)
    width, nu, speed = 1.0e-3, 1.0e-6, 1.0e-3
    dx = width / n
    length = 8 * dx
    fluid = lattice_box((0.0, 0.0), (length, width), dx)
    below = lattice_box((0.0, -3 * dx), (length, 0.0), dx)
    above = lattice_box((0.0, width), (length, width + 3 * dx), dx)
    velocity = np.zeros((len(below) + len(above), 2))
    velocity[len(below):, 0] = speed
    params = FluidParams(dim=2, dx=dx, h_factor=1.3, c0=speed / 0.1, mu=1000.0 * nu, gravity=(0.0, 0.0, 0.0),
                         container_lo=(0.0, 0.0, -1.0), container_hi=(length, width, 1.0),
                         periodic=(True, False, False))
    solver = WCSPHSolver(WCSPHModel(fluid, np.vstack([below, above]), params, wall_velocity=velocity))
    t, out = 0.0, []
    for stop in times:
        while t < stop * width ** 2 / nu - 1e-12:
            dt = min(solver.stable_dt(), stop * width ** 2 / nu - t)
            solver.step(dt)
            t += dt
            assert solver.problem() is None
        x = solver.fluid.numpy("position")
        out.append((t, x[:, 1].astype(np.float64), solver.fluid.numpy("velocity")[:, 0].astype(np.float64)))
    return speed, nu, width, out


def test_a_sliding_wall_drives_couette_flow_as_the_series_says():
    """The top wall of a periodic channel slides at U from t = 0 (its particles stay in place, their velocity
    prescribed): the water follows the series solution while the flow develops (t = 0.05 and 0.2 L²/ν) and ends
    on the linear profile (t = 1.5 L²/ν, where the series' slowest mode has fallen to 4e-7). Measured (n = 20):
    the largest difference 0.26 %, 0.063 % and 0.044 % of U; bounds 0.6 %, 0.2 %, 0.15 % (a wall that did not move
    its fluid, or moved it at half the speed, misses them by two orders of magnitude)."""
    speed, nu, width, out = couette_run(20, [0.05, 0.2, 1.5])
    for (t, y, u), bound in zip(out, (0.006, 0.002, 0.0015)):
        exact = couette_velocity(y, t, speed, nu, width)
        assert np.abs(u - exact).max() < bound * speed, (t, np.abs(u - exact).max() / speed)
    t, y, u = out[-1]
    assert np.abs(u - speed * y / width).max() < 0.0015 * speed


@pytest.mark.parametrize("wall_velocity,words", [
    (np.zeros((3, 2)), "one per wall particle"),
    (np.array([1.0, np.nan]), "finite"),
    (np.array([1.0, 0.0, 0.5]), "in the plane"),
])
def test_a_bad_wall_velocity_is_named(wall_velocity, words):
    fluid = lattice_box((0.0, 0.0), (0.2, 0.2), 0.05)
    walls = lattice_box((0.0, -0.15), (0.2, 0.0), 0.05)
    with pytest.raises(ParameterError) as info:
        WCSPHModel(fluid, walls, FluidParams(dim=2, dx=0.05), wall_velocity=wall_velocity)
    assert info.value.name == "wall_velocity" and words in str(info.value)


def test_the_lid_driven_cavity_at_re_100_matches_ghia_at_its_quick_settings(tmp_path):
    """The scene at its quick validation (n = 30, t = 20 L/U, averaged from 10): the rms difference from Ghia et al.
    over the 30 interior centreline points within the check's 2 % of U (measured 1.40 %), the vortex's smallest u on
    the vertical centreline within 0.03 U of Ghia's -0.2109 (measured -0.1907), and the cavity plot written."""
    out = tmp_path / "cavity"
    sets = [a for k, v in load_scene("lid_driven_cavity_2d").QUICK.items() for a in ("--set", f"{k}={v}")]
    assert main(["run", "lid_driven_cavity_2d", *sets, "--set", "vtk=false", "--no-frames", "--no-progress",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    cavity = summary["analysis"]["cavity"]
    assert summary["validation"]["passed"] and cavity["rms"] < ghia.PROFILE_TOLERANCE
    assert cavity["averaged_outputs"] == 21
    assert abs(cavity["u_min"] - cavity["u_min_ghia"]) < 0.03
    assert (out / "cavity.png").is_file()


@pytest.mark.parametrize("params,bad", [({"average_from": 25.0}, "average_from"), ({"n": 4}, "n"),
                                        ({"mach": 0.7}, "mach"), ({"wall_layers": 2}, "wall_layers")])
def test_bad_cavity_parameters_are_named(params, bad):
    with pytest.raises(ParameterError) as info:
        load_scene("lid_driven_cavity_2d").build(frames=False, vtk=False, **params)
    assert info.value.name == bad
