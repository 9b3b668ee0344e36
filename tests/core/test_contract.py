"""Every shipped scene through the solver contract, found by discovery (``warpfree.scenes``, each at its ``SMALLEST``
run): a time-dependent solver gives bitwise the same state for 1, 2 and 3 threads, a resumed run reproduces the
uninterrupted one bitwise (state, probes, and the output files written after the resume), and the members the run
shell relies on are consistent; a static solver's outputs are consistent after its solve."""

from __future__ import annotations

import json
import typing

import numpy as np
import pytest

from warpfree import device
from warpfree.run import StaticRun
from warpfree.scene_loader import load_scene, shipped_scenes
from warpfree.solver import State, StaticSolver, TimeDependentSolver
from warpfree.time_loop import TimeLoop

#: scene -> the run its build() returns (annotated: every scene declares it)
KINDS = {name: typing.get_type_hints(load_scene(path).build).get("return") for name, path in shipped_scenes().items()}
TIME_DEPENDENT = sorted(name for name, kind in KINDS.items() if kind is TimeLoop)
STATIC = sorted(name for name, kind in KINDS.items() if kind is StaticRun)


def build(name, **extra):
    """The scene at its smallest run, frames off (VTU on only where a test writes files)."""
    module = load_scene(name)
    return module.build(**{**module.SMALLEST, "frames": False, "vtk": False, **extra})


def test_every_scene_says_which_run_it_builds():
    assert set(TIME_DEPENDENT) | set(STATIC) == set(KINDS), {k: v for k, v in KINDS.items() if v not in
                                                               (TimeLoop, StaticRun)}


def _consistent_outputs(s) -> None:
    assert s.dim in (1, 2, 3) and s.work_items > 0 and s.work_unit
    sets = s.output_sets()
    assert sets and s.output_fields() == {o.name: list(o.fields) for o in sets}
    for o in sets:
        assert o.points.shape[1] == 3 and all(len(v) == len(o.points) for v in o.fields.values())
    json.dumps(s.describe(), default=str)
    assert all(np.isfinite(v) for v in s.diagnostics().values())


@pytest.mark.parametrize("name", TIME_DEPENDENT)
def test_solver_honours_the_contract(name):
    device.use("cpu", 2)
    run = build(name)
    s = run.solver
    assert isinstance(s, TimeDependentSolver) and isinstance(s.state, State) and s.state.arrays()
    assert s.step_rule().kind in ("variable", "constant", "fixed")
    if getattr(s, "injections", None) or getattr(s, "emitters", None):  # an open system may start empty
        s.step(s.stable_dt())
    assert s.stable_dt() > 0
    # a solver that splits its work over ranks resumes through restore_pieces on any rank count
    assert not s.distributes or type(s).restore_pieces is not TimeDependentSolver.restore_pieces
    _consistent_outputs(s)


@pytest.mark.parametrize("name", STATIC)
def test_static_solver_honours_the_contract(name):
    device.use("cpu", 2)
    s = build(name).solver
    assert isinstance(s, StaticSolver)
    s.solve()
    _consistent_outputs(s)
    assert {"assembly", "solve"} <= set(s.phases.as_dict())


def _bytes(value: np.ndarray) -> np.ndarray:
    """A state value's bytes (arrays and the host scalars, 0-d arrays in a checkpoint)."""
    return np.ascontiguousarray(np.atleast_1d(value)).view(np.uint8)


def _state_after(name, threads, steps=15):
    device.use("cpu", threads, min_items_per_thread=1)  # chunk even these small sets
    s = build(name).solver
    for _ in range(steps):
        s.step(s.stable_dt())
        assert s.problem() is None
    return s.state.numpy()


@pytest.mark.parametrize("name", TIME_DEPENDENT)
def test_state_bitwise_identical_for_1_2_3_threads(name):
    ref = _state_after(name, 1)
    for threads in (2, 3):
        other = _state_after(name, threads)
        for k in ref:
            assert np.array_equal(_bytes(ref[k]), _bytes(other[k])), (threads, k)


@pytest.mark.parametrize("name", TIME_DEPENDENT)
def test_resume_reproduces_the_uninterrupted_run_bitwise(name, tmp_path):
    device.use("cpu", 2)
    full = build(name, vtk=True)
    full.checkpoint_every = 3
    full.run(str(tmp_path / "full"), progress=False)
    cut = build(name, vtk=True)
    cut.checkpoint_every, cut.max_steps = 3, full.step_count // 2 + 1   # "killed" after a checkpoint
    cut.run(str(tmp_path / "cut"), progress=False)
    assert 3 <= cut.step_count < full.step_count - 3
    resumed = build(name, vtk=True)
    resumed.checkpoint_every = 3
    summary = resumed.run(str(tmp_path / "cut"), resume=True, progress=False)
    assert resumed.step_count == full.step_count and summary["time"] == full.time
    full_state, resumed_state = full.solver.state.numpy(), resumed.solver.state.numpy()
    for k in full_state:
        assert np.array_equal(_bytes(full_state[k]), _bytes(resumed_state[k])), k
    assert resumed.series == full.series and resumed.diag_series == full.diag_series
    for pvd in (tmp_path / "full").glob("*.pvd"):
        assert pvd.read_bytes() == (tmp_path / "cut" / pvd.name).read_bytes()
    vtus = sorted((tmp_path / "full" / "vtk").glob("*.vtu"))
    assert len(vtus) >= 6
    for vtu in vtus:
        assert vtu.read_bytes() == (tmp_path / "cut" / "vtk" / vtu.name).read_bytes(), vtu.name
