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


def channel(n: int, moving: str, factor=None) -> WCSPHSolver:
    """A periodic channel L = 1 mm wide (8 spacings long), ν = 1e-6 m²/s (L²/ν = 1 s), ``n`` particles across,
    three wall layers below and above, the ``moving`` one ("floor" or "roof") sliding along x at U = 1 mm/s times
    the velocity factor ``factor`` ((times, factors) or None: 1), c0 = 10 U."""
    device.use("cpu", 2)
    width, nu, speed = 1.0e-3, 1.0e-6, 1.0e-3
    dx = width / n
    length = 8 * dx
    fluid = lattice_box((0.0, 0.0), (length, width), dx)
    below = lattice_box((0.0, -3 * dx), (length, 0.0), dx)
    above = lattice_box((0.0, width), (length, width + 3 * dx), dx)
    velocity = np.zeros((len(below) + len(above), 2))
    velocity[slice(0, len(below)) if moving == "floor" else slice(len(below), None), 0] = speed
    params = FluidParams(dim=2, dx=dx, h_factor=1.3, c0=speed / 0.1, mu=1000.0 * nu, gravity=(0.0, 0.0, 0.0),
                         container_lo=(0.0, 0.0, -1.0), container_hi=(length, width, 1.0),
                         periodic=(True, False, False))
    return WCSPHSolver(WCSPHModel(fluid, np.vstack([below, above]), params, wall_velocity=velocity,
                                  wall_velocity_factor=factor))


def run_to(solver: WCSPHSolver, t: float, stop: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Step ``solver`` from ``t`` to ``stop`` (s): the time reached and the water's y and u there (float64)."""
    while t < stop - 1e-12:
        dt = min(solver.stable_dt(), stop - t)
        solver.step(dt)
        t += dt
        assert solver.problem() is None
    return (t, solver.fluid.numpy("position")[:, 1].astype(np.float64),
            solver.fluid.numpy("velocity")[:, 0].astype(np.float64))


def couette_run(n: int, times: list[float]):
    """The channel's roof sliding at U from t = 0, run to each of ``times`` (in L²/ν): the water's y and u at each."""
    width, nu, speed = 1.0e-3, 1.0e-6, 1.0e-3
    solver, t, out = channel(n, "roof"), 0.0, []
    for stop in times:
        t, y, u = run_to(solver, t, stop * width ** 2 / nu)
        out.append((t, y, u))
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


def rings(radii, dx):
    """Particles on concentric circles of the given radii, each circle's spaced as close to dx as a whole number
    allows."""
    points = []
    for r in radii:
        m = int(round(2.0 * np.pi * r / dx))
        angle = (np.arange(m) + 0.5) * 2.0 * np.pi / m
        points.append(np.column_stack([r * np.cos(angle), r * np.sin(angle)]))
    return np.vstack(points)


def taylor_couette_error(n: int) -> tuple[float, float, float]:
    """Water between a cylinder R1 = 1 mm spinning at ω R1 = 1 mm/s and a fixed one R2 = 2 mm (ν = 1e-6 m²/s, Re = 1,
    (R2 - R1)²/ν = 1 s), ``n`` rings across, run to t = 1.5 s: the rms and largest difference of the azimuthal
    velocity from the steady u_θ = A r + B/r, and the largest radial velocity, in units of ω R1."""
    device.use("cpu", 2)
    r1, r2, nu, speed = 1.0e-3, 2.0e-3, 1.0e-6, 1.0e-3
    omega, dx = speed / r1, (r2 - r1) / n
    fluid = rings(r1 + (np.arange(n) + 0.5) * dx, dx)
    inner = rings(r1 - (np.arange(3) + 0.5) * dx, dx)
    outer = rings(r2 + (np.arange(3) + 0.5) * dx, dx)
    velocity = np.zeros((len(inner) + len(outer), 2))
    velocity[:len(inner)] = omega * np.column_stack([-inner[:, 1], inner[:, 0]])  # ω × r: spinning in place
    edge = r2 + 4 * dx
    params = FluidParams(dim=2, dx=dx, h_factor=1.3, c0=speed / 0.1, mu=1000.0 * nu, gravity=(0.0, 0.0, 0.0),
                         container_lo=(-edge, -edge, -1.0), container_hi=(edge, edge, 1.0))
    model = WCSPHModel(fluid, np.vstack([inner, outer]), params, wall_velocity=velocity,
                       fluid_volume=np.pi * (r2 ** 2 - r1 ** 2) / len(fluid))
    solver = WCSPHSolver(model)
    t = 0.0
    while t < 1.5 - 1e-12:
        dt = min(solver.stable_dt(), 1.5 - t)
        solver.step(dt)
        t += dt
        assert solver.problem() is None
    x = solver.fluid.numpy("position")[:, :2].astype(np.float64)
    u = solver.fluid.numpy("velocity")[:, :2].astype(np.float64)
    r = np.hypot(x[:, 0], x[:, 1])
    u_theta = (x[:, 0] * u[:, 1] - x[:, 1] * u[:, 0]) / r
    u_r = (x[:, 0] * u[:, 0] + x[:, 1] * u[:, 1]) / r
    a = -omega * r1 ** 2 / (r2 ** 2 - r1 ** 2)
    b = omega * r1 ** 2 * r2 ** 2 / (r2 ** 2 - r1 ** 2)
    error = u_theta - (a * r + b / r)
    return (float(np.sqrt(np.mean(error ** 2)) / speed), float(np.abs(error).max() / speed),
            float(np.abs(u_r).max() / speed))


def test_a_cylinder_spinning_in_place_drives_taylor_couette_flow():
    """The inner of two cylinders spins (its wall particles stay on their circles and carry ω × r): the water between
    them settles on Couette's u_θ = A r + B/r and converges to it at first order, the curved walls' particles
    standing in for the circles (the ghost velocity mirrors across a plane). Measured at t = 1.5 (R2 - R1)²/ν: rms
    3.33 % and 1.59 % of ω R1 at 8 and 16 rings across (0.82 % at 32), the largest 6.8 % and 3.5 %, the radial
    velocity below 0.2 %; bounds: rms 2.5 % at 16, a fall by at least 1.7 from 8 to 16, radial 1 %."""
    coarse, fine = taylor_couette_error(8), taylor_couette_error(16)
    assert fine[0] < 0.025 and fine[1] < 0.05
    assert coarse[0] / fine[0] > 1.7
    assert max(coarse[2], fine[2]) < 0.01


def stokes_velocity(y, t, speed, omega, nu, width):
    """Stokes' second problem in a channel: the wall y = 0 oscillating in its plane at U cos(ωt), the wall y = L at
    rest, the periodic state: u = Re[U e^(iωt) sinh(λ(L - y))/sinh(λL)], λ = (1 + i) sqrt(ω/2ν)."""
    lam = (1.0 + 1.0j) * np.sqrt(omega / (2.0 * nu))
    return np.real(speed * np.exp(1j * omega * t) * np.sinh(lam * (width - y)) / np.sinh(lam * width))


def test_a_wall_oscillating_in_its_plane_gives_stokes_second_problem():
    """The floor of a periodic channel oscillates along x at U cos(ωt) (its velocity a table of cos(ωt), 200 points a
    period, times its surface velocity U), the roof at rest, L = 4 Stokes depths sqrt(2ν/ω), 20 particles across:
    after four periods (the start's transient down to e^-8) the water's velocity follows the periodic solution at
    two phases a quarter-period apart. Measured: the largest difference 0.55 % and 1.2 % of U; bound 2 %. A floor
    whose velocity the table did not drive (f = 1 throughout) misses it by 61 % and 88 %."""
    nu, width, speed = 1.0e-6, 1.0e-3, 1.0e-3
    depth = width / 4.0
    omega = 2.0 * nu / depth ** 2
    period = 2.0 * np.pi / omega
    times = np.linspace(0.0, 5.0 * period, 1001)
    solver, t = channel(20, "floor", (times, np.cos(omega * times))), 0.0
    for stop in (4.0 * period, 4.25 * period):
        t, y, u = run_to(solver, t, stop)
        error = np.abs(u - stokes_velocity(y, t, speed, omega, nu, width)).max() / speed
        assert error < 0.02, (t / period, error)


def test_a_bad_velocity_factor_is_named():
    fluid = lattice_box((0.0, 0.0), (0.2, 0.2), 0.05)
    walls = lattice_box((0.0, -0.15), (0.2, 0.0), 0.05)
    for table, words in ((([0.0, 1.0], [1.0]), "one factor per time"), (([0.0, 0.0], [1.0, 2.0]), "increase"),
                         (([0.0, np.inf], [1.0, 2.0]), "finite")):
        with pytest.raises(ParameterError) as info:
            WCSPHModel(fluid, walls, FluidParams(dim=2, dx=0.05), wall_velocity_factor=table)
        assert info.value.name == "wall_velocity_factor" and words in str(info.value)
