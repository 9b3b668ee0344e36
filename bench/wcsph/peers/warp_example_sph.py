"""Peer benchmark: Warp's bundled SPH example (``warp/examples/core/example_sph.py``).

What it models (read from the example source, warp-lang 1.19.0)
---------------------------------------------------------------
Müller, Charypar & Gross (2003) "interactive" SPH in 3-D, all particles fluid:
poly6 density (``(h^2 - r^2)^3``, self included), spiky pressure gradient with
the symmetrised ``(p_i + p_j) / (2 rho_j)``, viscosity-Laplacian term
(``(v_j - v_i)/rho_j * (h - r)``), linear EOS ``p = 20 (rho - 1)``, gravity
-0.1 along y, symplectic Euler (kick then drift) with a fixed ``dt = 0.01 h``,
and walls by clamping positions to the box ``[0,W] x [0,inf) x [0,L]`` and
reflecting the normal velocity with factor -0.95 -- no boundary particles,
no free-surface treatment, arbitrary units.  Particles start on a lattice of
spacing h (tiny jitter) filling ``[0, W/4] x [0, H] x [0, L/4]``, a column in
a corner of the box, which then collapses.  Neighbours come from a
``wp.HashGrid`` with cell size h queried with radius h (27 cells); pairs
beyond h contribute zero but are still visited.  The hash grid has only
``int(H/(4h))`` cells per axis for a box ``H/h`` cells tall, so cells alias
(hash collisions): measured ~110 candidates visited per particle for ~3-10
true neighbours within h.  Both are reported (``mean_candidates_visited``,
``mean_neighbours_within_h``, taken after the timed frames).

How the particle count is set
-----------------------------
``Example.__init__`` hard-codes ``h = 0.8`` and a box of ``80^3`` (62 500
particles), and derives everything from them: ``n = H (W/4) (H/4) / h^3``,
``particle_mass = 0.01 h^3``, ``dt = 0.01 h``, substeps per frame
``int(32 / h)`` (= 40), kernel normalisations and the hash-grid size
``int(H / (4h))``.  The lattice kernel places ``int(W/4h) x int(H/h) x
int(L/4h)`` points and wraps ``tid`` modulo those counts, so ``n`` matches the
lattice (no duplicated particles) only when ``W/(4h)`` and ``H/(4h)`` are
integers and ``L == H``.  We therefore keep the example's ``h = 0.8`` (so dt,
substeps, normalisations and the neighbour count per particle are exactly
the shipped ones) and scale the cubic box: side ``4 h k`` gives
``n = 4 k^3`` (the float formula may truncate to one fewer, which just drops
the last lattice point); ``k = round((n_target/4)^(1/3))`` (50 000 -> k = 23 ->
48 668 particles).  ``_derived`` mirrors the example's ``__init__``; before
reconfiguring we check that it reproduces the example's own attributes for
its defaults, so a change of the example in a newer Warp fails loudly.

What is timed
-------------
The example's own ``Example.step()`` (one render frame = ``int(32/h)``
substeps; each substep = hash-grid build + density pass + force pass + three
trivial per-particle passes).  After ``warmup`` frames (the first one also
loads / JIT-compiles the kernels), ``frames`` calls of ``step()`` are timed
with ``time.perf_counter`` around ``wp.synchronize_device``.  ``steps`` is
the number of substeps; particle-steps/s = ``n * steps / wall_s``.  The
example's ``wp.ScopedTimer("step")`` printout is switched off while timing.
On ``cpu`` Warp runs each kernel launch serially on one core.

CLI: ``python bench/wcsph/peers/warp_example_sph.py --n 50000 --steps 5 --device cpu``
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
import warp as wp

EXAMPLE_H = 0.8
EXAMPLE_SIDE = 80.0

PHYSICS = (
    "Müller et al. 2003 SPH, 3-D, all-fluid: poly6 density, spiky pressure gradient, "
    "viscosity-Laplacian term; linear EOS p = 20 (rho - 1); gravity -0.1; symplectic Euler "
    "(kick-drift), fixed dt = 0.01 h; walls = position clamping to the box with velocity "
    "reflection (-0.95), no boundary particles, no top lid; hash-grid neighbours within h "
    "(particle spacing = h, so few neighbours)."
)


def _example_class():
    """Import the example lazily (it imports ``warp.render``)."""
    from warp.examples.core import example_sph

    return example_sph


def lattice_k(n_target: int) -> int:
    """Lattice multiplier k for a cubic box of side 4 h k holding 4 k^3 particles."""
    return max(1, round((n_target / 4.0) ** (1.0 / 3.0)))


def _derived(h: float, width: float, height: float, length: float) -> dict:
    """Mirror of the derived quantities in ``Example.__init__`` (warp 1.19.0)."""
    mass = 0.01 * h**3
    return dict(
        smoothing_length=h,
        width=width,
        height=height,
        length=length,
        particle_mass=mass,
        dt=0.01 * h,
        n=int(height * (width / 4.0) * (height / 4.0) / (h**3)),
        sim_step_to_frame_ratio=int(32 / h),
        density_normalization=(315.0 * mass) / (64.0 * np.pi * h**9),
        pressure_normalization=-(45.0 * mass) / (np.pi * h**6),
        viscous_normalization=(45.0 * 0.025 * mass) / (np.pi * h**6),
    )


def check_mirror(example) -> None:
    """Fail if ``_derived`` no longer reproduces the example's own defaults."""
    ours = _derived(EXAMPLE_H, EXAMPLE_SIDE, EXAMPLE_SIDE, EXAMPLE_SIDE)
    for key, value in ours.items():
        theirs = getattr(example, key)
        if not math.isclose(float(theirs), float(value), rel_tol=1e-12):
            raise RuntimeError(f"example_sph changed: {key} = {theirs}, mirror gives {value}")
    if example.dynamic_visc != 0.025 or example.isotropic_exp != 20:
        raise RuntimeError("example_sph changed its viscosity or EOS constants")


def reconfigure(example, h: float, side: float) -> None:
    """Re-derive, re-allocate and re-initialise ``example`` for a cubic box."""
    mod = _example_class()
    for key, value in _derived(h, side, side, side).items():
        setattr(example, key, value)
    n = example.n
    example.x = wp.empty(n, dtype=wp.vec3)
    example.v = wp.zeros(n, dtype=wp.vec3)
    example.rho = wp.zeros(n, dtype=float)
    example.a = wp.zeros(n, dtype=wp.vec3)
    wp.launch(mod.initialize_particles, dim=n,
              inputs=[example.x, h, example.width, example.height, example.length])
    grid_size = int(example.height / (4.0 * h))
    example.grid = wp.HashGrid(grid_size, grid_size, grid_size)
    example.sim_time = 0.0


@wp.kernel
def _count_neighbours(grid: wp.uint64, x: wp.array(dtype=wp.vec3), radius: float,
                      within: wp.array(dtype=int), visited: wp.array(dtype=int)):
    """Per particle: neighbours within ``radius`` (self excluded) and candidates visited."""
    i = wp.tid()
    xi = x[i]
    n_in = int(0)
    n_vis = int(0)
    for j in wp.hash_grid_query(grid, xi, radius):
        n_vis += 1
        if j != i and wp.length(x[j] - xi) < radius:
            n_in += 1
    within[i] = n_in
    visited[i] = n_vis


def neighbour_stats(example) -> tuple[float, float]:
    """Mean neighbours within h and mean hash-grid candidates per query, now."""
    n = example.n
    within = wp.zeros(n, dtype=int)
    visited = wp.zeros(n, dtype=int)
    example.grid.build(example.x, example.smoothing_length)
    wp.launch(_count_neighbours, dim=n,
              inputs=[example.grid.id, example.x, example.smoothing_length, within, visited])
    return float(within.numpy().mean()), float(visited.numpy().mean())


def _timed_frames(example, frames: int) -> float:
    """Wall seconds for ``frames`` calls of ``example.step()``."""
    wp.synchronize_device()
    t0 = time.perf_counter()
    for _ in range(frames):
        example.step()
    wp.synchronize_device()
    return time.perf_counter() - t0


def run_warp_example_sph(n_particles_target: int, steps: int, device: str = "cpu",
                         warmup: int = 1) -> dict:
    """Time Warp's example SPH at about ``n_particles_target`` particles.

    ``steps`` is the number of timed ``Example.step()`` calls (frames); the
    returned ``steps`` counts substeps (frames x ``int(32/h)``).
    """
    wp.init()
    mod = _example_class()
    k = lattice_k(n_particles_target)
    side = 4.0 * EXAMPLE_H * k
    timer_enabled = wp.ScopedTimer.enabled
    wp.ScopedTimer.enabled = False
    try:
        with wp.ScopedDevice(device):
            example = mod.Example(stage_path=None)
            check_mirror(example)
            reconfigure(example, EXAMPLE_H, side)
            warm_s = _timed_frames(example, warmup)
            wall = _timed_frames(example, steps)
            nbr_within, nbr_visited = neighbour_stats(example)
            front = float(example.x.numpy()[:, 0].max())
    finally:
        wp.ScopedTimer.enabled = timer_enabled
    n = example.n
    substeps = steps * example.sim_step_to_frame_ratio
    return dict(
        code=f"warp {wp.__version__} examples/core/example_sph.py",
        device=str(device), n_particles=n, n_target=n_particles_target, lattice_k=k,
        box_side=side, smoothing_length=EXAMPLE_H, dt=example.dt,
        frames=steps, substeps_per_frame=example.sim_step_to_frame_ratio,
        steps=substeps, warmup_frames=warmup, warmup_s=warm_s, wall_s=wall,
        particle_steps_per_s=n * substeps / wall,
        neighbour_passes_per_step=2,
        mean_neighbours_within_h=nbr_within, mean_candidates_visited=nbr_visited,
        sim_time_after=(warmup + steps) * example.sim_step_to_frame_ratio * example.dt,
        x_front_after=front, physics=PHYSICS,
    )


def main(argv: list[str] | None = None) -> int:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50_000, help="target particle count")
    ap.add_argument("--steps", type=int, default=5, help="timed Example.step() calls (frames)")
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args(argv)
    res = run_warp_example_sph(args.n, args.steps, args.device, args.warmup)
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
