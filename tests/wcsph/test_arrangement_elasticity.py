"""A settled WCSPH particle arrangement under a uniform pressure has no shear stiffness: an inviscid shear flow
u = U sin(k y) x̂ in a doubly periodic box is an exact steady solution of the Euler equations, whatever the
background pressure p0.

An arrangement whose pressure term resisted shear with a modulus G = c p0 would turn that flow into a standing
shear wave of frequency k sqrt(G/ρ). With the kernel at 1.6 dx the standing wave in a tank runs about 1 % fast,
which a modulus of c = 0.01 of the hydrostatic pressure would explain exactly (the Rayleigh quotient of the first
sloshing mode with G = c ρ g (d − y) gives δω/ω = c for any k and d); this test bounds the bulk's c far below that:
the excess is not a shear stiffness of the bulk under pressure (its cause:
``warpfree/validation/standing_wave_2d/README.md``)."""

import math

import numpy as np

from warpfree import device
from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver

N, DX, P0, C0 = 16, 0.02, 2450.0, 31.3       # 16 x 16 particles; p0 = ρ0 g d/2 of the 0.5 m deep tank


def test_uniform_pressure_keeps_an_inviscid_shear_flow():
    """Over t = π/ω_c, half the period a modulus G = 0.01 p0 would give (which would reverse the flow), the shear
    mode's amplitude stays within 2 % of U: cos(sqrt(c/0.01) π) ≥ 0.98 bounds c = G/p0 below 4e-5."""
    device.use("cpu", 2)
    length = N * DX
    rng = np.random.default_rng(0)
    cells = (np.arange(N) + 0.5) * DX
    x = np.stack(np.meshgrid(cells, cells, indexing="ij"), -1).reshape(-1, 2)
    x = (x + 0.2 * DX * rng.uniform(-1.0, 1.0, x.shape)) % length
    params = FluidParams(dim=2, dx=DX, c0=C0, mu=0.0, alpha=0.0, delta=0.1, gravity=(0.0, 0.0, 0.0), cfl=0.2,
                         container_lo=(0.0, 0.0, -1.0), container_hi=(length, length, 1.0),
                         periodic=(True, True, False))
    rho = params.rho0 * (1.0 + P0 / params.b) ** (1.0 / params.gamma)
    solver = WCSPHSolver(WCSPHModel(x, np.zeros((0, 2)), params), density=np.full(N * N, rho))
    solver.settle(0.5, 20.0)  # the jittered lattice finds its own arrangement under p0
    k = 2.0 * math.pi / length
    omega_c = k * math.sqrt(0.01 * P0 / rho)
    speed = 0.002 * omega_c / k  # strain amplitude 0.002 in the stiff case
    xs = solver.fluid.numpy("position")
    v = np.zeros((N * N, 3), np.float32)
    v[:, 0] = speed * np.sin(k * xs[:, 1])
    solver.fluid["velocity"].assign(v)
    solver.initialise()

    def mode():
        p, u = solver.fluid.numpy("position"), solver.fluid.numpy("velocity")
        return 2.0 * float(np.mean(u[:, 0] * np.sin(k * p[:, 1]))) / speed

    start, t, t_end, low = mode(), 0.0, math.pi / omega_c, 1.0
    while t < t_end:
        dt = min(solver.stable_dt(), t_end - t)
        solver.step(dt)
        t += dt
        low = min(low, mode() / start)
    assert low > 0.98, low
