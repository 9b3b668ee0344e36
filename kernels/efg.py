"""EFG kernels (seeds 003 and 002): node supports, support rows, MLS shape functions, Gauss-point assembly.

Precision: float64 for everything the MLS algebra touches (positions ``wp.vec2d``, moment matrices, shape
functions, stiffness). The moment matrix A(x) = Σ_I w_I p_I p_Iᵀ is ill-conditioned: its condition grows like
(R/h)^(2·degree) and far more next to boundaries and in truncated supports; in float32 the partition of unity
is lost at the 1e-4 level and linear reproduction fails outright near collinear nodes. Float32 ``wp.vec3``
copies of the node positions serve only the ``wp.HashGrid`` query, whose candidates are tested in float64.

MLS (seed 003 eqs 3.22-3.29; seed 002 eqs 3.10-3.19), evaluated in the γ-form (Belytschko et al. 1996) with the
basis shifted to the evaluation point x and scaled by a length s (an MLS fit with a complete basis does not
depend on the shift; shifting and scaling keep A near unit size):

    p_I = p((x_I - x)/s),  A = Σ_I w_I(x) p_I p_Iᵀ,  γ = A⁻¹ p(0),  φ_I = w_I γ·p_I
    ∂_a γ = A⁻¹ (∂_a p - ∂_a A γ),  ∂_a A = Σ_I ∂_a w_I p_I p_Iᵀ
    ∂_a φ_I = w_I ∂_a γ·p_I + ∂_a w_I γ·p_I

With the shift frozen at x̄ during differentiation, u^h(x) = p((x - x̄)/s)ᵀ A⁻¹(x) B(x) u and p_I = p((x_I - x̄)/s);
at x̄ = x, ∂_a p = e_{1+a}/s for the linear and quadratic bases. A is solved by a Cholesky factorisation of its
Jacobi-scaled form; the smallest scaled pivot (``rcond``) measures its conditioning (0 for fewer nodes than
basis terms or collinear nodes with the linear basis).

Weights w(r), r = |x - x_I| / R_I (circular support) or w(|Δx|/R_x) w(|Δy|/R_y) (rectangular, seed 002 eq 3.23):
cubic spline (seed 003 eq 3.32), quartic (3.30), Gaussian (3.31, shifted to vanish at r = 1: the printed form
jumps by e^-6.25 there), and the singular weight w(r) = cubic(r) / (r² + ε²) with ε = 1e-8 whose shape functions
interpolate (seed 002 §3.5: φ_I(x_J) = δ_IJ to ~1e-14; the thesis's singular Schwarz weight is not printed).

Units: lengths in the scene's unit; shape functions dimensionless, gradients per length.
"""

import warp as wp

from .assembly import Loads, Triplets, write_load, write_triplet
from .neighbours import NeighbourRows
from .space import Box2d, offset2d

#: largest basis (quadratic in 2D: 1, ξ, η, ξ², ξη, η²)
MAX_TERMS = 6
#: most nearest neighbours the support sizing ranks (k of the k-th nearest node)
MAX_RANK = 16

vec6d = wp.types.vector(length=MAX_TERMS, dtype=wp.float64)
mat66d = wp.types.matrix(shape=(MAX_TERMS, MAX_TERMS), dtype=wp.float64)
vec16d = wp.types.vector(length=MAX_RANK, dtype=wp.float64)

CUBIC_SPLINE = wp.constant(0)
QUARTIC = wp.constant(1)
GAUSSIAN = wp.constant(2)
SINGULAR = wp.constant(3)

#: regularisation of the singular weight's 1/r² (in units of the support radius)
SINGULAR_EPS2 = wp.constant(wp.float64(1.0e-16))


@wp.struct
class MLSParams:
    """terms: 3 (linear basis) or 6 (quadratic); weight: CUBIC_SPLINE, QUARTIC, GAUSSIAN or SINGULAR;
    rectangular: 1 for tensor-product supports (half-widths R_x, R_y), 0 for circular (radius R_x)."""

    terms: int
    weight: int
    rectangular: int


@wp.func
def weight_and_slope(kind: int, r: wp.float64) -> wp.vec2d:
    """(w(r), dw/dr) for r >= 0 (w = 0 for r >= 1). Fractions are built as float64 quotients: a literal such
    as 4.0 / 3.0 enters a kernel as a float32 constant, and w and dw/dr would then disagree at 1e-7."""
    one = wp.float64(1.0)
    w = wp.float64(0.0)
    dw = wp.float64(0.0)
    if r < one:
        if kind == QUARTIC:  # seed 003 eq 3.30
            w = one - wp.float64(6.0) * r * r + wp.float64(8.0) * r * r * r - wp.float64(3.0) * r * r * r * r
            dw = -wp.float64(12.0) * r + wp.float64(24.0) * r * r - wp.float64(12.0) * r * r * r
        elif kind == GAUSSIAN:  # seed 003 eq 3.31, shifted: (e^-(r/α)² - e^-1/α²) / (1 - e^-1/α²), α = 0.4
            a2 = wp.float64(4.0) / wp.float64(25.0)
            tail = wp.exp(-one / a2)
            e = wp.exp(-r * r / a2)
            w = (e - tail) / (one - tail)
            dw = -wp.float64(2.0) * r / a2 * e / (one - tail)
        else:  # cubic spline, seed 003 eq 3.32 (also the numerator of the singular weight)
            if r <= wp.float64(0.5):
                w = wp.float64(2.0) / wp.float64(3.0) - wp.float64(4.0) * r * r + wp.float64(4.0) * r * r * r
                dw = -wp.float64(8.0) * r + wp.float64(12.0) * r * r
            else:
                third4 = wp.float64(4.0) / wp.float64(3.0)
                w = third4 - wp.float64(4.0) * r + wp.float64(4.0) * r * r - third4 * r * r * r
                dw = -wp.float64(4.0) + wp.float64(8.0) * r - wp.float64(4.0) * r * r
            if kind == SINGULAR:  # w / (r² + ε²): φ_I(x_I) = 1
                q = r * r + SINGULAR_EPS2
                dw = dw / q - w * wp.float64(2.0) * r / (q * q)
                w = w / q
    return wp.vec2d(w, dw)


@wp.func
def node_weight(params: MLSParams, d: wp.vec2d, support: wp.vec2d) -> wp.vec3d:
    """(w, ∂w/∂x, ∂w/∂y) of a node at offset d = x - x_I with support half-widths ``support``."""
    zero = wp.float64(0.0)
    if params.rectangular != 0:
        sx = wp.abs(d[0]) / support[0]
        sy = wp.abs(d[1]) / support[1]
        # the singular weight's 1/r² belongs to the distance, not to each axis: rectangular uses the cubic
        kind = params.weight
        if kind == SINGULAR:
            kind = CUBIC_SPLINE
        wx = weight_and_slope(kind, sx)
        wy = weight_and_slope(kind, sy)
        gx = wp.sign(d[0]) * wx[1] / support[0] * wy[0]
        gy = wp.sign(d[1]) * wy[1] / support[1] * wx[0]
        return wp.vec3d(wx[0] * wy[0], gx, gy)
    dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
    r = dist / support[0]
    w = weight_and_slope(params.weight, r)
    if dist > zero:
        s = w[1] / (support[0] * dist)
        return wp.vec3d(w[0], s * d[0], s * d[1])
    return wp.vec3d(w[0], zero, zero)


@wp.func
def inside_support(params: MLSParams, d: wp.vec2d, support: wp.vec2d) -> bool:
    """Is the offset d = x - x_I strictly inside node I's support (where its weight is > 0)?"""
    if params.rectangular != 0:
        return wp.abs(d[0]) < support[0] and wp.abs(d[1]) < support[1]
    return d[0] * d[0] + d[1] * d[1] < support[0] * support[0]


@wp.func
def serves(params: MLSParams, d: wp.vec2d, material: int, support: wp.vec2d, node_material: int) -> bool:
    """Does the node at offset d = x - x_I serve the point x of ``material``: x inside its support, and the node of
    the point's material or of every material (-1: on an interface or in a one-material model; seed 002 §3.3,
    domain truncation)?"""
    if not inside_support(params, d, support):
        return False
    return node_material < 0 or material < 0 or node_material == material


@wp.func
def basis(d: wp.vec2d, inv_scale: wp.float64, terms: int) -> vec6d:
    """p(d/s): [1, ξ, η] or [1, ξ, η, ξ², ξη, η²] (unused terms 0)."""
    p = vec6d()
    xi = d[0] * inv_scale
    eta = d[1] * inv_scale
    p[0] = wp.float64(1.0)
    p[1] = xi
    p[2] = eta
    if terms == 6:
        p[3] = xi * xi
        p[4] = xi * eta
        p[5] = eta * eta
    return p


@wp.func
def cholesky(a: mat66d, terms: int) -> mat66d:
    """Lower factor L (L Lᵀ = a) of the leading terms × terms block; a non-positive pivot leaves L_kk = 0."""
    lo = mat66d()
    for j in range(terms):
        s = a[j, j]
        for k in range(j):
            s = s - lo[j, k] * lo[j, k]
        if s > wp.float64(0.0):
            lo[j, j] = wp.sqrt(s)
        for i in range(j + 1, terms):
            t = a[i, j]
            for k in range(j):
                t = t - lo[i, k] * lo[j, k]
            if lo[j, j] > wp.float64(0.0):
                lo[i, j] = t / lo[j, j]
    return lo


@wp.func
def cholesky_solve(lo: mat66d, b: vec6d, terms: int) -> vec6d:
    """x with L Lᵀ x = b (leading terms)."""
    y = vec6d()
    for i in range(terms):
        t = b[i]
        for k in range(i):
            t = t - lo[i, k] * y[k]
        y[i] = t / lo[i, i]
    x = vec6d()
    for ii in range(terms):
        i = terms - 1 - ii
        t = y[i]
        for k in range(i + 1, terms):
            t = t - lo[k, i] * x[k]
        x[i] = t / lo[i, i]
    return x


@wp.func
def nearest_copy(box: Box2d, x32: wp.vec3, grid_points: wp.array(dtype=wp.vec3), source_id: wp.array(dtype=wp.int32),
                 k: int, radius: float) -> int:
    """The node behind HashGrid point k (a node or, in a periodic box, one of its images placed by
    ``warpfree.neighbours``), or -1 when that copy lies farther than ``radius`` from x32: a periodic side >= 2 radius
    leaves at most one copy of a node within reach, so no node enters a row twice. In free space every grid point is
    its node (no test: rows exactly as before periodic boxes)."""
    if box.periodic[0] + box.periodic[1] == wp.float64(0.0):
        return source_id[k]
    d = x32 - grid_points[k]
    if wp.dot(d, d) >= radius * radius:
        return -1
    return source_id[k]


@wp.struct
class NodeSet:
    """An MLS model's nodes as kernels read them (``EFGModel.node_set``): the HashGrid (``grid``, its ``grid_points``
    and the node behind each, ``source_id``: periodic images included), the ``box``, the query radius ``reach``,
    positions in float64 (``nodes``) and float32 (``nodes32``), support half-widths and the MLS parameters."""

    grid: wp.uint64
    grid_points: wp.array(dtype=wp.vec3)
    source_id: wp.array(dtype=wp.int32)
    box: Box2d
    reach: float
    nodes: wp.array(dtype=wp.vec2d)
    nodes32: wp.array(dtype=wp.vec3)
    support: wp.array(dtype=wp.vec2d)
    params: MLSParams


@wp.func
def serving_node(ns: NodeSet, x32: wp.vec3, x: wp.vec2d, k: int) -> int:
    """The node behind HashGrid point k of ``ns`` (:func:`nearest_copy`) when x lies inside its support, else -1."""
    j = nearest_copy(ns.box, x32, ns.grid_points, ns.source_id, k, ns.reach)
    if j < 0:
        return -1
    if not inside_support(ns.params, offset2d(ns.box, x, ns.nodes[j]), ns.support[j]):
        return -1
    return j


@wp.kernel
def kth_nearest(
    first: int,
    grid: wp.uint64,
    grid_points: wp.array(dtype=wp.vec3),
    source_id: wp.array(dtype=wp.int32),
    box: Box2d,
    nodes32: wp.array(dtype=wp.vec3),
    nodes: wp.array(dtype=wp.vec2d),
    rank: int,
    radius: float,
    distance: wp.array(dtype=wp.float64),
):
    """distance[i]: the distance from node i to its ``rank``-th nearest other node (seed 003 §4.1.1: c_I), or -1
    when fewer than ``rank`` nodes lie within ``radius`` (the caller widens it)."""
    i = first + wp.tid()
    best = vec16d()
    big = wp.float64(1.0e30)
    for k in range(MAX_RANK):
        best[k] = big
    found = int(0)
    xi = nodes[i]
    query = wp.hash_grid_query(grid, nodes32[i], radius)
    k = int(0)
    while wp.hash_grid_query_next(query, k):
        j = nearest_copy(box, nodes32[i], grid_points, source_id, k, radius)
        if j < 0 or j == i:
            continue
        d = offset2d(box, nodes[j], xi)
        dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
        if dist >= wp.float64(radius):
            continue
        found += 1
        if dist < best[rank - 1]:  # insert into the sorted ``rank`` smallest
            s = rank - 1
            while s > 0 and best[s - 1] > dist:
                best[s] = best[s - 1]
                s -= 1
            best[s] = dist
    if found >= rank:
        distance[i] = best[rank - 1]
    else:
        distance[i] = wp.float64(-1.0)


@wp.kernel
def support_rows(
    first: int,
    grid: wp.uint64,
    grid_points: wp.array(dtype=wp.vec3),
    source_id: wp.array(dtype=wp.int32),
    box: Box2d,
    radius: float,
    points32: wp.array(dtype=wp.vec3),
    points: wp.array(dtype=wp.vec2d),
    point_material: wp.array(dtype=wp.int32),
    nodes: wp.array(dtype=wp.vec2d),
    support: wp.array(dtype=wp.vec2d),
    node_material: wp.array(dtype=wp.int32),
    params: MLSParams,
    fill: int,
    rows: NeighbourRows,
):
    """Row i: the nodes whose support holds point i and whose material the point sees (seed 002 §3.3, domain
    truncation: a node of material m serves points of material m; a node with material -1, on an interface or in
    a one-material model, serves every point). ``fill`` 0 counts into ``rows.count``; 1 writes the indices at
    ``rows.start[i]`` in HashGrid order (a gather: thread i writes only row i)."""
    i = first + wp.tid()
    x = points[i]
    m = point_material[i]
    n = int(0)
    base = rows.start[i]
    query = wp.hash_grid_query(grid, points32[i], radius)
    k = int(0)
    while wp.hash_grid_query_next(query, k):
        j = nearest_copy(box, points32[i], grid_points, source_id, k, radius)
        if j < 0:
            continue
        if not serves(params, offset2d(box, x, nodes[j]), m, support[j], node_material[j]):
            continue
        if fill != 0:
            rows.index[base + n] = j
        n += 1
    if fill == 0:
        rows.count[i] = n


@wp.kernel
def support_rows_brute(
    first: int,
    n_nodes: int,
    box: Box2d,
    points: wp.array(dtype=wp.vec2d),
    point_material: wp.array(dtype=wp.int32),
    nodes: wp.array(dtype=wp.vec2d),
    support: wp.array(dtype=wp.vec2d),
    node_material: wp.array(dtype=wp.int32),
    params: MLSParams,
    fill: int,
    rows: NeighbourRows,
):
    """:func:`support_rows` by testing every node (O(points x nodes)): the reference for the HashGrid search (seed
    003 compared its k-d tree with brute force the same way). Rows in node order."""
    i = first + wp.tid()
    x = points[i]
    m = point_material[i]
    n = int(0)
    base = rows.start[i]
    for j in range(n_nodes):
        if not serves(params, offset2d(box, x, nodes[j]), m, support[j], node_material[j]):
            continue
        if fill != 0:
            rows.index[base + n] = j
        n += 1
    if fill == 0:
        rows.count[i] = n


@wp.func
def solve_scaled(lo: mat66d, sc: vec6d, b: vec6d, terms: int) -> vec6d:
    """γ = A⁻¹ b from the Cholesky factor of the scaled A_s = S A S: γ = S A_s⁻¹ S b."""
    sb = vec6d()
    for r in range(terms):
        sb[r] = sc[r] * b[r]
    y = cholesky_solve(lo, sb, terms)
    for r in range(terms):
        y[r] = y[r] * sc[r]
    return y


@wp.struct
class MLSFit:
    """The γ-form of an MLS fit at one point (module docstring): γ = A⁻¹ p(0), its derivatives ∂γ/∂x and ∂γ/∂y,
    and ``rcond``, the smallest pivot of the Jacobi-scaled A (0: singular, γ not computed)."""

    gamma: vec6d
    gamma_x: vec6d
    gamma_y: vec6d
    rcond: wp.float64


@wp.func
def mls_fit(a: mat66d, ax: mat66d, ay: mat66d, terms: int, inv_scale: wp.float64) -> MLSFit:
    """γ and ∂_a γ = A⁻¹ (e_{1+a}/s - ∂_a A γ) from the moment matrix A and its derivatives ∂_x A, ∂_y A."""
    fit = MLSFit()
    zero = wp.float64(0.0)
    # Jacobi scaling: A_s = S A S, S = diag(1/sqrt(A_rr)); solve A γ = b as A_s (S⁻¹γ) = S b
    sc = vec6d()
    scaled = mat66d()
    for r in range(terms):
        sc[r] = wp.float64(1.0) / wp.sqrt(a[r, r])
    for r in range(terms):
        for c in range(terms):
            scaled[r, c] = a[r, c] * sc[r] * sc[c]
    lo = cholesky(scaled, terms)
    smallest = wp.float64(1.0)
    for r in range(terms):
        smallest = wp.min(smallest, lo[r, r] * lo[r, r])
    fit.rcond = smallest
    if smallest <= zero:
        return fit
    p0 = vec6d()
    p0[0] = wp.float64(1.0)
    gamma = solve_scaled(lo, sc, p0, terms)
    bx = vec6d()
    by = vec6d()
    for r in range(terms):
        sx = zero
        sy = zero
        for c in range(terms):
            sx = sx + ax[r, c] * gamma[c]
            sy = sy + ay[r, c] * gamma[c]
        bx[r] = -sx
        by[r] = -sy
    bx[1] = bx[1] + inv_scale
    by[2] = by[2] + inv_scale
    fit.gamma = gamma
    fit.gamma_x = solve_scaled(lo, sc, bx, terms)
    fit.gamma_y = solve_scaled(lo, sc, by, terms)
    return fit


@wp.func
def shape_value(fit: MLSFit, w: wp.vec3d, p: vec6d, terms: int) -> wp.vec3d:
    """(φ_I, ∂φ_I/∂x, ∂φ_I/∂y) = (w γ·p, w ∂_xγ·p + ∂_x w γ·p, w ∂_yγ·p + ∂_y w γ·p) of a node with weight and
    slopes ``w`` and shifted basis ``p``."""
    gp = wp.float64(0.0)
    gxp = wp.float64(0.0)
    gyp = wp.float64(0.0)
    for r in range(terms):
        gp = gp + fit.gamma[r] * p[r]
        gxp = gxp + fit.gamma_x[r] * p[r]
        gyp = gyp + fit.gamma_y[r] * p[r]
    return wp.vec3d(w[0] * gp, w[0] * gxp + w[1] * gp, w[0] * gyp + w[2] * gp)


@wp.kernel
def shape_functions(
    first: int,
    box: Box2d,
    points: wp.array(dtype=wp.vec2d),
    rows: NeighbourRows,
    nodes: wp.array(dtype=wp.vec2d),
    support: wp.array(dtype=wp.vec2d),
    params: MLSParams,
    phi: wp.array(dtype=wp.float64),
    dphi: wp.array(dtype=wp.vec2d),
    rcond: wp.array(dtype=wp.float64),
):
    """φ_I(x) and ∇φ_I(x) for every node I of point i's row (module docstring), written at the row's entries;
    rcond[i]: the smallest pivot of the Jacobi-scaled moment matrix (0: singular, not inverted)."""
    i = first + wp.tid()
    x = points[i]
    start = rows.start[i]
    count = rows.count[i]
    terms = params.terms
    zero = wp.float64(0.0)
    scale = zero
    for k in range(count):
        scale = scale + support[rows.index[start + k]][0]
    if count == 0 or count < terms:
        rcond[i] = zero
        for k in range(count):
            phi[start + k] = zero
            dphi[start + k] = wp.vec2d(zero, zero)
        return
    inv_scale = wp.float64(count) / scale
    a = mat66d()
    ax = mat66d()
    ay = mat66d()
    for k in range(count):
        j = rows.index[start + k]
        d = offset2d(box, x, nodes[j])
        w = node_weight(params, d, support[j])
        p = basis(-d, inv_scale, terms)
        for r in range(terms):
            for c in range(terms):
                pp = p[r] * p[c]
                a[r, c] = a[r, c] + w[0] * pp
                ax[r, c] = ax[r, c] + w[1] * pp
                ay[r, c] = ay[r, c] + w[2] * pp
    fit = mls_fit(a, ax, ay, terms, inv_scale)
    rcond[i] = fit.rcond
    if fit.rcond <= zero:
        for k in range(count):
            phi[start + k] = zero
            dphi[start + k] = wp.vec2d(zero, zero)
        return
    for k in range(count):
        j = rows.index[start + k]
        d = offset2d(box, x, nodes[j])
        v = shape_value(fit, node_weight(params, d, support[j]), basis(-d, inv_scale, terms), terms)
        phi[start + k] = v[0]
        dphi[start + k] = wp.vec2d(v[1], v[2])


# --- assembly: every Gauss point writes its own slots (race-free, bitwise for any thread count) -------------


@wp.kernel
def conduction_stiffness(
    first: int,
    rows: NeighbourRows,
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """K_IJ += w_g k_g ∇ψ_I·∇φ_J (seed 002 eq 3.9 with the material's k; ``weight`` holds w_g |J| k_g); ∇ψ: the test
    gradients (corrected for consistent integration, or ∇φ itself)."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    for a in range(n):
        ga = test_dphi[start + a]
        ia = rows.index[start + a]
        for b in range(n):
            gb = dphi[start + b]
            write_triplet(out, s0 + a * n + b, ia, rows.index[start + b], wg * (ga[0] * gb[0] + ga[1] * gb[1]))


@wp.kernel
def elastic_stiffness(
    first: int,
    rows: NeighbourRows,
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    material: wp.array(dtype=wp.mat33d),
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """K_IJ += w_g B̂_Iᵀ D B_J (seed 003 eq 3.35), B_I = [[φ,x 0] [0 φ,y] [φ,y φ,x]], B̂ from the test gradients
    ``test_dphi``; unknowns (u_x, u_y) of node I at 2I, 2I + 1; four slots per node pair."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    dm = material[g]
    for a in range(n):
        ga = dphi[start + a]
        ia = rows.index[start + a]
        # D B_I (3 x 2), columns for u_x and u_y
        c0 = wp.vec3d(dm[0, 0] * ga[0] + dm[0, 2] * ga[1], dm[1, 0] * ga[0] + dm[1, 2] * ga[1],
                      dm[2, 0] * ga[0] + dm[2, 2] * ga[1])
        c1 = wp.vec3d(dm[0, 1] * ga[1] + dm[0, 2] * ga[0], dm[1, 1] * ga[1] + dm[1, 2] * ga[0],
                      dm[2, 1] * ga[1] + dm[2, 2] * ga[0])
        for b in range(n):
            gb = test_dphi[start + b]
            ib = rows.index[start + b]
            s = s0 + 4 * (a * n + b)
            # (B̂_J)ᵀ D B_I: the test node J gives the row, the trial node I the column
            write_triplet(out, s, 2 * ib, 2 * ia, wg * (gb[0] * c0[0] + gb[1] * c0[2]))
            write_triplet(out, s + 1, 2 * ib, 2 * ia + 1, wg * (gb[0] * c1[0] + gb[1] * c1[2]))
            write_triplet(out, s + 2, 2 * ib + 1, 2 * ia, wg * (gb[1] * c0[1] + gb[0] * c0[2]))
            write_triplet(out, s + 3, 2 * ib + 1, 2 * ia + 1, wg * (gb[1] * c1[1] + gb[0] * c1[2]))


@wp.kernel
def corrected_gradients(
    first: int,
    rows: NeighbourRows,
    dphi: wp.array(dtype=wp.vec2d),
    point_material: wp.array(dtype=wp.int32),
    materials: int,
    correction: wp.array(dtype=wp.vec2d),
    out: wp.array(dtype=wp.vec2d),
):
    """∇ψ_I(x_g) = ∇φ_I(x_g) + ξ_{I,m} at every entry of point g's row, m the point's material (variationally
    consistent integration; one correction per node and material region, ``materials`` regions)."""
    g = first + wp.tid()
    start = rows.start[g]
    m = point_material[g]
    for a in range(rows.count[g]):
        out[start + a] = dphi[start + a] + correction[rows.index[start + a] * materials + m]


@wp.kernel
def point_loads(
    first: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    value: wp.array(dtype=wp.float64),
    components: int,
    slot_start: wp.array(dtype=wp.int32),
    out: Loads,
):
    """f_{cI + k} += φ_I(x_g) v_{g,k} for k < ``components`` (``value`` holds w_g times the source, flux or
    traction component k at index components·g + k): seed 003 eq 3.36 f_I, seed 002 eq 3.9 b_j."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    for a in range(n):
        ia = rows.index[start + a]
        for k in range(components):
            write_load(out, s0 + components * a + k, components * ia + k, phi[start + a] * value[components * g + k])


@wp.kernel
def multiplier_coupling(
    first: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    weight: wp.array(dtype=wp.float64),
    multiplier: wp.array(dtype=wp.vec2i),
    multiplier_value: wp.array(dtype=wp.vec2d),
    components: int,
    constrained: wp.vec2i,
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """G_{(cI+k),(cK+k)} += -w_g φ_I(x_g) N_K(x_g) (seed 003 eq 3.36) on an essential boundary: each boundary Gauss
    point lies on one piece whose two end multipliers K (``multiplier``, -1: none) have the linear hat values
    ``multiplier_value``; ``constrained[k]`` 1 for the components k the boundary prescribes. Row: unknown of node
    I; column: multiplier unknown."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    mk = multiplier[g]
    nv = multiplier_value[g]
    for a in range(n):
        ia = rows.index[start + a]
        for e in range(2):
            for k in range(components):
                s = s0 + (a * 2 + e) * components + k
                if mk[e] >= 0 and constrained[k] != 0:
                    write_triplet(out, s, components * ia + k, components * mk[e] + k, -wg * phi[start + a] * nv[e])


@wp.struct
class InterfaceEntry:
    """One entry of an interface point's two rows: its ``node``, its share of the jump [φ] (+φ^a on side a, -φ^b on
    side b) and of the mean flux ½ k ∇φ·n."""

    node: int
    jump: wp.float64
    flux: wp.float64


@wp.func
def interface_entry(e: int, na: int, sa: int, sb: int, rows_a: NeighbourRows, phi_a: wp.array(dtype=wp.float64),
                    dphi_a: wp.array(dtype=wp.vec2d), rows_b: NeighbourRows, phi_b: wp.array(dtype=wp.float64),
                    dphi_b: wp.array(dtype=wp.vec2d), conductivity_a: wp.float64, conductivity_b: wp.float64,
                    nv: wp.vec2d) -> InterfaceEntry:
    """Entry e of the concatenated rows (side a's ``na`` entries from ``sa``, then side b's from ``sb``)."""
    out = InterfaceEntry()
    half = wp.float64(0.5)
    if e < na:
        out.node = rows_a.index[sa + e]
        out.jump = phi_a[sa + e]
        out.flux = half * conductivity_a * wp.dot(dphi_a[sa + e], nv)
    else:
        out.node = rows_b.index[sb + e - na]
        out.jump = -phi_b[sb + e - na]
        out.flux = half * conductivity_b * wp.dot(dphi_b[sb + e - na], nv)
    return out


@wp.kernel
def interface_terms(
    first: int,
    rows_a: NeighbourRows,
    phi_a: wp.array(dtype=wp.float64),
    dphi_a: wp.array(dtype=wp.vec2d),
    rows_b: NeighbourRows,
    phi_b: wp.array(dtype=wp.float64),
    dphi_b: wp.array(dtype=wp.vec2d),
    normal: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    conductivity_a: wp.float64,
    conductivity_b: wp.float64,
    penalty: wp.float64,
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """Symmetric Nitsche terms on a material interface between truncated supports (side a -> b along ``normal``):

        K_IJ += w_g ( -{k ∂φ_J/∂n}[φ_I] - {k ∂φ_I/∂n}[φ_J] + α [φ_I][φ_J] ),  [φ] = φ^a - φ^b,
        {k ∂φ/∂n} = ½ (k_a ∇φ^a + k_b ∇φ^b)·n

    over the entries of both sides' rows (a node on the interface appears in both): the interface term of the weak
    form that domain truncation drops, its symmetric partner and a penalty α = β k_max / h (``penalty``)."""
    g = first + wp.tid()
    sa = rows_a.start[g]
    na = rows_a.count[g]
    sb = rows_b.start[g]
    nb = rows_b.count[g]
    n = na + nb
    s0 = slot_start[g]
    wg = weight[g]
    nv = normal[g]
    for e in range(n):
        a = interface_entry(e, na, sa, sb, rows_a, phi_a, dphi_a, rows_b, phi_b, dphi_b, conductivity_a,
                            conductivity_b, nv)
        for f in range(n):
            b = interface_entry(f, na, sa, sb, rows_a, phi_a, dphi_a, rows_b, phi_b, dphi_b, conductivity_a,
                                conductivity_b, nv)
            write_triplet(out, s0 + e * n + f, a.node, b.node,
                          wg * (-b.flux * a.jump - a.flux * b.jump + penalty * a.jump * b.jump))


@wp.kernel
def boundary_mass(
    first: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    weight: wp.array(dtype=wp.float64),
    components: int,
    constrained: wp.vec2i,
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """M_{(cI+k),(cJ+k)} += w_g φ_I φ_J on a boundary, for the constrained components k (the penalty method's
    α ∫ φ_I φ_J dΓ, α applied by the caller through ``weight``)."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    for a in range(n):
        ia = rows.index[start + a]
        for b in range(n):
            ib = rows.index[start + b]
            for k in range(components):
                if constrained[k] != 0:
                    write_triplet(out, s0 + (a * n + b) * components + k, components * ia + k, components * ib + k,
                                  wg * phi[start + a] * phi[start + b])


@wp.kernel
def evaluate_field(
    first: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    dphi: wp.array(dtype=wp.vec2d),
    nodal: wp.array(dtype=wp.float64),
    components: int,
    value: wp.array(dtype=wp.float64),
    gradient: wp.array(dtype=wp.vec2d),
):
    """u^h_k(x_i) = Σ_I φ_I(x_i) u_{cI+k} and its gradient Σ_I ∇φ_I u_{cI+k} (seed 003 eq 3.28), k < components."""
    i = first + wp.tid()
    start = rows.start[i]
    n = rows.count[i]
    for k in range(components):
        v = wp.float64(0.0)
        gx = wp.float64(0.0)
        gy = wp.float64(0.0)
        for a in range(n):
            u = nodal[components * rows.index[start + a] + k]
            v = v + phi[start + a] * u
            d = dphi[start + a]
            gx = gx + d[0] * u
            gy = gy + d[1] * u
        value[components * i + k] = v
        gradient[components * i + k] = wp.vec2d(gx, gy)


# --- assembly by node rows: each node gathers its Gauss points (race-free, no triplet sum) ------------------


@wp.func
def pattern_position(cols: wp.array(dtype=wp.int32), lo: int, hi: int, j: int) -> int:
    """Position of column j in the sorted ``cols[lo:hi]`` of one pattern row (binary search; j is present)."""
    a = lo
    b = hi
    while a < b:
        m = (a + b) // 2
        if cols[m] < j:
            a = m + 1
        else:
            b = m
    return a


@wp.kernel
def conduction_rows(
    first: int,
    rows: NeighbourRows,
    node_entries: NeighbourRows,
    entry_point: wp.array(dtype=wp.int32),
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    pattern_start: wp.array(dtype=wp.int32),
    pattern_cols: wp.array(dtype=wp.int32),
    values: wp.array(dtype=wp.float64),
):
    """Row I of K_IJ = Σ_g w_g ∇ψ_I(x_g)·∇φ_J(x_g) (seed 002 eq 3.9): node I gathers the Gauss points g in its
    support (``node_entries``: the row entries that hold I, in Gauss-point order; ``entry_point``: entry -> g) and
    adds each pair into its slot of the CSR pattern (``pattern_start``/``pattern_cols``, sorted columns)."""
    i = first + wp.tid()
    lo = pattern_start[i]
    hi = pattern_start[i + 1]
    for k in range(node_entries.count[i]):
        e = node_entries.index[node_entries.start[i] + k]
        g = entry_point[e]
        t = test_dphi[e]
        wg = weight[g]
        s = rows.start[g]
        for b in range(rows.count[g]):
            q = dphi[s + b]
            pos = pattern_position(pattern_cols, lo, hi, rows.index[s + b])
            values[pos] = values[pos] + wg * (t[0] * q[0] + t[1] * q[1])


@wp.kernel
def elastic_rows(
    first: int,
    rows: NeighbourRows,
    node_entries: NeighbourRows,
    entry_point: wp.array(dtype=wp.int32),
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    material: wp.array(dtype=wp.mat33d),
    pattern_start: wp.array(dtype=wp.int32),
    pattern_cols: wp.array(dtype=wp.int32),
    values: wp.array(dtype=wp.mat22d),
):
    """Block row I of K_IJ = Σ_g w_g B̂_Iᵀ D_g B_J (seed 003 eq 3.35), 2 x 2 blocks (row: component of the test node
    I, column: of the trial node J), gathered as in :func:`conduction_rows`."""
    i = first + wp.tid()
    lo = pattern_start[i]
    hi = pattern_start[i + 1]
    for k in range(node_entries.count[i]):
        e = node_entries.index[node_entries.start[i] + k]
        g = entry_point[e]
        t = test_dphi[e]
        wg = weight[g]
        dm = material[g]
        s = rows.start[g]
        for b in range(rows.count[g]):
            q = dphi[s + b]
            # D B_J, columns for u_x and u_y of J
            c0 = wp.vec3d(dm[0, 0] * q[0] + dm[0, 2] * q[1], dm[1, 0] * q[0] + dm[1, 2] * q[1],
                          dm[2, 0] * q[0] + dm[2, 2] * q[1])
            c1 = wp.vec3d(dm[0, 1] * q[1] + dm[0, 2] * q[0], dm[1, 1] * q[1] + dm[1, 2] * q[0],
                          dm[2, 1] * q[1] + dm[2, 2] * q[0])
            block = wp.mat22d(t[0] * c0[0] + t[1] * c0[2], t[0] * c1[0] + t[1] * c1[2],
                              t[1] * c0[1] + t[0] * c0[2], t[1] * c1[1] + t[0] * c1[2])
            pos = pattern_position(pattern_cols, lo, hi, rows.index[s + b])
            values[pos] = values[pos] + wg * block
