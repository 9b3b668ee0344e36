"""MLS kernels (seeds 003 and 002), shared by EFG and PIC: node supports, support rows, moment accumulation, fits and
shape functions.

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

from .neighbours import NeighbourRows
from .smoothing import unit_cubic_spline
from .space import Box2d, offset2d

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
            w, dw = unit_cubic_spline(r)
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
    """An MLS model's nodes as kernels read them (``MLSModel.node_set``): the HashGrid (``grid``, its ``grid_points``
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
class Moments:
    """A point's moment matrix A = Σ_I w_I p_I p_Iᵀ and its derivatives ∂_x A = Σ_I ∂_x w_I p_I p_Iᵀ, ∂_y A (module
    docstring; the leading terms × terms block)."""

    a: mat66d
    ax: mat66d
    ay: mat66d


def _node_adder(terms: int):
    @wp.func
    def add_node(m: Moments, w: wp.vec3d, p: vec6d) -> Moments:
        """``m`` plus one node's share: weight and slopes ``w`` = (w_I, ∂_x w_I, ∂_y w_I), shifted basis ``p`` = p_I."""
        a = m.a
        ax = m.ax
        ay = m.ay
        for r in range(wp.static(terms)):
            for c in range(wp.static(terms)):
                pp = p[r] * p[c]
                a[r, c] = a[r, c] + w[0] * pp
                ax[r, c] = ax[r, c] + w[1] * pp
                ay[r, c] = ay[r, c] + w[2] * pp
        out = Moments()
        out.a = a
        out.ax = ax
        out.ay = ay
        return out

    return add_node


#: basis size -> ``add_node(m, w, p) -> Moments``, the moment accumulation of every MLS fit (shape functions here, the
#: PIC particles' fits), made for each basis size at import so that its loops have constant bounds (the PIC fits
#: run twice as long with the size read at run time)
NODE_ADDERS = {terms: _node_adder(terms) for terms in (3, MAX_TERMS)}


@wp.struct
class MLSFit:
    """The γ-form of an MLS fit at one point (module docstring): γ = A⁻¹ p(0), its derivatives ∂γ/∂x and ∂γ/∂y,
    and ``rcond``, the smallest pivot of the Jacobi-scaled A (0: singular, γ not computed)."""

    gamma: vec6d
    gamma_x: vec6d
    gamma_y: vec6d
    rcond: wp.float64


@wp.func
def mls_fit(m: Moments, terms: int, inv_scale: wp.float64) -> MLSFit:
    """γ and ∂_a γ = A⁻¹ (e_{1+a}/s - ∂_a A γ) from the moment matrix A and its derivatives ∂_x A, ∂_y A."""
    fit = MLSFit()
    a = m.a
    ax = m.ax
    ay = m.ay
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


_SHAPE_FUNCTIONS: dict = {}


def shape_functions_kernel(basis_terms: int):
    """The kernel ``shape_functions`` for a basis of ``basis_terms`` (3 linear, 6 quadratic; ``params.terms`` must
    be the same), its moment loops of constant bounds (cached: one compile per basis size)."""
    if basis_terms in _SHAPE_FUNCTIONS:
        return _SHAPE_FUNCTIONS[basis_terms]
    add_node = NODE_ADDERS[basis_terms]

    @wp.kernel(module="unique")
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
        terms = wp.static(basis_terms)
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
        moments = Moments()
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            moments = add_node(moments, node_weight(params, d, support[j]), basis(-d, inv_scale, terms))
        fit = mls_fit(moments, terms, inv_scale)
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

    _SHAPE_FUNCTIONS[basis_terms] = shape_functions
    return shape_functions
