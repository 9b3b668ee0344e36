"""Solids on their true surfaces: which side of a solid a point is on, how deep, and the penalty that keeps fluid out.

A solid is a closed surface with a side the particles must stay on: inside a container, outside an obstacle.

- 3D: a watertight triangle mesh (``wp.Mesh``); the closest point and the sign from Warp's angle-weighted
  pseudo-normal test (robust for watertight, non-self-intersecting meshes), with Warp's own tolerance for
  telling a closest point on an edge or a vertex from one inside a face.
- 2D: a closed polygon (points in the z = 0 plane); the closest point on its edges and the side from the
  crossing-number parity, exact (a handful of edges per polygon, looped over).

:class:`Solids` holds both kinds for a scene (``planar`` says which); :func:`closest_point` answers for one
solid. Gather form: every kernel writes only its own particle's entries. Precision float32; lengths in the
scene's unit.
"""

import warp as wp


@wp.struct
class Solids:
    """The solids of a scene. 3D: ``meshes``; 2D: polygon k's vertices at ``vertices[start[k]:start[k+1]]``."""

    meshes: wp.array(dtype=wp.uint64)
    vertices: wp.array(dtype=wp.vec2)
    start: wp.array(dtype=wp.int32)
    inside_allowed: wp.array(dtype=wp.int32)  # 1: a container (stay inside), 0: an obstacle (stay outside)
    count: int
    planar: int                                # 1: 2D polygons, 0: 3D meshes
    max_dist: float                            # query reach of the mesh searches (m)


@wp.func
def closest_point(s: Solids, k: int, x: wp.vec3, max_dist: float):
    """(found, closest point on solid k's surface, x inside solid k) within ``max_dist`` (2D: any distance)."""
    found = int(0)
    closest = wp.vec3(0.0, 0.0, 0.0)
    inside = int(0)
    if s.planar != 0:
        p = wp.vec2(x[0], x[1])
        best = float(1.0e30)
        crossings = int(0)
        a0 = s.start[k]
        n = s.start[k + 1] - a0
        for e in range(n):
            a = s.vertices[a0 + e]
            b = s.vertices[a0 + (e + 1) % n]
            ab = b - a
            t = wp.clamp(wp.dot(p - a, ab) / wp.max(wp.dot(ab, ab), 1.0e-30), 0.0, 1.0)
            on_edge = a + t * ab
            d2 = wp.dot(p - on_edge, p - on_edge)
            if d2 < best:
                best = d2
                closest = wp.vec3(on_edge[0], on_edge[1], 0.0)
            if (a[1] > p[1]) != (b[1] > p[1]):
                x_at = a[0] + (p[1] - a[1]) * ab[0] / ab[1]
                if p[0] < x_at:
                    crossings += 1
        found = 1
        inside = crossings % 2
    else:
        mesh = s.meshes[k]
        query = wp.mesh_query_point_sign_normal(mesh, x, max_dist)
        if query.result:
            found = 1
            closest = wp.mesh_eval_position(mesh, query.face, query.u, query.v)
            if query.sign < 0.0:
                inside = 1
    return found, closest, inside


@wp.kernel
def penetration_depth(
    first: int,
    s: Solids,
    positions: wp.array(dtype=wp.vec3),
    depth: wp.array(dtype=float),
    which: wp.array(dtype=wp.int32),
):
    """depth[i] = the largest distance of particle i below the surface of a solid it is on the wrong side of (m;
    0 if none); which[i] = that solid."""
    i = first + wp.tid()
    x = positions[i]
    deepest = float(0.0)
    solid = int(-1)
    for k in range(s.count):
        found, closest, inside = closest_point(s, k, x, s.max_dist)
        if found != 0 and inside != s.inside_allowed[k]:
            d = wp.length(x - closest)
            if d > deepest:
                deepest = d
                solid = k
    depth[i] = deepest
    which[i] = solid


@wp.kernel
def signed_distance(
    first: int,
    s: Solids,
    k: int,
    positions: wp.array(dtype=wp.vec3),
    distance: wp.array(dtype=float),
):
    """distance[i] = distance from point i to solid k's surface, negative inside it (m); +max_dist if nothing is
    within reach (3D)."""
    i = first + wp.tid()
    x = positions[i]
    found, closest, inside = closest_point(s, k, x, s.max_dist)
    d = s.max_dist
    if found != 0:
        d = wp.length(x - closest)
        if inside != 0:
            d = -d
    distance[i] = d


@wp.struct
class SurfacePenalty:
    """A stiff penalty on the true surfaces of the solids: r0 (m), the reach; stiffness c0²/r0² (1/s²)."""

    solids: Solids
    reach: float
    stiffness: float


@wp.func
def surface_overlap(penalty: SurfacePenalty, k: int, x: wp.vec3):
    """(r0 - s, n) for solid k when point x is closer to its surface than r0 on the allowed side, or past it (s the
    signed distance, > 0 on the allowed side; n the unit normal pointing to the allowed side); (0, 0) otherwise."""
    s = penalty.solids
    found, closest, inside = closest_point(s, k, x, 2.0 * penalty.reach)
    depth = float(0.0)
    n = wp.vec3(0.0, 0.0, 0.0)
    if found != 0:
        d = x - closest
        dist = wp.length(d)
        allowed = inside == s.inside_allowed[k]
        signed = dist
        if not allowed:
            signed = -dist
        if signed < penalty.reach and dist > 0.0:
            depth = penalty.reach - signed
            n = d / dist
            if not allowed:
                n = -n
    return depth, n


@wp.kernel
def add_surface_penalty(
    first: int,
    penalty: SurfacePenalty,
    near_wall: wp.array(dtype=wp.int32),
    positions: wp.array(dtype=wp.vec3),
    acceleration: wp.array(dtype=wp.vec3),
):
    """acceleration[i] += stiffness (r0 - s) n for every solid whose surface particle i is closer to than r0:
    s the signed distance (> 0 on the allowed side), n the unit normal pointing to the allowed side. Its
    potential, c0²/2 at s = 0, exceeds the kinetic energy of any particle slower than c0: no particle crosses.

    ``near_wall[i]`` > 0 where particle i has wall particles among its neighbour candidates (a particle within r0
    of a surface always has: the first wall layer lies r0 beyond it); the others skip the queries. In 2D the
    closest points lie in the plane, so the penalty has no z component."""
    i = first + wp.tid()
    if near_wall[i] == 0:
        return
    x = positions[i]
    a = wp.vec3(0.0, 0.0, 0.0)
    for k in range(penalty.solids.count):
        depth, n = surface_overlap(penalty, k, x)
        if depth > 0.0:
            a += penalty.stiffness * depth * n
    acceleration[i] = acceleration[i] + a


@wp.kernel
def contact_acceleration(
    first: int,
    penalty: SurfacePenalty,
    solid_count: int,
    rows: wp.array(dtype=wp.int32),
    offset: int,
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    acceleration: wp.array(dtype=wp.vec3),
):
    """The contact of a moving body's wall particle i = offset + rows[tid] with the first ``solid_count`` solids (the
    static ones): for every surface it is closer to than r0 on the allowed side (or past), the acceleration
    max(stiffness (r0 - s) - 2 sqrt(stiffness) v·n, 0) n, the penalty of ``add_surface_penalty`` with a critical
    damper on the normal speed (a body comes to rest on a floor without bouncing, and the damper never pulls)."""
    t = first + wp.tid()
    i = offset + rows[t]
    x = positions[i]
    v = velocities[i]
    a = wp.vec3(0.0, 0.0, 0.0)
    for k in range(solid_count):
        depth, n = surface_overlap(penalty, k, x)
        if depth > 0.0:
            push = penalty.stiffness * depth - 2.0 * wp.sqrt(penalty.stiffness) * wp.dot(v, n)
            a += wp.max(push, 0.0) * n
    acceleration[t] = a
