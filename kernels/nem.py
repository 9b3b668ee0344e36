"""NEM kernels (Rocha 2012, §3.4): Laplace (non-Sibsonian) shape functions from the Delaunay triangulation of the nodes.

Precision: float64 throughout (positions ``wp.vec2d``, circumcentres, shape functions): near a boundary edge the
circumcentres grow like L²/d (d: the distance to the edge, L the spacing) and the gradients lose about log10(L/d)
digits to cancellation, which float32 (7 digits) could not afford.

Laplace shape functions (Belikov, Ivanov, Kontorovich, Korytnik & Semenov 1997; Sukumar, Moran, Semenov &
Belikov 2001, IJNME 50:1), Rocha (2012), eqs 3.45-3.46:

    φ_i(x) = α_i(x) / Σ_j α_j(x),   α_i = s_i / h_i,   h_i = |x - x_i| / 2

s_i: the length of the edge that the Voronoi cell of x (in the diagram of the nodes plus x) shares with the cell of
node i. The natural neighbours of x are the vertices of the Bowyer-Watson cavity: the Delaunay triangles whose
circumcircle strictly contains x, connected to the triangle that holds x. The cavity is star-shaped from x, a disk
whose vertices all lie on its boundary; a neighbour across a kept side of a cavity triangle belongs to it exactly
when x is inside its circumcircle. So the kernels walk the cavity's boundary (``next_boundary_side``: from a
boundary side u → v, turn about v through cavity triangles to the next side whose far triangle is outside) and hold
no list of triangles or neighbours: each natural neighbour is one corner of the walk. Inserting x joins it to every
directed boundary side (u → v) of the cavity (counter-clockwise: the cavity on its left); the circumcentre c_e of
the new triangle (x, u, v) is a vertex of x's Voronoi cell, shared by the edges of u and v. With
t_i = rot90(x_i - x) / |x_i - x| the unit tangent of node i's Voronoi edge (both of its ends lie on the bisector of
x and x_i), and e_in, e_out the boundary sides ending and starting at node i:

    s_i = c_out·t_i - c_in·t_i      (= |c_out - c_in|)

Summed over the corners this keeps Σ_i α_i (x_i - x) = 2 rot(Σ_i (c_out - c_in)) = 0, so linear reproduction
holds to round-off by construction; s_i = 0 for a neighbour co-circular with x's cavity
(regular grids) without a kink in its gradient.

Gradients (Rocha 2012, §1.2 [INFERENCE], checked against central differences in the tests): the circumcentre c of
(x, p, q) solves (p - x)·∂c/∂x_a = c_a - x_a and (q - x)·∂c/∂x_a = c_a - x_a, so ∂c/∂x_a = w (c - x)_a
with w = M⁻¹ (1, 1)ᵀ, M = [p - x; q - x]. Since c_out - c_in ∥ t_i, ∇t_i drops out:

    ∇s_i = (t_i·w_out) (c_out - x) - (t_i·w_in) (c_in - x),   ∇h_i = (x - x_i) / (4 h_i),   ∇α_i = ∇s_i / h_i - s_i ∇h_i / h_i²
    ∇φ_i = (∇α_i - φ_i Σ_j ∇α_j) / Σ_j α_j

Special points (``laplace_rows``, then ``edge_gradients`` for points on a boundary edge):

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

Every kernel is a gather: thread i writes only point i's row (bitwise the same for any thread count). A thread
holds a few scalars and vectors, no dynamically indexed array (which a GPU keeps in local memory): a vertex of a
triangle picked by a run-time index goes through ``vertex``.
Units: lengths in the scene's unit; shape functions dimensionless, gradients per length.
"""

import warp as wp

from .neighbours import NeighbourRows

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("laplace_rows", "edge_gradients")

#: most triangles one turn around a natural neighbour crosses (typically 1-4): a guard on the walk of the cavity's
#: boundary, which cannot close when the in-circle predicate contradicts itself (many nodes on one circle)
MAX_CAVITY = 64
#: most sides of one cavity's boundary, i.e. natural neighbours (typically 4-7)
MAX_NEIGHBOURS = 64

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
def outside_cavity(mesh: Triangulation, nb: int, x: wp.vec2d) -> bool:
    """Is the triangle ``nb`` across a side of a cavity triangle outside x's cavity? -1 (a boundary side) is. A
    neighbour across a kept side is in the cavity exactly when x is inside its circumcircle."""
    out = bool(True)
    if nb >= 0:
        out = not in_circumcircle(mesh, nb, x)
    return out


@wp.func
def vertex(tv: wp.vec3i, k: int) -> int:
    """tv[k % 3] by selection: a vector indexed by a run-time value would be kept in local memory on a GPU."""
    kk = k % 3
    out = tv[0]
    if kk == 1:
        out = tv[1]
    if kk == 2:
        out = tv[2]
    return out


@wp.func
def vertex_slot(tv: wp.vec3i, node: int) -> int:
    k = int(0)
    if tv[1] == node:
        k = 1
    if tv[2] == node:
        k = 2
    return k


@wp.func
def next_boundary_side(mesh: Triangulation, x: wp.vec2d, t: int, e: int):
    """The cavity's boundary side that follows side e of cavity triangle t (u -> v, the cavity on its left): turn
    counter-clockwise about v through cavity triangles to the first side starting at v whose far triangle is
    outside. Returns (triangle, side, triangles turned through); more than MAX_CAVITY turns: the walk failed."""
    tv = mesh.triangles[t]
    v = vertex(tv, e + 2)
    tri = int(t)
    side = (e + 1) % 3  # v -> tv[e]
    turns = int(0)
    found = bool(False)
    while not found and turns <= MAX_CAVITY:
        nb = vertex(mesh.adjacent[tri], side)
        if outside_cavity(mesh, nb, x):
            found = True
        else:
            tri = nb
            side = (vertex_slot(mesh.triangles[tri], v) + 2) % 3
            turns += 1
    return tri, side, turns


@wp.func
def side_vertex(mesh: Triangulation, x: wp.vec2d, t: int, e: int):
    """Boundary side e of triangle t, u -> v: its start u, the circumcentre c_e of (x, u, v) relative to x, and
    w = M⁻¹ (1, 1) (∂c_e/∂x_a = w (c_e - x)_a; module docstring). Returns (u, c, w)."""
    tv = mesh.triangles[t]
    u = vertex(tv, e + 1)
    a = mesh.nodes[u] - x
    b = mesh.nodes[vertex(tv, e + 2)] - x
    det = cross2(a, b)
    aa = wp.dot(a, a)
    bb = wp.dot(b, b)
    two = wp.float64(2.0) * det
    c = wp.vec2d((b[1] * aa - a[1] * bb) / two, (a[0] * bb - b[0] * aa) / two)
    w = wp.vec2d((b[1] - a[1]) / det, (a[0] - b[0]) / det)
    return u, c, w


@wp.func
def alpha_at_corner(mesh: Triangulation, x: wp.vec2d, node: int, c_in: wp.vec2d, w_in: wp.vec2d, c_out: wp.vec2d,
                    w_out: wp.vec2d):
    """One corner of the cavity's boundary at ``node`` (the side ending there has Voronoi vertex c_in, the side
    starting there c_out): its part of α_i = s_i / h_i and ∇α_i, s_i = (c_out - c_in)·t_i,
    ∇s_i = (t_i·w_out) c_out - (t_i·w_in) c_in (module docstring). Returns (α, ∇α)."""
    r = mesh.nodes[node] - x
    rr = wp.dot(r, r)
    tn = rot90(r) / wp.sqrt(rr)
    s = wp.dot(c_out, tn) - wp.dot(c_in, tn)
    gs = wp.dot(tn, w_out) * c_out - wp.dot(tn, w_in) * c_in
    h = wp.float64(0.5) * wp.sqrt(rr)
    q = s / (wp.float64(4.0) * h * h * h)  # s ∇h / h² = s (x - x_i) / (4 h³)
    return s / h, gs / h + q * r


@wp.func
def degenerate(total: wp.float64, total_grad: wp.vec2d) -> bool:
    return not (total > wp.float64(0.0)) or not wp.isfinite(total) or not wp.isfinite(total_grad[0]) or not wp.isfinite(
        total_grad[1])


@wp.func
def cavity_boundary(mesh: Triangulation, x: wp.vec2d, t0: int):
    """The boundary of x's natural-neighbour cavity (t0 in it), walked once: a first side (turning about t0's
    vertex 0, a vertex of the cavity's boundary), the number m of its sides, which is the number of natural
    neighbours, the status and the normalising sums Σα, Σ∇α over its corners. The cavity is a disk with every
    vertex on its boundary (Bowyer-Watson: star-shaped from x; the kept triangles of a simple polygon keep it so),
    hence m - 2 triangles, each met once at each of its corners: a walk that meets another number of corners (a
    boundary that touches itself or has a hole: the in-circle predicate contradicting itself) is DEGENERATE, and so
    is Σα <= 0 or not finite. Returns (triangle, side, m, status, Σα, Σ∇α)."""
    status = int(OK)
    t_first, e_first, turns = next_boundary_side(mesh, x, t0, 1)
    corners = int(0)
    m = int(0)
    total = wp.float64(0.0)
    total_grad = wp.vec2d(total, total)
    if turns > MAX_CAVITY:
        status = CAVITY_OVERFLOW
    else:
        t = int(t_first)
        e = int(e_first)
        _u0, c_in, w_in = side_vertex(mesh, x, t, e)
        closed = bool(False)
        while not closed and status == OK:
            t, e, turns = next_boundary_side(mesh, x, t, e)
            corners += turns + 1
            m += 1
            if turns > MAX_CAVITY:
                status = CAVITY_OVERFLOW
            else:
                u, c, w = side_vertex(mesh, x, t, e)
                a, g = alpha_at_corner(mesh, x, u, c_in, w_in, c, w)
                total = total + a
                total_grad = total_grad + g
                c_in = c
                w_in = w
                if t == t_first and e == e_first:
                    closed = True
                elif m >= MAX_NEIGHBOURS:
                    status = NEIGHBOUR_OVERFLOW
    if status == OK and (corners != 3 * (m - 2) or degenerate(total, total_grad)):
        status = DEGENERATE
    if status != OK:
        total = wp.float64(1.0)
    return t_first, e_first, m, status, total, total_grad


@wp.func
def alpha_sums(mesh: Triangulation, x: wp.vec2d, t_first: int, e_first: int, m: int, node: int):
    """Σ α and Σ ∇α over the corners of the cavity's boundary at ``node`` (all corners when node < 0): a node's
    α_i and ∇α_i, or the normalising sums. Returns (corners at node, α, ∇α)."""
    t = int(t_first)
    e = int(e_first)
    u, c_in, w_in = side_vertex(mesh, x, t, e)
    corners = int(0)
    alpha = wp.float64(0.0)
    grad = wp.vec2d(alpha, alpha)
    for k in range(m):
        t, e, _turns = next_boundary_side(mesh, x, t, e)
        u, c, w = side_vertex(mesh, x, t, e)
        if node < 0 or u == node:
            a, g = alpha_at_corner(mesh, x, u, c_in, w_in, c, w)
            alpha = alpha + a
            grad = grad + g
            corners += 1
        c_in = c
        w_in = w
    return corners, alpha, grad


@wp.func
def normalised(alpha: wp.float64, grad: wp.vec2d, total: wp.float64, total_grad: wp.vec2d):
    """φ_i = α_i / Σα and ∇φ_i = (∇α_i - φ_i Σ∇α) / Σα. Returns (φ, ∇φ)."""
    ph = alpha / total
    return ph, (grad - ph * total_grad) / total


@wp.func
def where_on_triangle(mesh: Triangulation, x: wp.vec2d, t: int):
    """Where x lies on its triangle t: at vertex ``node`` (within NODE_TOL × the longest side, else -1), or on the
    boundary side ``edge`` (opposite that vertex, within EDGE_TOL in barycentric coordinates, else -1) at
    parameter τ from its start. A point on a boundary side is evaluated at x_ε = x_p + ε (x_w - x_p) (x_p its
    projection on the side, x_w the opposite vertex; ``inward`` = x_ε - x_p). Returns (node, edge, τ, x_ε, inward)."""
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
    edge = int(-1)
    smallest = EDGE_TOL
    for k in range(3):
        if nb3[k] < 0 and lam[k] <= smallest:
            edge = k
            smallest = lam[k]
    zero = wp.float64(0.0)
    xe = x
    inward = wp.vec2d(zero, zero)
    tau = zero
    if edge >= 0:
        u = mesh.nodes[vertex(tv, edge + 1)]
        d = mesh.nodes[vertex(tv, edge + 2)] - u
        tau = wp.clamp(wp.dot(x - u, d) / wp.dot(d, d), zero, wp.float64(1.0))
        xp = u + tau * d
        inward = EDGE_OFFSET * (mesh.nodes[vertex(tv, edge)] - xp)
        xe = xp + inward
    return node, edge, tau, xe, inward


@wp.func
def write_entry(tv: wp.vec3i, edge: int, tau: wp.float64, nd: int,
                alpha: wp.float64, grad: wp.vec2d, total: wp.float64, total_grad: wp.vec2d, rows: NeighbourRows,
                at: int, phi: wp.array(dtype=wp.float64), dphi: wp.array(dtype=wp.vec2d)):
    """Entry ``at`` of a row: node ``nd``, φ = α / Σα (on a boundary side the 1D linear interpolant between its
    ends instead) and ∇φ (``normalised``)."""
    value, g = normalised(alpha, grad, total, total_grad)
    if edge >= 0:
        value = wp.float64(0.0)
        if nd == vertex(tv, edge + 1):
            value = wp.float64(1.0) - tau
        if nd == vertex(tv, edge + 2):
            value = tau
    rows.index[at] = nd
    phi[at] = value
    dphi[at] = g


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
    indices, φ and ∇φ at ``rows.start[i]`` (module docstring: nodes, boundary edges; on a boundary side ∇φ at the
    first offset, which ``edge_gradients`` then extrapolates). The natural neighbours are met by walking the
    cavity's boundary, with no per-point list: a thread holds a few scalars and vectors (registers on a GPU, no
    local memory)."""
    i = first + wp.tid()
    x = points[i]
    t = triangle[i]
    tv = mesh.triangles[t]
    node, edge, tau, xe, _inward = where_on_triangle(mesh, x, t)
    zero = wp.float64(0.0)
    base = rows.start[i]
    if node >= 0:  # Kronecker delta; ∇φ of the linear interpolant on triangle t
        if fill == 0:
            rows.count[i] = 3
            status[i] = OK
        else:
            p0 = mesh.nodes[tv[0]]
            area2 = cross2(mesh.nodes[tv[1]] - p0, mesh.nodes[tv[2]] - p0)
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
    t1, e1, m, st, total, total_grad = cavity_boundary(mesh, xe, t)
    if fill == 0:
        rows.count[i] = m
        status[i] = st
        return
    tw = int(t1)
    ew = int(e1)
    _u, c_in, w_in = side_vertex(mesh, xe, tw, ew)
    for k in range(m):
        tw, ew, _turns = next_boundary_side(mesh, xe, tw, ew)
        nd, c, w = side_vertex(mesh, xe, tw, ew)
        alpha, grad = alpha_at_corner(mesh, xe, nd, c_in, w_in, c, w)
        c_in = c
        w_in = w
        write_entry(tv, edge, tau, nd, alpha, grad, total, total_grad, rows, base + k, phi, dphi)


@wp.kernel
def edge_gradients(
    first: int,
    mesh: Triangulation,
    points: wp.array(dtype=wp.vec2d),
    triangle: wp.array(dtype=wp.int32),
    rows: NeighbourRows,
    dphi: wp.array(dtype=wp.vec2d),
):
    """Point i on a boundary side (``where_on_triangle``; every other point is left alone): Richardson's
    ∇φ(0) ≈ 2 ∇φ(ε) - ∇φ(2ε) over the row ``laplace_rows`` wrote (∇φ at ε), when the second offset has the same
    natural neighbours (else the single offset stays; module docstring)."""
    i = first + wp.tid()
    x = points[i]
    t = triangle[i]
    node, edge, _tau, xe, inward = where_on_triangle(mesh, x, t)
    if node >= 0 or edge < 0:
        return
    x2 = xe + inward
    t2, e2, m2, st2, total2, total_grad2 = cavity_boundary(mesh, x2, t)
    base = rows.start[i]
    count = rows.count[i]
    same = bool(st2 == OK and m2 == count)
    for k in range(count):
        at, _a, _g = alpha_sums(mesh, x2, t2, e2, m2, rows.index[base + k])
        if at == 0:
            same = False
    if same:
        for k in range(count):
            _at, alpha2, grad2 = alpha_sums(mesh, x2, t2, e2, m2, rows.index[base + k])
            _value2, g2 = normalised(alpha2, grad2, total2, total_grad2)
            dphi[base + k] = wp.float64(2.0) * dphi[base + k] - g2
