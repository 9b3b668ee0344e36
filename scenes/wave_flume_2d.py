"""Wave flume: a piston or flap wave maker makes regular waves, measured against linear wave-maker theory.

A flume of still water ``depth`` d deep and ``flume_length`` long, closed by a wall at its far end; at its near end
a paddle oscillates at the ``wave_period`` T with the stroke S (its full excursion at the still water level) that
Biesel's transfer function gives for the ``wave_height`` H asked for, S = H/(H/S)(kd), as a wave maker is driven,
reaching it over ``ramp`` periods (an envelope (1 - cos πt/t_ramp)/2). The paddle is a rigid body of wall particles
(``RigidBody`` with a ``PrescribedMotion``): a ``piston`` translates, a ``flap`` turns about a hinge on the bed.
The default wave, H = d/10 at kd = 1.02 (steepness H/L = 0.016), is weakly nonlinear: linear theory's regime.

Water gauges every L/8 from two depths off the paddle (past its evanescent modes) to one wavelength L further read
the surface every T/40 (``sensors/gauges.csv``). The analysis fits each gauge's first harmonic over the whole
periods between the steady waves' arrival at the last gauge (the ramp, then its group-velocity travel, then two
periods) and the return of the far wall's reflection (``warpfree.validation.wave_flume_2d``). It checks the height
the paddle makes, the gauges' heights fitted by H0 e^(-κx) at the paddle, within 5 % of H (Biesel's transfer
function), and the wavelength, from the phases along the gauges, within 2 % of the dispersion relation's; it reports
the height the waves lose over a wavelength (the fluid's dissipation: 3-6 % at 12-30 particles over the depth, 74-185
a wavelength) and each gauge's height, and draws ``waves.png``. A run too short for a whole period
in its window reports and checks nothing.

Model: WCSPH, Wendland C2, h = 1.6 dx, δ-SPH δ = 0.1, the laminar viscosity of water, no artificial viscosity,
dynamic (Adami 2012) wall particles, the paddle's acceleration in its wall pressure; c0 = ``sound_speed``
sqrt(g d) (the waves' celerity is about 0.9 sqrt(g d) at kd = 1: the compressibility shortens the wavelength by
about (c/c0)²/2, 0.4 % at c0 = 10 sqrt(g d)). The water starts at rest with its hydrostatic density.
"""

from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.geometry import lattice_box
from warpfree.parameters import Choice, CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import (BoundaryModel, FluidField, FluidParams, PrescribedMotion, RigidBody, WCSPHModel,
                                    WCSPHSolver)
from warpfree.solvers.wcsph.parameters import (Courant, DensityDiffusion, EndTime, FrameField, HFactor,
                                               OutputInterval, WallLayers, WallSafety)
from warpfree.solvers.wcsph.scene_tools import require_wall_cover
from warpfree.solvers.wcsph.sensors import WaterGauge
from warpfree.time_loop import TimeLoop
from warpfree.validation import wave_flume_2d as theory

#: the smallest run of this scene worth making (literal values only)
SMALLEST = {"n": 8, "flume_length": 5.0, "ramp": 0.0, "wave_height": 0.3, "t_end": 0.4, "output_interval": 0.2}

#: ``warpfree validate --quick``: 12 particles over the depth (under a minute on 2 cores)
QUICK = {"n": 12}

#: gauges per wavelength, and the samples a period
GAUGES_PER_WAVELENGTH = 8
SAMPLES_PER_PERIOD = 40
#: the first gauge's distance from the paddle, in depths (the evanescent modes have decayed by e^{-2π} there)
FIRST_GAUGE = 2.0
#: the spline points per period of the paddle's motion
MOTION_POINTS_PER_PERIOD = 40
G = 9.81


class Paddle(Choice):
    """The wave maker's motion."""

    PISTON = "piston", "a vertical plate moving back and forth"
    FLAP = "flap", "a plate turning about a hinge on the bed"


@checked_parameters
def build(n: Annotated[int, Param("", "particles over the water's depth (dx = depth/n)", "[4, inf)")] = 20,
          depth: Annotated[float, Param("m", "still water depth d", "(0, inf)")] = 0.5,
          wave_period: Annotated[float, Param("s", "the paddle's period T", "(0, inf)")] = 1.6,
          wave_height: Annotated[float, Param("m", "the wave height H the paddle is driven for (its stroke from "
                                                   "Biesel's transfer function)", "(0, inf)")] = 0.05,
          paddle: Annotated[Paddle, Param("", "the wave maker")] = Paddle.PISTON,
          ramp: Annotated[float, Param("T", "the paddle's stroke grows to S over this many periods", "[0, inf)")]
          = 2.0,
          flume_length: Annotated[float, Param("m", "from the paddle at rest to the far wall", "(0, inf)")] = 15.0,
          sound_speed: Annotated[float, Param("sqrt(gd)", "numerical speed of sound c0, in units of the long-wave "
                                                          "speed sqrt(g d)", "(0, inf)")] = 10.0,
          t_end: EndTime = 17.0, output_interval: OutputInterval = 0.2, h_factor: HFactor = 1.6,
          delta: DensityDiffusion = 0.1, wall_layers: WallLayers = 3, wall_safety: WallSafety = 0.75,
          cfl: Courant = 0.25, checkpoint_every: CheckpointEvery = 0, frames: Frames = True,
          frame_field: FrameField = FluidField.VELOCITY_X, vtk: Vtk = True) -> TimeLoop:
    """``n`` particles over the ``depth`` d (m); the paddle's ``wave_period`` (s) and ``wave_height`` (m); SI units."""
    params = dict(locals())
    dx = depth / n
    omega = 2.0 * np.pi / wave_period
    k = theory.wavenumber(omega, depth, G)
    wavelength = 2.0 * np.pi / k
    first_gauge = FIRST_GAUGE * depth
    gauges = first_gauge + wavelength * np.arange(GAUGES_PER_WAVELENGTH + 1) / GAUGES_PER_WAVELENGTH
    if gauges[-1] >= flume_length - depth:
        raise ParameterError("flume_length", f"must reach a depth past the last gauge, {gauges[-1]:.4g} m from the "
                                             f"paddle (two depths, then a wavelength of {wavelength:.4g} m)")
    stroke = wave_height / theory.transfer_function(paddle.value, k * depth)
    if not 0.5 * stroke < depth:
        raise ParameterError("wave_height", f"needs a stroke of {stroke:.4g} m: its half must be below the depth "
                                            f"{depth} m")
    support = 2.0 * h_factor * dx
    require_wall_cover(wall_layers, dx, support)
    c0 = sound_speed * np.sqrt(G * depth)
    w = wall_layers * dx
    top = depth + max(4.0 * stroke, 0.5 * depth)  # the paddle's and the far wall's top: above any crest
    t_ramp = ramp * wave_period

    def envelope(t):
        return 0.5 * (1.0 - np.cos(np.pi * t / t_ramp)) if t < t_ramp else 1.0

    times = np.arange(0.0, t_end + 2.0 * wave_period, wave_period / MOTION_POINTS_PER_PERIOD)
    if paddle is Paddle.PISTON:
        motion = PrescribedMotion(times, displacement=lambda t: (0.5 * stroke * envelope(t) * np.sin(omega * t), 0.0))
    else:  # turning clockwise (negative about z) moves the flap's top towards +x
        motion = PrescribedMotion(times, angle=lambda t: -np.arctan(0.5 * stroke * envelope(t) * np.sin(omega * t)
                                                                    / depth), centre=(0.0, 0.0, 0.0))
    back = 0.5 * stroke + w
    with reported_as(dx="n, wall_layers"):
        fluid = lattice_box((0.0, 0.0), (flume_length, depth), dx)
        walls = np.vstack([lattice_box((-back - w, -w), (flume_length + w, 0.0), dx),
                           lattice_box((flume_length, 0.0), (flume_length + w, top), dx)])
        plate = lattice_box((-w, 0.0), (0.0, top), dx)
    surface = np.array([(-w, 0.0), (0.0, 0.0), (0.0, top), (-w, top)])
    # the water at rest: hydrostatic density, p = ρ0 g (d - y) through the inverse Tait equation
    rho0, gamma = 1000.0, 7.0
    density = rho0 * (1.0 + gamma * G * (depth - fluid[:, 1]) / c0 ** 2) ** (1.0 / gamma)
    with reported_as(lj_r0="wall_safety"):
        fp = FluidParams(dim=2, dx=dx, h_factor=h_factor, rho0=rho0, c0=c0, mu=1.0e-3, alpha=0.0, delta=delta,
                         gravity=(0.0, -G, 0.0), boundary_model=BoundaryModel.DYNAMIC, cfl=cfl, lj_d=G * depth,
                         lj_r0=wall_safety * dx, container_lo=(-back, -0.5 * w, -1.0),
                         container_hi=(flume_length + 0.5 * w, top + 2.0 * depth, 1.0))
        model = WCSPHModel(fluid, walls, fp,
                           bodies=[RigidBody(plate, motion, surface=surface, name=paddle.value)],
                           containers=[np.array([(-back - w, 0.0), (flume_length, 0.0), (flume_length, top + 2 * depth),
                                                 (-back - w, top + 2 * depth)])])
    solver = WCSPHSolver(model, density=density)

    cg = theory.group_velocity(omega, k, depth)
    # steady waves at the last gauge: the ramp, the front's travel at c_g, two periods; the far wall's reflection
    # back at the last gauge after (2 L_f - x)/c_g
    window = (t_ramp + gauges[-1] / cg + 2.0 * wave_period, (2.0 * flume_length - gauges[-1]) / cg)

    def wave_analysis(run: TimeLoop, out_dir: str) -> dict:
        rows = np.asarray(run.sensor_rows["gauges"])
        t, elevation = rows[:, 0], rows[:, 1:]
        end = min(window[1], float(t[-1]))
        fit = theory.harmonics(t, elevation, omega, (window[0], end))
        res = {"paddle": paddle.value, "n": n, "dx": dx, "kd": k * depth, "c0": c0, "stroke": stroke,
               "gauges": gauges.tolist(),
               "window": [window[0], end], "periods_fitted": fit["periods"]}
        if fit["periods"] < 1:
            return {"waves": res}
        res.update(theory.wave_checks(gauges, fit, paddle.value, stroke, omega, depth, G,
                                      basis=f"{fit['periods']} periods fitted at n = {n} (dx = {dx:.4g} m)"))
        res["second_harmonic"] = np.asarray(fit["second"]).tolist()
        if out_dir is not None:
            theory.plot_waves(f"{out_dir}/waves.png", t, elevation, gauges, res, (window[0], end),
                              f"warpfree, {paddle.value}, n = {n}")
        return {"waves": res}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="wave_flume_2d", params=params,
                   analyses=[wave_analysis], checkpoint_every=checkpoint_every,
                   output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                        frame_bounds=((-back - w, min(flume_length + w, gauges[-1] + depth)),
                                                      (-w, top)),
                                        frame_range={"velocity_x": (-0.5 * omega * stroke, 0.5 * omega * stroke)}))
    run.add_sensor(WaterGauge("gauges", np.column_stack([gauges, np.zeros_like(gauges)]),
                              wave_period / SAMPLES_PER_PERIOD))
    return run
