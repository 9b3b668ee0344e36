"""Sensors on a fluid: the pressure at points and on walls' faces against hydrostatics, a water gauge against the
depth, the sampling schedule, resume, and sensors from the command line."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from warpfree import device
from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.scene_loader import load_scene
from warpfree.sensors import FieldSensor, PressureSensor, due_time, parse_sensor
from warpfree.solvers.wcsph.sensors import ForceSensor, WaterGauge, surface_height

G, RHO0 = 9.81, 1000.0
WIDTH, DEPTH, DX = 0.5, 0.4, 0.025


@pytest.fixture(scope="module")
def tank():
    """The scene's relaxed and settled tank (0.5 m wide, 0.4 m deep, dx = 0.025), held 0.1 s."""
    device.use("cpu", 2)
    run = load_scene("tank_at_rest_2d").build(width=WIDTH, depth=DEPTH, dx=DX, t_end=0.1, output_interval=0.1,
                                              frames=False, vtk=False)
    run.run(None, progress=False)
    return run


def _eos_pressure(solver) -> tuple[np.ndarray, np.ndarray]:
    """Every fluid particle's position and its equation-of-state pressure (Pa)."""
    P = solver.model.params
    rho = solver.fluid.numpy("density").astype(np.float64)
    return solver.fluid.numpy("position").astype(np.float64), P.b * ((rho / P.rho0) ** P.gamma - 1.0)


def test_field_at_reads_the_particles_pressure_inside_the_water_and_on_the_walls_faces(tank):
    """Against the straight line p(y) fitted through every particle's own pressure (the settled tank's, 1.4 % above
    ρ0 g (H - y) at the floor): inside the water, on the floor's face, a side wall's face, a corner and just under the
    surface within 1 % of ρ0 g H (measured 2026-12-05: 0.03-0.85 %, 1.1 % 0.02 m under the surface). The Shepard
    average of the particles' pressures reads the floor 4 % low (at the centroid of the water above it, ρ0 g 0.4 h
    lower). Against ρ0 g (H - y), as the scene checks its particles: within 3 %. The filled fraction is 1 inside,
    about 1/2 on the walls' faces and the surface, 0 above, where no field has a value."""
    solver = tank.solver
    bottom = RHO0 * G * DEPTH
    x, p = _eos_pressure(solver)
    slope, intercept = np.polyfit(x[:, 1], p, 1)
    points = np.array([[0.5 * WIDTH, 0.1], [0.5 * WIDTH, 0.2], [0.5 * WIDTH, 0.3], [0.5 * WIDTH, 0.0],
                       [0.25 * WIDTH, 0.0], [0.0, 0.1], [WIDTH, 0.2], [0.0, 0.0]])
    got = solver.field_at(points)
    line = intercept + slope * points[:, 1]
    assert np.max(np.abs(got["pressure"] - line)) < 0.01 * bottom, (got["pressure"] - line) / bottom
    assert np.max(np.abs(got["pressure"] - RHO0 * G * (DEPTH - points[:, 1]))) < 0.03 * bottom
    assert np.all(np.abs(got["filled"][:3] - 1.0) < 0.03) and np.all(np.abs(got["filled"][3:7] - 0.5) < 0.05)
    P = solver.model.params
    compressed = P.rho0 * (1.0 + line / P.b) ** (1.0 / P.gamma)   # the equation of state's density at the line
    assert np.max(np.abs(got["density"][:3] - compressed[:3])) < 1e-4 * RHO0 and np.max(np.abs(got["velocity"])) < 0.01
    h, mass, rho = solver.model.params.h, solver.fluid.numpy("mass"), solver.fluid.numpy("density")
    q = np.linalg.norm(x[:, :2] - points[3], axis=1) / h
    weight = mass / rho * np.where(q < 2.0, (1.0 - 0.5 * q) ** 4 * (2.0 * q + 1.0), 0.0)  # Wendland C2, 2D
    shepard = np.sum(weight * p) / np.sum(weight)
    assert shepard - line[3] < -0.03 * bottom
    air, surface = solver.field_at(np.array([[0.5 * WIDTH, DEPTH + 0.1], [0.5 * WIDTH, DEPTH]]))["filled"]
    assert air == 0.0 and abs(surface - 0.5) < 0.1
    dry = solver.field_at(np.array([[0.5 * WIDTH, DEPTH + 0.1]]))
    assert np.isnan(dry["pressure"][0]) and np.all(np.isnan(dry["velocity"][0]))


def _wendland_weights(positions: np.ndarray, mass: np.ndarray, density: np.ndarray, at: np.ndarray, h: float):
    """V_j W(|x - x_j|) of the Wendland C2 kernel in 2D without its constant (it cancels in an average)."""
    q = np.linalg.norm(positions[:, :2] - at, axis=1) / h
    return mass / density * np.where(q < 2.0, (1.0 - 0.5 * q) ** 4 * (2.0 * q + 1.0), 0.0)


def test_wall_pressure_is_the_average_over_the_water_and_the_wall_and_reads_the_faces_and_corners(tank):
    """The wall pressure at a point is (Σ_fluid V W p + Σ_walls V W p) / (Σ_fluid V W + Σ_walls V W), the walls
    carrying their condition's pressures (checked against that sum in float64 to 1e-5 of ρ0 g H). On the floor's
    face, the side walls' faces and in a corner it reads the line through the particles' pressures within 1 % of
    ρ0 g H (measured 2026-12-05: 0.1-0.6 %, the corner 0.3 %), where the fluid's own average reads the corner 4.6 % low
    (at the water's centroid, up and away from both walls); inside the water it is the fluid's average. A pressure
    sensor reads it; a panel (``mean=True``) reads its mean over its points, a dry one counting 0."""
    solver = tank.solver
    bottom = RHO0 * G * DEPTH
    x, p = _eos_pressure(solver)
    slope, intercept = np.polyfit(x[:, 1], p, 1)
    faces = np.array([[0.5 * WIDTH, 0.0], [0.25 * WIDTH, 0.0], [0.0, 0.1], [WIDTH, 0.2], [0.0, 0.3], [0.0, 0.0]])
    inside = np.array([[0.5 * WIDTH, 0.2]])
    got = solver.field_at(np.vstack([faces, inside]))["wall_pressure"]
    line = intercept + slope * faces[:, 1]
    assert np.max(np.abs(got[:-1] - line)) < 0.01 * bottom, (got[:-1] - line) / bottom
    h = solver.model.params.h
    fluid_mass, fluid_density = solver.fluid.numpy("mass"), solver.fluid.numpy("density").astype(np.float64)
    walls = solver.boundary.numpy()
    for k, at in enumerate(np.vstack([faces, inside])):
        wf = _wendland_weights(x, fluid_mass, fluid_density, at, h)
        ww = _wendland_weights(walls["position"].astype(np.float64), walls["mass"], walls["density"], at, h)
        expected = (np.sum(wf * p) + np.sum(ww * walls["pressure"])) / (np.sum(wf) + np.sum(ww))
        assert abs(got[k] - expected) < 1e-5 * bottom, (k, got[k], expected)
        if k == len(faces) - 1:   # the corner: the fluid's own average is read at its centroid
            assert np.sum(wf * p) / np.sum(wf) - line[k] < -0.03 * bottom
    assert np.sum(_wendland_weights(walls["position"], walls["mass"], walls["density"], inside[0], h)) == 0.0
    sensor = PressureSensor("p", faces)
    sensor.check(solver)
    assert np.array_equal(sensor.sample(solver), got[:-1])
    panel = PressureSensor("panel", np.vstack([faces[:2], [[0.5 * WIDTH, DEPTH + 0.1]]]), mean=True)
    panel.check(solver)   # a face of three points, one of them in the air (0 Pa)
    assert panel.columns(solver) == [("pressure", "Pa")]
    assert panel.sample(solver)[0] == pytest.approx((got[0] + got[1]) / 3.0, rel=1e-12)


def test_filled_support_is_one_in_the_water_and_against_walls_and_less_in_the_surface_layer(tank):
    """Σ V W over the fluid and the walls: 1 (within 2 %) wherever the support is under water, also in the rows
    against the floor and the side walls; 0.6-0.9 in the top row (dx/2 under the surface, its support cut: measured
    0.70-0.86); the body's noise leaves that row out (``pressure_noise(body_only=True)``), so it is at most the whole
    fluid's."""
    from warpfree.solvers.wcsph.scene_tools import BODY_FILLED, filled_support, pressure_noise

    solver = tank.solver
    x = solver.fluid_positions().astype(np.float64)
    filled = filled_support(solver)
    top = x[:, 1] > DEPTH - DX
    under = x[:, 1] < DEPTH - 2.0 * solver.model.params.h   # the whole support under the surface
    against_walls = (x[:, 1] < DX) | (x[:, 0] < DX) | (x[:, 0] > WIDTH - DX)
    assert np.all(np.abs(filled[under] - 1.0) < 0.02), (filled[under].min(), filled[under].max())
    assert np.count_nonzero(against_walls & under) > 40
    assert np.all((filled[top] > 0.6) & (filled[top] < BODY_FILLED))
    assert 0.0 < pressure_noise(solver, body_only=True) <= pressure_noise(solver)


def test_a_gauge_reads_the_depth_a_pressure_sensor_zero_in_air_and_the_force_on_the_tank_its_weight(tank):
    """The gauge on the floor reads H within dx/4 (measured 0.07 dx); a pressure sensor above the water reads 0 Pa
    (gauge), on the floor ρ0 g H within 3 %; the water's force on the tank's walls is its weight within 1 % (measured
    0.35 % short), with no sideways force or moment about the tank's middle."""
    solver = tank.solver
    gauge = WaterGauge("h", [[0.5 * WIDTH, 0.0], [0.2 * WIDTH, 0.0]])
    gauge.check(solver)
    assert np.all(np.abs(gauge.sample(solver) - DEPTH) < 0.25 * DX), gauge.sample(solver)
    sensor = PressureSensor("p", [[0.5 * WIDTH, 0.0], [0.5 * WIDTH, DEPTH + 0.1]])
    sensor.check(solver)
    p = sensor.sample(solver)
    assert abs(p[0] - RHO0 * G * DEPTH) < 0.03 * RHO0 * G * DEPTH and p[1] == 0.0
    assert [c for c, _ in sensor.columns(solver)] == ["pressure_0", "pressure_1"]
    force = ForceSensor("f", [0.5 * WIDTH, DEPTH], walls="containers")
    force.check(solver)
    assert force.columns(solver) == [("force_x", "N/m"), ("force_y", "N/m"), ("moment_z", "N")]
    fx, fy, mz = force.sample(solver)
    weight = solver.diagnostics()["mass"] * G
    assert abs(fy + weight) < 0.01 * weight and abs(fx) < 1e-3 * weight and abs(mz) < 1e-3 * weight * WIDTH
    with pytest.raises(ParameterError, match="no obstacles"):
        ForceSensor("g", [0.0, 0.0]).check(solver)


def test_surface_height_interpolates_the_first_crossing_going_up():
    heights = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    assert surface_height(heights, np.array([1.0, 1.0, 0.75, 0.25, 0.9])) == pytest.approx(2.5)
    assert surface_height(heights, np.array([0.2, 1.0, 1.0, 1.0, 1.0])) == 0.0
    assert surface_height(heights, np.ones(5)) == 4.0


def test_sensors_sample_on_their_own_interval_without_changing_the_run(tmp_path):
    """A sensor is sampled after the first step ending at or past each multiple of its interval, at that step's time
    (one row for a step passing several); the run's steps, time and outputs are those of the run without it."""
    device.use("cpu", 1)
    module = load_scene("dam_break_2d")
    settings = dict(dx=0.05, t_end=0.05, output_interval=0.025, frames=False, vtk=False)
    plain = module.build(**settings)
    plain.run(None, progress=False)
    sensed = module.build(**settings)
    interval = 0.0037
    sensed.add_sensor(PressureSensor("p", [[0.0, 0.1]], interval))
    sensed.add_sensor(WaterGauge("h", [[0.25, 0.0]], 0.01))
    summary = sensed.run(str(tmp_path), progress=False)
    assert sensed.step_count == plain.step_count and sensed.time == plain.time
    assert np.array_equal(sensed.solver.state.numpy()["position"], plain.solver.state.numpy()["position"])
    times = np.array([row[0] for row in sensed.sensor_rows["p"]])
    assert times[0] == 0.0 and np.all(np.diff(times) > 0)
    due = [due_time(interval, t) for t in times[:-1]]
    assert np.all(times[1:] >= np.array(due) * (1 - 1e-12))
    assert len(times) == int(np.floor(sensed.time / interval)) + 1
    info = summary["sensors"]["p"]
    assert info["samples"] == len(times) and info["columns"] == ["time [s]", "pressure [Pa]"]
    with open(tmp_path / info["file"]) as f:
        table = list(csv.reader(f))
    assert table[0] == ["time [s]", "pressure [Pa]"] and len(table) == len(times) + 1
    assert np.allclose(np.array(table[1:], dtype=float), np.vstack(sensed.sensor_rows["p"]), rtol=1e-8, atol=1e-6)
    heights = np.array(sensed.sensor_rows["h"])[:, 1]
    assert heights[0] == pytest.approx(2.0 * 1.0, abs=0.05)  # the column (2a, a = 1 m) over the gauge at x = 0.25


def test_a_resumed_run_continues_its_sensors_bitwise(tmp_path):
    device.use("cpu", 1)
    module = load_scene("dam_break_2d")
    settings = dict(dx=0.05, t_end=0.04, output_interval=0.02, frames=False, vtk=False, checkpoint_every=5)

    def build():
        run = module.build(**settings)
        run.add_sensor(PressureSensor("p", [[0.0, 0.1], [0.5, 0.0]], 0.002))
        return run

    whole = build()
    whole.run(str(tmp_path / "whole"), progress=False)
    cut = build()
    cut.max_steps = 12
    cut.run(str(tmp_path / "cut"), progress=False)
    resumed = build()
    resumed.run(str(tmp_path / "cut"), resume=True, progress=False)
    assert np.array_equal(np.vstack(resumed.sensor_rows["p"]), np.vstack(whole.sensor_rows["p"]))
    assert (tmp_path / "cut" / "sensors" / "p.csv").read_text() == (tmp_path / "whole" / "sensors" / "p.csv").read_text()


def test_bad_sensors_are_named_before_the_run():
    with pytest.raises(ParameterError, match="sensor"):
        parse_sensor("p1=pressure")
    with pytest.raises(ParameterError, match="unknown kind"):
        parse_sensor("p1=temperature:0,0")
    with pytest.raises(ParameterError, match="numbers"):
        parse_sensor("p1=pressure:0,a")
    with pytest.raises(ParameterError, match="same number"):
        parse_sensor("p1=pressure:0,0;1,1,1")
    with pytest.raises(ParameterError, match="must be > 0"):
        parse_sensor("p1=pressure:0,0@0")
    with pytest.raises(ParameterError, match="name"):
        PressureSensor("a/b", [[0.0, 0.0]])
    s = parse_sensor("p1=pressure:0.8245,0.471,0.021;0.8245,0.471,0.101@0.0005")
    assert isinstance(s, FieldSensor) and s.points.shape == (2, 3) and s.interval == 0.0005
    assert isinstance(parse_sensor("h4 = height : 2.638,0.5,0"), WaterGauge)
    panel = parse_sensor("P1=panel:3.22,0.07;3.22,0.16")
    assert isinstance(panel, PressureSensor) and panel.mean and panel.points.shape == (2, 2)
    assert not s.mean


def test_sensors_from_the_command_line(tmp_path, capsys):
    """``--sensor`` on a shipped scene writes the series; a bad one exits 2 with one line naming it, before any
    set-up; two of one name and a sensor on a static solve are refused."""
    out = tmp_path / "run"
    args = ["run", "dam_break_2d", "--set", "dx=0.05", "--set", "t_end=0.01", "--no-frames", "--no-progress",
            "--threads", "1", "--out", str(out)]
    assert main(args + ["--sensor", "wall=pressure:4.0,0.1@0.002", "--sensor", "h=height:0.5,0"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sensors"]["wall"]["samples"] == 6 and (out / "sensors" / "h.csv").is_file()
    assert json.loads((out / "run.json").read_text())["sensors"] == ["wall=pressure:4.0,0.1@0.002", "h=height:0.5,0"]
    capsys.readouterr()
    for bad in (["--sensor", "p=pressure:1,x"], ["--sensor", "p=pressure:1,1", "--sensor", "p=height:1,0"]):
        assert main(args[:-1] + [str(tmp_path / "bad"), *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "sensor" in err[0], err
        assert not (tmp_path / "bad").exists()
    assert main(["run", "efg_cook", "--set", "cells=4", "--out", str(tmp_path / "static"),
                 "--no-progress", "--sensor", "p=pressure:0,0"]) == 2
    assert "static" in capsys.readouterr().err



class _Fluid:
    """The fluid arrays ``pressure_noise`` reads (positions, pressure, mass, density), without a solver."""

    def __init__(self, arrays: dict):
        self.arrays = arrays

    def numpy(self, name: str) -> np.ndarray:
        return self.arrays[name]


class _Held:
    """A solver's face for ``pressure_noise``: its model's parameters, its fluid positions and arrays."""

    def __init__(self, x: np.ndarray, p: np.ndarray, dx: float, dim: int):
        from types import SimpleNamespace

        from warpfree.solvers.wcsph import FluidParams

        self.model = SimpleNamespace(params=FluidParams(dim=dim, dx=dx))
        n = len(x)
        pos = np.zeros((n, 3), dtype=np.float32)
        pos[:, :dim] = x
        self.fluid = _Fluid({"position": pos, "pressure": p.astype(np.float32),
                             "mass": np.full(n, 1000.0 * dx ** dim, np.float32), "density": np.full(n, 1000.0, np.float32)})

    def fluid_positions(self) -> np.ndarray:
        return self.fluid.numpy("position")


@pytest.mark.parametrize("dim", [2, 3])
def test_pressure_noise_is_zero_for_a_linear_field_and_the_rms_of_added_noise(dim):
    """``pressure_noise`` on a block of water with a free surface and walls cutting the supports: a hydrostatic field
    (linear in depth) has no noise (the fit is linear, so the boundaries add none: a kernel average would read 1.3 %
    of ρ g H in the tank at rest), and white noise of rms σ added to it reads as 0.9-1 σ: never high, a little low
    because each particle's fit takes a share of its own noise (measured 0.95-0.97 σ on these blocks, 0.89-0.94 σ on
    blocks a third as wide, where more particles sit at the boundaries)."""
    from warpfree.solvers.wcsph.scene_tools import pressure_noise

    dx, n = 0.05, (60 if dim == 2 else 16)
    g = (np.arange(n) + 0.5) * dx
    x = np.stack(np.meshgrid(*[g] * dim, indexing="ij"), -1).reshape(-1, dim)
    depth = n * dx
    p = 1000.0 * 9.81 * (depth - x[:, -1])
    assert pressure_noise(_Held(x, p, dx, dim)) < 1e-4 * 1000.0 * 9.81 * depth
    sigma = 100.0
    noisy = p + np.random.default_rng(1).normal(0.0, sigma, len(p))
    assert 0.9 < pressure_noise(_Held(x, noisy, dx, dim)) / sigma <= 1.0
