"""Steps that never wait on the host: with a device clock (``warpfree.clock``) a time-dependent solver's step picks its
Δt on the device, writes nothing from the host and reads back one small report; the step can be recorded as Warp
graphs and replayed, bitwise equal to stepping. PIC (a fixed Δt) reads its clock, with its report (history row and
flags) in the clock's report slots, once a step. Counted on the CPU device through the code path a GPU takes (``tests/helpers/host_traffic.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from helpers.host_traffic import host_traffic
from warpfree import device
from warpfree.scene_loader import load_scene
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.scene_tools import box_walls_2d, hydrostatic_density
from warpfree.geometry import lattice_box


def _column(skin: float = 0.15) -> WCSPHSolver:
    """A 0.2 x 0.4 m water column collapsing in a 0.6 m box, dx = 0.02 (200 fluid particles)."""
    dx, g = 0.02, 9.81
    fluid = lattice_box((0.0, 0.0), (0.2, 0.4), dx)
    params = FluidParams(dim=2, dx=dx, c0=10.0 * math.sqrt(2 * g * 0.4), alpha=0.1, delta=0.1, skin=skin,
                         gravity=(0.0, -g, 0.0), cfl=0.4, container_lo=(0.0, 0.0, -1.0),
                         container_hi=(0.6, 0.6, 1.0))
    model = WCSPHModel(fluid, box_walls_2d(0.6, 0.6, dx, 3), params)
    return WCSPHSolver(model, density=hydrostatic_density(fluid[:, 1], 0.4, params.rho0, params.c0, g))


def _spem():
    module = load_scene("em_waveguide_2d")
    return module.build(**module.SMALLEST, frames=False, vtk=False).solver


def _start(solver) -> None:
    """The clock set up as a run's time loop sets it (an end far away, no output on the way)."""
    rule = solver.step_rule()
    slots = dict(time=0.0, next_output=math.inf, end=math.inf, fixed=0.0)
    if rule.kind != "variable":
        slots.update(fixed=rule.value, limit=rule.value)
    solver.clock.set(**slots)


def _run(solver, steps: int) -> int:
    """``steps`` steps as the time loop takes them (advance, then the step's report); the neighbour rebuilds made."""
    moving = getattr(solver, "moving_neighbours", None)  # a solver whose particles move
    builds = moving.builds if moving is not None else 0
    for _ in range(steps):
        solver.advance()
        assert solver.clock.problem() is None and solver.problem() is None
    return (moving.builds if moving is not None else 0) - builds


def _refills(solver) -> int:
    """Rows laid out again (a row outgrew its room) over the solver's neighbour tables so far."""
    moving = getattr(solver, "moving_neighbours", None)
    return 0 if moving is None else sum(t[0].refills for t in moving.tables.values())


@pytest.mark.cuda
@pytest.mark.parametrize("make,steps,rebuild", [(_column, 40, False), (lambda: _column(skin=0.0), 12, True),
                                                (_spem, 40, False)], ids=["wcsph", "wcsph-rebuild-every-step", "spem"])
def test_a_step_reads_one_report_and_writes_nothing(make, steps, rebuild, device_name):
    """Per step: one read (the clock with the step report), no write. A WCSPH step that rebuilds its neighbour tables
    also reads each table's worst overflow (three tables), and a table whose row outgrew its room reads where its
    rows end (two values) before it fills them again."""
    device.use(device_name, 2)
    solver = make()
    _start(solver)
    solver.clock.report()
    refills = _refills(solver)
    with host_traffic() as traffic:
        rebuilds = _run(solver, steps)
    refills = _refills(solver) - refills
    assert (rebuilds == steps) if rebuild else (rebuilds < steps)
    assert traffic.writes == 0, traffic.where
    assert traffic.reads == steps + 3 * rebuilds + 2 * refills, (rebuilds, refills, traffic.where)


@pytest.mark.parametrize("make,steps", [(_column, 40), (lambda: _column(skin=0.0), 6), (_spem, 40)],
                         ids=["wcsph", "wcsph-rebuild-every-step", "spem"])
@pytest.mark.cuda
def test_replayed_steps_are_bitwise_the_stepped_ones(make, steps, device_name):
    """The same steps taken by :meth:`advance` and replayed from the recorded graphs give bitwise the same state
    (with a neighbour rebuild every step too: the host decides between the graphs)."""
    device.use(device_name, 2)
    stepped, replayed = make(), make()
    for s in (stepped, replayed):
        _start(s)
    _run(stepped, steps)
    graph = replayed.step_graph()
    assert graph.graphs >= 1
    for _ in range(steps):
        graph.replay()
        assert replayed.clock.problem() is None and replayed.problem() is None
    a, b = stepped.state.numpy(), replayed.state.numpy()
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k].view(np.uint8), b[k].view(np.uint8)), k
    assert stepped.clock.time == replayed.clock.time > 0.0


@pytest.mark.cuda
def test_a_replayed_step_follows_a_table_that_grew(device_name):
    """A rebuild that lays a table's rows out in a new, larger index (the replay's first fill finds the index too
    small) records the rates again: the replayed steps stay bitwise the stepped ones."""
    device.use(device_name, 2)
    stepped, replayed = _column(skin=0.0), _column(skin=0.0)
    for s in (stepped, replayed):
        _start(s)
    steps = 4
    _run(stepped, steps)
    graph = replayed.step_graph()
    table = replayed.moving_neighbours.table("fluid_fluid")
    table.rows.index.zero_()  # what a graph still reading the old index would find: every neighbour particle 0
    table.rows.index = wp.empty(1, dtype=wp.int32, device=table.launcher.device)  # as if the rows had outgrown it
    table._entries_allocated = 1
    for _ in range(steps):
        graph.replay()
    assert table.refills >= 1 and table.rows.index.shape[0] > 1
    a, b = stepped.state.numpy(), replayed.state.numpy()
    for k in a:
        assert np.array_equal(a[k].view(np.uint8), b[k].view(np.uint8)), k


@pytest.mark.cuda
@pytest.mark.parametrize("scene,open_walls", [("pic_two_stream", False), ("pic_diode", True)])
def test_a_pic_step_reads_its_report_and_writes_nothing(scene, open_walls, device_name):
    """A PIC step with the field solved on the device (a GPU's default; on the CPU device its dense map, as Warp's CG
    checks its residual on the host there) reads one report (the clock, whose report slots hold its history row and
    the fits' flag) and writes nothing; with open walls the sort also reads the live count (and, in a step that
    absorbs particles, their walls and species: two reads more)."""
    device.use(device_name, 2)
    module = load_scene(scene)
    solver = module.build(**module.SMALLEST, frames=False, vtk=False,
                          field_solve="dense" if device_name == "cpu" else "device").solver
    _start(solver)
    solver.clock.report()
    steps = 6
    with host_traffic() as traffic:
        for _ in range(steps):
            solver.advance()
            assert solver.clock.problem() is None and solver.problem() is None
    reads = [where for kind, where in traffic.where if kind == "read"]
    report, sort = reads.count("clock.py:report"), reads.count("particles.py:sort")
    assert traffic.writes == 0, traffic.where
    assert report == steps and traffic.reads == report + sort, traffic.where
    if open_walls:
        assert sort >= steps and (sort - steps) % 2 == 0, traffic.where
    else:
        assert sort == 0
    assert len(solver.history["time"]) == steps


@pytest.mark.cuda
@pytest.mark.parametrize("scene", ["pic_plasma_oscillation", "pic_two_stream"])
def test_replayed_pic_steps_are_bitwise_the_stepped_ones(scene, device_name):
    """PIC steps replayed from the recorded graphs (the push; the fields) around the host's sort and grid build give
    bitwise the state and history of stepping."""
    device.use(device_name, 2)
    module = load_scene(scene)
    make = lambda: module.build(**module.SMALLEST, frames=False, vtk=False, field_solve="dense").solver  # noqa: E731
    stepped, replayed = make(), make()
    for s in (stepped, replayed):
        _start(s)
    steps = 6
    for _ in range(steps):
        stepped.advance()
        assert stepped.problem() is None
    graph = replayed.step_graph()
    assert graph.graphs == 2
    for _ in range(steps):
        graph.replay()
        assert replayed.problem() is None
    a, b = stepped.state.numpy(), replayed.state.numpy()
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(np.atleast_1d(a[k]).view(np.uint8), np.atleast_1d(b[k]).view(np.uint8)), k
    assert stepped.history == replayed.history and len(stepped.history["time"]) == steps
