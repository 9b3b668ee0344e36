"""Rigid bodies with a prescribed motion (``RigidBody``, ``PrescribedMotion``): the motion's spline, a tank lifted
with an acceleration against the same tank at rest under the summed gravity, a tank carried far across its tables'
cells, a resumed run, the flume's paddle sensor, bodies that sink and float (2D and 3D), and bad bodies named; the
floating box and the flume at their validation sizes are run and checked by CI's `warpfree validate --quick`."""


import numpy as np
import pytest

from helpers.runs import cut_and_resumed
from warpfree import device
from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.geometry import lattice_box
from warpfree.scene_loader import load_scene
from warpfree.solvers.wcsph import FluidParams, PrescribedMotion, RigidBody, WCSPHModel, WCSPHSolver

G = 9.81


def test_a_prescribed_motion_is_a_clamped_spline_through_its_table():
    """Through every point of the table, at rest before and after it, and a sine sampled 40 times a period within
    1e-5 of its amplitude between the points away from the ends (where the clamped ends bring it to rest)."""
    times = np.linspace(0.0, 2.0, 81)
    motion = PrescribedMotion(times, displacement=lambda t: (0.1 * np.sin(2 * np.pi * t), 0.0), angle=times ** 2)
    spline = motion.spline(2)
    assert spline.shape == (80, 4, 4)
    for p in (0, 17, 79):
        np.testing.assert_allclose(spline[p, 0, 0], 0.1 * np.sin(2 * np.pi * times[p]), atol=1e-15)
        np.testing.assert_allclose(spline[p, 3, 0], times[p] ** 2, atol=1e-15)
    t = np.linspace(0.0, 2.0, 1001)[1:-1]
    x = np.array([motion.at(s, 2)[0][0] for s in t])
    inner = (t > 0.2) & (t < 1.8)
    assert np.max(np.abs(x - 0.1 * np.sin(2 * np.pi * t))[inner]) < 1e-5 * 0.1
    assert motion.at(-1.0, 2)[0][0] == motion.at(0.0, 2)[0][0] and motion.at(5.0, 2)[1] == pytest.approx(4.0)


def the_tank(motion=None, gravity=-G, dx=0.01):
    """A tank 0.2 m wide with 0.1 m of water at its hydrostatic density, its walls a rigid body moving by ``motion``
    (or at rest, walls of the container, without one); δ-SPH with the renormalised density gradient."""
    device.use("cpu", 2)
    width, depth, w, c0 = 0.2, 0.1, 3 * dx, 20.0
    fluid = lattice_box((0.0, 0.0), (width, depth), dx)
    walls = np.vstack([lattice_box((-w, -w), (width + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, depth + 0.1), dx),
                       lattice_box((width, 0.0), (width + w, depth + 0.1), dx)])
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=1e-3, delta=0.1, delta_gradient=True, gravity=(0.0, gravity, 0.0),
                         container_lo=(-1.0, -1.0, -1.0), container_hi=(20.0, 20.0, 1.0))
    density = 1000.0 * (1.0 + 7.0 * -gravity * (depth - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    if motion is None:
        return WCSPHSolver(WCSPHModel(fluid, walls, params), density=density)
    return WCSPHSolver(WCSPHModel(fluid, np.zeros((0, 2)), params, bodies=[RigidBody(walls, motion)]),
                       density=density)


def run_to(solver, stop, t=0.0):
    """Step ``solver`` from ``t`` to ``stop`` (s), its status checked at every step; the time reached."""
    while t < stop - 1e-12:
        dt = min(solver.stable_dt(), stop - t)
        solver.step(dt)
        t += dt
        assert solver.problem() is None
    return t


def bottom_pressures(solver, lift=0.0):
    """The water's pressure (Pa) at five points one spacing above the tank's floor (raised by ``lift``)."""
    points = np.column_stack([np.linspace(0.04, 0.16, 5), np.full(5, 0.01 + lift)])
    return solver.field_at(points)["pressure"]


def lift_motion(acceleration, ramp, until):
    """Upwards from rest: the acceleration rising linearly to ``acceleration`` over ``ramp`` s, then constant."""
    def height(t):
        if t < ramp:
            return acceleration * t ** 3 / (6.0 * ramp)
        return acceleration * (ramp ** 2 / 6.0 + 0.5 * ramp * (t - ramp) + 0.5 * (t - ramp) ** 2)
    times = np.linspace(0.0, until, int(until / 0.0025) + 1)
    return PrescribedMotion(times, displacement=lambda t: (0.0, height(t))), height


def test_a_tank_lifted_with_an_acceleration_holds_its_water_as_under_the_summed_gravity():
    """The tank, a rigid body, accelerates upwards at A = 5 m/s² (reached over 0.2 s): at t = 0.6 s (1.0 m up, the
    walls 100 spacings from where the tables were first built, rebuilt on the way) the water's pressure near the floor
    is that of the same tank at rest under g + A, within 1 %. Measured: 0.33 %. The walls' acceleration enters their
    Adami pressure; the fluid itself knows nothing of the motion but through the walls. δ-SPH is corrected by the
    renormalised density gradient: its hydrostatic form assumes the density gradient of gravity alone, ρ0 g/c0², and
    diffuses the rest of the lifted water's, ρ0 A/c0² (measured with it: the pressure falls steadily, 1.3 % low at
    0.45 s, 2.3 % at 0.6 s, 3.6 % at 1 s)."""
    acceleration = 5.0
    motion, height = lift_motion(acceleration, 0.2, 1.0)
    lifted = the_tank(motion)
    run_to(lifted, 0.6)
    at_rest = the_tank(gravity=-(G + acceleration))
    run_to(at_rest, 0.6)
    p_lifted, p_rest = bottom_pressures(lifted, height(0.6)), bottom_pressures(at_rest)
    assert lifted.moving_neighbours.builds > 20
    assert np.all(np.abs(p_lifted / p_rest - 1.0) < 0.01), (p_lifted, p_rest)
    # and not what the tank under g alone holds: 1000 (g + A) against 1000 g
    assert np.all(p_lifted / bottom_pressures(the_tank(), 0.0) > 1.3)


def carried_tank(distance=1.0, duration=1.0):
    """The tank carried ``distance`` along x over ``duration`` s from rest to rest (the minimum-jerk profile
    x = D (10 s³ - 15 s⁴ + 6 s⁵), s = t/T), its true surface following it and holding the water."""
    def x(t):
        s = min(max(t / duration, 0.0), 1.0)
        return (distance * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5), 0.0)
    motion = PrescribedMotion(np.linspace(0.0, duration, 201), displacement=x)
    device.use("cpu", 2)
    dx, width, depth, w, c0 = 0.01, 0.2, 0.1, 0.03, 20.0
    fluid = lattice_box((0.0, 0.0), (width, depth), dx)
    walls = np.vstack([lattice_box((-w, -w), (width + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, depth + 0.1), dx),
                       lattice_box((width, 0.0), (width + w, depth + 0.1), dx)])
    surface = np.array([(0.0, 0.0), (width, 0.0), (width, 1.0), (0.0, 1.0)])
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=1e-3, delta=0.1, delta_gradient=True,
                         container_lo=(-1.0, -1.0, -1.0), container_hi=(20.0, 20.0, 1.0))
    density = 1000.0 * (1.0 + 7.0 * G * (depth - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    body = RigidBody(walls, motion, surface=surface, holds_fluid=True, name="tank")
    return WCSPHSolver(WCSPHModel(fluid, np.zeros((0, 2)), params, bodies=[body]), density=density)


def test_a_tank_carried_from_rest_to_rest_takes_its_water_along_and_keeps_it():
    """Carried 1 m (100 spacings, 30 supports) in 1 s, peak speed 1.9 m/s and acceleration 5.8 m/s²: the water
    sloshes but stays in the tank, audited every 0.25 s against the tank's true surface, which moves with it (a
    surface left behind would find every particle outside it); the walls end 1 m on; the water's centre, averaged
    over one period of the sloshing mode (0.53 s) once the tank rests, is 1 m on within 1 mm while it sloshes by
    ±1 cm (measured: 0.01 mm)."""
    tank = carried_tank()
    start = tank.fluid.numpy("position").astype(np.float64).mean(axis=0)
    t, audit_at, centre = 0.0, 0.25, []
    while t < 1.73:
        tank.step(tank.stable_dt())
        t = float(tank.clock.time)
        assert tank.problem() is None
        if t >= audit_at:
            assert tank.audit() is None, t
            audit_at += 0.25
        if t >= 1.2 and (not centre or t - centre[-1][0] >= 0.01):
            centre.append((t, tank.fluid.numpy("position").astype(np.float64).mean(axis=0)[0] - start[0]))
    along = np.array([c[1] for c in centre])
    assert along.max() - along.min() > 0.01                      # it sloshes
    assert abs(along.mean() - 1.0) < 1e-3, along.mean()
    walls = tank.obstacle.numpy("position").astype(np.float64)
    np.testing.assert_allclose(walls.min(axis=0)[:2], [1.0 - 0.03 + 0.005, -0.03 + 0.005], atol=1e-5)


def test_a_3d_tank_lifted_carries_its_mesh_and_its_water():
    """A 3D tank (its walls' particles and its watertight box mesh, holding the water) lifted 0.3 m from rest to rest
    in 0.5 s, higher than its own height: the mesh follows the body (refitted each step), so the audit against it
    finds no water outside it at every 0.1 s (a mesh left in place would find all of it outside by the end), and the
    water ends 0.3 m up with it, within a spacing."""
    from warpfree.geometry import box_mesh

    device.use("cpu", 2)
    dx, w, c0 = 0.02, 0.06, 20.0
    fluid = lattice_box((0.0, 0.0, 0.0), (0.12, 0.12, 0.08), dx)
    outer = lattice_box((-w, -w, -w), (0.12 + w, 0.12 + w, 0.2), dx)
    inside = np.all((outer > 0.0) & (outer < [0.12, 0.12, 1.0]), axis=1)
    walls = outer[~inside]

    def z(t):
        s = min(max(t / 0.5, 0.0), 1.0)
        return (0.0, 0.0, 0.3 * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5))

    tank = RigidBody(walls, PrescribedMotion(np.linspace(0.0, 0.5, 101), displacement=z),
                     surface=box_mesh((0.0, 0.0, 0.0), (0.12, 0.12, 0.2)), holds_fluid=True)
    params = FluidParams(dim=3, dx=dx, c0=c0, mu=1e-3, delta=0.1, delta_gradient=True, gravity=(0.0, 0.0, -G),
                         container_lo=(-1.0, -1.0, -1.0), container_hi=(1.0, 1.0, 2.0))
    density = 1000.0 * (1.0 + 7.0 * G * (0.08 - fluid[:, 2]) / c0 ** 2) ** (1.0 / 7.0)
    solver = WCSPHSolver(WCSPHModel(fluid, np.zeros((0, 3)), params, bodies=[tank]), density=density)
    start = solver.fluid.numpy("position").astype(np.float64).mean(axis=0)
    t = 0.0
    for stop in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6):
        t = run_to(solver, stop, t)
        assert solver.audit() is None, stop
    moved = solver.fluid.numpy("position").astype(np.float64).mean(axis=0) - start
    assert abs(moved[2] - 0.3) < dx and np.all(np.abs(moved[:2]) < 0.1 * dx), moved


@pytest.mark.parametrize("make, parameter", [
    (lambda w: PrescribedMotion([0.0], displacement=[(0.0, 0.0)]), "times"),
    (lambda w: PrescribedMotion([0.0, 1.0, 0.5]), "times"),
    (lambda w: PrescribedMotion([0.0, 1.0], axis=(0.0, 0.0, 0.0)), "axis"),
    (lambda w: RigidBody(w, PrescribedMotion([0.0, 1.0], displacement=[(0.0, 0.0, 0.0, 0.0)] * 2)), "displacement"),
    (lambda w: RigidBody(w, PrescribedMotion([0.0, 1.0], angle=[0.0, np.nan])), "angle"),
    (lambda w: RigidBody(w, PrescribedMotion([0.0, 1.0], angle=[0.0, 1.0], axis=(1.0, 0.0, 0.0))), "axis"),
    (lambda w: RigidBody(np.zeros((0, 2)), PrescribedMotion([0.0, 1.0])), "bodies"),
    (lambda w: RigidBody(w, None), "density"),
    (lambda w: RigidBody(w, None, density=500.0), "bodies"),
    (lambda w: RigidBody(w, None, surface=[(0.0, 0.0), (0.1, 0.0), (0.1, 0.1)], density=500.0, free=("rx",)), "free"),
    (lambda w: RigidBody(w, "piston"), "bodies"),
])
def test_a_bad_body_is_named_before_any_set_up(make, parameter):
    device.use("cpu", 1)
    walls = lattice_box((-0.03, -0.03), (0.23, 0.0), 0.01)
    fluid = lattice_box((0.0, 0.0), (0.2, 0.1), 0.01)
    params = FluidParams(dim=2, dx=0.01, c0=20.0, container_lo=(-1.0, -1.0, -1.0), container_hi=(1.0, 1.0, 1.0))
    with pytest.raises(ParameterError) as err:
        WCSPHModel(fluid, np.zeros((0, 2)), params, bodies=[make(walls)])
    assert err.value.name == parameter


def test_a_body_s_walls_take_no_surface_velocity():
    device.use("cpu", 1)
    walls = lattice_box((-0.03, -0.03), (0.23, 0.0), 0.01)
    fluid = lattice_box((0.0, 0.0), (0.2, 0.1), 0.01)
    params = FluidParams(dim=2, dx=0.01, c0=20.0, container_lo=(-1.0, -1.0, -1.0), container_hi=(1.0, 1.0, 1.0))
    with pytest.raises(ParameterError) as err:
        WCSPHModel(fluid, np.zeros((0, 2)), params, wall_velocity=(1.0, 0.0),
                   bodies=[RigidBody(walls, PrescribedMotion([0.0, 1.0]))])
    assert err.value.name == "wall_velocity"


@pytest.mark.parametrize("setting, parameter", [("wave_height=2.0", "wave_height"), ("flume_length=3", "flume_length"),
                                                ("paddle=wedge", "paddle"), ("n=2", "n")])
def test_the_wave_flume_names_a_bad_setting_in_one_line(setting, parameter, capsys, tmp_path):
    assert main(["run", "wave_flume_2d", "--set", setting, "--out", str(tmp_path / "run"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"warpfree: error: {parameter}"), err
    assert not (tmp_path / "run").exists() or not any((tmp_path / "run").iterdir())  # nothing written


def test_a_floating_body_resumes_bitwise(tmp_path):
    """The floating box's run cut after a checkpoint and resumed ends with the uninterrupted run's state (the
    bodies' state and their state at the last table build included) and its body sensor's rows, bitwise."""
    device.use("cpu", 2)

    def build():
        run = load_scene("floating_box_2d").build(dx=0.04, settle=0.0, t_end=0.3, output_interval=0.1, frames=False,
                                                  vtk=False)
        run.checkpoint_every = 40
        return run

    full, resumed = cut_and_resumed(build, tmp_path)
    a, b = full.solver.state.numpy(), resumed.solver.state.numpy()
    assert "body_state" in a and "body_state_at_build" in a
    for key in a:
        assert np.array_equal(a[key], b[key]), key
    assert np.array_equal(np.asarray(resumed.sensor_rows["box"]), np.asarray(full.sensor_rows["box"]))


def test_a_body_sensor_records_the_paddle_where_its_motion_puts_it(tmp_path):
    """``--sensor paddle=body:0`` on the flume's smallest run: the piston's x at every sample is its prescribed
    displacement (the motion's spline at the sample's time, float64 on the device) to round-off, y and the angle do not
    move, and the columns carry their units."""
    from warpfree.validation import wave_flume_2d as flume

    module = load_scene("wave_flume_2d")
    sets = [a for k, v in module.SMALLEST.items() for a in ("--set", f"{k}={v}")]
    assert main(["run", "wave_flume_2d", *sets, "--set", "vtk=false", "--no-frames", "--no-progress",
                 "--sensor", "paddle=body:0@0.02", "--out", str(tmp_path / "run")]) == 0
    lines = (tmp_path / "run" / "sensors" / "paddle.csv").read_text().splitlines()
    assert lines[0].startswith("time [s],x [m],y [m],angle [rad],vx [m/s],vy [m/s],spin [rad/s],force_x [N/m]")
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert len(rows) >= 15
    params = {**module.SMALLEST}
    depth, period, height = 0.5, 1.6, params["wave_height"]
    omega = 2 * np.pi / period
    stroke = height / flume.transfer_function("piston", flume.wavenumber(omega, depth) * depth)
    times = np.arange(0.0, params["t_end"] + 2 * period, period / 40)
    motion = PrescribedMotion(times, displacement=lambda t: (0.5 * stroke * np.sin(omega * t), 0.0))
    expected = np.array([motion.at(t, 2)[0][0] for t in rows[:, 0]])
    np.testing.assert_allclose(rows[:, 1] - rows[0, 1], expected - expected[0], atol=1e-9)
    assert np.ptp(rows[:, 2]) == 0.0 and np.all(rows[:, 3] == 0.0)


def test_a_body_denser_than_water_sinks_and_rests_on_the_floor():
    """A box 0.2 × 0.1 m of density 2000 kg/m³ released at mid-depth sinks (at about 0.6 m/s), lands and rests on the
    floor: its contact with the tank's true surface keeps its own surface one spacing above the floor's (one layer of
    water, the last the resolution holds, stays under it) within 1 mm, its vertical speed below 1 cm/s, it turns by
    less than 0.01 rad, and no water is inside any solid (the tank's surface or the box's). Measured (dx = 0.02 m, at
    1.2-1.6 s): its bottom 19.86-19.93 mm above the floor, at most 5.7 mm/s up or down, 0.35 mrad. The contact has
    no friction: the box slides with the water's sloshing (up to 1.9 cm/s; 2.5 cm by 2 s)."""
    device.use("cpu", 2)
    dx, width, depth, height, breadth = 0.02, 1.0, 0.4, 0.1, 0.2
    c0 = 10.0 * np.sqrt(G * depth)
    x0, y0 = 0.5 * (width - breadth), 0.2
    fluid = lattice_box((0.0, 0.0), (width, depth), dx)
    fluid = fluid[~((fluid[:, 0] > x0) & (fluid[:, 0] < x0 + breadth) & (fluid[:, 1] > y0) & (fluid[:, 1] < y0 + height))]
    w = 3 * dx
    walls = np.vstack([lattice_box((-w, -w), (width + w, 0.0), dx), lattice_box((-w, 0.0), (0.0, depth + 0.3), dx),
                       lattice_box((width, 0.0), (width + w, depth + 0.3), dx)])
    surface = np.array([(x0, y0), (x0 + breadth, y0), (x0 + breadth, y0 + height), (x0, y0 + height)])
    box = RigidBody(lattice_box((x0, y0), (x0 + breadth, y0 + height), dx), None, surface=surface, density=2000.0)
    params = FluidParams(dim=2, dx=dx, c0=c0, mu=1e-3, delta=0.1, cfl=0.25, lj_d=G * depth, lj_r0=0.75 * dx,
                         container_lo=(-w, -w, -1.0), container_hi=(width + w, 2.0, 1.0))
    water = 1000.0 * (1.0 + 7.0 * G * (depth - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    solver = WCSPHSolver(WCSPHModel(fluid, walls, params, bodies=[box],
                                    containers=[np.array([(0.0, 0.0), (width, 0.0), (width, 2.0), (0.0, 2.0)])]),
                         density=water)
    t = run_to(solver, 1.2)
    assert solver.audit() is None
    rest = []
    while t < 1.6:
        t = run_to(solver, t + 0.01, t)
        row = solver.body_state()[0]
        rest.append((row[1] - 0.5 * height, abs(row[8]), 2.0 * np.arctan2(row[5], row[6]), abs(row[7])))
    rest = np.array(rest)
    assert np.all(np.abs(rest[:, 0] - dx) < 1e-3), rest[:, 0]
    assert rest[:, 1].max() < 0.01 and np.abs(rest[:, 2]).max() < 0.01
    assert solver.audit() is None


def test_a_3d_floating_box_settles_at_archimedes_draft_upright():
    """3D: a box 0.2 × 0.2 × 0.1 m of density 500 kg/m³ (draft 5 cm; its mass and inertia from its mesh) released
    1 cm too high in a tank 0.6 m square, free in all six degrees of freedom, the water settled with damping for
    1.5 s, then 0.3 s free: its draft (the level at four gauges off the box less its bottom) is Archimedes' within 5 %,
    it is upright within 0.02 rad and has not drifted by a spacing; its mass and inertia are the mesh's. Measured
    (dx = 0.025 m, the draft two spacings, h = 1.3 dx): −3.98 %, 2.45 mrad, 0.13 mm (after 1 s of settling, −8.2 %:
    not yet settled)."""
    from warpfree.geometry import box_mesh

    device.use("cpu", 2)
    dx, side, depth, breadth, height, density, drop = 0.025, 0.6, 0.3, 0.2, 0.1, 500.0, 0.01
    c0 = 10.0 * np.sqrt(G * depth)
    draft = density / 1000.0 * height
    lo = np.array([0.5 * (side - breadth), 0.5 * (side - breadth), depth - (draft - drop)])
    hi = lo + [breadth, breadth, height]
    fluid = lattice_box((0.0, 0.0, 0.0), (side, side, depth), dx)
    fluid = fluid[~np.all((fluid > lo) & (fluid < hi), axis=1)]
    w = 3 * dx
    outer = lattice_box((-w, -w, -w), (side + w, side + w, depth + 0.2), dx)
    walls = outer[~np.all((outer > 0.0) & (outer < [side, side, 10.0]), axis=1)]
    box = RigidBody(lattice_box(lo, hi, dx), None, surface=box_mesh(lo, hi), density=density)
    params = FluidParams(dim=3, dx=dx, c0=c0, mu=1e-3, delta=0.1, cfl=0.25, gravity=(0.0, 0.0, -G),
                         lj_d=G * depth, lj_r0=0.75 * dx, container_lo=(-w, -w, -w), container_hi=(side + w, side + w, 1.0))
    water = 1000.0 * (1.0 + 7.0 * G * (depth - fluid[:, 2]) / c0 ** 2) ** (1.0 / 7.0)
    solver = WCSPHSolver(WCSPHModel(fluid, walls, params, bodies=[box],
                                    containers=[box_mesh((0.0, 0.0, 0.0), (side, side, 1.0))]), density=water)
    bodies = solver.model.bodies
    assert bodies.mass[0] == pytest.approx(density * breadth * breadth * height)
    np.testing.assert_allclose(np.diag(bodies.inertia[0]), bodies.mass[0] / 12.0 * np.array(
        [breadth ** 2 + height ** 2, breadth ** 2 + height ** 2, 2 * breadth ** 2]), rtol=1e-9)
    solver.settle(1.5, 5.0)
    run_to(solver, 0.3)
    from warpfree.solvers.wcsph.sensors import WaterGauge

    row = solver.body_state()[0]
    gauges = WaterGauge("level", [(0.1, 0.1, 0.0), (0.5, 0.1, 0.0), (0.1, 0.5, 0.0), (0.5, 0.5, 0.0)], 0.01)
    gauges.check(solver)
    level = float(gauges.sample(solver).mean())
    measured = level - (row[2] - 0.5 * height)
    tilt = 2.0 * np.arccos(min(abs(row[6]), 1.0))
    moved = np.hypot(row[0] - 0.5 * side, row[1] - 0.5 * side)
    message = f"draft {measured:.5f} against {draft} ({measured / draft - 1:+.4f}), tilt {tilt:.2e} rad, moved " \
              f"{moved:.2e} m"
    assert abs(measured / draft - 1.0) < 0.05 and tilt < 0.02 and moved < dx, message
    assert solver.audit() is None
