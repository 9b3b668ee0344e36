"""A channel between an inlet and an outlet: water in at a set velocity, out at a set pressure, against Poiseuille.

A channel of width H = ``width`` between no-slip walls, ``lengths`` widths long between its two openings, no gravity.
At x = 0 an inlet lets the water in at a uniform velocity U (a buffer of particles moving at U, reached smoothly over
``ramp``); at x = L an outlet holds the pressure at 0 (a buffer whose particles take the water's velocity mirrored
across its plane and the set pressure continued with the water's gradient: ``warpfree.solvers.wcsph.openings``). The
water starts at rest. It develops the steady Poiseuille profile u(y) = 6U y(H - y)/H², u_max = 3U/2, within about
0.6 H + 0.05 Re H of the inlet; its flux is the inlet's.

Measured at every output, over the particles from 2 H downstream of the inlet to 1 H before the outlet (the flow from
the uniform inlet has developed there: its last deviation decays as e^(-4.2 x/H)): the mean velocity U' of the
Poiseuille profile that fits them best (least squares) and the velocity averaged in ``bins`` bins across against
that profile averaged over the same particles, in units of u_max (``bin_error_K``, ``profile_error_max``,
``profile_error_rms``, ``u_bin_K``); the fluid particles in the domain (between the planes) and in all, and the
particles each opening made and took out. The analysis averages over the outputs of the run's last 0.5 H²/ν (from
3.5 H²/ν at the default ``t_end`` = 4 H²/ν, when the water that came in through the inlet fills the measured
stretch; a weakly compressible channel between a set velocity and a set pressure also rings with its slowest sound
mode, about 1 % of u_max from one output to the next, which the average takes out) and checks
(``warpfree.validation.channel_flow_2d``):

- the profile's shape: the averaged bin errors within 1 % of u_max;
- the mass balance: the particles that entered through the inlet and those that left through the outlet over the
  same outputs, equal within one buffer column (n particles);
- every particle accounted for: the count at the end is the first plus those made less those taken out.

The analysis also reports U'/U, the flux the measured stretch carries over the inlet's (0.3-1.2 % above 1: the weakly
compressible water is lighter and faster where its pressure has fallen), and the pressure drop between the planes (a
straight line fitted to the particles' pressure in the measured stretch) against 12 μ U L/H², not checked (the
channel's sound mode rings through it), and writes ``channel.png``.

Model: WCSPH with Morris' laminar viscosity, Wendland C2 with h = 1.6 dx, dynamic (Adami 2012) walls, no-slip, particle
shifting (A = 2): the water that enters at a uniform velocity is strained as the profile develops (its rows stretch
along the centre and bunch along the walls), and without shifting its arrangement leaves holes there (the shape's error
0.98 % at n = 20 against 0.45-0.48 % with it). c0 is the larger of 10 u_max and the speed at which the steady pressure drop compresses the water by ``compression``
(ΔP = 12 μ U L/H² against ρ0 c0²): a channel flow at low Reynolds number is driven by a pressure drop much larger than
its dynamic pressure.

``driven_by = pressure`` drives the same channel by a pressure difference alone: the inlet prescribes the pressure
12 μ U L/H² (Poiseuille's drop at the flux U) and the outlet 0, both raised by ``background`` times that drop, and
the inlet's buffer takes the water's velocity mirrored as the outlet's does. The flux U'/U then measures how well the
set pressures reach the water: 0.83 at n = 10 and 0.93 at n = 20 (still rising slowly at 4 H²/ν); with both raised
by the drop, 0.77 at n = 10, and by twice the drop the flux no longer settles (between 0.44 and 1.14 over 8 H²/ν):
the known limit of a pressure set at an opening (docs/methods/fluids.md). The checks stay those of the shape, the
mass balance and the count.
"""

import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.geometry import lattice_box
from warpfree.parameters import CheckpointEvery, Choice, Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions
from warpfree.smoothing import SmoothingKernel
from warpfree.solvers.wcsph import BoundaryModel, FluidField, FluidParams, Opening, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.parameters import (Courant, FrameField, HFactor, Kernel, RestDensity, Shifting,
                                                WallLayers)
from warpfree.solvers.wcsph.scene_tools import require_wall_cover
from warpfree.time_loop import TimeLoop
from warpfree.validation import channel_flow_2d as reference

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"n": 8, "lengths": 3.5, "bins": 4, "t_end": 0.6, "output_interval": 0.1}

#: ``warpfree validate --quick``: the defaults (n = 20 across, 5 widths long, to 4 H²/ν)
QUICK = {"n": 20}

#: the profile is checked averaged over the outputs of the run's last this many H²/ν
AVERAGED = 0.5


class Drive(Choice):
    """What drives the channel's flow."""

    VELOCITY = "velocity", "the inlet lets the water in at U; the outlet holds its pressure"
    PRESSURE = "pressure", "the inlet holds Poiseuille's drop at U above the outlet's pressure"


@checked_parameters
def build(n: Annotated[int, Param("", "particles across the channel (dx = width/n)", "[4, inf)")] = 20,
          width: Annotated[float, Param("m", "channel width H", "(0, inf)")] = 1.0e-3,
          lengths: Annotated[float, Param("H", "the channel's length L between the inlet and the outlet, in widths",
                                          "[3.5, inf)")] = 5.0,
          reynolds: Annotated[float, Param("", "Reynolds number U H/ν of the inflow", "(0, inf)")] = 1.0,
          driven_by: Annotated[Drive, Param("", "what drives the flow")] = Drive.VELOCITY,
          background: Annotated[float, Param("ΔP", "pressure added to both openings' (driven_by = pressure), in "
                                                   "units of the drop 12 μ U L/H²", "[0, inf)")] = 0.0,
          nu: Annotated[float, Param("m²/s", "kinematic viscosity ν", "(0, inf)")] = 1.0e-6,
          compression: Annotated[float, Param("", "the density change ΔP/(ρ0 c0²) the steady pressure drop may make",
                                              "(0, 0.1]")] = 0.01,
          rho0: RestDensity = 1000.0, h_factor: HFactor = 1.6, kernel: Kernel = SmoothingKernel.WENDLAND_C2,
          shifting: Shifting = 2.0,
          wall_layers: WallLayers = 4,
          bins: Annotated[int, Param("", "bins across the channel for the velocity profile", "[1, inf)")] = 10,
          cfl: Courant = 0.1,
          ramp: Annotated[float, Param("H²/ν", "the inflow's start-up: it rises smoothly from 0 to U over this time",
                                       "[0, inf)")] = 0.25,
          t_end: Annotated[float, Param("H²/ν", "simulated time at which the run ends", "(0, inf)")] = 4.0,
          output_interval: Annotated[float, Param("H²/ν", "simulated time between outputs", "(0, inf)")] = 0.05,
          checkpoint_every: CheckpointEvery = 0, frames: Frames = True, frame_field: FrameField = FluidField.SPEED,
          vtk: Vtk = True) -> TimeLoop:
    """``n`` particles across the channel of width H = ``width`` (m), ``lengths`` H long between its openings; the inflow
    U = Re ν/H; t_end and output_interval in units of H²/ν; particle shifting A = ``shifting``."""
    params = dict(locals())
    if bins > n:
        raise ParameterError("bins", f"must be <= n = {n} (every bin needs a layer of particles), got {bins}")
    dx = width / n
    length = lengths * width
    columns = length / dx
    if abs(columns - round(columns)) > 1e-6 * columns:
        raise ParameterError("lengths", f"the channel must be whole spacings long: {lengths} widths are "
                                        f"{columns:.6g} spacings at n = {n}")
    support = kernel.support * h_factor * dx
    require_wall_cover(wall_layers, dx, support)
    viscous_time = width ** 2 / nu
    if output_interval > AVERAGED:
        raise ParameterError("output_interval", f"must be at most {AVERAGED} H²/ν: the profile is averaged over the "
                                                f"outputs of the run's last {AVERAGED} H²/ν")
    if t_end <= AVERAGED:
        raise ParameterError("t_end", f"must be more than the {AVERAGED} H²/ν the profile is averaged over")
    inflow = reynolds * nu / width
    mu = rho0 * nu
    drop = reference.pressure_drop(inflow, mu, width, length)
    c0 = max(10.0 * 1.5 * inflow, float(np.sqrt(drop / (rho0 * compression))))
    skin = 0.15 * support  # FluidParams' default skin, a fraction of the support
    buffer = np.ceil((support + skin) / dx - 1e-9) * dx
    reach = buffer + skin + wall_layers * dx  # the walls run past the buffers and the skin beyond them
    with reported_as(dx="n, lengths, wall_layers"):  # the count: (lengths n + buffers) x n, and the walls
        fluid = lattice_box((-buffer, 0.0), (length + buffer, width), dx)
        walls = np.vstack([lattice_box((-reach, -wall_layers * dx), (length + reach, 0.0), dx),
                           lattice_box((-reach, width), (length + reach, width + wall_layers * dx), dx)])
    fp = FluidParams(dim=2, dx=dx, h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, shifting=shifting,
                     gravity=(0.0, 0.0, 0.0), boundary_model=BoundaryModel.DYNAMIC, no_slip=True, cfl=cfl,
                     container_lo=(-reach, -wall_layers * dx, -1.0),
                     container_hi=(length + reach, width + wall_layers * dx, 1.0))
    outlet_pressure = background * drop if driven_by is Drive.PRESSURE else 0.0
    inlet = Opening(point=(0.0, 0.0), normal=(1.0, 0.0), velocity=(inflow, 0.0), ramp=ramp * viscous_time,
                    name="inlet")
    if driven_by is Drive.PRESSURE:
        inlet = Opening(point=(0.0, 0.0), normal=(1.0, 0.0), pressure=outlet_pressure + drop, name="inlet")
    openings = [inlet, Opening(point=(length, 0.0), normal=(-1.0, 0.0), pressure=outlet_pressure, name="outlet")]
    solver = WCSPHSolver(WCSPHModel(fluid, walls, fp, openings=openings))
    u_max = 1.5 * inflow
    edges = np.linspace(0.0, width, bins + 1)
    start, end = reference.measured_window(length, width)
    cache = {"at": None}

    def binned(s, t):
        """Over the particles of the measured stretch (once per output): the mean velocity U' of the Poiseuille profile
        that fits them best, and the bin means of u and of that profile."""
        if cache["at"] != (float(t), id(s)):
            p = s.fluid.numpy("position").astype(np.float64)
            u = s.fluid.numpy("velocity").astype(np.float64)[:, 0]
            middle = (p[:, 0] > start) & (p[:, 0] < end)
            mean_velocity = reference.fitted_mean_velocity(p[middle, 1], u[middle], width)
            cache["at"] = (float(t), id(s))
            cache["values"] = reference.binned_profile(p[middle, 1], u[middle], edges, mean_velocity, width)
            cache["mean_velocity"] = mean_velocity
            cache["inside"] = int(np.count_nonzero((p[:, 0] >= 0.0) & (p[:, 0] <= length)))
            cache["all"] = len(p)
        return cache

    def error(kind):
        def probe(s, t):
            u, exact, _ = binned(s, t)["values"]
            e = (u - exact) / u_max
            return float(np.max(np.abs(e)) if kind == "max" else np.sqrt(np.mean(e * e)))
        return probe

    def counted(opening, what):
        return lambda s, t: float(s.opening_counts()[opening][what])

    def total(what):
        return lambda s, t: float(sum(c[what] for c in s.opening_counts().values()))

    def bin_error(k):
        def probe(s, t):
            u, exact, _ = binned(s, t)["values"]
            return float((u[k] - exact[k]) / u_max)
        return probe

    probes = {"profile_error_max": error("max"), "profile_error_rms": error("rms"),
              **{f"u_bin_{k}": (lambda k: lambda s, t: float(binned(s, t)["values"][0][k]))(k) for k in range(bins)},
              **{f"bin_error_{k}": bin_error(k) for k in range(bins)},
              "mean_velocity_ratio": lambda s, t: float(binned(s, t)["mean_velocity"] / inflow),
              "particles_in_domain": lambda s, t: float(binned(s, t)["inside"]),
              "particles": lambda s, t: float(binned(s, t)["all"]),
              "inlet_made": counted("inlet", "made"), "outlet_taken_out": counted("outlet", "taken_out"),
              "made": total("made"), "taken_out": total("taken_out"),
              "pressure_drop": lambda s, t: reference.measured_drop(s, length, width)}

    def channel_analysis(run: TimeLoop, out_dir: str) -> dict:
        y_bins = binned(run.solver, run.time)["values"][2]
        res = reference.channel_checks(run.series, n, u_max, drop, bins, (t_end - AVERAGED) * viscous_time)
        res.update({"u_max": u_max, "c0": c0, "pressure_drop_theory": drop, "buffer_depth": buffer,
                    "y_bins": y_bins.tolist()})
        if out_dir is not None:
            reference.plot_channel(os.path.join(out_dir, "channel.png"), run.series, res, width, n)
        return {"channel": res}

    return TimeLoop(solver, t_end=t_end * viscous_time, output_interval=output_interval * viscous_time,
                    name="channel_flow_2d", params=params, probes=probes, analyses=[channel_analysis],
                    checkpoint_every=checkpoint_every,
                    output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                         frame_bounds=((-reach, length + reach),
                                                       (-wall_layers * dx, width + wall_layers * dx)),
                                         frame_range={"speed": (0.0, u_max)}))
