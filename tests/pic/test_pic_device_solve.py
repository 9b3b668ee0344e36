"""The PIC field solve on the device (``warpfree.solvers.pic.device_solve``) against the host's SuperLU solve, on the
CPU device: the potential, the nodal fields of the momentum gather and the net charge density, to 1e-10 of the
largest value, for a periodic node lattice, jittered periodic nodes (the antisymmetrised gather) and walls."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpfree.errors import ParameterError
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.scene_loader import load_scene
from warpfree.solvers.pic import PlasmaPoisson
from warpfree.solvers.pic.device_solve import DeviceFieldSolve
from warpfree.solvers.pic.scene_tools import lattice_nodes, periodic_box, walled_box

#: CG iterations on the near-neutral deposit (192 nodes; measured: pinned 70, the singular K runs to its cap, 868)
ITERATIONS_NEAR_NEUTRAL = 100


def _case(kind: str, rng):
    if kind == "walls":
        space = walled_box(4.0, 4.0)
        model = MLSModel(lattice_nodes(space, 0.25), MLSSettings(d_max=2.0), space=space)
        return PlasmaPoisson(model, walls=(0.0, 1.5)), 0.3
    space = periodic_box(8.0, 6.0)
    nodes = lattice_nodes(space, 0.5)
    if kind == "jittered":
        nodes = np.mod(nodes + 0.1 * (rng.random(nodes.shape) - 0.5), space.length[:2])
    field = PlasmaPoisson(MLSModel(nodes, MLSSettings(d_max=2.0), space=space))
    assert field.antisymmetrise == (kind == "jittered")
    return field, 1.0


@pytest.mark.parametrize("kind,method", [("lattice", "cg"), ("lattice", "dense"), ("jittered", "cg"),
                                         ("jittered", "dense"), ("walls", "dense")])
def test_device_solve_equals_superlu(kind, method, launcher):
    rng = np.random.default_rng(7)
    field, background = _case(kind, rng)
    n = field.model.node_count
    charge = -background * field.node_integral * (1.0 + 0.3 * rng.standard_normal(n))  # a noisy plasma's deposit
    u = field.solve(charge, background)
    e = field.nodal_field(u, charge)
    solver = DeviceFieldSolve(field, background, True, launcher, method)
    solver.solve(wp.array(charge, dtype=wp.float64))
    scale = np.abs(u).max()
    assert np.abs(solver.potential.numpy() - u).max() < 1e-10 * scale
    assert np.abs(solver.nodal_field.numpy() - e).max() < 1e-10 * np.abs(e).max()
    if not field.walled:
        assert abs(solver.net.numpy()[0] - field.net_charge_density) < 1e-10 * abs(background)


def test_the_device_solve_refuses_what_it_cannot_do(launcher):
    field, background = _case("walls", np.random.default_rng(0))
    with pytest.raises(ParameterError, match="field_solve"):
        DeviceFieldSolve(field, background, True, launcher, "cg")
    with pytest.raises(ParameterError, match="field_solve"):
        DeviceFieldSolve(field, background, True, launcher, "lu")


def test_cg_converges_on_a_near_neutral_plasma(launcher):
    """A deposit that cancels the background to 1e-6: the load |b| ≪ |Q|, whose round-off along K's null space
    (the constants) slows CG on the singular K; pinned (``device_solve``) it converges as on any load."""
    rng = np.random.default_rng(3)
    field, background = _case("lattice", rng)
    n = field.model.node_count
    charge = -background * field.node_integral * (1.0 + 1e-6 * rng.standard_normal(n))
    u = field.solve(charge, background)
    solver = DeviceFieldSolve(field, background, False, launcher, "cg")
    solver.solve(wp.array(charge, dtype=wp.float64))
    # both solves round the load at ~1e-16 |Q|: the scale is the potential a deposit of the charge's own size makes
    scale = np.abs(field.solve_gauged(np.abs(charge).mean() * rng.standard_normal(n))).max()
    assert np.abs(solver.potential.numpy() - u).max() < 1e-10 * scale
    assert solver.iterations <= ITERATIONS_NEAR_NEUTRAL, solver.iterations


@pytest.mark.parametrize("scene,solves", [("pic_plasma_oscillation", ("dense", "cg")), ("pic_diode", ("device",))])
def test_a_scene_steps_alike_with_the_field_solved_on_the_device(scene, solves):
    """Ten steps of a shipped scene (smallest size) with the host's and the device's field solve: the particles'
    positions and velocities agree to 1e-10 of their range (the solves agree to round-off; the leapfrog keeps it)."""
    module = load_scene(scene)

    def stepped(field_solve):
        solver = module.build(**module.SMALLEST, frames=False, vtk=False, field_solve=field_solve).solver
        for _ in range(10):
            solver.step(solver.dt)
        n = solver.count
        return solver.state.position.numpy()[:n], solver.state.velocity.numpy()[:n], solver.history

    x, v, history = stepped("host")
    for method in solves:
        x_d, v_d, history_d = stepped(method)
        assert x_d.shape == x.shape
        assert np.abs(x_d - x).max() < 1e-10 * np.abs(x).max()
        assert np.abs(v_d - v).max() < 1e-10 * np.abs(v).max()
        assert np.allclose(history_d["field_energy"], history["field_energy"], rtol=1e-9, atol=0.0)
