"""2D tank at rest, upright or tilted: WCSPH pressure against the hydrostatic p = ρ0 g (H - y).

Water of depth H in a tank of width W, starting from the hydrostatic density. The pressure along the depth must follow p = ρ0 g (H - y); no particle may leave
the container, the kinetic energy must decay from the start and the free surface stay level.

The quiet start (measured in ``warpfree/validation/tank_at_rest_2d/README.md``): a square lattice under
hydrostatic pressure is not stable in WCSPH (it rearranges along slip lines after about a second, the kinetic
energy growing 20-fold), and one meeting tilted walls starts out of balance. So by default (``relax``) the
water's particles are first relaxed to a uniform concentration inside the water's region against the walls
and the empty space above (``warpfree.solvers.wcsph.relaxation``), then settled in the solver's own discretisation for
``settle_periods`` periods of the first sloshing mode, damped critically (``scene_tools.settle_water``),
before t = 0. ``relax=False, settle_periods=0`` gives the plain lattice start.

``tilt`` (degrees) rotates the tank (W × 2H) about its lower-left corner and lifts it so its lowest corner
is at y = 0; the water fills it up to the level y = H, its surface horizontal. The walls are placed along
the tank's true sides (``warpfree.solvers.wcsph.surface_layers``) and the water keeps dx/2 from them, whatever the tilt;
at every output the fluid is checked against the true sides.

The run writes ``pressure.png`` (binned SPH pressure against ρ0 g (H - y)) and the errors, normalised
by the bottom pressure ρ0 g H, into ``summary.json``, with the settling report, the kinetic energy's largest
value up to t = 0.5 s and after it, and the probe ``surface_spread`` (in dx): over columns 2 dx wide, 3 dx
clear of the walls, the highest particle's height, largest minus smallest.

Time step: seed eq. 5-12 with Courant number 0.4, as the dam breaks (the study: ``bench/results/scene_studies.md``).
"""

import os

import numpy as np

from warpfree.errors import reported_as, require_finite
from warpfree.solvers.wcsph.scene_tools import box_2d, require_scene_values, still_water_2d
from warpfree.run import OutputOptions
from warpfree.time_loop import TimeLoop


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"dx": 0.05, "t_end": 0.05, "output_interval": 0.01, "settle_periods": 0.25}


def build(width: float = 1.0, depth: float = 0.5, dx: float = 0.02, t_end: float = 2.0,
          output_interval: float = 0.05, h_factor: float = 1.6, kernel: str = "wendland_c2",
          alpha: float = 0.1, delta: float = 0.1, mu: float = 1.0e-3, boundary_model: str = "dynamic", wall_safety: float = 0.75,
          cfl: float = 0.4, g: float = 9.81, rho0: float = 1000.0, wall_layers: int = 3,
          checkpoint_every: int = 0, dt: float | None = None, frames: bool = True, frame_field: str = "pressure", vtk: bool = True,
          tilt: float = 0.0, shifting: float = 0.0, relax: bool = True, settle_periods: float = 3.0) -> TimeLoop:
    """Build the tank; the container is twice as high as the water."""
    params = dict(locals())
    require_scene_values(positive=dict(width=width, depth=depth, dx=dx, g=g, rho0=rho0),
                         layers=dict(wall_layers=wall_layers))
    angle = np.radians(require_finite("tilt", tilt))
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    tank = box_2d(width, 2.0 * depth) @ rotation.T
    tank[:, 1] -= tank[:, 1].min()
    c0 = 10.0 * np.sqrt(2.0 * g * depth)
    with reported_as(layers="wall_layers", lj_r0="wall_safety"):
        solver, water, settled = still_water_2d(
            tank, depth, dx, dict(h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, alpha=alpha, delta=delta,
                                  gravity=(0.0, -g, 0.0), boundary_model=boundary_model, cfl=cfl, shifting=shifting,
                                  lj_d=2.0 * g * depth,
                                  lj_r0=dx if boundary_model == "lennard_jones" else wall_safety * dx),
            wall_layers=wall_layers, relax=relax, settle_periods=settle_periods)
    lo, hi = tank.min(axis=0), tank.max(axis=0)

    def pressure_analysis(sim: TimeLoop, out_dir: str) -> dict:
        res = hydrostatic_profile(sim.solver, depth, rho0, g, dx)
        plot_pressure(os.path.join(out_dir, "pressure.png"), res)
        t = np.asarray(sim.series["time"])
        ke = np.asarray(sim.diag_series["kinetic_energy"])
        start = t <= 0.5 + 1e-9
        return {"hydrostatic": {k: v for k, v in res.items()}, "settling": settled,
                "kinetic_energy_start_max": float(ke[start].max()),
                "kinetic_energy_after_start_max": float(ke[~start].max()) if np.any(~start) else None,
                "surface_spread_max": float(np.max(sim.series["surface_spread"]))}

    def surface_spread(s, t):
        """Highest particle per column (2 dx wide, 3 dx clear of the walls): largest minus smallest, in dx."""
        return surface_level_spread(s.fluid.numpy("position"), water, dx)

    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="tank_at_rest_2d",
                      params=params, analyses=[pressure_analysis], dt=dt,
                      probes={"surface_spread": surface_spread},
                      checkpoint_every=checkpoint_every,
                      output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                           frame_bounds=((lo[0] - 0.1 * width, hi[0] + 0.1 * width),
                                                         (lo[1] - 0.1 * depth, hi[1] + 0.1 * depth))))


def surface_level_spread(x: np.ndarray, water: np.ndarray, dx: float) -> float:
    """The free surface's unevenness (in dx): the highest particle of each column 2 dx wide whose both sides are
    3 dx clear of the water region's ends at the surface, largest minus smallest."""
    top = water[:, 1].max()
    ends = water[np.abs(water[:, 1] - top) < 1e-6 * max(abs(top), 1.0), 0]
    edges = np.arange(ends.min() + 3.0 * dx, ends.max() - 5.0 * dx + 1e-12, 2.0 * dx)
    tops = [x[(x[:, 0] >= a) & (x[:, 0] < a + 2.0 * dx), 1].max() for a in edges
            if np.any((x[:, 0] >= a) & (x[:, 0] < a + 2.0 * dx))]
    return float((max(tops) - min(tops)) / dx) if tops else 0.0


def hydrostatic_profile(solver, depth: float, rho0: float, g: float, dx: float, bins: int = 10) -> dict:
    """Mean SPH pressure of the fluid in horizontal bins against ρ0 g (H - y) at the bin's mean y.

    Errors are normalised by the bottom pressure ρ0 g H; the top bin (the free surface, where the
    exact pressure tends to zero) is included; bins with fewer than 3 particles (the corner of a tilted
    tank) are left out.
    """
    y = solver.fluid.numpy("position")[:, 1].astype(float)
    p = solver.fluid.numpy("pressure").astype(float)
    edges = np.linspace(0.0, depth, bins + 1)
    idx = np.clip(np.digitize(y, edges) - 1, 0, bins - 1)
    full = [k for k in range(bins) if np.count_nonzero(idx == k) >= 3]
    ym = np.array([y[idx == k].mean() for k in full])
    pm = np.array([p[idx == k].mean() for k in full])
    p_exact = rho0 * g * (depth - ym)
    err = (pm - p_exact) / (rho0 * g * depth)
    return {"y": ym.tolist(), "p_sph": pm.tolist(), "p_exact": p_exact.tolist(), "rel_err": err.tolist(),
            "max_rel_err": float(np.max(np.abs(err)))}


def plot_pressure(path: str, res: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.5, 4.5), dpi=110)
    ax.plot(res["p_exact"], res["y"], "k-", label="ρ0 g (H − y)")
    ax.plot(res["p_sph"], res["y"], "o", mfc="none", label="warpfree (binned mean)")
    ax.set_xlabel("pressure (Pa)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"Tank at rest: max error {100 * res['max_rel_err']:.2f}% of ρ0 g H")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
