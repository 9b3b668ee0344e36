"""NEM kernels (seed 003 §3.4): Laplace (non-Sibsonian) shape functions from the Delaunay triangulation of the nodes.

Precision: float64 throughout (positions ``wp.vec2d``, circumcentres, shape functions): near a boundary edge the
circumcentres grow like L²/d (d: the distance to the edge, L the spacing) and the gradients lose about log10(L/d)
digits to cancellation, which float32 (7 digits) could not afford.

Laplace shape functions (Belikov, Ivanov, Kontorovich, Korytnik & Semenov 1997; Sukumar, Moran, Semenov &
Belikov 2001, IJNME 50:1), seed 003 eqs 3.45-3.46:

    φ_i(x) = α_i(x) / Σ_j α_j(x),   α_i = s_i / h_i,   h_i = |x - x_i| / 2

s_i: the length of the edge that the Voronoi cell of x (in the diagram of the nodes plus x) shares with the cell of
node i. The natural neighbours of x are the vertices of the Bowyer-Watson cavity: the Delaunay triangles whose
circumcircle strictly contains x, found by a breadth-first walk over triangle adjacency from the triangle that
holds x (the cavity is connected). Inserting x joins it to every directed boundary edge (u → v) of the cavity
(counter-clockwise: the cavity on its left); the circumcentre c_e of the new triangle (x, u, v) is a vertex of x's
Voronoi cell, shared by the edges of u and v. With t_i = rot90(x_i - x) / |x_i - x| the unit tangent of node i's
Voronoi edge (both of its ends lie on the bisector of x and x_i):

    s_i = Σ_{e starting at i} c_e·t_i - Σ_{e ending at i} c_e·t_i      (= |c_b - c_a| for a star-shaped cavity)

This signed sum needs no angular sort of the neighbours and keeps Σ_i α_i (x_i - x) = 2 rot(Σ_i (c_b - c_a)) = 0,
so linear reproduction holds to round-off by construction; s_i = 0 for a neighbour co-circular with x's cavity
(regular grids) without a kink in its gradient.

Gradients (seed 003 §1.2 [INFERENCE], checked against central differences in the tests): the circumcentre c of
(x, p, q) solves (p - x)·∂c/∂x_a = c_a - x_a and (q - x)·∂c/∂x_a = c_a - x_a, so ∂c/∂x_a = w (c - x)_a
with w = M⁻¹ (1, 1)ᵀ, M = [p - x; q - x]. Since c_b - c_a ∥ t_i, ∇t_i drops out:

    ∇s_i = Σ± (t_i·w_e) (c_e - x),   ∇h_i = (x - x_i) / (4 h_i),   ∇α_i = ∇s_i / h_i - s_i ∇h_i / h_i²
    ∇φ_i = (∇α_i - φ_i Σ_j ∇α_j) / Σ_j α_j

Special points (``laplace_rows``):

- x at a node (within ``NODE_TOL`` × the longest edge of its triangle): φ = Kronecker delta; the row is the three
  vertices of the located triangle and ∇φ the gradient of the linear (P1) interpolant on it. The Laplace functions
  are only C⁰ at a node: the limit of ∇φ depends on the direction of approach, so this is a choice (it keeps
  Σ∇φ_i = 0 and Σ∇φ_i x_iᵀ = I).
- x on a boundary edge (u, v) of the triangulation (a triangle side with no neighbour: the convex hull, or the side
  of a triangle removed by a non-convex domain) within ``EDGE_TOL`` in barycentric coordinates: the Voronoi cell is
  unbounded there and the interpolant is the 1D linear one between u and v (Sukumar et al. 2001): φ_u = 1 - τ,
  φ_v = τ (τ: the projection of x on the edge), 0 for the other neighbours (the row lists the natural neighbours
  of the point below). ∇φ is the one-sided limit from inside, extrapolated from two interior points:
  ∇φ ≈ 2 ∇φ(x_ε) - ∇φ(x_2ε), x_ε = x_p + ε (x_w - x_p) (x_p the projection, x_w the triangle's third vertex,
  ε = ``EDGE_OFFSET``: points inside the triangle at ε and 2ε times its height from the edge); a single offset when the
  two have different natural neighbours. Measured on a 11 x 11 random grid (spacing 0.1): the interior gradient
  approaches its limit linearly, relative error ≈ 30 d / L at distance d (3e-4 at d = 1e-6), while rounding grows
  like 1e-16 L / d; the extrapolation at ε = 3e-7 is within ~2e-9 of the limit (a single offset at best ~3e-7).
  Points just inside, with a barycentric coordinate between EDGE_TOL and ~1e-7, take the interior route: exact φ,
  ∇φ with a rounding error up to ~1e-16 L / d (1e-6 at the EDGE_TOL band's edge).

Every kernel is a gather: thread i writes only point i's row (bitwise the same for any thread count).
Units: lengths in the scene's unit; shape functions dimensionless, gradients per length.
"""

import warp as wp

from .neighbours import NeighbourRows

#: most Delaunay triangles in one natural-neighbour cavity (typically 2-6; a point on the common circle of many
#: co-circular nodes has more)
MAX_CAVITY = 64
#: most natural neighbours of one point (typically 4-7)
MAX_NEIGHBOURS = 32

OK = wp.constant(0)
CAVITY_OVERFLOW = wp.constant(1)
NEIGHBOUR_OVERFLOW = wp.constant(2)
DEGENERATE = wp.constant(3)

#: a point within NODE_TOL × the longest side of its triangle of a vertex is at that node
NODE_TOL = wp.constant(wp.float64(1.0e-12))
#: a point whose barycentric coordinate opposite a boundary edge is <= EDGE_TOL lies on that edge
EDGE_TOL = wp.constant(wp.float64(1.0e-10))
#: where the gradient of a point on a boundary edge is taken: this fraction (ε) of the way to the opposite vertex,
#: and 2ε (Richardson extrapolation to the edge)
EDGE_OFFSET = wp.constant(wp.float64(3.0e-7))

veccavity = wp.types.vector(length=MAX_CAVITY, dtype=wp.int32)
vecnbi = wp.types.vector(length=MAX_NEIGHBOURS, dtype=wp.int32)
vecnbd = wp.types.vector(length=MAX_NEIGHBOURS, dtype=wp.float64)


@wp.struct
class Triangulation:
    """The (kept) Delaunay triangles: ``triangles`` vertex indices counter-clockwise, ``adjacent[t][k]`` the triangle
    across the side opposite vertex k (-1: a boundary side, of the hull or of a removed triangle), ``nodes`` (m)."""

    nodes: wp.array(dtype=wp.vec2d)
    triangles: wp.array(dtype=wp.vec3i)
    adjacent: wp.array(dtype=wp.vec3i)


@wp.func
def cross2(a: wp.vec2d, b: wp.vec2d) -> wp.float64:
    return a[0] * b[1] - a[1] * b[0]


@wp.func
def in_circumcircle(mesh: Triangulation, t: int, x: wp.vec2d) -> bool:
    """Is x strictly inside the circumcircle of triangle t (counter-clockwise)? The in-circle determinant in
    coordinates relative to x (no circumradius: well conditioned for the flat triangles along a straight hull)."""
    tv = mesh.triangles[t]
    a = mesh.nodes[tv[0]] - x
    b = mesh.nodes[tv[1]] - x
    c = mesh.nodes[tv[2]] - x
    det = (wp.dot(a, a) * cross2(b, c) + wp.dot(b, b) * cross2(c, a) + wp.dot(c, c) * cross2(a, b))
    return det > wp.float64(0.0)


@wp.func
def rot90(d: wp.vec2d) -> wp.vec2d:
    return wp.vec2d(-d[1], d[0])


@wp.func
def laplace_at(mesh: Triangulation, x: wp.vec2d, t0: int):
    """Natural neighbours of x (whose cavity holds triangle t0) and their φ, ∂φ/∂x, ∂φ/∂y (module docstring).
    Returns (count, status, node ids, φ, ∂φ/∂x, ∂φ/∂y)."""
    zero = wp.float64(0.0)
    status = int(OK)
    # breadth-first walk of the cavity
    cav = veccavity()
    cav[0] = t0
    ncav = int(1)
    head = int(0)
    while head < ncav:
        t = cav[head]
        head += 1
        nb3 = mesh.adjacent[t]
        for e in range(3):
            nb = nb3[e]
            if nb >= 0:
                listed = bool(False)
                for j in range(ncav):
                    if cav[j] == nb:
                        listed = True
                if not listed:
                    if in_circumcircle(mesh, nb, x):
                        if ncav < MAX_CAVITY:
                            cav[ncav] = nb
                            ncav += 1
                        else:
                            status = CAVITY_OVERFLOW
    # boundary edges (u -> v, cavity on the left): Voronoi vertex c_e, accumulate s_i and ∇s_i
    ids = vecnbi()
    s = vecnbd()
    gsx = vecnbd()
    gsy = vecnbd()
    count = int(0)
    for k in range(ncav):
        t = cav[k]
        tv = mesh.triangles[t]
        nb3 = mesh.adjacent[t]
        for e in range(3):
            nb = nb3[e]
            inner = bool(False)
            if nb >= 0:
                for j in range(ncav):
                    if cav[j] == nb:
                        inner = True
            if not inner:
                u = tv[(e + 1) % 3]
                v = tv[(e + 2) % 3]
                a = mesh.nodes[u] - x
                b = mesh.nodes[v] - x
                det = cross2(a, b)
                aa = wp.dot(a, a)
                bb = wp.dot(b, b)
                two = wp.float64(2.0) * det
                c = wp.vec2d((b[1] * aa - a[1] * bb) / two, (a[0] * bb - b[0] * aa) / two)  # c_e - x
                w = wp.vec2d((b[1] - a[1]) / det, (a[0] - b[0]) / det)  # M⁻¹ (1, 1)
                # the edge starts at u (+ c_e·t_u) and ends at v (- c_e·t_v)
                for end in range(2):
                    node = u
                    r = a
                    rr = aa
                    sign = wp.float64(1.0)
                    if end == 1:
                        node = v
                        r = b
                        rr = bb
                        sign = wp.float64(-1.0)
                    slot = int(-1)
                    for j in range(count):
                        if ids[j] == node:
                            slot = j
                    if slot < 0:
                        if count < MAX_NEIGHBOURS:
                            slot = count
                            ids[count] = node
                            s[count] = zero
                            gsx[count] = zero
                            gsy[count] = zero
                            count += 1
                        else:
                            status = NEIGHBOUR_OVERFLOW
                    if slot >= 0:
                        tn = rot90(r) / wp.sqrt(rr)
                        kn = wp.dot(tn, w)
                        s[slot] = s[slot] + sign * wp.dot(c, tn)
                        gsx[slot] = gsx[slot] + sign * kn * c[0]
                        gsy[slot] = gsy[slot] + sign * kn * c[1]
    # α_i = s_i / h_i and its gradient (reusing s, gsx, gsy), then φ_i and ∇φ_i
    total = zero
    tgx = zero
    tgy = zero
    for k in range(count):
        d = x - mesh.nodes[ids[k]]
        h = wp.float64(0.5) * wp.sqrt(wp.dot(d, d))
        al = s[k] / h
        q = s[k] / (wp.float64(4.0) * h * h * h)  # s ∇h / h² = s (x - x_i) / (4 h³)
        gx = gsx[k] / h - q * d[0]
        gy = gsy[k] / h - q * d[1]
        s[k] = al
        gsx[k] = gx
        gsy[k] = gy
        total = total + al
        tgx = tgx + gx
        tgy = tgy + gy
    if not (total > zero) or not wp.isfinite(total) or not wp.isfinite(tgx) or not wp.isfinite(tgy):
        if status == OK:
            status = DEGENERATE
        total = wp.float64(1.0)
    for k in range(count):
        ph = s[k] / total
        s[k] = ph
        gsx[k] = (gsx[k] - ph * tgx) / total
        gsy[k] = (gsy[k] - ph * tgy) / total
    return count, status, ids, s, gsx, gsy


@wp.kernel
def laplace_rows(
    first: int,
    mesh: Triangulation,
    points: wp.array(dtype=wp.vec2d),
    triangle: wp.array(dtype=wp.int32),
    fill: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    dphi: wp.array(dtype=wp.vec2d),
    status: wp.array(dtype=wp.int32),
):
    """Point i (in triangle ``triangle[i]``, found on the host): ``fill`` 0 writes its natural-neighbour count into
    ``rows.count`` and its status (OK, CAVITY_OVERFLOW, NEIGHBOUR_OVERFLOW, DEGENERATE); 1 writes the row's node
    indices, φ and ∇φ at ``rows.start[i]`` (module docstring: nodes, boundary edges)."""
    i = first + wp.tid()
    x = points[i]
    t = triangle[i]
    tv = mesh.triangles[t]
    nb3 = mesh.adjacent[t]
    p0 = mesh.nodes[tv[0]]
    p1 = mesh.nodes[tv[1]]
    p2 = mesh.nodes[tv[2]]
    area2 = cross2(p1 - p0, p2 - p0)
    lam = wp.vec3d(cross2(p1 - x, p2 - x) / area2, cross2(p2 - x, p0 - x) / area2, cross2(p0 - x, p1 - x) / area2)
    longest = wp.max(wp.max(wp.length_sq(p1 - p0), wp.length_sq(p2 - p1)), wp.length_sq(p0 - p2))
    node = int(-1)
    for k in range(3):
        d = x - mesh.nodes[tv[k]]
        if wp.dot(d, d) <= NODE_TOL * NODE_TOL * longest:
            node = k
    zero = wp.float64(0.0)
    base = rows.start[i]
    if node >= 0:  # Kronecker delta; ∇φ of the linear interpolant on triangle t
        if fill == 0:
            rows.count[i] = 3
            status[i] = OK
        else:
            for k in range(3):
                a = mesh.nodes[tv[(k + 1) % 3]]
                b = mesh.nodes[tv[(k + 2) % 3]]
                rows.index[base + k] = tv[k]
                if k == node:
                    phi[base + k] = wp.float64(1.0)
                else:
                    phi[base + k] = zero
                dphi[base + k] = wp.vec2d(a[1] - b[1], b[0] - a[0]) / area2
        return
    edge = int(-1)
    smallest = EDGE_TOL
    for k in range(3):
        if nb3[k] < 0 and lam[k] <= smallest:
            edge = k
            smallest = lam[k]
    xe = x
    inward = wp.vec2d(zero, zero)
    tau = zero
    if edge >= 0:  # on a boundary edge u -> v: evaluate the gradient just inside
        u = mesh.nodes[tv[(edge + 1) % 3]]
        v = mesh.nodes[tv[(edge + 2) % 3]]
        d = v - u
        tau = wp.clamp(wp.dot(x - u, d) / wp.dot(d, d), zero, wp.float64(1.0))
        xp = u + tau * d
        inward = EDGE_OFFSET * (mesh.nodes[tv[edge]] - xp)
        xe = xp + inward
    count, st, ids, ph, gx, gy = laplace_at(mesh, xe, t)
    if fill == 0:
        rows.count[i] = count
        status[i] = st
        return
    if edge >= 0:  # Richardson: ∇φ(0) ≈ 2 ∇φ(ε) - ∇φ(2ε) when both offsets have the same natural neighbours
        # (else the single offset)
        count2, st2, ids2, _ph2, gx2, gy2 = laplace_at(mesh, xe + inward, t)
        same = bool(st2 == OK and count2 == count)
        slot = vecnbi()
        for k in range(count):
            slot[k] = -1
            for j in range(count2):
                if ids2[j] == ids[k]:
                    slot[k] = j
            if slot[k] < 0:
                same = False
        if same:
            for k in range(count):
                gx[k] = wp.float64(2.0) * gx[k] - gx2[slot[k]]
                gy[k] = wp.float64(2.0) * gy[k] - gy2[slot[k]]
    for k in range(count):
        value = ph[k]
        if edge >= 0:
            value = zero
            if ids[k] == tv[(edge + 1) % 3]:
                value = wp.float64(1.0) - tau
            if ids[k] == tv[(edge + 2) % 3]:
                value = tau
        rows.index[base + k] = ids[k]
        phi[base + k] = value
        dphi[base + k] = wp.vec2d(gx[k], gy[k])
