"""PIC in a region of any shape (``warpfree.solvers.pic.electrodes``, ``warpfree.solvers.pic.boundary``): the field
between electrodes held or floating on exact curves against the coaxial line's analytic potential, charge and
surface field; particles crossing the boundary absorbed with their charge on the electrode they hit, or reflected
specularly by an insulating wall."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.galerkin.region import Region
from warpfree.kernels import pic as pk
from warpfree.solvers.pic.boundary import ParticleBoundary, Wall
from warpfree.solvers.pic.electrodes import Electrode, ElectrodeField


@pytest.fixture(scope="module")
def launcher():
    return Launcher("cpu", 2)


def _coax(spacing: float, basis: str = "quadratic", d_max: float = 3.0, launcher=None):
    region = Region.disc((0.0, 0.0), 2.0, "anode") - Region.disc((0.0, 0.0), 1.0, "cathode")
    nodes = region.nodes(spacing)
    return region, nodes, MLSModel(nodes.position, MLSSettings(basis=basis, d_max=d_max), launcher=launcher)


def test_coaxial_vacuum_field_charges_and_a_floating_conductor(launcher):
    """Cathode r = 1 at 0, anode r = 2 at 1, no charge: u = ln r / ln 2; the surface field 1/ln 2 at r = 1 to second
    order (quadratic basis: 1.0e-2, 2.3e-3, 5.8e-4 at spacings 0.2, 0.1, 0.05); the electrodes' charges ∓2π/ln 2.
    The cathode floating with charge 2 inside the grounded anode: V = 2 ln 2 / 2π."""
    errors = []
    for spacing in (0.2, 0.1, 0.05):
        region, nodes, model = _coax(spacing, launcher=launcher)
        field = ElectrodeField(model, region, nodes, [Electrode("cathode", 0.0), Electrode("anode", 1.0)])
        u = field.solve(np.zeros(model.node_count))
        t = np.linspace(0.0, 2.0 * math.pi, 97)[:-1]
        surface = np.column_stack([np.cos(t), np.sin(t)])
        gradient = model.evaluate(u, model.shape_at(surface))[1].reshape(len(t), 2)
        errors.append(float(np.max(np.abs(np.linalg.norm(gradient, axis=1) * math.log(2.0) - 1.0))))
        assert field.charges == pytest.approx([-2 * math.pi / math.log(2.0), 2 * math.pi / math.log(2.0)], rel=1e-4)
    assert errors[-1] < 1e-3 and math.log2(errors[1] / errors[2]) > 1.7, errors
    inside = np.column_stack([np.linspace(1.1, 1.9, 9), np.zeros(9)])
    assert model.evaluate(u, model.shape_at(inside))[0].ravel() == pytest.approx(np.log(inside[:, 0]) / math.log(2.0),
                                                                                abs=1e-5)
    floating = ElectrodeField(model, region, nodes, [Electrode("cathode", None, charge=2.0), Electrode("anode", 0.0)])
    floating.solve(np.zeros(model.node_count))
    assert floating.potentials[0] == pytest.approx(2.0 * math.log(2.0) / (2.0 * math.pi), rel=1e-5)
    assert floating.charges[0] == pytest.approx(2.0, rel=1e-12)


def test_a_uniform_space_charge_between_grounded_cylinders(launcher):
    """ρ uniform between grounded r = 1 and r = 2: u = -ρ r²/4 + A ln r + B (u(1) = u(2) = 0), and the electrodes
    hold the opposite of the space charge, -ρ · 3π (Gauss), to the consistent integration's 1e-5."""
    region, nodes, model = _coax(0.1, launcher=launcher)
    field = ElectrodeField(model, region, nodes, [Electrode("cathode", 0.0), Electrode("anode", 0.0)])
    rho = 1.5
    u = field.solve(np.zeros(model.node_count), background_density=rho)
    a_coef = rho * 3.0 / (4.0 * math.log(2.0))
    r = np.linspace(1.05, 1.95, 10)
    exact = -rho * r ** 2 / 4 + a_coef * np.log(r) + rho / 4
    inside = np.column_stack([r, np.zeros_like(r)])
    assert model.evaluate(u, model.shape_at(inside))[0].ravel() == pytest.approx(exact, abs=1e-5)
    assert sum(field.charges) == pytest.approx(-rho * 3.0 * math.pi, rel=1e-4)


@pytest.mark.parametrize("electrodes,match", [
    ([Electrode("cathode", None), Electrode("anode", None)], "every electrode floats"),
    ([Electrode("plate", 0.0)], "no piece is tagged 'plate'"),
    ([Electrode("cathode", 0.0), Electrode(("anode", "cathode"), 1.0)], "belong to electrodes"),
    ([], "at least one electrode")])
def test_bad_electrodes_are_named(launcher, electrodes, match):
    region, nodes, model = _coax(0.25, "linear", 2.0, launcher)
    with pytest.raises(ParameterError, match=match):
        ElectrodeField(model, region, nodes, electrodes)


def _particles(position, velocity, device):
    n = len(position)
    arrays = pk.ParticleArrays()
    arrays.position = wp.array(np.asarray(position, float), dtype=wp.vec2d, device=device)
    arrays.velocity = wp.array(np.asarray(velocity, float), dtype=wp.vec2d, device=device)
    arrays.species = wp.zeros(n, dtype=wp.int32, device=device)
    arrays.particle_id = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device=device)
    arrays.position32 = wp.zeros(n, dtype=wp.vec3, device=device)
    arrays.exit_wall = wp.zeros(n, dtype=wp.int32, device=device)
    return arrays


def test_crossing_the_boundary_absorbs_at_electrodes_and_reflects_at_walls(launcher):
    """A square box (sides "box", reflecting) less a disc of radius 0.5 (an electrode): a particle whose step ends
    inside the disc is absorbed into the electrode's group; one that crosses a side is mirrored back with its normal
    velocity reversed (speed kept); one that crosses nothing is left alone; one whose step crosses the side and then
    the disc is reflected, then absorbed."""
    region = Region.rectangle((-2.0, -2.0), (2.0, 2.0), "box") - Region.disc((0.0, 0.0), 0.5, "target")
    boundary = ParticleBoundary(region, [Electrode("target", 0.0)], [Wall("box")], launcher, first_exit=10)
    assert boundary.names == ["target", "box"] and boundary.absorbs == [True, False]
    dt = 0.1
    # positions after the push (x^{n+1}); velocities v^{n+1/2}
    position = [[0.45, 0.0], [2.05, 1.0], [1.0, 1.0], [-1.0, 2.03], [0.0, -0.3]]
    velocity = [[-2.0, 0.0], [1.0, 0.5], [1.0, 1.0], [0.0, 0.5], [0.0, 3.0]]
    arrays = _particles(position, velocity, launcher.device)
    launcher.launch(pk.cross_boundary, len(position), [boundary.struct, wp.float64(dt), arrays])
    codes = arrays.exit_wall.numpy()
    x, v = arrays.position.numpy(), arrays.velocity.numpy()
    assert codes.tolist() == [10, 0, 0, 0, 10]
    assert x[1] == pytest.approx([1.95, 1.0], abs=1e-12) and v[1] == pytest.approx([-1.0, 0.5], abs=1e-12)
    assert x[2] == pytest.approx([1.0, 1.0]) and v[2] == pytest.approx([1.0, 1.0])
    assert x[3] == pytest.approx([-1.0, 1.97], abs=1e-12) and v[3] == pytest.approx([0.0, -0.5], abs=1e-12)


def test_electrons_fired_at_a_floating_target_charge_it_and_the_charge_is_kept(launcher):
    """A ring of cold electrons (r 1 to 1.5) moving inward at speed 1 inside a grounded square (sides "box",
    absorbing) around a floating disc (r = 0.5, uncharged): the target absorbs them; at every step the plasma's
    charge plus what each group absorbed is the loaded charge to round-off (integer counts), the target's charge
    is what it absorbed, its potential the one the field solve gives for that charge with no plasma left, and the
    plasma's charge and the electrodes' sum to zero to the consistent integration's 1e-4."""
    from warpfree.solvers.pic.solver import PICSolver
    from warpfree.solvers.pic.species import Species, load_in_region

    region = Region.rectangle((-2.0, -2.0), (2.0, 2.0), "box") - Region.disc((0.0, 0.0), 0.5, "target")
    nodes = region.nodes(0.2)
    model = MLSModel(nodes.position, MLSSettings(d_max=2.0), launcher=launcher)
    electrodes = [Electrode("box", 0.0), Electrode("target", None)]
    field = ElectrodeField(model, region, nodes, electrodes)
    angle = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
    radius = np.repeat([1.0, 1.25, 1.5], 64)
    direction = np.tile(np.column_stack([np.cos(angle), np.sin(angle)]), (3, 1))
    load = load_in_region(Species("electrons", -1.0, 1.0, 0.01), region, radius[:, None] * direction,
                          velocity=-direction)
    solver = PICSolver(field, [load], dt=0.05, background_density=0.0, gather="energy")
    for _ in range(40):
        solver.step(solver.dt)
    h = solver.history
    loaded = solver.initial_particle_charge
    kept = np.asarray(h["deposited_charge"]) + np.asarray(h["absorbed_charge_target"]) + np.asarray(h["absorbed_charge_box"])
    assert np.abs(kept - loaded).max() < 1e-12 * abs(loaded)
    assert h["particles"][-1] == 0 and h["absorbed_charge_target"][-1] < 0.9 * loaded
    assert h["charge_target"][-1] == pytest.approx(h["absorbed_charge_target"][-1], rel=1e-12)
    alone = ElectrodeField(model, region, nodes, [Electrode("box", 0.0), Electrode("target", None,
                                                                                    charge=h["charge_target"][-1])])
    alone.solve(np.zeros(model.node_count))
    assert h["potential_target"][-1] == pytest.approx(alone.potentials[1], rel=1e-10)
    total = np.asarray(h["deposited_charge"]) + np.asarray(h["charge_box"]) + np.asarray(h["charge_target"])
    assert np.abs(total).max() < 1e-4 * abs(loaded)


def test_a_cold_beam_leaves_a_curved_cathode_along_its_normal_and_the_anode_takes_it(launcher):
    """A cold beam (speed 1, a faint density: its space charge negligible, no voltage) from the cathode r = 1 of a
    coaxial region: every particle starts on the circle (within a step's travel) moving along its outward normal (its
    chord's: 4 096 of them) at the beam's speed,
    the source emits its particles a step, and once the beam has crossed (r 1 to 2: one time unit) the anode absorbs
    what the cathode emits; the charge in the region plus what each electrode absorbed is the emitted charge to
    round-off."""
    from warpfree.solvers.pic.emission import SurfaceSource
    from warpfree.solvers.pic.solver import PICSolver
    from warpfree.solvers.pic.species import Species

    region, nodes, model = _coax(0.25, "linear", 2.0, launcher)
    field = ElectrodeField(model, region, nodes, [Electrode("cathode", 0.0), Electrode("anode", 0.0)])
    beam = SurfaceSource(Species("electrons", -1.0, 1.0, 1e-8), "cathode", "beam", speed=1.0, particles_per_step=16)
    solver = PICSolver(field, [], dt=0.05, background_density=0.0, gather="energy", surface_sources=[beam])
    solver.step(solver.dt)
    p, v = solver.state.position.numpy()[:solver.count], solver.state.velocity.numpy()[:solver.count]
    r = np.linalg.norm(p, axis=1)
    assert solver.count == 16
    assert np.all((r > 1.0) & (r < 1.0 + 0.05 + 1e-5))
    assert v == pytest.approx(p / r[:, None], abs=1e-3)   # the chord's normal: within half its turn, 8e-4
    for _ in range(59):
        solver.step(solver.dt)
    h = solver.history
    emitted = np.asarray(h["injected_charge"])
    balance = np.asarray(h["deposited_charge"]) + np.asarray(h["absorbed_charge_anode"]) + np.asarray(
        h["absorbed_charge_cathode"]) - emitted
    assert np.abs(balance).max() < 1e-12 * abs(emitted[-1])
    assert h["absorbed_charge_cathode"][-1] == 0.0
    # the row of time k Δt counts k steps' emission, 16 particles each; the last 20 steps' (1 time unit) in flight
    weight, steps = solver.emitters[0].weight, len(emitted) - 1
    assert emitted[-1] == pytest.approx(-16 * steps * weight, rel=1e-12)
    assert h["absorbed_charge_anode"][-1] == pytest.approx(-16 * (steps - 20) * weight, rel=0.05)


def test_the_cylindrical_diode_draws_langmuir_blodgett_s_current(tmp_path):
    """The cathode emitting space-charge limited (Gauss's law on its multipliers) at a short size (nodes 0.05 apart
    at the cathode growing to 0.1, quadratic MLS, Δt 0.02, t = 10, 20 particles a step): the anode current within 4 %
    of Langmuir and Blodgett's (measured +2.3 %; the scene's defaults +1.3 %), almost none of the emission turned back
    to the cathode (measured 5e-4 of the current; a local estimate of σ over-emitted and returned most of it), the
    mean potential along a radius within 0.02 V (4.5e-3)."""
    from warpfree.scene_loader import load_scene

    summary = load_scene("pic_cylindrical_diode").build(node_spacing=0.1, cathode_spacing=0.05, t_end=10.0,
                                                         particles_per_step=20.0, frames=False,
                                                         vtk=False).run(str(tmp_path), progress=False)
    diode = summary["analysis"]["diode"]
    assert abs(diode["anode_over_langmuir_blodgett"] - 1.0) < 0.04, diode
    assert abs(diode["returned_over_langmuir_blodgett"]) < 1e-2
    assert diode["potential_max_error"] < 0.02
    assert diode["beta_squared"] == pytest.approx(0.2793, abs=1e-4)


def test_langmuir_blodgett_beta_squared_matches_their_table_and_series():
    """β² at r_a/r_c = 2, 5, 10, 100: 0.279, 0.767, 0.978, 1.078 (Langmuir & Blodgett 1923, Table I); near the cathode
    the series γ - 2γ²/5 + 11γ³/120 - 47γ⁴/3300; the planar limit of the current, 2π r_c (4/9) sqrt(2) V^{3/2}/d²."""
    from warpfree.validation.pic_cylindrical_diode import beta_squared, current_per_length

    for ratio, table in ((2.0, 0.279), (5.0, 0.767), (10.0, 0.978), (100.0, 1.078)):
        assert beta_squared(ratio) == pytest.approx(table, abs=6e-4)
    gamma = math.log(1.05)
    series = gamma - 0.4 * gamma ** 2 + 11 / 120 * gamma ** 3 - 47 / 3300 * gamma ** 4
    assert beta_squared(1.05) == pytest.approx(series ** 2, rel=1e-6)
    gap = 1e-3
    planar = 2 * math.pi * 1.0 * 4 / 9 * math.sqrt(2.0) / gap ** 2
    assert current_per_length(1.0, 1.0, 1.0 + gap) == pytest.approx(planar, rel=2e-3)


def test_the_cylindrical_diode_refuses_a_cathode_spacing_above_the_node_spacing():
    """The nodes grade from the cathode outward: a cathode spacing above the node spacing is named."""
    from warpfree.scene_loader import load_scene

    with pytest.raises(ParameterError, match="cathode_spacing.*must not exceed node_spacing"):
        load_scene("pic_cylindrical_diode").build(node_spacing=0.05, cathode_spacing=0.1)


def test_a_region_s_field_is_solved_on_the_host_by_default_on_a_gpu_too(monkeypatch):
    """With no ``field_solve`` given, a region's field goes to the host's SuperLU on any device (the device's solves
    are a box's: given a region's field they failed on a GPU, the cylindrical diode stopping at set-up); a box's goes
    to the device on a GPU. The launcher made to say it is not a CPU, as on a GPU."""
    from warpfree.scene_loader import load_scene
    from warpfree.solvers.pic.device_solve import FieldSolve
    from warpfree.solvers.pic.solver import default_field_solve

    assert default_field_solve(on_cpu=False, in_region=True) is FieldSolve.HOST
    assert default_field_solve(on_cpu=False, in_region=False) is FieldSolve.DEVICE
    assert default_field_solve(on_cpu=True, in_region=False) is FieldSolve.HOST
    monkeypatch.setattr(Launcher, "is_cpu", property(lambda self: False))
    scene = load_scene("pic_cylindrical_diode")
    run = scene.build(**scene.SMALLEST, frames=False, vtk=False)
    assert run.solver.coupling.field_solve is FieldSolve.HOST
