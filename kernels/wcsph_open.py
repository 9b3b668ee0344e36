"""Open boundaries of a WCSPH fluid: the buffer particles' values (float32, SI).

An opening is a plane (a point on it, its unit normal n pointing into the domain) with a buffer zone of depth T behind
it: fluid particles whose signed distance d = (x - x_o)·n is negative belong to the opening (the first one listed
whose half-space holds them). Buffer particles are fluid particles that the rates leave alone (``kernels/wcsph.py``:
no acceleration, no density rate, no shift): they move with the velocity this pass gives them and carry its density,
so that the fluid next to the plane sees a full support of particles continuing the flow.

Each step, at the predicted state, a buffer particle i at depth δ = -d_i takes its values from the domain's fluid
around its mirror point x_m = x_i + 2δ n (Tafuni et al. 2018): the linear moving-least-squares fit of
``kernels/wcsph_sensors.py`` (basis [1, r/h], the Shepard average where the fit is ill posed), over the fluid particles
of the domain within the support of x_m, gives φ(x_m) and ∇φ(x_m). Then

- velocity: prescribed (an inlet's U, rising as U (1 - cos(π t/t_r))/2 over its start-up t_r), or φ(x_m): the mirror's value, the zero normal gradient of an outflow;
- pressure: prescribed at the plane and continued with the fluid's gradient, p_i = p_o - δ n·∇p(x_m), or extrapolated
  to first order, p_i = p(x_m) - 2δ n·∇p(x_m) (hydrostatic pressure, a pressure drop along a channel);
- density: ρ_i = ρ0 (1 + p_i/B)^(1/γ), the inverse of the equation of state.

Where no fluid of the domain is within the support of x_m the buffer particle keeps its values. Particles are made and
taken out on the host at the neighbour tables' rebuilds (``solvers/wcsph/openings.py``).
"""

import warp as wp

from .clock import STEP, TIME
from .smoothing import kernel_shape, kernel_sigma
from .space import displacement_function, image_displacement
from .wcsph import FluidArrays, FluidConstants, tait_density
from .wcsph_sensors import linear_fit


@wp.struct
class Openings:
    """The openings of a fluid's domain (count rows each)."""

    count: int
    point: wp.array(dtype=wp.vec3)        # a point of the opening's plane (m)
    normal: wp.array(dtype=wp.vec3)       # unit normal, into the domain
    velocity: wp.array(dtype=wp.vec3)     # the prescribed velocity (m/s) where ``set_velocity``
    ramp: wp.array(dtype=wp.float64)      # the prescribed velocity's start-up (s): U (1 - cos(π t/ramp))/2 before it
    set_velocity: wp.array(dtype=wp.int32)
    pressure: wp.array(dtype=float)       # the prescribed pressure at the plane (Pa) where ``set_pressure``
    set_pressure: wp.array(dtype=wp.int32)


@wp.func
def opening_of(o: Openings, x: wp.vec3) -> int:
    """The opening whose buffer holds x (the first whose plane x is behind), or -1 inside the domain."""
    for k in range(o.count):
        if wp.dot(x - o.point[k], o.normal[k]) < 0.0:
            return k
    return -1


_made: dict = {}


def make_buffer_values(kind: int, dim: int, periodic: tuple) -> "wp.Kernel":
    """The ``buffer_values`` kernel of one smoothing kernel, dimension and pattern of periodic axes (cached)."""
    key = (kind, dim, tuple(periodic))
    if key in _made:
        return _made[key]
    disp = displacement_function(tuple(periodic))

    @wp.kernel(module="unique")
    def buffer_values(first: int, c: FluidConstants, f: FluidArrays, o: Openings, grid: wp.uint64,
                      grid_points: wp.array(dtype=wp.vec3), source_id: wp.array(dtype=wp.int32), reach: float,
                      rows: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64), at_step_end: int):
        """Fluid row i = rows[tid]: its zone (0 in the domain, k + 1 in opening k's buffer) and, in a buffer, its
        velocity, density and pressure at the predicted state (module docstring): at the clock's t, plus its step with
        ``at_step_end`` (the rates after a drift are those at t + Δt)."""
        i = rows[first + wp.tid()]
        x = f.position[i]
        k = opening_of(o, x)
        f.zone[i] = k + 1
        if k < 0:
            return
        n = o.normal[k]
        depth = -wp.dot(x - o.point[k], n)
        xm = x + (2.0 * depth) * n
        sigma = kernel_sigma(wp.static(kind), wp.static(dim), c.h)
        s = float(0.0)
        s2 = float(0.0)
        m = wp.mat44(0.0)
        m2 = wp.mat44(0.0)
        bp = wp.vec4(0.0)
        bx = wp.vec4(0.0)
        by = wp.vec4(0.0)
        bz = wp.vec4(0.0)
        for g in wp.hash_grid_query(grid, xm, reach):
            d0 = image_displacement(xm, grid_points[g])
            if wp.dot(d0, d0) >= reach * reach:
                continue
            j = source_id[g]
            xj = f.position[j]
            if opening_of(o, xj) >= 0:  # the domain's fluid only
                continue
            r = disp(c.box, xj, xm)
            r2 = wp.dot(r, r)
            if r2 >= c.support2:
                continue
            w = (f.mass[j] / f.density_eval[j]) * sigma * kernel_shape(wp.static(kind), wp.static(dim),
                                                                       wp.sqrt(r2) * c.inv_h)
            q = r * c.inv_h
            p = wp.vec4(1.0, q[0], q[1], q[2])
            if wp.static(dim == 2):
                p = wp.vec4(1.0, q[0], q[1], 0.0)
            s += w
            s2 += w * w
            m += w * wp.outer(p, p)
            m2 += (w * w) * wp.outer(p, p)
            v = f.velocity_eval[j]
            bp += (w * f.pressure[j]) * p
            bx += (w * v[0]) * p
            by += (w * v[1]) * p
            bz += (w * v[2]) * p
        if s <= 0.0:
            return
        fit = linear_fit(m, m2, s, s2, wp.static(dim))
        ap = fit * bp                                         # [p(x_m), h ∇p(x_m)]
        gradient_p = wp.vec3(ap[1], ap[2], ap[3]) * c.inv_h
        pressure = ap[0] - 2.0 * depth * wp.dot(n, gradient_p)
        if o.set_pressure[k] != 0:
            pressure = o.pressure[k] - depth * wp.dot(n, gradient_p)
        pressure = wp.max(pressure, c.p_floor)
        t = clock[TIME]
        if at_step_end != 0:
            t = t + clock[STEP]
        rise = float(1.0)
        if t < o.ramp[k]:
            rise = float(wp.float64(0.5) * (wp.float64(1.0) - wp.cos(wp.float64(wp.pi) * t / o.ramp[k])))
        velocity = rise * o.velocity[k]
        if o.set_velocity[k] == 0:
            velocity = wp.vec3((fit * bx)[0], (fit * by)[0], (fit * bz)[0])
        density = tait_density(pressure, c.rho0, c.b, c.gamma)
        f.velocity[i] = velocity
        f.velocity_eval[i] = velocity
        f.density[i] = density
        f.density_eval[i] = density
        f.pressure[i] = pressure

    _made[key] = buffer_values
    return buffer_values
