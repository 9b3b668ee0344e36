"""Fluid values at points: the gather behind ``WCSPHSolver.field_at`` and the fluid sensors (float32, SI).

At a point x, over the fluid particles j within the support (V_j = m_j/ρ_j, W_j = W(|x - x_j|, h), r_j = x_j - x):

- the filled fraction s = Σ_j V_j W_j (dimensionless: 1 inside the fluid, about 1/2 on a flat free surface or at a
  wall's face under water, 0 in air);
- each field φ (the pressure p_j = B[(ρ_j/ρ0)^γ - 1] of the current density, the density, the velocity) by a
  first-order consistent fit, moving least squares with the linear basis p(r) = [1, r/h]: the a minimising
  Σ_j V_j W_j (φ_j - a·p(r_j))², and φ(x) = a_0. It reproduces a linear field exactly, also where a wall or the free
  surface cuts the support: a sensor on a wall reads a hydrostatic pressure at the wall's face, where a Shepard
  average s⁻¹ Σ_j V_j W_j φ_j would read it at the centroid of the water near it (about 0.4 h above, ρ g 0.4 h low).
  Where the fit's moment matrix, divided by s, has a determinant below :data:`SINGULAR`, or the fit would multiply
  the particles' noise by more than :data:`NOISE_GAIN` against the average (a few particles along a line, a thin sheet
  arriving on a wall), the Shepard average is taken;
- the wall pressure, what a transducer in a wall's face reads: the Shepard average over the fluid and the wall
  particles within the support, (Σ_j V_j W_j p_j + Σ_k V_k W_k p_k) / (Σ_j V_j W_j + Σ_k V_k W_k), each wall particle
  k with the pressure the wall condition gives it (Adami et al. 2012: the fluid's near it, extrapolated along
  gravity; 0 with no fluid near) and V_k = m_k/ρ_k. At a face the support is cut half by the water and half by
  the wall, so a linear field is read at the face itself (in a hydrostatic tank, on the floor, the side walls and in
  a corner within 0.6 % of ρ g H), and as an average with positive weights it never amplifies the particles' noise,
  which the linear fit multiplies 3.5 times in variance on a face and 8.7 times in a corner (its weights change sign
  across them). Inside the water, where no wall is within the support, it is the fluid's Shepard average; with walls
  that carry no pressure (Lennard-Jones) it is that everywhere.

The fluid is found through the neighbour grid of the step (built at the positions of the last rebuild, with the
reach support + skin: every particle now within the support of a fixed point was within the reach of it then); a
grid point is taken only within the reach of x, so a periodic image and its particle are never both counted.
"""

import warp as wp

from .smoothing import kernel_shape, kernel_sigma
from .space import displacement_function, image_displacement
from .wcsph import FluidArrays, FluidConstants, fluid_pressure

#: the determinant of the normalised moment matrix below which the linear fit gives way to the Shepard average (a full
#: support's is about 10⁻² in 2D and 10⁻³ in 3D for the Wendland C2 kernel at h = 1.6 dx)
SINGULAR = wp.constant(1.0e-6)

#: the most the linear fit may multiply the variance of the particles' noise, against the Shepard average's (its
#: weights' sum of squares over the average's); beyond it the average is taken. Measured (2D, Wendland C2, h = 1.6 dx):
#: 1 inside the water, 3.4-3.6 on a wall's face under water, 8.7 in a corner; 13-350 where a thin sheet arrives on a
#: wall (a few particles along a line, which the fit extrapolates from)
NOISE_GAIN = wp.constant(10.0)



@wp.func
def linear_fit(m: wp.mat44, m2: wp.mat44, s: float, s2: float, dim: int) -> wp.mat44:
    """The fit's matrix F, the coefficients a = F b of φ ≈ a·p(r) from b = Σ V W p φ (p = [1, r/h]): M⁻¹ where the
    moment matrix M = Σ V W p pᵀ, divided by s = Σ V W, has a determinant above :data:`SINGULAR` and the fit's value
    multiplies the noise by at most :data:`NOISE_GAIN` (M2 = Σ (V W)² p pᵀ, s2 = Σ (V W)²), else the Shepard
    average's diag(1/s, 0, 0, 0). In 2D the 4th row and column are unused (zero)."""
    shepard = wp.mat44(1.0 / s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    mn = m / s
    fit = shepard
    if dim == 2:
        m3 = wp.mat33(mn[0, 0], mn[0, 1], mn[0, 2], mn[1, 0], mn[1, 1], mn[1, 2], mn[2, 0], mn[2, 1], mn[2, 2])
        if wp.determinant(m3) > SINGULAR:
            inv = wp.inverse(m3) / s
            fit = wp.mat44(inv[0, 0], inv[0, 1], inv[0, 2], 0.0, inv[1, 0], inv[1, 1], inv[1, 2], 0.0,
                           inv[2, 0], inv[2, 1], inv[2, 2], 0.0, 0.0, 0.0, 0.0, 0.0)
    else:
        if wp.determinant(mn) > SINGULAR:
            fit = wp.inverse(mn) / s
    # the fit's weights a_j = V_j W_j row·p_j against the average's V_j W_j / s: Σ a_j² / Σ (V_j W_j / s)²
    row = wp.vec4(fit[0, 0], fit[0, 1], fit[0, 2], fit[0, 3])
    if wp.dot(row, m2 * row) > NOISE_GAIN * s2 / (s * s):
        fit = shepard
    return fit


_made: dict = {}


def make_sample(kind: int, dim: int, periodic: tuple, walls: bool) -> "wp.Kernel":
    """The ``sample`` kernel of one smoothing kernel, dimension (2 or 3), periodic axes and whether there are wall
    particles (cached)."""
    key = (kind, dim, tuple(periodic), walls)
    if key in _made:
        return _made[key]
    disp = displacement_function(tuple(periodic))

    @wp.kernel(module="unique")
    def sample(first: int, c: FluidConstants, f: FluidArrays, grid: wp.uint64, grid_points: wp.array(dtype=wp.vec3),
               source_id: wp.array(dtype=wp.int32), wall_grid: wp.uint64, wall_grid_points: wp.array(dtype=wp.vec3),
               wall_source_id: wp.array(dtype=wp.int32), reach: float, points: wp.array(dtype=wp.vec3),
               filled: wp.array(dtype=float), pressure: wp.array(dtype=float), density: wp.array(dtype=float),
               velocity: wp.array(dtype=wp.vec3), wall_pressure: wp.array(dtype=float)):
        """Filled fraction, pressure (Pa), density (kg/m³), velocity (m/s) and the two-sided surface pressure (Pa)
        at ``points[first + tid]``."""
        i = first + wp.tid()
        x = points[i]
        sigma = kernel_sigma(wp.static(kind), wp.static(dim), c.h)
        s = float(0.0)
        m = wp.mat44(0.0)                      # Σ V W p pᵀ, p = [1, r/h] (the 4th row and column unused in 2D)
        m2 = wp.mat44(0.0)                     # Σ (V W)² p pᵀ: the fit's noise gain
        s2 = float(0.0)                        # Σ (V W)²
        bp = wp.vec4(0.0)                      # Σ V W p φ for the pressure, the density, each velocity component
        br = wp.vec4(0.0)
        bx = wp.vec4(0.0)
        by = wp.vec4(0.0)
        bz = wp.vec4(0.0)
        for k in wp.hash_grid_query(grid, x, reach):
            d0 = image_displacement(x, grid_points[k])
            if wp.dot(d0, d0) >= reach * reach:
                continue
            j = source_id[k]
            r = disp(c.box, f.position[j], x)
            r2 = wp.dot(r, r)
            if r2 >= c.support2:
                continue
            rho = f.density[j]
            w = (f.mass[j] / rho) * sigma * kernel_shape(wp.static(kind), wp.static(dim), wp.sqrt(r2) * c.inv_h)
            q = r * c.inv_h
            p = wp.vec4(1.0, q[0], q[1], q[2])
            if wp.static(dim == 2):
                p = wp.vec4(1.0, q[0], q[1], 0.0)
            s += w
            m += w * wp.outer(p, p)
            s2 += w * w
            m2 += (w * w) * wp.outer(p, p)
            v = f.velocity[j]
            bp += (w * fluid_pressure(c, rho)) * p
            br += (w * rho) * p
            bx += (w * v[0]) * p
            by += (w * v[1]) * p
            bz += (w * v[2]) * p
        # the two-sided average: the fluid's and the wall particles' pressures (those the wall condition gives them)
        sa = s
        spa = bp[0]
        if wp.static(walls):
            for k in wp.hash_grid_query(wall_grid, x, reach):
                d0 = image_displacement(x, wall_grid_points[k])
                if wp.dot(d0, d0) >= reach * reach:
                    continue
                j = f.nf + wall_source_id[k]
                r = disp(c.box, f.position[j], x)
                r2 = wp.dot(r, r)
                if r2 >= c.support2:
                    continue
                w = (f.mass[j] / f.density[j]) * sigma * kernel_shape(wp.static(kind), wp.static(dim),
                                                                      wp.sqrt(r2) * c.inv_h)
                sa += w
                spa += w * f.pressure[j]
        filled[i] = s
        if s <= 0.0:
            nan = wp.nan
            wall_pressure[i] = nan
            pressure[i] = nan
            density[i] = nan
            velocity[i] = wp.vec3(nan, nan, nan)
            return
        # the linear fit where it is well posed: φ(x) = first component of M⁻¹ b (row 0 of the inverse)
        fit = linear_fit(m, m2, s, s2, wp.static(dim))
        row = wp.vec4(fit[0, 0], fit[0, 1], fit[0, 2], fit[0, 3])
        pressure[i] = wp.dot(row, bp)
        density[i] = wp.dot(row, br)
        velocity[i] = wp.vec3(wp.dot(row, bx), wp.dot(row, by), wp.dot(row, bz))
        wall_pressure[i] = spa / sa

    _made[key] = sample
    return sample

