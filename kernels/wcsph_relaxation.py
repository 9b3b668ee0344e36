"""Particle relaxation kernels: move particles down the gradient of their kernel concentration.

The concentration of particle i (dimensionless) and its gradient (1/m), with V the volume per particle:

    C_i = Σ_j V_j W_ij,   ∇C_i = Σ_j V_j ∇W_ij + Σ_q s_q W(|x_i - y_q|) n_q

The first sum runs over the moving particles and any fixed ones (walls, which count as the material behind
the boundary). The second replaces the material missing beyond a free boundary: by the divergence theorem,
∫_outside ∇_x W(x - y) dy = ∮_∂Ω W(x - y) n dS for the region Ω the particles fill (n its outward normal), so
points y_q on the free part of ∂Ω with their outward normals n_q and lengths (2D) or areas (3D) s_q give the
gradient of a continuum outside, and a particle near a free boundary feels a full support (Zhu, Zhang & Hu
2021 use a level set for the same term). A uniform arrangement filling Ω has ∇C_i = 0 everywhere; the step

    x_i ← x_i - (β/K) ∇C_i,   K = -(dx/h)^d σ_d f''(0)/h²

moves every particle towards it. K is the self-stiffness ∂(∇C_i)/∂x_i of a particle in a lattice (1/m²;
Wendland C2, h = 1.3 dx, 2D: 1.65/h²), so β is the fraction of a particle's own offset removed per iteration.

Gather form (thread i writes only entry i); positions float32 vec3 (z = 0 in 2D), lengths in metres.
"""

import warp as wp

from .neighbours import NeighbourRows
from .smoothing import kernel_grad_coef, kernel_shape
from .space import Box, displacement


@wp.struct
class RelaxationConstants:
    """Constants of one relaxation (SI)."""

    box: Box             # the space (periodic axes get the minimum image)
    kind: int            # smoothing kernel id
    dim: int
    inv_h: float
    support2: float      # (support radius)² (m²)
    grad_factor: float   # σ_d/h²: ∇W = grad_factor (df/dq)/q r_ij
    w_factor: float      # σ_d: W = w_factor f(q)
    volume: float        # V of a moving particle (m^dim)
    wall_volume: float   # V of a fixed particle (m^dim)
    step: float          # β/K (m²)


@wp.kernel
def relaxation_step(first: int, c: RelaxationConstants, x: wp.array(dtype=wp.vec3), moving: NeighbourRows,
                    walls: wp.array(dtype=wp.vec3), wall_rows: NeighbourRows,
                    surface: wp.array(dtype=wp.vec3), surface_normal: wp.array(dtype=wp.vec3),
                    surface_weight: wp.array(dtype=float), surface_rows: NeighbourRows,
                    shift: wp.array(dtype=wp.vec3), shift2: wp.array(dtype=float)):
    """shift[i] = -(β/K) ∇C_i (m) over moving neighbours, walls and free-boundary points; shift2[i] = |shift[i]|²."""
    i = first + wp.tid()
    xi = x[i]
    g = wp.vec3(0.0, 0.0, 0.0)
    for n in range(moving.start[i], moving.start[i] + moving.count[i]):
        rij = displacement(c.box, xi, x[moving.index[n]])
        r2 = wp.dot(rij, rij)
        if r2 < c.support2:
            g += (c.volume * c.grad_factor * kernel_grad_coef(c.kind, c.dim, wp.sqrt(r2) * c.inv_h)) * rij
    for n in range(wall_rows.start[i], wall_rows.start[i] + wall_rows.count[i]):
        rij = displacement(c.box, xi, walls[wall_rows.index[n]])
        r2 = wp.dot(rij, rij)
        if r2 < c.support2:
            g += (c.wall_volume * c.grad_factor * kernel_grad_coef(c.kind, c.dim, wp.sqrt(r2) * c.inv_h)) * rij
    for n in range(surface_rows.start[i], surface_rows.start[i] + surface_rows.count[i]):
        q = surface_rows.index[n]
        rij = displacement(c.box, xi, surface[q])
        r2 = wp.dot(rij, rij)
        if r2 < c.support2:
            g += (surface_weight[q] * c.w_factor * kernel_shape(c.kind, c.dim, wp.sqrt(r2) * c.inv_h)) * surface_normal[q]
    s = -c.step * g
    shift[i] = s
    shift2[i] = wp.dot(s, s)


@wp.kernel
def apply_shift(first: int, x: wp.array(dtype=wp.vec3), shift: wp.array(dtype=wp.vec3),
                at_build: wp.array(dtype=wp.vec3), moved2: wp.array(dtype=float)):
    """x[i] += shift[i]; moved2[i] = |x[i] - x(at the neighbour build)|² (m²)."""
    i = first + wp.tid()
    xn = x[i] + shift[i]
    x[i] = xn
    d = xn - at_build[i]
    moved2[i] = wp.dot(d, d)
