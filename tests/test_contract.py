"""Every time-dependent solver through the contract: bitwise the same state for 1, 2 and 3 threads, a resumed
run reproduces the uninterrupted one bitwise (state, probes, and the output files written after the resume),
and the members the run shell relies on are consistent."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from warpfree import device
from warpfree.scene_loader import load_scene
from warpfree.solver import State, TimeDependentSolver

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: scene -> small parameters (frames off; VTU on where the test writes files)
SCENES = {
    "dam_break_2d": dict(dx=0.08, frames=False),
    "dam_break_3d": dict(dx=0.1, frames=False),
    "tank_at_rest_2d": dict(dx=0.05, frames=False, settle_periods=0.25),  # relaxed, briefly settled
    "heat_conduction_2d": dict(n=16, frames=False),
    "em_line_1d": dict(particles_per_wavelength=10, frames=False),
    "em_cavity_2d": dict(cells_per_radius=8, frames=False),
    "em_waveguide_2d": dict(particles_per_wavelength=20, frames=False),
    "em_plane_wave_2d": dict(particles_per_wavelength=20, size=0.2, margin=0.03, frames=False),
    "pic_two_stream": dict(node_spacing=1.0, length_y=4.0, particles_per_node=2, d_max=1.8, frames=False),
    # an open system: starts empty, injects 20 particles a step (the arrays grow twice within 15 steps)
    "pic_diode": dict(node_spacing=1.0 / 16.0, width=0.5, particles_per_step=20, frames=False),
}


#: scene -> the run of the resume test (a few outputs, enough steps for checkpoints every 3 steps)
RESUME = {"heat_conduction_2d": dict(t_end=2.0, output_interval=0.25),
          "em_line_1d": dict(t_end=1.0e-9, output_interval=0.25e-9),
          "em_cavity_2d": dict(t_end=1.0e-9, output_interval=0.25e-9),
          "em_waveguide_2d": dict(t_end=1.64e-9, output_interval=0.41e-9),
          "em_plane_wave_2d": dict(t_end=1.0e-9, output_interval=0.25e-9),
          "pic_two_stream": dict(t_end=2.4, output_every=4),
          "pic_diode": dict(t_end=0.6, output_every=5)}


def build(name, **extra):
    return load_scene(os.path.join(ROOT, "scenes", f"{name}.py")).build(**{**SCENES[name], **extra})


@pytest.mark.parametrize("name", SCENES)
def test_solver_honours_the_contract(name):
    device.use("cpu", 2)
    run = build(name, t_end=1.0)
    s = run.solver
    assert isinstance(s, TimeDependentSolver) and isinstance(s.state, State) and s.state.arrays()
    if getattr(s, "injections", None):  # an open system may start empty
        s.step(s.stable_dt())
    assert s.dim in (1, 2, 3) and s.work_items > 0 and s.work_unit
    assert s.stable_dt() > 0
    sets = s.output_sets()
    assert s.output_fields() == {o.name: list(o.fields) for o in sets}
    for o in sets:
        assert o.points.shape[1] == 3 and all(len(v) == len(o.points) for v in o.fields.values())
    json.dumps(s.describe(), default=str)
    assert all(np.isfinite(v) for v in s.diagnostics().values())


def _state_after(name, threads, steps=15):
    device.use("cpu", threads, min_items_per_thread=1)  # chunk even these small sets
    s = build(name, t_end=10.0).solver
    for _ in range(steps):
        s.step(s.stable_dt())
        assert s.problem() is None
    return s.state.numpy()


@pytest.mark.parametrize("name", SCENES)
def test_state_bitwise_identical_for_1_2_3_threads(name):
    ref = _state_after(name, 1)
    for threads in (2, 3):
        other = _state_after(name, threads)
        for k in ref:
            assert np.array_equal(ref[k].view(np.uint8), other[k].view(np.uint8)), (threads, k)


@pytest.mark.parametrize("name", SCENES)
def test_resume_reproduces_the_uninterrupted_run_bitwise(name, tmp_path):
    device.use("cpu", 2)
    kw = RESUME.get(name, dict(t_end=0.05, output_interval=0.01))
    full = build(name, vtk=True, **kw)
    full.checkpoint_every = 3
    full.run(str(tmp_path / "full"), progress=False)
    cut = build(name, vtk=True, **kw)
    cut.checkpoint_every, cut.max_steps = 3, full.step_count // 2 + 1   # "killed" after a checkpoint
    cut.run(str(tmp_path / "cut"), progress=False)
    assert 3 <= cut.step_count < full.step_count - 3
    resumed = build(name, vtk=True, **kw)
    resumed.checkpoint_every = 3
    summary = resumed.run(str(tmp_path / "cut"), resume=True, progress=False)
    assert resumed.step_count == full.step_count and summary["time"] == full.time
    full_state, resumed_state = full.solver.state.numpy(), resumed.solver.state.numpy()
    for k in full_state:
        assert np.array_equal(full_state[k].view(np.uint8), resumed_state[k].view(np.uint8)), k
    assert resumed.series == full.series and resumed.diag_series == full.diag_series
    for pvd in (tmp_path / "full").glob("*.pvd"):
        assert pvd.read_bytes() == (tmp_path / "cut" / pvd.name).read_bytes()
    vtus = sorted((tmp_path / "full" / "vtk").glob("*.vtu"))
    assert len(vtus) >= 6
    for vtu in vtus:
        assert vtu.read_bytes() == (tmp_path / "cut" / "vtk" / vtu.name).read_bytes(), vtu.name
