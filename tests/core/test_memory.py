"""The device memory a solver holds (``warpfree/memory.py``) and the allocations of its steps, counted by Warp's own
allocation tracker (``warp/native``: every ``wp_alloc``, arrays and hash grids alike)."""

from __future__ import annotations

import gc
import re

import numpy as np
import pytest
import warp as wp

from warpfree import device
from warpfree.memory import HASH_GRID_BYTES_PER_CELL, HASH_GRID_BYTES_PER_POINT, solver_memory
from warpfree.neighbours import build_hash_grid
from warpfree.scene_loader import load_scene, shipped_scenes
from warpfree.time_loop import TimeLoop


class _Tracker:
    """Warp's allocation tracker (process-wide), on while in use: live bytes and allocations since :meth:`reset`."""

    def __enter__(self):
        from warp._src.context import runtime

        self.core = runtime.core
        gc.collect()
        self.core.wp_alloc_tracker_enable(1)
        self.core.wp_alloc_tracker_reset()
        return self

    def __exit__(self, *exc):
        self.core.wp_alloc_tracker_enable(0)

    def reset(self) -> None:
        self.core.wp_alloc_tracker_reset()

    def live_bytes(self) -> int:
        gc.collect()
        return int(self.core.wp_alloc_tracker_get_current_bytes())

    def allocations(self) -> int:
        """Allocations on the CPU since the last reset (Warp's report: ``Total allocations: cpu N (...)``)."""
        text = wp._src.context.alloc_tracker_report_text(0, 1)
        found = re.search(r"Total allocations:\s*\n\s*cpu\s+(\d+)", text)
        return int(found.group(1)) if found else 0


class _Holder:
    """A stand-in solver: arrays, a view, a Warp struct, a hash grid, a state."""

    work_unit = "particle-steps"

    def __init__(self, launcher):
        self.launcher = launcher
        self.work_items = 100


def test_the_report_counts_each_array_once_views_inside_their_arrays_structs_and_grids():
    solver = _Holder(device.use("cpu", 1))
    a = wp.zeros(100, dtype=wp.vec3, device="cpu")            # 1 200 bytes
    b = wp.zeros(50, dtype=float, device="cpu")               # 200
    rows = __import__("warpfree.kernels.neighbours", fromlist=["NeighbourRows"]).NeighbourRows()
    rows.start = wp.zeros(10, dtype=wp.int32, device="cpu")   # 40
    rows.count = wp.zeros(10, dtype=wp.int32, device="cpu")   # 40
    rows.index = wp.zeros(30, dtype=wp.int32, device="cpu")   # 120
    grid = wp.HashGrid(4, 4, 1, device="cpu")
    build_hash_grid(grid, a, 0.1)                              # 16 cells, room for 150 points
    solver.state = type("State", (), {})()
    solver.state.position = a
    solver.fields = {"view": a[10:20], "again": a, "b": b, "pair": (b, [b])}
    solver.rows, solver.grid = rows, grid
    solver.host = np.zeros(10_000)                             # host memory: not counted
    report = solver_memory(solver)
    grid_bytes = 16 * HASH_GRID_BYTES_PER_CELL + 150 * HASH_GRID_BYTES_PER_POINT
    assert report["parts"] == {"state": 1200, "neighbours": 200 + grid_bytes, "other": 200}
    assert report["bytes"] == 1600 + grid_bytes and report["per_item"] == report["bytes"] / 100
    assert report["item"] == "particle"


@pytest.mark.parametrize("scene", ["heat_conduction_2d", "em_scatterer_2d", "dam_break_2d"])
def test_the_report_agrees_with_warps_allocation_tracker(scene):
    """After a short run, the solver's bytes against the live bytes Warp's tracker counted from before the set-up:
    measured equal for the heat and scatterer scenes, 0.9987 for the dam break (on the CPU the launcher's replay
    cache may also hold an array the solver has let go)."""
    device.use("cpu", 2)
    module = load_scene(scene)
    with _Tracker() as tracker:
        run = module.build(**{**module.SMALLEST, "frames": False, "vtk": False})
        run.max_steps = 10
        run.run(None, progress=False)
        live = tracker.live_bytes()
        report = solver_memory(run.solver)
    assert 0.95 * live <= report["bytes"] <= 1.05 * live, (report, live)
    assert report["per_item"] > 0 and sum(report["parts"].values()) == report["bytes"]


def test_every_run_reports_its_memory_per_item(tmp_path):
    device.use("cpu", 1)
    module = load_scene("em_line_1d")
    summary = module.build(**{**module.SMALLEST, "frames": False, "vtk": False}).run(str(tmp_path), progress=False)
    memory = summary["memory"]
    assert memory["item"] == "particle" and memory["bytes"] > 0
    assert memory["per_item"] == pytest.approx(memory["bytes"] / summary["throughput"]["work_items"])


def _time_dependent_scenes() -> list[str]:
    return [name for name in sorted(shipped_scenes()) if not name.startswith("efg_")]


def _openings_traffic(solver) -> int:
    return sum(c["made"] + c["taken_out"] for c in solver.opening_counts().values())


#: scenes whose particles come and go, what counts them and when arrays may be made: inlets and outlets lay the arrays
#: out again at a step where particles entered or left; an injected plasma grows its arrays (by doubling) past the most
#: particles it held
CHANGING = {"cylinder_flow_2d": (_openings_traffic, "changed"), "pic_diode": (lambda s: s.n, "grew"),
            "pic_cylindrical_diode": (lambda s: s.n, "grew"), "pic_sheath": (lambda s: s.n, "grew")}


@pytest.mark.slow
@pytest.mark.parametrize("scene", _time_dependent_scenes())
def test_steps_allocate_nothing(scene):
    """Every time-dependent scene at its smallest, 40 steps after 30: no Warp allocation in a step or in the loop's
    work after it (neighbour rebuilds, sensors, floating bodies' loads, reductions and the step's report included),
    save, where particles come and go, at a step whose count needs it."""
    device.use("cpu", 2)
    module = load_scene(scene)
    run = module.build(**{**module.SMALLEST, "frames": False, "vtk": False})
    if not isinstance(run, TimeLoop):
        pytest.skip("a static solve")
    solver, warm, counted = run.solver, 30, 40
    run.t_end, run.output_interval = 1e6 * run.t_end, 1e6 * run.t_end  # no output in the counted steps
    run.max_steps = warm + counted + 1
    count, rule = CHANGING.get(scene, (lambda s: s.work_items, "none"))
    per_step, counts, step = [], [], {"n": 0}
    advance = solver.advance
    with _Tracker() as tracker:
        def counted_advance():  # the allocations since the last call: the last step's and its loop's work
            if step["n"] > warm:
                per_step.append(tracker.allocations())
                counts.append(count(solver))
            step["n"] += 1
            tracker.reset()
            advance()

        solver.advance = counted_advance
        run.run(None, progress=False)
    assert len(per_step) == counted
    allocating = [k for k, a in enumerate(per_step) if a]
    if rule == "none":
        assert not allocating, per_step
    else:  # counts[k]: after step k; a step that changed the count (or grew it past the most so far) may allocate
        changed = {k for k in range(1, counted) if (counts[k] != counts[k - 1] if rule == "changed"
                                                    else counts[k] > max(counts[:k]))}
        assert set(allocating) <= changed | {0}, (per_step, counts)
