"""Rigid bodies among the walls: their poses in time and the wall particles and surfaces that follow them.

A body is a set of wall particles (and optionally its true surface, a polygon or a mesh) that moves rigidly. Its
state is one float64 row of ``BODY_COLUMNS``: the position c of its reference point (m), its rotation q (a unit
quaternion x, y, z, w, body to world), its velocity V (m/s), spin Ω (rad/s), acceleration A (m/s²) and spin rate
α (rad/s²). A point of the body at offset r0 from the reference point in the body's frame is at

    x = c + q r0 q*,   v = V + Ω × r,   a = A + α × r + Ω × (Ω × r),   r = x - c,

the velocity entering continuity and the no-slip ghost velocity, the acceleration the walls' Adami pressure
(``kernels/wcsph.py``: p_w carries (g - a_w)·Σ ρ_f r_wf W_wf).

A prescribed motion gives the reference point's displacement d(t) from where it starts, c(t) = c0 + d(t), and an
angle θ(t) about a fixed axis n through it, q = (n sin θ/2, cos θ/2), as cubic splines of time with clamped ends
(the body at rest before the first and after the last point of its table): positions, velocities and accelerations
are the spline's value and its first two derivatives, continuous, evaluated at the step's time in float64.

Precision: the body state and the offsets float64; positions, velocities and accelerations written float32, as the
fluid's. Units SI.
"""

import warp as wp

from .clock import STEP, TIME
from .space import Box, displacement, wrap

#: the columns of a body's state row
BODY_POSITION = wp.constant(0)      # c (3), m
BODY_ROTATION = wp.constant(3)      # q (4): x, y, z, w
BODY_VELOCITY = wp.constant(7)      # V (3), m/s
BODY_SPIN = wp.constant(10)         # Ω (3), rad/s
BODY_ACCELERATION = wp.constant(13)  # A (3), m/s²
BODY_SPIN_RATE = wp.constant(16)    # α (3), rad/s²
BODY_COLUMNS = 19

#: the channels of a prescribed motion's spline: the displacement's x, y, z, then the angle
MOTION_CHANNELS = 4


@wp.func
def body_vec(state: wp.array2d(dtype=wp.float64), b: int, col: int) -> wp.vec3d:
    return wp.vec3d(state[b, col], state[b, col + 1], state[b, col + 2])


@wp.func
def set_body_vec(state: wp.array2d(dtype=wp.float64), b: int, col: int, v: wp.vec3d):
    state[b, col] = v[0]
    state[b, col + 1] = v[1]
    state[b, col + 2] = v[2]


@wp.func
def body_rotation(state: wp.array2d(dtype=wp.float64), b: int) -> wp.quatd:
    return wp.quatd(state[b, BODY_ROTATION], state[b, BODY_ROTATION + 1], state[b, BODY_ROTATION + 2],
                    state[b, BODY_ROTATION + 3])


@wp.func
def to_vec3(v: wp.vec3d) -> wp.vec3:
    return wp.vec3(float(v[0]), float(v[1]), float(v[2]))


@wp.kernel
def prescribed_poses(first: int, clock: wp.array(dtype=wp.float64), at_step_end: int,
                     table_start: wp.array(dtype=wp.int32), times: wp.array(dtype=wp.float64),
                     coefficients: wp.array3d(dtype=wp.float64), start_position: wp.array(dtype=wp.vec3d),
                     axis: wp.array(dtype=wp.vec3d), body: wp.array(dtype=wp.int32),
                     state: wp.array2d(dtype=wp.float64)):
    """The state of prescribed body ``body[tid]`` at the clock's time (plus its step with ``at_step_end``: the rates
    after a drift are those at t + Δt). Its table is ``times[table_start[m]:table_start[m + 1]]`` (m = first + tid),
    its spline pieces ``coefficients[table_start[m] - m + p, channel, power]`` (p: the piece, s = t - t_p, value
    Σ_k a_k s^k); outside its table it rests at the end values."""
    m = first + wp.tid()
    b = body[m]
    t = clock[TIME]
    if at_step_end != 0:
        t = t + clock[STEP]
    t0 = table_start[m]
    t1 = table_start[m + 1]
    zero = wp.float64(0.0)
    piece = int(0)
    s = zero
    moving = wp.float64(1.0)
    if t <= times[t0]:
        s = zero
        moving = zero
    elif t >= times[t1 - 1]:
        piece = t1 - t0 - 2
        s = times[t1 - 1] - times[t1 - 2]
        moving = zero
    else:
        lo = int(0)
        hi = t1 - t0 - 1
        while hi - lo > 1:  # times[t0 + lo] < t <= times[t0 + hi]
            mid = (lo + hi) // 2
            if times[t0 + mid] < t:
                lo = mid
            else:
                hi = mid
        piece = lo
        s = t - times[t0 + lo]
    row = t0 - m + piece
    value = wp.vec4d()
    rate = wp.vec4d()
    rate2 = wp.vec4d()
    for ch in range(MOTION_CHANNELS):
        a0 = coefficients[row, ch, 0]
        a1 = coefficients[row, ch, 1]
        a2 = coefficients[row, ch, 2]
        a3 = coefficients[row, ch, 3]
        value[ch] = a0 + s * (a1 + s * (a2 + s * a3))
        rate[ch] = moving * (a1 + s * (wp.float64(2.0) * a2 + s * wp.float64(3.0) * a3))
        rate2[ch] = moving * (wp.float64(2.0) * a2 + wp.float64(6.0) * a3 * s)
    n = axis[m]
    half = wp.float64(0.5) * value[3]
    q = wp.quatd(n[0] * wp.sin(half), n[1] * wp.sin(half), n[2] * wp.sin(half), wp.cos(half))
    set_body_vec(state, b, BODY_POSITION, start_position[m] + wp.vec3d(value[0], value[1], value[2]))
    state[b, BODY_ROTATION] = q[0]
    state[b, BODY_ROTATION + 1] = q[1]
    state[b, BODY_ROTATION + 2] = q[2]
    state[b, BODY_ROTATION + 3] = q[3]
    set_body_vec(state, b, BODY_VELOCITY, wp.vec3d(rate[0], rate[1], rate[2]))
    set_body_vec(state, b, BODY_SPIN, rate[3] * n)
    set_body_vec(state, b, BODY_ACCELERATION, wp.vec3d(rate2[0], rate2[1], rate2[2]))
    set_body_vec(state, b, BODY_SPIN_RATE, rate2[3] * n)


@wp.kernel
def rigid_walls(first: int, nf: int, box: Box, body_of_wall: wp.array(dtype=wp.int32),
                offset: wp.array(dtype=wp.vec3d), state: wp.array2d(dtype=wp.float64),
                position: wp.array(dtype=wp.vec3), velocity: wp.array(dtype=wp.vec3),
                wall_acceleration: wp.array(dtype=wp.vec3), wall_position_at_build: wp.array(dtype=wp.vec3),
                report: wp.array(dtype=wp.vec4)):
    """Held wall k = first + tid (particle nf + k) of body ``body_of_wall[k]`` (-1: a wall at rest, left as it is)
    where its body's state puts it: position, velocity, acceleration (module docstring), and its row of the step
    report, nf + k: (|x - x at the tables' build|², |v|², |a|², 0), so that the rebuild decision and the stable step
    see the walls as the fluid."""
    k = first + wp.tid()
    b = body_of_wall[k]
    if b < 0:
        return
    c = body_vec(state, b, BODY_POSITION)
    r = wp.quat_rotate(body_rotation(state, b), offset[k])
    omega = body_vec(state, b, BODY_SPIN)
    v = body_vec(state, b, BODY_VELOCITY) + wp.cross(omega, r)
    a = (body_vec(state, b, BODY_ACCELERATION) + wp.cross(body_vec(state, b, BODY_SPIN_RATE), r)
         + wp.cross(omega, wp.cross(omega, r)))
    x = wrap(box, to_vec3(c + r))
    position[nf + k] = x
    velocity[nf + k] = to_vec3(v)
    af = to_vec3(a)
    wall_acceleration[k] = af
    vf = to_vec3(v)
    moved = displacement(box, x, wall_position_at_build[k])
    report[nf + k] = wp.vec4(wp.dot(moved, moved), wp.dot(vf, vf), wp.dot(af, af), 0.0)


@wp.kernel
def rigid_points(first: int, box: Box, body_of_point: wp.array(dtype=wp.int32), offset: wp.array(dtype=wp.vec3d),
                 state: wp.array2d(dtype=wp.float64), points: wp.array(dtype=wp.vec3)):
    """Point k = first + tid of body ``body_of_point[k]`` (-1: left as it is) where its body's state puts it: the
    walls' positions at the tables' build from the bodies' state then, after a checkpoint is read."""
    k = first + wp.tid()
    b = body_of_point[k]
    if b < 0:
        return
    x = body_vec(state, b, BODY_POSITION) + wp.quat_rotate(body_rotation(state, b), offset[k])
    points[k] = wrap(box, to_vec3(x))


@wp.kernel
def rigid_vertices(first: int, body_of_vertex: wp.array(dtype=wp.int32), offset: wp.array(dtype=wp.vec3d),
                   state: wp.array2d(dtype=wp.float64), vertices: wp.array(dtype=wp.vec2)):
    """Polygon vertex k = first + tid of a 2D solid that moves with body ``body_of_vertex[k]`` (-1: at rest) where the
    body's state puts it (the true surface the penalty and the audit use)."""
    k = first + wp.tid()
    b = body_of_vertex[k]
    if b < 0:
        return
    x = body_vec(state, b, BODY_POSITION) + wp.quat_rotate(body_rotation(state, b), offset[k])
    vertices[k] = wp.vec2(float(x[0]), float(x[1]))


@wp.kernel
def rigid_mesh_points(first: int, body: int, offset: wp.array(dtype=wp.vec3d), state: wp.array2d(dtype=wp.float64),
                      points: wp.array(dtype=wp.vec3)):
    """Vertex k = first + tid of a 3D solid's mesh that moves with body ``body`` where the body's state puts it (the
    mesh is refitted after)."""
    k = first + wp.tid()
    x = body_vec(state, body, BODY_POSITION) + wp.quat_rotate(body_rotation(state, body), offset[k])
    points[k] = to_vec3(x)
