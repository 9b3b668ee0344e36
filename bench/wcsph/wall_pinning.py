"""Wall pinning: how strongly the wall particles hold the fluid next to them at sub-particle displacements.

What it measures
    Water d = 0.5 m deep in a channel periodic along x (1 m), on a bottom wall of ``--layers`` rows of wall
    particles (spacing ``--wall-spacing`` dx along the wall, volume (spacing dx) dx each), a jittered lattice
    settled at rest for ``--settle`` s. The fluid is then shifted rigidly by δ along the wall and the rates
    recomputed: fluid-fluid forces cancel in pairs, so the total horizontal force is the wall's. Printed: the
    restoring stiffness per metre of wall, -ΔF/(δ L), in units of ρ0 g d/dx, at δ = 0.02 ... 0.5 dx (a smooth
    wall gives 0). Through the Rayleigh quotient of the first sloshing mode (bottom displacement A/sinh(kd)) a
    stiffness K (those units) adds K d/(2 dx sinh²(kd)) to ω/ω0 - 1.

    python bench/wcsph/wall_pinning.py --dx 0.02 [--wall-spacing 0.5] [--threads 2]
"""

import argparse
import json
import math

import numpy as np

from warpfree import device
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
from warpfree.solvers.wcsph.scene_tools import hydrostatic_density

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--dx", "0.04"], ["--dx", "0.02"]]


def wall_stiffness(dx: float, h_factor: float = 1.6, layers: int = 3, settle: float = 2.0,
                   wall_spacing: float = 1.0, length: float = 1.0, depth: float = 0.5, seed: int = 0) -> dict:
    g = 9.81
    nx, ny = int(round(length / dx)), int(round(depth / dx))
    c0 = 10.0 * math.sqrt(2.0 * g * depth)
    cells = np.stack(np.meshgrid((np.arange(nx) + 0.5) * dx, (np.arange(ny) + 0.5) * dx, indexing="ij"), -1)
    x = cells.reshape(-1, 2) + 0.2 * dx * np.random.default_rng(seed).uniform(-1.0, 1.0, (nx * ny, 2))
    x[:, 0] %= length
    x[:, 1] = np.maximum(x[:, 1], 0.3 * dx)
    ws = wall_spacing * dx
    walls = np.array([[(j + 0.5) * ws, -(k + 0.5) * dx] for k in range(layers) for j in range(int(round(length / ws)))])
    params = FluidParams(dim=2, dx=dx, h_factor=h_factor, c0=c0, mu=1e-3, alpha=0.02, delta=0.1, gravity=(0, -g, 0),
                         cfl=0.2, container_lo=(0, -1, -1), container_hi=(length, 2 * depth, 1),
                         periodic=(True, False, False))
    solver = WCSPHSolver(WCSPHModel(x, walls, params, boundary_volume=ws * dx),
                         density=hydrostatic_density(x[:, 1], depth, params.rho0, c0, g))
    solver.settle(settle, 2.0 * math.sqrt(g * math.pi / length * math.tanh(math.pi / length * depth)))
    x0 = solver.fluid.numpy("position").copy()
    m = solver.fluid.numpy("mass").astype(np.float64)

    def wall_force(shift: float) -> float:
        xs = x0.copy()
        xs[:, 0] = (xs[:, 0] + shift) % length
        solver.fluid["position"].assign(xs)
        solver.fluid["velocity"].zero_()
        solver.initialise()
        return float(np.sum(m * solver.arrays.acceleration.numpy()[:, 0]))

    f0 = wall_force(0.0)
    unit = params.rho0 * g * depth / dx
    return {"dx": dx, "h_factor": h_factor, "wall_spacing": wall_spacing,
            "stiffness": {f"{frac:g} dx": -(wall_force(frac * dx) - f0) / (frac * dx) / length / unit
                          for frac in (0.02, 0.05, 0.1, 0.25, 0.5)}}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.02)
    ap.add_argument("--h-factor", type=float, default=1.6)
    ap.add_argument("--wall-spacing", type=float, default=1.0)
    ap.add_argument("--settle", type=float, default=2.0)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    device.use("cpu", a.threads)
    print(json.dumps(wall_stiffness(a.dx, a.h_factor, settle=a.settle, wall_spacing=a.wall_spacing), indent=1))
