"""The fluid pairs read from the neighbour grid at every sweep (``fluid_pairs="grid"``, no table) give bitwise the
state of the table's rows (the same candidates in the same order), across rebuilds, in 2D and 3D, in a periodic box,
with the density-gradient and shifting sums; and hold less memory."""

from __future__ import annotations

import numpy as np
import pytest

from warpfree import device
from warpfree.errors import ParameterError
from warpfree.memory import solver_memory
from warpfree.scene_loader import load_scene
from warpfree.solvers.wcsph import FluidParams
from warpfree.solvers.wcsph.model import FluidPairs


def _stepped(scene: str, pairs: str, steps: int, monkeypatch, **settings):
    """``scene`` at its smallest with every model's fluid pairs ``pairs``, ``steps`` steps of its stable step."""
    post = FluidParams.__post_init__

    def with_pairs(self):
        self.fluid_pairs = pairs
        post(self)

    monkeypatch.setattr(FluidParams, "__post_init__", with_pairs)
    module = load_scene(scene)
    solver = module.build(**{**module.SMALLEST, "frames": False, "vtk": False, **settings}).solver
    monkeypatch.setattr(FluidParams, "__post_init__", post)
    assert solver.model.terms.fluid_pairs == pairs
    dt = solver.stable_dt()
    for _ in range(steps):
        solver.step(dt)
    return solver


@pytest.mark.parametrize("scene,steps,settings", [
    ("dam_break_2d", 60, {"shifting": 1.0, "delta_gradient": True}),
    ("taylor_green_2d", 30, {}),
    ("dam_break_3d", 20, {}),
])
def test_grid_pairs_are_bitwise_the_rows(scene, steps, settings, monkeypatch):
    device.use("cpu", 2)
    rows = _stepped(scene, "rows", steps, monkeypatch, **settings)
    grid = _stepped(scene, "grid", steps, monkeypatch, **settings)
    assert rows.moving_neighbours.builds == grid.moving_neighbours.builds >= 2  # rebuilds inside the steps
    a, b = rows.state.numpy(), grid.state.numpy()
    for k in a:
        assert np.array_equal(np.asarray(a[k]).view(np.uint8), np.asarray(b[k]).view(np.uint8)), k
    held_rows, held_grid = solver_memory(rows), solver_memory(grid)
    assert held_grid["parts"]["state"] == held_rows["parts"]["state"]
    # the table's index held at least one entry per fluid pair within the support: gone
    pairs = int(rows.fluid_fluid.counts().sum())
    assert held_rows["parts"]["neighbours"] - held_grid["parts"]["neighbours"] >= 4 * pairs
    # the load balance's work per particle: the candidates within reach at the last build, as the table's rows hold
    assert np.array_equal(grid.fluid_fluid.counts(), rows.fluid_fluid.counts())


def test_fluid_pairs_named_when_wrong():
    with pytest.raises(ParameterError, match="fluid_pairs"):
        FluidParams(fluid_pairs="cells")
    assert FluidParams(fluid_pairs="grid").fluid_pairs is FluidPairs.GRID
