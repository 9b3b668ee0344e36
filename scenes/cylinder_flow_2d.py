"""Flow past a circular cylinder between an inlet and an outlet: drag, wake length and shedding against the published.

A cylinder of diameter D = ``diameter`` (its centre at the origin) in a stream of speed U = Re ν/D: the water enters
``upstream`` D before the cylinder through an inlet at U (uniform) and leaves ``downstream`` D behind it through an
outlet held at the background pressure p_b = ``background`` ρU² (``warpfree.solvers.wcsph.openings``); across the
stream the space is periodic, ``width`` D wide (a row of cylinders ``width`` D apart: blockage D/W). The water starts
from the inviscid flow past the cylinder (``potential_flow``, with Bernoulli's pressure about p_b): it
meets the cylinder without the impact of an impulsive uniform start, and the no-slip surface then makes the boundary
layer and the wake. At Re = 20 the drag depends on the domain far beyond a few diameters: the defaults' domain keeps
that within 3 % (an inlet 6 D before the cylinder and a stream 12 D wide add 14 %; ``bench/results/cylinder_flow.md``).

The ``cylinder`` force sensor records the fluid's force on the cylinder's wall particles (the reaction to their wall
terms) every ``sensor_interval`` D/U (``sensors/cylinder.csv``); at every output the probe ``wake_length`` measures
the recirculating wake: the velocity interpolated along the centreline behind the cylinder (``field_at``), from its
rear to where it turns forward; the probes ``particles``, ``made`` and ``taken_out`` count the water and what the inlet
made and the outlet took out. Over the run's last ``averaged`` D/U the analysis takes the mean drag and lift
coefficients C = F/(ρU²D/2), the mean wake length and the Strouhal number f D/U of the lift's strongest frequency, and
checks them against the published values (``warpfree.validation.cylinder_flow_2d``): at Re = 20 (steady) the drag
within 5 % of Dennis & Chang's 2.045, the wake within 10 % of their 0.94 D and the mean lift within 0.02 of zero; at
Re = 100 (vortex shedding; give it t_end of about 150 D/U and ``averaged`` 60) the mean drag within 5 % of Park et al.'s
1.33 and St within 5 % of Williamson's 0.164; at other Reynolds numbers it reports them. It draws ``cylinder.png``.

Model: WCSPH with Morris' laminar viscosity, Wendland C2 with h = 1.6 dx, δ-SPH δ = 0.1, particle shifting A = 2 (the
stream's particles, strained round the cylinder, keep an even arrangement), dynamic (Adami 2012) wall particles in
rings inside the cylinder's true surface, no-slip; c0 = ``sound_speed`` U. The background pressure keeps the water's
pressure positive in the cylinder's wake (p falls about ρU² below the stream's there): water under tension opens voids
behind the cylinder.
"""

import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.geometry import circle_polygon, lattice_box
from warpfree.parameters import CheckpointEvery, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import BoundaryModel, FluidField, FluidParams, Opening, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.parameters import Courant, FrameField, RestDensity, Shifting, WallLayers
from warpfree.solvers.wcsph.scene_tools import clear_of, require_wall_cover, require_whole_spacings
from warpfree.solvers.wcsph.sensors import ForceSensor
from warpfree.solvers.wcsph.surface_layers import surface_layers
from warpfree.time_loop import TimeLoop
from warpfree.validation import cylinder_flow_2d as reference

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"per_diameter": 4, "upstream": 2.0, "downstream": 3.0, "width": 4.0, "t_end": 0.5,
            "output_interval": 0.25, "averaged": 0.5}

#: ``warpfree validate --quick``: 8 particles across the cylinder (the default 10; at 6 the wake is 11 % short and
#: the mean lift's noise 0.025)
QUICK = {"per_diameter": 8}

#: h = H_FACTOR dx, the kinematic viscosity (m²/s) and the centreline's samples per spacing
H_FACTOR, NU, SAMPLES_PER_DX = 1.6, 1.0e-6, 2


def potential_flow(points: np.ndarray, speed: float, radius: float) -> np.ndarray:
    """The inviscid stream U past a cylinder of ``radius`` at the origin, u = U (1 - R²(x² - y²)/r⁴),
    v = -2 U R² x y/r⁴ (m/s), at ``points`` ((N, 2), m): (N, 3). Its velocity along the surface and none through it;
    the water starts from it, so that it meets the cylinder without the impact an impulsive uniform start makes (a
    pressure pulse ρ c0 U that rings for tens of D/U)."""
    x, y = points[:, 0], points[:, 1]
    r4 = (x * x + y * y) ** 2
    velocity = np.zeros((len(points), 3))
    velocity[:, 0] = speed * (1.0 - radius ** 2 * (x * x - y * y) / r4)
    velocity[:, 1] = -2.0 * speed * radius ** 2 * x * y / r4
    return velocity


@checked_parameters
def build(per_diameter: Annotated[int, Param("", "particles across the cylinder (dx = D/per_diameter)", "[4, inf)")]
          = 10,
          diameter: Annotated[float, Param("m", "the cylinder's diameter D", "(0, inf)")] = 0.01,
          reynolds: Annotated[float, Param("", "Reynolds number U D/ν", "(0, 200]")] = 20.0,
          upstream: Annotated[float, Param("D", "the inlet's distance before the cylinder's centre", "[2, inf)")]
          = 12.0,
          downstream: Annotated[float, Param("D", "the outlet's distance behind the cylinder's centre", "[3, inf)")]
          = 14.0,
          width: Annotated[float, Param("D", "the periodic stream's width W (blockage D/W)", "[4, inf)")] = 24.0,
          sound_speed: Annotated[float, Param("U", "numerical speed of sound c0", "[5, inf)")] = 15.0,
          background: Annotated[float, Param("ρU²", "the outlet's (background) pressure p_b", "[0, inf)")] = 2.0,
          rho0: RestDensity = 1000.0,
          shifting: Shifting = 2.0,
          delta: Annotated[float, Param("", "δ-SPH density diffusion δ (0: off)", "[0, inf)")] = 0.1,
          wall_layers: WallLayers = 4,
          cfl: Courant = 0.2,
          t_end: Annotated[float, Param("D/U", "simulated time at which the run ends", "(0, inf)")] = 30.0,
          averaged: Annotated[float, Param("D/U", "the run's last stretch the forces and the wake are averaged over",
                                           "(0, inf)")] = 5.0,
          output_interval: Annotated[float, Param("D/U", "simulated time between outputs", "(0, inf)")] = 0.5,
          sensor_interval: Annotated[float, Param("D/U", "simulated time between the force sensor's samples",
                                                  "(0, inf)")] = 0.05,
          checkpoint_every: CheckpointEvery = 0, frames: Frames = True, frame_field: FrameField = FluidField.SPEED,
          vtk: Vtk = True) -> TimeLoop:
    """``per_diameter`` particles across the cylinder of diameter D = ``diameter`` (m) at Re = ``reynolds``; lengths in
    D, times in D/U, the background pressure in ρU²."""
    params = dict(locals())
    dx = diameter / per_diameter
    require_whole_spacings({"upstream": upstream, "downstream": downstream, "width": width}, per_diameter, "D",
                           "per_diameter")
    if averaged > t_end:
        raise ParameterError("averaged", f"must be at most t_end = {t_end} D/U, got {averaged}")
    if output_interval > averaged:
        raise ParameterError("output_interval", f"must be at most averaged = {averaged} D/U: the wake is averaged "
                                                f"over the outputs of the run's last {averaged} D/U")
    support = 2.0 * H_FACTOR * dx  # Wendland C2's support, 2h
    require_wall_cover(wall_layers, dx, support)
    speed = reynolds * NU / diameter
    time_unit = diameter / speed
    c0 = sound_speed * speed
    p_b = background * rho0 * speed ** 2
    skin = 0.15 * support  # FluidParams' default skin, a fraction of the support
    buffer = np.ceil((support + skin) / dx - 1e-9) * dx
    reach = buffer + skin + dx  # the container holds the buffers' far ends, the removal margin and the skin
    x_in, x_out, half = -upstream * diameter, downstream * diameter, 0.5 * width * diameter
    radius = 0.5 * diameter
    with reported_as(dx="per_diameter, upstream, downstream, width", layers="wall_layers"):  # guards before allocating
        lattice = lattice_box((x_in - buffer, -half), (x_out + buffer, half), dx)
        section = circle_polygon(radius, dx)
        fluid = clear_of(lattice, section, 0.5 * dx)
        rings = surface_layers(section, dx, wall_layers, "inside")
    fp = FluidParams(dim=2, dx=dx, h_factor=H_FACTOR, rho0=rho0, c0=c0, mu=rho0 * NU, delta=delta, shifting=shifting,
                     gravity=(0.0, 0.0, 0.0), boundary_model=BoundaryModel.DYNAMIC, no_slip=True, cfl=cfl,
                     container_lo=(x_in - reach, -half, -1.0), container_hi=(x_out + reach, half, 1.0),
                     periodic=(False, True, False))
    openings = [Opening(point=(x_in, 0.0), normal=(1.0, 0.0), velocity=(speed, 0.0), name="inlet"),
                Opening(point=(x_out, 0.0), normal=(-1.0, 0.0), pressure=p_b, name="outlet")]
    model = WCSPHModel(fluid, np.zeros((0, 2)), fp, obstacle_boundary=rings, obstacles=[section], openings=openings)
    velocity = potential_flow(fluid, speed, radius)
    pressure = p_b + 0.5 * rho0 * (speed ** 2 - np.einsum("ij,ij->i", velocity, velocity))  # Bernoulli's
    density = rho0 * (1.0 + fp.gamma * pressure / (rho0 * c0 ** 2)) ** (1.0 / fp.gamma)  # the Tait EOS inverted
    solver = WCSPHSolver(model, density=density, velocity=velocity)

    reach_behind = min(4.0 * diameter, x_out - 2.0 * buffer)  # the centreline from the rear, clear of the outlet
    centreline_x = np.arange(radius, reach_behind, dx / SAMPLES_PER_DX)
    centreline = np.column_stack([centreline_x, np.zeros_like(centreline_x)])
    last = {}

    def wake(s, t):
        u = s.field_at(centreline)["velocity"][:, 0]
        last["u"] = u
        return reference.wake_length(centreline_x, u, radius) / diameter

    def cylinder_analysis(run: TimeLoop, out_dir: str) -> dict:
        rows = np.asarray(run.sensor_rows["cylinder"])
        t = rows[:, 0] / time_unit
        drag = reference.force_coefficient(rows[:, 1], rho0, speed, diameter)
        lift = reference.force_coefficient(rows[:, 2], rho0, speed, diameter)
        start = run.time / time_unit - averaged
        window = t >= start - 1e-9
        times = np.asarray(run.series["time"]) / time_unit
        wakes = np.asarray(run.series["wake_length"])[times >= start - 1e-9]
        strouhal, lift_amplitude, cycles = reference.shedding(rows[window, 0], lift[window], diameter, speed)
        res = {"reynolds": reynolds, "speed": speed, "c0": c0, "background_pressure": p_b, "dx": dx,
               "averaged_from": start, "drag_mean": float(drag[window].mean()),
               "drag_range": float(np.ptp(drag[window])), "lift_mean": float(lift[window].mean()),
               "lift_amplitude": lift_amplitude, "lift_range": float(np.ptp(lift[window])),
               "wake_length": float(np.mean(wakes)),
               "wake_length_range": float(np.ptp(wakes)), "strouhal": strouhal, "shedding_cycles": cycles,
               "blockage": 1.0 / width}
        basis = (f"{per_diameter} particles across D, the stream {width:g} D wide, {upstream:g} D + {downstream:g} D "
                 f"long, averaged over the last {averaged:g} D/U of {t_end:g}")
        checks = reference.cylinder_checks(reynolds, res["drag_mean"], res["lift_mean"], res["wake_length"], strouhal,
                                           basis)
        if checks:
            res["checks"] = checks
        if out_dir is not None:
            reference.plot_cylinder(os.path.join(out_dir, "cylinder.png"), t, drag, lift, centreline_x / diameter,
                                    last.get("u", np.full_like(centreline_x, np.nan)) / speed, radius / diameter, res,
                                    f"warpfree, D = {per_diameter} dx")
        return {"cylinder": res}

    run = TimeLoop(solver, t_end=t_end * time_unit, output_interval=output_interval * time_unit,
                   name="cylinder_flow_2d", params=params,
                   probes={"wake_length": wake, "particles": lambda s, t: float(len(s.fluid.numpy("position"))),
                           "made": lambda s, t: float(s.opening_counts()["inlet"]["made"]),
                           "taken_out": lambda s, t: float(s.opening_counts()["outlet"]["taken_out"])},
                   analyses=[cylinder_analysis], checkpoint_every=checkpoint_every,
                   output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                        frame_bounds=((max(x_in, -4.0 * diameter), min(x_out, 12.0 * diameter)),
                                                      (-min(half, 4.0 * diameter), min(half, 4.0 * diameter))),
                                        frame_range={"speed": (0.0, 1.5 * speed)}))
    run.add_sensor(ForceSensor("cylinder", (0.0, 0.0), "obstacles", sensor_interval * time_unit))
    return run
