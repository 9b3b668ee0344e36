"""Colour function of a particle set sampled on a regular grid (for free-surface extraction).

    χ(x) = Σ_j V_j W(|x - x_j|, h)                                  (dimensionless)

with V_j the particle volume (m³), W the 3D smoothing kernel (1/m³) and h the smoothing length (m).
Inside a uniformly filled region χ ≈ 1; outside the support of every particle χ = 0; the free surface is
taken as the iso-surface χ = 1/2.

Gather form: one thread per grid node; node ``i`` (flat, C order over (nx, ny, nz)) is at
``lower + cell * (ix, iy, iz)`` with ``i = (ix * ny + iy) * nz + iz``.
"""

import warp as wp

from .smoothing import kernel_w


@wp.kernel
def colour_function_grid(
    first: int,
    grid: wp.uint64,
    positions: wp.array(dtype=wp.vec3),
    volumes: wp.array(dtype=float),
    lower: wp.vec3,
    cell: float,
    ny: int,
    nz: int,
    query_radius: float,
    support: float,
    kind: int,
    h: float,
    chi: wp.array(dtype=float),
):
    """chi[i] = Σ_j V_j W(|x_i - x_j|, h) at grid node i (dimensionless)."""
    i = first + wp.tid()
    iz = i % nz
    iy = (i // nz) % ny
    ix = i // (ny * nz)
    x = lower + wp.vec3(float(ix) * cell, float(iy) * cell, float(iz) * cell)
    s = float(0.0)
    for j in wp.hash_grid_query(grid, x, query_radius):
        r = wp.length(x - positions[j])
        if r < support:
            s += volumes[j] * kernel_w(kind, 3, r, h)
    chi[i] = s
