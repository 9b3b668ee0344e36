"""The run shell for static solves and time loops: summary, phases, outputs written beside the run (the
same files as inline), a writer that fails, checkpoints killed mid-write, bad output options."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from helpers.example_static_solver import NodalValuesSolver
from warpfree import device
from warpfree.errors import ParameterError, RunError
from warpfree.geometry import jittered_lattice
from warpfree.io import checkpoint
from warpfree.io.vtk import read_pvd, read_units
from warpfree.run import OutputOptions, StaticRun
from warpfree.solver import OutputSet, State, TimeDependentSolver
from warpfree.solvers.heat import HeatModel, HeatSolver
from warpfree.space import Space
from warpfree.time_loop import TimeLoop


def nodal_values_run(**output):
    device.use("cpu", 2)
    dx = 0.05
    x = jittered_lattice((0.0, 0.0), (1.0, 1.0), dx, amplitude=0.2, seed=3)
    f = np.sin(3.0 * x[:, 0]) * np.cos(2.0 * x[:, 1])
    solver = NodalValuesSolver(x, dx, f, Space.free(2))
    return StaticRun(solver, name="nodal_values", params={"dx": dx}, output=OutputOptions(**output),
                     analyses=[lambda run, out: {"error": run.solver.diagnostics()["max_interpolation_error"]}])


def test_static_solve_through_the_run_shell(tmp_path):
    """Mendes (2010) eq. 3.35 solved once: the SPH interpolant of the nodal values reproduces the imposed values at
    every particle (jittered), to the round-off of the float64 solve; the shell writes the summary with the
    solve's phases and throughput, one VTU, one frame, the analysis."""
    run = nodal_values_run()
    summary = run.run(str(tmp_path))
    assert summary["status"] == "ok" and summary["kind"] == "static" and summary["solver"] == "nodal_values"
    assert {"neighbours", "assembly", "factorisation", "solve", "output", "analysis"} <= set(summary["phases_s"])
    assert summary["throughput"]["unit"] == "particles/s" and summary["throughput"]["value"] > 0
    assert summary["analysis"]["error"] < 1e-9
    # the nodal values differ from the imposed ones (no Kronecker delta), by more than the solve's error
    s = run.solver
    assert np.max(np.abs(s.nodal - s.imposed)) > 1e-3
    assert read_pvd(tmp_path / "particles.pvd")[0][0] == 0.0
    assert (tmp_path / "frames" / "frame_00000.png").stat().st_size > 5000
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "ok"


def test_static_run_refuses_resume_and_time_loop_refuses_static_solver(tmp_path):
    run = nodal_values_run()
    with pytest.raises(ParameterError, match="resume"):
        run.run(str(tmp_path), resume=True)
    with pytest.raises(ParameterError, match="solver"):
        TimeLoop(run.solver, t_end=1.0, output_interval=0.1)


def heat_run(tmp_dim=2, n=16, t_end=0.4, **output):
    device.use("cpu", 2)
    length = 1.0
    dx = length / n
    if tmp_dim == 1:
        x = (np.arange(n) + 0.5)[:, None] * dx
        space = Space(1, (0, 0, 0), (length, 0, 0), (True, False, False))
    else:
        g = (np.arange(n) + 0.5) * dx
        x = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
        space = Space(2, (0, 0, 0), (length, length, 0), (True, True, False))
    model = HeatModel(x, dx, 0.01, space)
    solver = HeatSolver(model, 300.0 + np.sin(2 * np.pi * x[:, 0]))
    return TimeLoop(solver, t_end=t_end, output_interval=0.1, name="heat", output=OutputOptions(**output),
                    checkpoint_every=5)


@pytest.mark.parametrize("dim", [2, 1])
def test_background_writer_writes_the_same_files_as_inline(tmp_path, dim):
    """VTU, PVD and PNG files are byte for byte the same whether a worker process writes them or the run does (2D:
    the frames' template and particle image; 1D: the curve over the saved background)."""
    heat_run(tmp_dim=dim, background=True).run(str(tmp_path / "bg"), progress=False)
    heat_run(tmp_dim=dim, background=False).run(str(tmp_path / "inline"), progress=False)
    files = sorted(p.relative_to(tmp_path / "bg") for p in (tmp_path / "bg").rglob("*")
                   if p.is_file() and p.suffix in (".vtu", ".pvd", ".png"))
    assert len([f for f in files if f.suffix == ".png"]) == 5 and len([f for f in files if f.suffix == ".vtu"]) == 5
    for rel in files:
        assert (tmp_path / "bg" / rel).read_bytes() == (tmp_path / "inline" / rel).read_bytes(), rel


def test_one_dimensional_run_writes_line_frames(tmp_path):
    summary = heat_run(tmp_dim=1, n=64).run(str(tmp_path), progress=False)
    assert summary["status"] == "ok" and summary["model"]["space"]["dim"] == 1
    assert len(list((tmp_path / "frames").glob("*.png"))) == 5


@pytest.mark.parametrize("background", [True, False])
def test_a_failing_writer_stops_the_run_cleanly(tmp_path, background):
    """The frames folder cannot be made (a file stands in its place): the run stops with a RunError naming the
    failed write, keeps its last good state as a checkpoint, and the summary says so."""
    (tmp_path / "frames").write_text("not a folder")
    run = heat_run(background=background)
    with pytest.raises(RunError, match="frame") as info:
        run.run(str(tmp_path), progress=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "error" and "frame" in summary["error"]
    assert info.value.last_good and os.path.isfile(info.value.last_good)
    assert run.step_count < 40  # stopped early: 0.4 s at the heat step is ~40 steps


def test_checkpoint_killed_mid_write_is_never_picked_up(tmp_path):
    """Leftovers of a write killed before its move (a hidden temporary, the old '.tmp.npz' name) are ignored
    by the newest-checkpoint search and removed by the next save."""
    cdir = str(tmp_path / "checkpoints")
    state = {"temperature": np.arange(4, dtype=np.float32)}
    good = checkpoint.save(cdir, 10, {"time": 0.1, "step": 10, "n_outputs": 2}, {"probe:time": np.zeros(2)}, state)
    (tmp_path / "checkpoints" / ".step_00000020.npz.tmp123").write_bytes(b"PK\x03\x04 half a zip")
    (tmp_path / "checkpoints" / "step_00000030.npz.tmp.npz").write_bytes(b"PK\x03\x04 half a zip")
    assert checkpoint.latest(cdir) == good
    loop, series, arrays = checkpoint.load(good)
    assert loop["step"] == 10 and np.array_equal(arrays["temperature"], state["temperature"])
    checkpoint.save(cdir, 40, loop, series, state)
    assert not (tmp_path / "checkpoints" / ".step_00000020.npz.tmp123").exists()
    (tmp_path / "checkpoints" / "step_00000050.npz").write_bytes(b"PK\x03\x04 damaged")
    with pytest.raises(ParameterError, match="resume"):
        checkpoint.load(checkpoint.latest(cdir))


def test_resume_from_a_checkpoint_of_another_scene_is_refused(tmp_path):
    heat_run(n=16).run(str(tmp_path), progress=False)
    other = heat_run(n=12)
    with pytest.raises(ParameterError, match="resume.*temperature"):
        other.run(str(tmp_path), resume=True, progress=False)


@pytest.mark.parametrize("option,value", [("frame_field", "pressure"), ("frame_set", "fluid")])
def test_bad_frame_options_name_the_option(option, value):
    with pytest.raises(ParameterError, match=option):
        heat_run(**{option: value})


STATIC_SCENE = '''
import numpy as np
from helpers.example_static_solver import NodalValuesSolver
from warpfree.geometry import jittered_lattice
from warpfree.run import OutputOptions, StaticRun
from warpfree.space import Space


def build(dx: float = 0.05, frames: bool = True):
    x = jittered_lattice((0.0, 0.0), (1.0, 1.0), dx, amplitude=0.2, seed=3)
    solver = NodalValuesSolver(x, dx, np.sin(3.0 * x[:, 0]), Space.free(2))
    return StaticRun(solver, name="nodal_values", params={"dx": dx}, output=OutputOptions(frames=frames))
'''


def test_static_scene_through_the_cli(tmp_path, capsys):
    """Same CLI, run directory and exit codes as a time loop: exit 0 with a static summary; checkpoints, which a
    static solve has not, are refused naming the option (exit 2)."""
    from warpfree.cli import main

    scene = tmp_path / "nodal_values.py"
    scene.write_text(STATIC_SCENE)
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kind"] == "static" and summary["status"] == "ok" and "setup" in summary["phases_s"]
    assert "solved" in capsys.readouterr().out and (out / "frames" / "frame_00000.png").is_file()
    assert main(["run", str(scene), "--out", str(tmp_path / "again"), "--checkpoint-every", "5",
                 "--no-progress"]) == 2
    assert "--checkpoint-every" in capsys.readouterr().err


# ------------------------------------------------------------------------------------ frame series, units, options

class RampSolver(TimeDependentSolver):
    """A field at rest at t = 0 that then grows: ``level`` = 0 on every particle at first, ``x * step`` after; a
    vector ``flow`` (x component ``step``); and a set without points. For the frame series' ranges and units."""

    name = "ramp"
    work_unit = "particle-steps"

    def __init__(self, n: int = 64):
        super().__init__(None, device.current_launcher())
        g = (np.arange(8) + 0.5) / 8
        self.points = np.zeros((n, 3))
        self.points[:, :2] = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)[:n]
        self.state = State()
        self.state.steps = 0

    dim = 2
    work_items = 64

    def output_sets(self):
        k = self.state.steps
        level = self.points[:, 0] * k
        flow = np.stack([np.full(len(self.points), float(k)), -self.points[:, 1]], axis=1)
        return [OutputSet("cells", self.points, {"level": level, "flow": flow}, frame_field="level",
                          units={"position": "m", "level": "K", "flow": "m/s"}),
                OutputSet("empty", np.zeros((0, 3)), {"level": np.zeros(0)}, units={"position": "m"})]

    def describe(self):
        return {}

    def advance(self):
        self.state.steps += 1
        self.clock.launch_advance_and_choose()

    def stable_dt(self):
        return 0.1


def ramp_run(**output):
    device.use("cpu", 2)
    return TimeLoop(RampSolver(), t_end=0.4, output_interval=0.1, name="ramp",
                    output=OutputOptions(background=False, **output))


def frame_ranges(run, directory):
    """Run, recording every frame job's (series, vmin, vmax)."""
    jobs = []
    original = run._frame_job

    def recorded(*args, **kwargs):
        job = original(*args, **kwargs)
        jobs.append((os.path.basename(job[1]["path"]).rsplit("_", 1)[0], job[1]["vmin"], job[1]["vmax"]))
        return job

    run._frame_job = recorded
    run.run(str(directory), progress=False)
    return jobs


def test_a_series_keeps_the_range_of_its_first_frame_with_a_spread(tmp_path):
    """The field at rest at t = 0 (no scale given) is drawn about its value (never a degenerate range) and fixes
    nothing; the next frame's spread fixes the range for the rest of the series, though the field keeps growing."""
    jobs = frame_ranges(ramp_run(), tmp_path)
    assert [j[0] for j in jobs] == ["frame"] * 5
    assert jobs[0][1:] == (-1.0, 1.0)
    first_spread = (float(RampSolver().points[:, 0].min()), float(RampSolver().points[:, 0].max()))
    assert all(j[1:] == pytest.approx(first_spread) for j in jobs[1:])


def test_a_scale_fixes_every_frame_of_a_series_and_components_are_drawn(tmp_path):
    jobs = frame_ranges(ramp_run(frame_range={"level": (0.0, 4.0), "flow_x": (-1.0, 5.0)},
                                 extra_frames=(("cells", "flow_x"),)), tmp_path)
    assert {j for j in jobs if j[0] == "frame"} == {("frame", 0.0, 4.0)}
    assert {j for j in jobs if j[0] != "frame"} == {("cells_flow_x", -1.0, 5.0)}
    assert len(list((tmp_path / "frames").glob("cells_flow_x_*.png"))) == 5


def test_outputs_carry_units_and_a_set_without_points_writes_no_series(tmp_path):
    summary = ramp_run().run(str(tmp_path), progress=False)
    assert summary["units"] == {"time": "s", "outputs": {"cells": {"position": "m", "level": "K", "flow": "m/s"},
                                                         "empty": {"position": "m"}}}
    assert not (tmp_path / "empty.pvd").exists() and not list((tmp_path / "vtk").glob("empty_*"))
    assert read_units(tmp_path / read_pvd(tmp_path / "cells.pvd")[-1][1]) == {"position": "m", "level": "K",
                                                                              "flow": "m/s"}
    # the scene's units over the solver's
    summary = ramp_run(units={"level": "consistent units"}).run(str(tmp_path / "over"), progress=False)
    assert summary["units"]["outputs"]["cells"]["level"] == "consistent units"


def test_heat_run_records_its_units(tmp_path):
    summary = heat_run().run(str(tmp_path), progress=False)
    assert summary["units"] == {"time": "s", "outputs": {"particles": {"position": "m", "temperature": "K"}}}


@pytest.mark.parametrize("output,match", [
    ({"frame_range": {"level": (1.0, 1.0)}}, "frame_range"),
    ({"frame_range": {"level": (2.0, 1.0)}}, "frame_range"),
    ({"frame_range": {"level": (0.0, float("inf"))}}, "frame_range"),
    ({"frame_range": {"level": 3.0}}, "frame_range"),
    ({"frame_range": {"pressure": (0.0, 1.0)}}, "frame_range"),
    ({"frame_range": [(0.0, 1.0)]}, "frame_range"),
    ({"frame_field": "flow"}, "frame_field"),     # a vector: name a component
    ({"frame_field": "flow_z"}, "frame_field"),   # a component it has not
    ({"extra_frames": (("cells", "flow"),)}, "extra_frames"),
    ({"units": {"level": 3}}, "units"),
])
def test_bad_frame_ranges_fields_and_units_name_the_option(output, match):
    with pytest.raises(ParameterError, match=match):
        ramp_run(**output)
