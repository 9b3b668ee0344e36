"""Penetration of particles into solids, from the true surfaces (``wp.Mesh``, closest point and sign).

A solid is a closed triangle mesh with a side the particles must stay on: inside a container, outside an
obstacle. For particle i the depth is the distance to the surface when it is on the wrong side, 0
otherwise (m); kernels over several solids keep the largest depth. 2D solids are polygons extruded into
prisms and queried in their z = 0 plane. The sign comes from Warp's angle-weighted pseudo-normal test
(robust for watertight, non-self-intersecting meshes). Every query passes ``TIE`` = 1e-6 as the tolerance
within which Warp treats two distances as equal (a fraction of the mesh's mean edge length; its default,
1e-3, is wider than dx for a small scene with tall prisms, and gave a particle the sign of the wrong side).

Gather form: thread i writes only depth[i]. Precision float32 (the queries are), so depths below about
1e-6 of the mesh size are round-off.
"""

import warp as wp

#: distances within this fraction of the mean edge length count as equal in the closest-feature search
TIE = wp.constant(1.0e-6)


@wp.kernel
def penetration_depth(
    first: int,
    mesh: wp.uint64,
    solid: int,
    inside_allowed: int,
    max_dist: float,
    positions: wp.array(dtype=wp.vec3),
    depth: wp.array(dtype=float),
    which: wp.array(dtype=wp.int32),
):
    """depth[i] = max(depth[i], distance to the mesh if particle i is on the forbidden side); which[i] = the
    solid of the largest depth so far."""
    i = first + wp.tid()
    x = positions[i]
    q = wp.mesh_query_point_sign_normal(mesh, x, max_dist, TIE)
    if q.result:
        inside = q.sign < 0.0
        if inside != (inside_allowed != 0):
            d = wp.length(x - wp.mesh_eval_position(mesh, q.face, q.u, q.v))
            if d > depth[i]:
                depth[i] = d
                which[i] = solid


@wp.kernel
def signed_distance(
    first: int,
    mesh: wp.uint64,
    max_dist: float,
    positions: wp.array(dtype=wp.vec3),
    distance: wp.array(dtype=float),
):
    """distance[i] = distance from point i to the mesh, negative inside (m); +max_dist if nothing is closer."""
    i = first + wp.tid()
    x = positions[i]
    q = wp.mesh_query_point_sign_normal(mesh, x, max_dist, TIE)
    d = max_dist
    if q.result:
        d = wp.length(x - wp.mesh_eval_position(mesh, q.face, q.u, q.v)) * q.sign
    distance[i] = d


@wp.struct
class SurfacePenalty:
    """A stiff penalty on the true surfaces of the solids: r0 (m), the reach; stiffness c0²/r0² (1/s²)."""

    meshes: wp.array(dtype=wp.uint64)        # one per solid
    inside_allowed: wp.array(dtype=wp.int32)  # 1: a container (stay inside), 0: an obstacle (stay outside)
    reach: float                              # r0 (m)
    stiffness: float                          # c0²/r0² (1/s²)
    planar: int                               # 1 in 2D: the solids are prisms, the penalty acts in z = 0 only


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
    of a surface always has: the first wall layer lies r0 beyond it); the others skip the mesh queries."""
    i = first + wp.tid()
    if near_wall[i] == 0:
        return
    x = positions[i]
    a = wp.vec3(0.0, 0.0, 0.0)
    for k in range(penalty.meshes.shape[0]):
        mesh = penalty.meshes[k]
        q = wp.mesh_query_point_sign_normal(mesh, x, 2.0 * penalty.reach, TIE)
        if q.result:
            closest = wp.mesh_eval_position(mesh, q.face, q.u, q.v)
            d = x - closest
            if penalty.planar != 0:
                # the closest point on a prism's tall faces carries a float32 error in z: keep the penalty in
                # the plane, else that error becomes a z-acceleration that lifts 2D particles out of it
                d = wp.vec3(d[0], d[1], 0.0)
            dist = wp.length(d)
            outside_side = q.sign >= 0.0
            allowed = outside_side != (penalty.inside_allowed[k] != 0)
            s = dist
            if not allowed:
                s = -dist
            if s < penalty.reach and dist > 0.0:
                n = d / dist
                if not allowed:
                    n = -n
                a += penalty.stiffness * (penalty.reach - s) * n
    acceleration[i] = acceleration[i] + a
