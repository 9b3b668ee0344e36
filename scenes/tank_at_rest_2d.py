"""2D tank at rest (hydrostatic): water of depth H in a tank of width W, starting from the
hydrostatic density. After settling, the pressure along the depth must follow p = ρ0 g (H - y);
no particle may leave the container and the kinetic energy must decay.

The run writes ``pressure.png`` (binned SPH pressure against ρ0 g (H - y)) and the errors, normalised
by the bottom pressure ρ0 g H, into ``summary.json``.
"""

import os

import numpy as np

from warpfree.geometry import lattice_box
from warpfree.solvers.wcsph.scene_tools import box_walls_2d, hydrostatic_density, require_scene_values
from warpfree.run import OutputOptions
from warpfree.solvers.wcsph import FluidParams, WCSPHSolver
from warpfree.time_loop import TimeLoop


def build(width: float = 1.0, depth: float = 0.5, dx: float = 0.02, t_end: float = 2.0,
          output_interval: float = 0.05, h_factor: float = 1.3, kernel: str = "wendland_c2",
          alpha: float = 0.1, delta: float = 0.1, mu: float = 1.0e-3, boundary_model: str = "dynamic", wall_safety: float = 0.75,
          cfl: float = 0.1, g: float = 9.81, rho0: float = 1000.0, wall_layers: int = 3,
          checkpoint_every: int = 0, dt: float = 0.0, frames: bool = True, frame_field: str = "pressure", vtk: bool = True) -> TimeLoop:
    """Build the tank; the container is twice as high as the water."""
    params = dict(locals())
    require_scene_values(positive=dict(width=width, depth=depth, dx=dx, g=g, rho0=rho0),
                         layers=dict(wall_layers=wall_layers))
    c0 = 10.0 * np.sqrt(2.0 * g * depth)
    fluid = lattice_box((0.0, 0.0), (width, depth), dx)
    walls = box_walls_2d(width, 2.0 * depth, dx, wall_layers)
    fp = FluidParams(dim=2, dx=dx, h_factor=h_factor, kernel=kernel, rho0=rho0, c0=c0, mu=mu, alpha=alpha,
                     delta=delta, gravity=(0.0, -g, 0.0), boundary_model=boundary_model, cfl=cfl,
                     lj_d=2.0 * g * depth,
                     lj_r0=dx if boundary_model == "lennard_jones" else wall_safety * dx, container_lo=(0.0, 0.0, -1.0),
                     container_hi=(width, 2.0 * depth, 1.0))
    solver = WCSPHSolver(fluid, walls, fp, density=hydrostatic_density(fluid[:, 1], depth, rho0, c0, g))

    def pressure_analysis(sim: TimeLoop, out_dir: str) -> dict:
        res = hydrostatic_profile(sim.solver, depth, rho0, g, dx)
        plot_pressure(os.path.join(out_dir, "pressure.png"), res)
        ke = np.asarray(sim.diag_series["kinetic_energy"])
        return {"hydrostatic": {k: v for k, v in res.items()},
                "kinetic_energy_first_half_max": float(ke[: len(ke) // 2].max()),
                "kinetic_energy_last_quarter_max": float(ke[3 * len(ke) // 4:].max())}

    return TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="tank_at_rest_2d",
                      params=params, analyses=[pressure_analysis], dt=dt or None,
                      checkpoint_every=checkpoint_every,
                      output=OutputOptions(vtk=vtk, frames=frames, frame_field=frame_field,
                                           frame_bounds=((-0.1 * width, 1.1 * width), (-0.1 * depth, 2.1 * depth))))


def hydrostatic_profile(solver, depth: float, rho0: float, g: float, dx: float, bins: int = 10) -> dict:
    """Mean SPH pressure of the fluid in horizontal bins against ρ0 g (H - y) at the bin's mean y.

    Errors are normalised by the bottom pressure ρ0 g H; the top bin (the free surface, where the
    exact pressure tends to zero) is included.
    """
    y = solver.fluid.numpy("position")[:, 1].astype(float)
    p = solver.fluid.numpy("pressure").astype(float)
    edges = np.linspace(0.0, depth, bins + 1)
    idx = np.clip(np.digitize(y, edges) - 1, 0, bins - 1)
    ym = np.array([y[idx == k].mean() for k in range(bins)])
    pm = np.array([p[idx == k].mean() for k in range(bins)])
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
