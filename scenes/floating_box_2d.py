"""Floating box: a box released above its draft settles where Archimedes' principle puts it and stays there.

A box ``breadth`` B wide and ``height`` H tall, of ``density`` ρ_b, floats in a tank 2 m wide with 0.4 m of water;
it is a rigid body of wall particles with its true surface (``RigidBody`` without a motion: its mass and inertia from
its polygon, moved by the fluid's load on it and its weight, free in x, y and rotation). Released ``drop`` above
Archimedes' draft T = (ρ_b/ρ0) H, it comes down while the water is settled with damping for ``settle`` s before
t = 0 (``WCSPHSolver.settle``: the water's and the box's velocities are then set to zero); from t = 0 it floats free.

Every 10 ms the ``body`` sensor records the box (``sensors/box.csv``: its centre of mass, angle, velocity and load) and
two water gauges 0.2 m from the side walls the level (``sensors/level.csv``). The analysis takes the draft as the
gauges' mean level less the box's bottom and checks its mean within 1 % of T, and the box at rest: its height within a
range of 1 mm, its sideways position within 1 cm, its angle within 0.01 rad
(``warpfree.validation.floating_box_2d``); it draws ``draft.png``. A box whose metacentric height is negative (a
square one at ρ_b = ρ0/2) rolls onto a corner, as it must, and fails the rest checks.

Model: WCSPH, Wendland C2, h = 1.6 dx, δ-SPH δ = 0.1, the laminar viscosity of water, dynamic (Adami 2012) wall
particles, c0 = 10 sqrt(g d); the water starts at rest with its hydrostatic density.
"""

from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.geometry import lattice_box
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import BoundaryModel, FluidField, FluidParams, RigidBody, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.parameters import EndTime, FrameField, OutputInterval, Spacing
from warpfree.solvers.wcsph.sensors import BodySensor, WaterGauge
from warpfree.time_loop import TimeLoop
from warpfree.validation import floating_box_2d as archimedes

#: the smallest run of this scene worth making (literal values only)
SMALLEST = {"dx": 0.05, "settle": 0.2, "t_end": 0.1, "output_interval": 0.05}

#: ``warpfree validate --quick``: the default run (about half a minute on 2 cores)
QUICK = {}

#: the tank: its width and the water's depth (m), gravity (m/s²), the water's density (kg/m³), the settling's damping
#: (1/s) and the sensors' interval (s)
WIDTH, DEPTH, G, RHO0, DAMPING, SENSOR_INTERVAL = 2.0, 0.4, 9.81, 1000.0, 5.0, 0.01


@checked_parameters
def build(dx: Spacing = 0.02,
          density: Annotated[float, Param("kg/m³", "the box's density (below the water's: it floats)",
                                          "(0, 1000)")] = 500.0,
          breadth: Annotated[float, Param("m", "the box's breadth B", "(0, 1.5)")] = 0.4,
          height: Annotated[float, Param("m", "the box's height H", "(0, 0.8)")] = 0.2,
          drop: Annotated[float, Param("m", "how far above Archimedes' draft the box is released", "[0, inf)")]
          = 0.02,
          settle: Annotated[float, Param("s", "the water settled with damping before t = 0 (0: none)", "[0, inf)")]
          = 3.0,
          t_end: EndTime = 1.0, output_interval: OutputInterval = 0.1, checkpoint_every: CheckpointEvery = 0,
          frames: Frames = True, frame_field: FrameField = FluidField.PRESSURE, vtk: Vtk = True) -> TimeLoop:
    """The box (``breadth``, ``height`` m, ``density`` kg/m³) released ``drop`` m above its draft; SI units."""
    params = dict(locals())
    draft = archimedes.archimedes_draft(density, RHO0, height)
    bottom = DEPTH - (draft - drop)
    if not 0.0 < bottom < DEPTH:
        raise ParameterError("drop", f"puts the box's bottom at {bottom:.4g} m, outside the water (0, {DEPTH}) m")
    if breadth + 0.5 > WIDTH:
        raise ParameterError("breadth", f"leaves the gauges no water: the tank is {WIDTH} m wide")
    c0 = 10.0 * np.sqrt(G * DEPTH)
    x0 = 0.5 * (WIDTH - breadth)
    w = 3 * dx
    with reported_as(dx="dx"):
        fluid = lattice_box((0.0, 0.0), (WIDTH, DEPTH), dx)
        fluid = fluid[~((fluid[:, 0] > x0) & (fluid[:, 0] < x0 + breadth) & (fluid[:, 1] > bottom))]
        walls = np.vstack([lattice_box((-w, -w), (WIDTH + w, 0.0), dx),
                           lattice_box((-w, 0.0), (0.0, DEPTH + height + 0.2), dx),
                           lattice_box((WIDTH, 0.0), (WIDTH + w, DEPTH + height + 0.2), dx)])
        particles = lattice_box((x0, bottom), (x0 + breadth, bottom + height), dx)
    surface = np.array([(x0, bottom), (x0 + breadth, bottom), (x0 + breadth, bottom + height), (x0, bottom + height)])
    top = 2.0 * (DEPTH + height)
    fp = FluidParams(dim=2, dx=dx, h_factor=1.6, rho0=RHO0, c0=c0, mu=1.0e-3, delta=0.1, gravity=(0.0, -G, 0.0),
                     boundary_model=BoundaryModel.DYNAMIC, cfl=0.25, lj_d=G * DEPTH, lj_r0=0.75 * dx,
                     container_lo=(-w, -w, -1.0), container_hi=(WIDTH + w, top, 1.0))
    water = RHO0 * (1.0 + 7.0 * G * (DEPTH - fluid[:, 1]) / c0 ** 2) ** (1.0 / 7.0)
    model = WCSPHModel(fluid, walls, fp, bodies=[RigidBody(particles, None, surface=surface, density=density,
                                                           name="box")],
                       containers=[np.array([(0.0, 0.0), (WIDTH, 0.0), (WIDTH, top), (0.0, top)])])
    solver = WCSPHSolver(model, density=water)
    settled = solver.settle(settle, DAMPING) if settle > 0 else {}

    def floating_analysis(run: TimeLoop, out_dir: str) -> dict:
        box = np.asarray(run.sensor_rows["box"])
        level = np.asarray(run.sensor_rows["level"])[:, 1:].mean(axis=1)
        t, x, y, angle = box[:, 0], box[:, 1], box[:, 2], box[:, 3]
        measured = level - (y - 0.5 * height)
        res = {"draft_archimedes": draft, "draft_mean": float(measured.mean()),
               "draft_error": float(measured.mean() / draft - 1.0), "heave_range": float(np.ptp(y)),
               "sway_range": float(np.ptp(x)), "largest_angle": float(np.max(np.abs(angle))),
               "metacentric_height": archimedes.metacentric_height(breadth, height, draft), "settling": settled,
               "checks": archimedes.checks(measured, x, y, angle, draft,
                                           f"dx = {dx} m, {t[-1]:.3g} s free after {settle} s of settling")}
        if out_dir is not None:
            archimedes.plot_draft(f"{out_dir}/draft.png", t, measured, x, angle, draft, f"warpfree, dx = {dx} m")
        return {"floating": res}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="floating_box_2d", params=params,
                   analyses=[floating_analysis], checkpoint_every=checkpoint_every,
                   output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                        frame_bounds=((-w, WIDTH + w), (-w, DEPTH + height + 0.2)),
                                        frame_range={"pressure": (0.0, RHO0 * G * DEPTH)}))
    run.add_sensor(BodySensor("box", 0, SENSOR_INTERVAL))
    run.add_sensor(WaterGauge("level", [(0.2, 0.0), (WIDTH - 0.2, 0.0)], SENSOR_INTERVAL))
    return run
