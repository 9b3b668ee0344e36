"""Field monitors of SPEM (``warpfree.solvers.spem.monitors``): the running DFT against NumPy's sum of the recorded
fields, the interpolation exact for quadratic fields, the transforms restored on resume bitwise, bad monitors refused
by name."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.solvers.spem import PlaneWave, SPEMModel, SPEMSolver, Waveform, staggered_box, staggered_line
from warpfree.solvers.spem.monitors import DFTMonitor, interpolation_rows


def test_the_running_dft_is_the_sum_of_the_fields_at_their_own_times():
    """A plane wave crossing a box: the monitor's transforms of Ez, Hx and Hy at particles equal Σ u(t) e^{-2πift} w
    of the fields read after every step (Ez at t + Δt/2, H at t + Δt; each sample standing for its step, w the part of
    that step inside the window), to float64 rounding of float32 values; the window's ends fall between steps and
    the windows summed are exactly stop - start."""
    layout = staggered_box((0.0, 0.0), (0.3, 0.3), 0.01)
    model = SPEMModel(layout)
    f = 2.0e9
    wave = PlaneWave(Waveform(f, ramp=1.0), lower=(0.05, 0.05), upper=(0.25, 0.25), direction=(0.6, 0.8))
    e_at = np.flatnonzero(np.all(np.abs(layout.e_position[:, :2] - 0.15) < 0.03, axis=1))
    h_at = np.flatnonzero(np.all(np.abs(layout.h_position[:, :2] - 0.15) < 0.03, axis=1))
    hx_at = h_at[layout.h_carries[h_at] == 0]
    points = np.vstack([layout.e_position[e_at, :2], layout.h_position[hx_at, :2]])
    frequencies = (f, 1.3 * f)
    start, stop = 0.2e-9, 1.7e-9
    solver = SPEMSolver(model, [wave], monitors=[DFTMonitor("probe", points, frequencies, ("ez", "hx"), start=start,
                                                            stop=stop)])
    dt = 0.9 * solver.stable_dt()
    solver.use_step(dt)
    steps = 120
    expect_e = np.zeros((points.shape[0], 2), complex)
    expect_h = np.zeros((points.shape[0], 2), complex)
    w = 2.0 * math.pi * np.asarray(frequencies)
    for n in range(steps):
        solver.step(dt)
        te, th = (n + 0.5) * dt, (n + 1) * dt
        part_e = max(0.0, min(te + 0.5 * dt, stop) - max(te - 0.5 * dt, start))  # of its step [t - Δt/2, t + Δt/2]
        part_h = max(0.0, min(th + 0.5 * dt, stop) - max(th - 0.5 * dt, start))
        expect_e[:e_at.size] += np.outer(solver.electric.numpy("ez")[e_at], np.exp(-1j * w * te)) * part_e
        expect_h[e_at.size:] += np.outer(solver.magnetic.numpy("hx")[hx_at], np.exp(-1j * w * th)) * part_h
    got = solver.dft("probe")
    scale = np.abs(expect_e).max()
    assert scale > 1e-11
    assert np.abs(got["ez"][:e_at.size] - expect_e[:e_at.size]).max() < 1e-9 * scale
    assert np.abs(got["hx"][e_at.size:] - expect_h[e_at.size:]).max() < 1e-9 * np.abs(expect_h).max()
    assert steps * dt > stop + dt and abs(start / dt - round(start / dt)) > 0.1  # the ends cut steps
    assert solver.dft_window("probe", "ez") == pytest.approx(stop - start, rel=1e-9)
    assert solver.dft_window("probe", "hx") == pytest.approx(stop - start, rel=1e-9)


@pytest.mark.parametrize("dim", [1, 2])
def test_interpolation_is_exact_for_quadratic_fields(dim):
    rng = np.random.default_rng(4)
    spacing = 0.1
    if dim == 1:
        particles = np.arange(0.0, 2.0 + 1e-9, spacing)[:, None] + rng.uniform(-0.03, 0.03, (21, 1))
        field = lambda p: 1.0 + 2.0 * p[:, 0] - 3.0 * p[:, 0] ** 2  # noqa: E731
        points = rng.uniform(0.3, 1.7, (50, 1))
    else:
        g = np.arange(0.0, 1.0 + 1e-9, spacing)
        particles = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2) + rng.uniform(-0.03, 0.03, (121, 2))
        field = lambda p: 1.0 + p[:, 0] - 2.0 * p[:, 1] + 3.0 * p[:, 0] * p[:, 1] - p[:, 1] ** 2  # noqa: E731
        points = rng.uniform(0.2, 0.8, (50, 2))
    rows = interpolation_rows(particles, points, dim, spacing)
    assert rows @ field(particles) == pytest.approx(field(points), abs=1e-10)
    on = interpolation_rows(particles, particles[:3], dim, spacing)
    assert np.array_equal(on.toarray()[:, :3], np.eye(3)) and on.nnz == 3


def test_monitors_continue_bitwise_after_a_resume(tmp_path):
    """The scatterer's smallest run, uninterrupted and resumed from a checkpoint inside the DFT's window (its last 2 of
    6 periods): the DFT file is the same."""
    whole, resumed = tmp_path / "whole", tmp_path / "resumed"
    args = ["run", "em_scatterer_2d", "--no-frames", "--set", "vtk=false", "--set", "particles_per_wavelength=8",
            "--set", "periods=6", "--set", "window=2"]
    assert main(args + ["--out", str(whole)]) == 0
    steps = json.loads((whole / "summary.json").read_text())["steps"]
    every = (5 * steps) // 6  # one checkpoint in the window (from step 4/6 on), the next would be past the end
    assert main(args + ["--out", str(resumed), "--checkpoint-every", str(every)]) == 0
    checkpoints = sorted((resumed / "checkpoints").glob("step_*"), key=lambda p: int(p.stem.split("_")[1]))
    inside = [p for p in checkpoints if 4 * steps / 6 < int(p.stem.split("_")[1]) < steps]
    assert len(inside) == 1
    with np.load(inside[0]) as saved:
        assert np.abs(saved["state__dft_near_field_ez_real"]).max() > 0  # the sums a resume must restore
    for later in checkpoints[checkpoints.index(inside[0]) + 1:]:
        later.unlink()
    (resumed / "monitors" / "near_field.csv").unlink()
    assert main(["run", "--resume", str(resumed), "--no-frames"]) == 0
    a = (whole / "monitors" / "near_field.csv").read_text()
    b = (resumed / "monitors" / "near_field.csv").read_text()
    assert a == b and len(a.splitlines()) > 100
    assert json.loads((resumed / "summary.json").read_text())["steps_this_run"] < \
        json.loads((whole / "summary.json").read_text())["steps"]


@pytest.mark.parametrize("monitor,reason", [
    (DFTMonitor("m", [[0.5, 0.5]], (1e9,)), "outside the domain"),
    (DFTMonitor("m", [[0.1, 0.1]], (1e12,)), "above the resolved band"),
    (DFTMonitor("m", [[0.1, 0.1]], (-1.0,)), "frequencies must be finite and > 0"),
    (DFTMonitor("m", [[0.1, 0.1]], (1e9,), ("ex",)), "fields are of"),
    (DFTMonitor("a b", [[0.1, 0.1]], (1e9,)), "a monitor's name"),
    (DFTMonitor("m", [[0.1, 0.1]], (1e9,), start=2e-9, stop=1e-9), "must come after its start"),
])
def test_bad_monitors_are_refused_by_name(monitor, reason):
    layout = staggered_box((0.0, 0.0), (0.3, 0.3), 0.01)
    with pytest.raises(ParameterError, match="monitor") as info:
        SPEMSolver(SPEMModel(layout), monitors=[monitor])
    assert reason in str(info.value)
    with pytest.raises(ParameterError, match="fields are of"):
        SPEMSolver(SPEMModel(staggered_line(0.0, 1.0, 0.05)), monitors=[DFTMonitor("m", [[0.5]], (1e8,), ("hx",))])



def test_the_flux_of_a_plane_wave_through_a_line_and_a_closed_square():
    """A plane wave at 30° to x through a vertical line of length l: ½ E0²/η0 l cos 30° within 0.1 % at 30 particles
    per wavelength (measured +0.02 %; second order in time and space: -0.004 % at 15, +0.006 % at 60); through a
    closed square inside the total-field box: 0 within 1e-4 of the line's (what enters leaves)."""
    from warpfree.solvers.spem import EPS0, MU0, PML, C0
    from warpfree.solvers.spem.monitors import FluxMonitor

    f = 1.0e9
    wavelength = C0 / f
    spacing, half = wavelength / 30.0, wavelength
    pml = 12 * spacing
    layout = staggered_box((-half - pml, -half - pml), (half + pml, half + pml), spacing)
    model = SPEMModel(layout, pml=PML(pml), interior=((-half, -half), (half, half)))
    angle = math.radians(30.0)
    wave = PlaneWave(Waveform(f, ramp=2.0), lower=(-0.8 * half, -0.8 * half), upper=(0.8 * half, 0.8 * half),
                     direction=(math.cos(angle), math.sin(angle)))
    period = 1.0 / f
    line = FluxMonitor("line", [[0.0, -0.3 * half], [0.0, 0.3 * half]], (f,), start=8 * period)
    square = FluxMonitor("square", [[-0.5 * half, -0.5 * half], [0.5 * half, -0.5 * half], [0.5 * half, 0.5 * half],
                                    [-0.5 * half, 0.5 * half]], (f,), start=8 * period, closed=True)
    solver = SPEMSolver(model, [wave], monitors=[line, square])
    dt = period / round(period / (0.95 * solver.stable_dt()))
    solver.use_step(dt)
    for _ in range(int(round(12 * period / dt))):
        solver.step(dt)
    expected = 0.5 * math.sqrt(EPS0 / MU0) * 0.6 * half * math.cos(angle)
    through = solver.flux("line")["power"][0]
    assert through == pytest.approx(expected, rel=1e-3)
    assert abs(solver.flux("square")["power"][0]) < 1e-4 * expected
    tables = solver.output_tables()
    assert tables["monitors/line"][1][0, 2] == pytest.approx(through)


def test_field_sensors_read_the_fields_at_points():
    """A field sensor on SPEM (``SPEMSolver.field_at``): at particles it reads their values exactly; between them a
    wave sin(k·x) set on the particles within 0.1 % of its amplitude at 20 particles per wavelength (the quadratic
    fit's O((kΔ)³): measured 0.49 %, 0.061 %, 0.0073 % at 10, 20, 40); a point outside the domain reads NaN; its rows are the sensor's samples."""
    from warpfree.sensors import FieldSensor
    from warpfree.time_loop import TimeLoop

    f = 1.0e9
    layout = staggered_box((0.0, 0.0), (0.6, 0.6), 0.015)
    wave = PlaneWave(Waveform(f, ramp=1.0), lower=(0.1, 0.1), upper=(0.5, 0.5), direction=(1.0, 0.0))
    solver = SPEMSolver(SPEMModel(layout), [wave])
    on = layout.e_position[[1000, 1001], :2]
    between = np.array([[0.3071, 0.2913], [0.2437, 0.3333]])
    run = TimeLoop(solver, t_end=2.0e-9, output_interval=1.0e-9, name="probe")
    run.add_sensor(FieldSensor("points", np.vstack([on, between, [[2.0, 2.0]]]), {"ez": "V/m", "hy": "A/m"},
                               interval=0.25e-9))
    run.run(None, progress=False)
    values = solver.field_at(np.vstack([on, between, [[2.0, 2.0]]]))
    assert np.array_equal(values["ez"][:2], solver.electric.numpy("ez")[[1000, 1001]])
    assert np.isnan(values["ez"][4]) and np.isnan(values["hy"][4])
    rows = run.sensor_rows["points"]
    assert len(rows) == 9 and rows[-1][1] == values["ez"][0]
    k = 2.0 * math.pi / (20 * 0.015) * np.array([0.8, 0.6])
    solver.state.ez.assign(np.sin(layout.e_position[:, :2] @ k).astype(np.float32))
    solver._field_rows.clear()
    points = np.random.default_rng(2).uniform(0.1, 0.5, (40, 2))
    assert np.abs(solver.field_at(points)["ez"] - np.sin(points @ k)).max() < 1e-3


def test_the_em_sensor_of_the_command_line_records_the_fields_of_the_dimension():
    """``--sensor p=em:X,Y@T`` makes a sensor of Ez, Hx, Hy in 2D and of Ez, Hy on a line."""
    from warpfree.sensors import parse_sensor

    sensor = parse_sensor("p=em:0.1,0.1;0.2,0.15@1e-11")
    assert sensor.kind == "em" and sensor.interval == 1e-11
    sensor.check(SPEMSolver(SPEMModel(staggered_box((0.0, 0.0), (0.3, 0.3), 0.01))))
    assert [c for c, _ in sensor.columns(None)] == ["ez_0", "hx_0", "hy_0", "ez_1", "hx_1", "hy_1"]
    line = parse_sensor("q=em:0.5@1e-11")
    line.check(SPEMSolver(SPEMModel(staggered_line(0.0, 1.0, 0.05))))
    assert list(line.fields) == ["ez", "hy"]
