"""MLS kernels (Rocha 2012; Marques 2008), shared by EFG and PIC: node supports, support rows, moment accumulation, fits and
shape functions.

Precision: float64 for everything the MLS algebra touches (positions ``wp.vec2d``, moment matrices, shape
functions, stiffness). The moment matrix A(x) = Σ_I w_I p_I p_Iᵀ is ill-conditioned: its condition grows like
(R/h)^(2·degree) and far more next to boundaries and in truncated supports; in float32 the partition of unity
is lost at the 1e-4 level and linear reproduction fails outright near collinear nodes. Float32 ``wp.vec3``
copies of the node positions serve only the ``wp.HashGrid`` query, whose candidates are tested in float64.

MLS (Rocha 2012, eqs 3.22-3.29; Marques 2008, eqs 3.10-3.19), evaluated in the γ-form (Belytschko et al. 1996) with the
basis shifted to the evaluation point x and scaled by a length s (an MLS fit with a complete basis does not
depend on the shift; shifting and scaling keep A near unit size):

    p_I = p((x_I - x)/s),  A = Σ_I w_I(x) p_I p_Iᵀ,  γ = A⁻¹ p(0),  φ_I = w_I γ·p_I
    ∂_a γ = A⁻¹ (∂_a p - ∂_a A γ),  ∂_a A = Σ_I ∂_a w_I p_I p_Iᵀ
    ∂_a φ_I = w_I ∂_a γ·p_I + ∂_a w_I γ·p_I

With the shift frozen at x̄ during differentiation, u^h(x) = p((x - x̄)/s)ᵀ A⁻¹(x) B(x) u and p_I = p((x_I - x̄)/s);
at x̄ = x, ∂_a p = e_{1+a}/s for the linear and quadratic bases. A is solved by a Cholesky factorisation of its
Jacobi-scaled form; the smallest scaled pivot (``rcond``) measures its conditioning (0 for fewer nodes than
basis terms or collinear nodes with the linear basis).

Weights w(r), r = |x - x_I| / R_I (circular support) or w(|Δx|/R_x) w(|Δy|/R_y) (rectangular, Marques 2008, eq. 3.23):
cubic spline (Rocha 2012, eq. 3.32), quartic (3.30), Gaussian (3.31, shifted to vanish at r = 1: the printed form
jumps by e^-6.25 there), and the singular weight w(r) = cubic(r) / (r² + ε²) with ε = 1e-8 whose shape functions
interpolate (Marques 2008, §3.5: φ_I(x_J) = δ_IJ to ~1e-14; the thesis's singular Schwarz weight is not printed).

Units: lengths in the scene's unit; shape functions dimensionless, gradients per length.
"""


from types import SimpleNamespace

import warp as wp

from .neighbours import NeighbourRows
from .smoothing import unit_cubic_spline
from .space import Box2d, offset2d

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("shape_functions", "moment_factors", "slope_fits", "slope_solves", "shape_values")

MAX_TERMS = 6
#: most nearest neighbours the support sizing ranks (k of the k-th nearest node)
MAX_RANK = 16
vec6d = wp.types.vector(length=MAX_TERMS, dtype=wp.float64)
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
        if kind == QUARTIC:  # Rocha (2012), eq. 3.30
            w = one - wp.float64(6.0) * r * r + wp.float64(8.0) * r * r * r - wp.float64(3.0) * r * r * r * r
            dw = -wp.float64(12.0) * r + wp.float64(24.0) * r * r - wp.float64(12.0) * r * r * r
        elif kind == GAUSSIAN:  # Rocha (2012), eq. 3.31, shifted: (e^-(r/α)² - e^-1/α²) / (1 - e^-1/α²), α = 0.4
            a2 = wp.float64(4.0) / wp.float64(25.0)
            tail = wp.exp(-one / a2)
            e = wp.exp(-r * r / a2)
            w = (e - tail) / (one - tail)
            dw = -wp.float64(2.0) * r / a2 * e / (one - tail)
        else:  # cubic spline, Rocha (2012), eq. 3.32 (also the numerator of the singular weight)
            w, dw = unit_cubic_spline(r)
            if kind == SINGULAR:  # w / (r² + ε²): φ_I(x_I) = 1
                q = r * r + SINGULAR_EPS2
                dw = dw / q - w * wp.float64(2.0) * r / (q * q)
                w = w / q
    return wp.vec2d(w, dw)


_WEIGHT_FUNCTIONS: dict = {}


def weight_function(kind: int, rectangular: bool):
    """``weight(d, support) -> (w, ∂w/∂x, ∂w/∂y)`` of a node at offset d = x - x_I with support half-widths
    ``support``, for one weight ``kind`` on circular or ``rectangular`` supports, fixed when the kernel is compiled
    (cached). A kernel that picks its weight at run time carries every weight's code at once: on a GPU the loop over a
    point's nodes then held 158 registers a thread against 72-89."""
    key = (int(kind), bool(rectangular))
    if key in _WEIGHT_FUNCTIONS:
        return _WEIGHT_FUNCTIONS[key]
    # the singular weight's 1/r² belongs to the distance, not to each axis: rectangular uses the cubic
    axis_kind = CUBIC_SPLINE if key[0] == SINGULAR else key[0]

    @wp.func
    def weight(d: wp.vec2d, support: wp.vec2d) -> wp.vec3d:
        zero = wp.float64(0.0)
        if wp.static(key[1]):
            wx = weight_and_slope(wp.static(axis_kind), wp.abs(d[0]) / support[0])
            wy = weight_and_slope(wp.static(axis_kind), wp.abs(d[1]) / support[1])
            gx = wp.sign(d[0]) * wx[1] / support[0] * wy[0]
            gy = wp.sign(d[1]) * wy[1] / support[1] * wx[0]
            return wp.vec3d(wx[0] * wy[0], gx, gy)
        dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
        w = weight_and_slope(wp.static(key[0]), dist / support[0])
        if dist > zero:
            s = w[1] / (support[0] * dist)
            return wp.vec3d(w[0], s * d[0], s * d[1])
        return wp.vec3d(w[0], zero, zero)

    _WEIGHT_FUNCTIONS[key] = weight
    return weight


@wp.func
def inside_support(params: MLSParams, d: wp.vec2d, support: wp.vec2d) -> bool:
    """Is the offset d = x - x_I strictly inside node I's support (where its weight is > 0)?"""
    if params.rectangular != 0:
        return wp.abs(d[0]) < support[0] and wp.abs(d[1]) < support[1]
    return d[0] * d[0] + d[1] * d[1] < support[0] * support[0]


@wp.func
def serves(params: MLSParams, d: wp.vec2d, material: int, support: wp.vec2d, node_material: int) -> bool:
    """Does the node at offset d = x - x_I serve the point x of ``material``: x inside its support, and the node of
    the point's material or of every material (-1: on an interface or in a one-material model; Marques 2008, §3.3,
    domain truncation)?"""
    if not inside_support(params, d, support):
        return False
    return node_material < 0 or material < 0 or node_material == material


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
    """distance[i]: the distance from node i to its ``rank``-th nearest other node (Rocha 2012, §4.1.1: c_I), or -1
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
    """Row i: the nodes whose support holds point i and whose material the point sees (Marques 2008, §3.3, domain
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
    """:func:`support_rows` by testing every node (O(points x nodes)): the reference for the HashGrid search (Rocha
    2012 compared its k-d tree with brute force the same way). Rows in node order."""
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


@wp.struct
class MLSFit:
    """The γ-form of an MLS fit at one point, stored at the largest basis size (module docstring): γ = A⁻¹ p(0), its
    derivatives ∂γ/∂x and ∂γ/∂y (the leading terms; the rest 0), and ``rcond``, the smallest pivot of the
    Jacobi-scaled A (0: singular, γ not computed)."""

    gamma: vec6d
    gamma_x: vec6d
    gamma_y: vec6d
    rcond: wp.float64


def _algebra(terms: int) -> SimpleNamespace:
    """The MLS algebra of one basis size, on vectors of exactly ``terms`` and symmetric matrices packed as their
    lower triangle, row by row (``packed``: terms (terms + 1) / 2 entries; constant loop bounds and indices: on a
    GPU every entry stays in a register; a 6 x 6 matrix for the linear basis held 213-255 registers a thread, the
    full 6 x 6 moment matrix 36 where 21 entries are distinct):

    - ``Moments``: A = Σ_I w_I p_I p_Iᵀ and ∂_x A, ∂_y A (packed);
    - ``local_basis(d, inv_scale)``: p(d/s) = [1, ξ, η] or [1, ξ, η, ξ², ξη, η²];
    - ``add_node(m, w, p)``: ``m`` plus one node's share (weight and slopes ``w`` = (w_I, ∂_x w_I, ∂_y w_I), p = p_I);
    - ``mls_fit(m, inv_scale)``: γ and ∂_a γ = A⁻¹ (e_{1+a}/s - ∂_a A γ) by a Cholesky factorisation of the
      Jacobi-scaled A (:class:`MLSFit`);
    - ``shape_value(fit, w, p)``: (φ_I, ∂φ_I/∂x, ∂φ_I/∂y) = (w γ·p, w ∂_xγ·p + ∂_x w γ·p, w ∂_yγ·p + ∂_y w γ·p)."""
    vec = wp.types.vector(length=terms, dtype=wp.float64)
    packed = wp.types.vector(length=terms * (terms + 1) // 2, dtype=wp.float64)

    @wp.func
    def entry(r: int, c: int) -> int:
        """Index of (r, c) in a packed symmetric matrix (constant for constant r, c)."""
        k = r * (r + 1) // 2 + c
        if c > r:
            k = c * (c + 1) // 2 + r
        return k

    @wp.struct
    class Moments:
        a: packed
        ax: packed
        ay: packed

    @wp.func
    def local_basis(d: wp.vec2d, inv_scale: wp.float64) -> vec:
        p = vec()
        xi = d[0] * inv_scale
        eta = d[1] * inv_scale
        p[0] = wp.float64(1.0)
        p[1] = xi
        p[2] = eta
        if wp.static(terms == 6):
            p[3] = xi * xi
            p[4] = xi * eta
            p[5] = eta * eta
        return p

    @wp.func
    def add_node(m: Moments, w: wp.vec3d, p: vec) -> Moments:
        a = m.a
        ax = m.ax
        ay = m.ay
        for r in range(wp.static(terms)):
            for c in range(wp.static(terms)):
                if c <= r:
                    pp = p[r] * p[c]
                    k = entry(r, c)
                    a[k] = a[k] + w[0] * pp
                    ax[k] = ax[k] + w[1] * pp
                    ay[k] = ay[k] + w[2] * pp
        out = Moments()
        out.a = a
        out.ax = ax
        out.ay = ay
        return out

    @wp.func
    def cholesky(a: packed) -> packed:
        """Lower factor L (L Lᵀ = a), packed; a non-positive pivot leaves L_kk = 0."""
        lo = packed()
        for j in range(wp.static(terms)):
            s = a[entry(j, j)]
            for k in range(j):
                s = s - lo[entry(j, k)] * lo[entry(j, k)]
            if s > wp.float64(0.0):
                lo[entry(j, j)] = wp.sqrt(s)
            for i in range(j + 1, wp.static(terms)):
                t = a[entry(i, j)]
                for k in range(j):
                    t = t - lo[entry(i, k)] * lo[entry(j, k)]
                if lo[entry(j, j)] > wp.float64(0.0):
                    lo[entry(i, j)] = t / lo[entry(j, j)]
        return lo

    @wp.func
    def solve_scaled(lo: packed, sc: vec, b: vec) -> vec:
        """γ = A⁻¹ b from the Cholesky factor of the scaled A_s = S A S: γ = S A_s⁻¹ S b."""
        y = vec()
        for i in range(wp.static(terms)):
            t = sc[i] * b[i]
            for k in range(i):
                t = t - lo[entry(i, k)] * y[k]
            y[i] = t / lo[entry(i, i)]
        x = vec()
        for ii in range(wp.static(terms)):
            i = wp.static(terms) - 1 - ii
            t = y[i]
            for k in range(i + 1, wp.static(terms)):
                t = t - lo[entry(k, i)] * x[k]
            x[i] = t / lo[entry(i, i)]
        for r in range(wp.static(terms)):
            x[r] = x[r] * sc[r]
        return x

    @wp.func
    def factor(a: packed):
        """(L, S, rcond): the Cholesky factor L of the Jacobi-scaled A_s = S A S, S = diag(1/sqrt(A_rr)), and its
        smallest pivot L_rr² (0: singular)."""
        sc = vec()
        scaled = packed()
        for r in range(wp.static(terms)):
            sc[r] = wp.float64(1.0) / wp.sqrt(a[entry(r, r)])
        for r in range(wp.static(terms)):
            for c in range(wp.static(terms)):
                if c <= r:
                    scaled[entry(r, c)] = a[entry(r, c)] * sc[r] * sc[c]
        lo = cholesky(scaled)
        smallest = wp.float64(1.0)
        for r in range(wp.static(terms)):
            smallest = wp.min(smallest, lo[entry(r, r)] * lo[entry(r, r)])
        return lo, sc, smallest

    @wp.func
    def first_solve(lo: packed, sc: vec) -> vec:
        """γ = A⁻¹ p(0)."""
        p0 = vec()
        p0[0] = wp.float64(1.0)
        return solve_scaled(lo, sc, p0)

    @wp.func
    def slope_solves(lo: packed, sc: vec, gamma: vec, bx: vec, by: vec, inv_scale: wp.float64,
                     rcond: wp.float64) -> MLSFit:
        """The fit: γ, and ∂_a γ = A⁻¹ (e_{1+a}/s + b_a) for b_a = -∂_a A γ."""
        bx[1] = bx[1] + inv_scale
        by[2] = by[2] + inv_scale
        gx = solve_scaled(lo, sc, bx)
        gy = solve_scaled(lo, sc, by)
        out = MLSFit()
        out.rcond = rcond
        for r in range(wp.static(terms)):
            out.gamma[r] = gamma[r]
            out.gamma_x[r] = gx[r]
            out.gamma_y[r] = gy[r]
        return out

    @wp.func
    def mls_fit(m: Moments, inv_scale: wp.float64) -> MLSFit:
        fit = MLSFit()
        zero = wp.float64(0.0)
        lo, sc, smallest = factor(m.a)
        fit.rcond = smallest
        if smallest <= zero:
            return fit
        gamma = first_solve(lo, sc)
        bx = vec()
        by = vec()
        for r in range(wp.static(terms)):
            sx = zero
            sy = zero
            for c in range(wp.static(terms)):
                sx = sx + m.ax[entry(r, c)] * gamma[c]
                sy = sy + m.ay[entry(r, c)] * gamma[c]
            bx[r] = -sx
            by[r] = -sy
        return slope_solves(lo, sc, gamma, bx, by, inv_scale, smallest)

    @wp.func
    def add_moment(a: packed, w: wp.float64, p: vec) -> packed:
        """A + w p pᵀ (the moment matrix alone: the slopes come from :func:`add_slope` once γ is known)."""
        out = a
        for r in range(wp.static(terms)):
            for c in range(wp.static(terms)):
                if c <= r:
                    k = entry(r, c)
                    out[k] = out[k] + w * (p[r] * p[c])
        return out

    @wp.func
    def add_slope(b: vec, w_slope: wp.float64, p: vec, gamma: vec) -> vec:
        """b - ∂_a w_I p_I (p_I·γ): one node's share of -∂_a A γ, accumulated after γ without the matrices ∂_a A."""
        pg = wp.float64(0.0)
        for r in range(wp.static(terms)):
            pg = pg + p[r] * gamma[r]
        out = b
        for r in range(wp.static(terms)):
            out[r] = out[r] - w_slope * pg * p[r]
        return out

    @wp.func
    def shape_value(fit: MLSFit, w: wp.vec3d, p: vec) -> wp.vec3d:
        gp = wp.float64(0.0)
        gxp = wp.float64(0.0)
        gyp = wp.float64(0.0)
        for r in range(wp.static(terms)):
            gp = gp + fit.gamma[r] * p[r]
            gxp = gxp + fit.gamma_x[r] * p[r]
            gyp = gyp + fit.gamma_y[r] * p[r]
        return wp.vec3d(w[0] * gp, w[0] * gxp + w[1] * gp, w[0] * gyp + w[2] * gp)

    @wp.func
    def shape(fit: MLSFit, w: wp.vec3d, p: vec) -> wp.float64:
        """φ_I = w γ·p alone."""
        gp = wp.float64(0.0)
        for r in range(wp.static(terms)):
            gp = gp + fit.gamma[r] * p[r]
        return w[0] * gp

    return SimpleNamespace(vec=vec, packed=packed, Moments=Moments, local_basis=local_basis, add_node=add_node,
                           mls_fit=mls_fit, factor=factor, first_solve=first_solve, slope_solves=slope_solves,
                           add_moment=add_moment, add_slope=add_slope, shape_value=shape_value, shape=shape,
                           solve_scaled=solve_scaled)


#: basis size -> the MLS algebra of that size (:func:`_algebra`): the moment accumulation and fit of every MLS fit
#: (shape functions here, the PIC particles' fits), made for each basis size at import so that its loops have constant
#: bounds (the PIC fits ran twice as long with the size read at run time)
ALGEBRA = {terms: _algebra(terms) for terms in (3, MAX_TERMS)}


@wp.func
def row_inv_scale(rows: NeighbourRows, support: wp.array(dtype=wp.vec2d), start: int, count: int) -> wp.float64:
    """1 / s, the basis's scale: a row's count over the sum of its nodes' support radii."""
    scale = wp.float64(0.0)
    for k in range(count):
        scale = scale + support[rows.index[start + k]][0]
    return wp.float64(count) / scale


_SHAPE_FUNCTIONS: dict = {}


def shape_functions_kernel(basis_terms: int, weight_kind: int = 0, rectangular: bool = False):
    """The kernel ``shape_functions`` for a basis of ``basis_terms`` (3 linear, 6 quadratic; ``params.terms`` must
    be the same) and the weight ``weight_kind`` on circular or ``rectangular`` supports (``params``' own), its moment
    loops of constant bounds (cached: one compile per combination)."""
    key = (basis_terms, int(weight_kind), bool(rectangular))
    if key in _SHAPE_FUNCTIONS:
        return _SHAPE_FUNCTIONS[key]
    alg = ALGEBRA[basis_terms]
    node_weight = weight_function(weight_kind, rectangular)

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
        if count == 0 or count < terms:
            rcond[i] = zero
            for k in range(count):
                phi[start + k] = zero
                dphi[start + k] = wp.vec2d(zero, zero)
            return
        inv_scale = row_inv_scale(rows, support, start, count)
        # three passes over the row: A (then γ), -∂_a A γ (then ∂_a γ), the shape functions: the matrices ∂_a A are
        # never held (on a GPU 130 registers a thread instead of 255 with the linear basis)
        a = alg.packed()
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            a = alg.add_moment(a, node_weight(d, support[j])[0], alg.local_basis(-d, inv_scale))
        fit = MLSFit()
        lo, sc, smallest = alg.factor(a)
        fit.rcond = smallest
        if smallest > zero:
            gamma = alg.first_solve(lo, sc)
            bx = alg.vec()
            by = alg.vec()
            for k in range(count):
                j = rows.index[start + k]
                d = offset2d(box, x, nodes[j])
                w = node_weight(d, support[j])
                p = alg.local_basis(-d, inv_scale)
                bx = alg.add_slope(bx, w[1], p, gamma)
                by = alg.add_slope(by, w[2], p, gamma)
            fit = alg.slope_solves(lo, sc, gamma, bx, by, inv_scale, smallest)
        rcond[i] = fit.rcond
        if fit.rcond <= zero:
            for k in range(count):
                phi[start + k] = zero
                dphi[start + k] = wp.vec2d(zero, zero)
            return
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            v = alg.shape_value(fit, node_weight(d, support[j]), alg.local_basis(-d, inv_scale))
            phi[start + k] = v[0]
            dphi[start + k] = wp.vec2d(v[1], v[2])

    _SHAPE_FUNCTIONS[key] = shape_functions
    if basis_terms == MAX_TERMS:  # what a GPU runs instead (made, not compiled, here)
        staged_shape_functions(basis_terms, weight_kind, rectangular)
        REPLACED_ON_GPU.append(shape_functions.module)
    return shape_functions


_STAGED_SHAPE_FUNCTIONS: dict = {}
#: the Warp modules of kernels a GPU runs in place of a CPU kernel that was made (``staged_shape_functions`` for
#: each quadratic ``shape_functions``): the CUDA compile check compiles them with the modules a session loaded
DEVICE_VARIANTS: list = []
#: the Warp modules of the CPU kernels those replace on a GPU (the quadratic ``shape_functions``)
REPLACED_ON_GPU: list = []


def staged_shape_functions(basis_terms: int, weight_kind: int = 0, rectangular: bool = False) -> SimpleNamespace:
    """``shape_functions`` in four kernels that meet through a per-point buffer ``fits`` of ``size`` float64 entries
    (L packed, S, γ, ∂_xγ, ∂_yγ), for a GPU: no kernel holds the factor, γ and both slope right-hand sides at once,
    so the quadratic basis keeps within 128 registers a thread with no stack (the single kernel needs 164; capped at
    128 it spills). Results are bitwise those of ``shape_functions`` (the same sums in the same order); on the CPU
    the single kernel is faster (it sweeps the row 3 times, these 4, and keeps the fit in registers).

    - ``moment_factors``: A (first sweep), its factor and γ = A⁻¹ p(0); rcond[i];
    - ``slope_fits`` (``axis`` 0, 1: one launch each): b_a = e_{1+a}/s - ∂_a A γ (second and third sweeps);
    - ``slope_solves``: ∂_a γ = A⁻¹ b_a, in place;
    - ``shape_values``: φ_I and ∇φ_I (fourth sweep; zeros where rcond is 0)."""
    key = (basis_terms, int(weight_kind), bool(rectangular))
    if key in _STAGED_SHAPE_FUNCTIONS:
        return _STAGED_SHAPE_FUNCTIONS[key]
    alg = ALGEBRA[basis_terms]
    node_weight = weight_function(weight_kind, rectangular)
    terms = basis_terms
    npk = terms * (terms + 1) // 2
    size = npk + 4 * terms  # L, S, γ, ∂xγ, ∂yγ
    at_sc = npk
    at_gamma = npk + terms

    @wp.kernel(module="unique")
    def moment_factors(first: int, box: Box2d, points: wp.array(dtype=wp.vec2d), rows: NeighbourRows,
                       nodes: wp.array(dtype=wp.vec2d), support: wp.array(dtype=wp.vec2d),
                       rcond: wp.array(dtype=wp.float64), fits: wp.array(dtype=wp.float64)):
        i = first + wp.tid()
        x = points[i]
        start = rows.start[i]
        count = rows.count[i]
        zero = wp.float64(0.0)
        if count == 0 or count < wp.static(terms):
            rcond[i] = zero
            return
        inv_scale = row_inv_scale(rows, support, start, count)
        a = alg.packed()
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            a = alg.add_moment(a, node_weight(d, support[j])[0], alg.local_basis(-d, inv_scale))
        lo, sc, smallest = alg.factor(a)
        rcond[i] = smallest
        if smallest > zero:
            gamma = alg.first_solve(lo, sc)
            base = i * wp.static(size)
            for k in range(wp.static(npk)):
                fits[base + k] = lo[k]
            for r in range(wp.static(terms)):
                fits[base + wp.static(at_sc) + r] = sc[r]
                fits[base + wp.static(at_gamma) + r] = gamma[r]

    @wp.kernel(module="unique")
    def slope_fits(first: int, box: Box2d, points: wp.array(dtype=wp.vec2d), rows: NeighbourRows,
                   nodes: wp.array(dtype=wp.vec2d), support: wp.array(dtype=wp.vec2d),
                   rcond: wp.array(dtype=wp.float64), fits: wp.array(dtype=wp.float64), axis: int):
        i = first + wp.tid()
        if not (rcond[i] > wp.float64(0.0)):
            return
        x = points[i]
        start = rows.start[i]
        count = rows.count[i]
        base = i * wp.static(size)
        inv_scale = row_inv_scale(rows, support, start, count)
        gamma = alg.vec()
        for r in range(wp.static(terms)):
            gamma[r] = fits[base + wp.static(at_gamma) + r]
        b = alg.vec()
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            w = node_weight(d, support[j])
            w_slope = w[1]
            if axis == 1:
                w_slope = w[2]
            b = alg.add_slope(b, w_slope, alg.local_basis(-d, inv_scale), gamma)
        if axis == 0:
            b[1] = b[1] + inv_scale
        else:
            b[2] = b[2] + inv_scale
        out = base + wp.static(at_gamma + terms) + axis * wp.static(terms)
        for r in range(wp.static(terms)):
            fits[out + r] = b[r]

    @wp.kernel(module="unique")
    def slope_solves(first: int, rcond: wp.array(dtype=wp.float64), fits: wp.array(dtype=wp.float64)):
        i = first + wp.tid()
        if not (rcond[i] > wp.float64(0.0)):
            return
        base = i * wp.static(size)
        lo = alg.packed()
        sc = alg.vec()
        for k in range(wp.static(npk)):
            lo[k] = fits[base + k]
        for r in range(wp.static(terms)):
            sc[r] = fits[base + wp.static(at_sc) + r]
        for axis in range(2):
            out = base + wp.static(at_gamma + terms) + axis * wp.static(terms)
            b = alg.vec()
            for r in range(wp.static(terms)):
                b[r] = fits[out + r]
            g = alg.solve_scaled(lo, sc, b)
            for r in range(wp.static(terms)):
                fits[out + r] = g[r]

    @wp.kernel(module="unique")
    def shape_values(first: int, box: Box2d, points: wp.array(dtype=wp.vec2d), rows: NeighbourRows,
                     nodes: wp.array(dtype=wp.vec2d), support: wp.array(dtype=wp.vec2d),
                     rcond: wp.array(dtype=wp.float64), fits: wp.array(dtype=wp.float64),
                     phi: wp.array(dtype=wp.float64), dphi: wp.array(dtype=wp.vec2d)):
        i = first + wp.tid()
        x = points[i]
        start = rows.start[i]
        count = rows.count[i]
        zero = wp.float64(0.0)
        if not (rcond[i] > zero):
            for k in range(count):
                phi[start + k] = zero
                dphi[start + k] = wp.vec2d(zero, zero)
            return
        inv_scale = row_inv_scale(rows, support, start, count)
        base = i * wp.static(size) + wp.static(at_gamma)
        fit = MLSFit()
        for r in range(wp.static(terms)):
            fit.gamma[r] = fits[base + r]
            fit.gamma_x[r] = fits[base + wp.static(terms) + r]
            fit.gamma_y[r] = fits[base + wp.static(2 * terms) + r]
        for k in range(count):
            j = rows.index[start + k]
            d = offset2d(box, x, nodes[j])
            v = alg.shape_value(fit, node_weight(d, support[j]), alg.local_basis(-d, inv_scale))
            phi[start + k] = v[0]
            dphi[start + k] = wp.vec2d(v[1], v[2])

    out = SimpleNamespace(moment_factors=moment_factors, slope_fits=slope_fits, slope_solves=slope_solves,
                          shape_values=shape_values, size=size)
    _STAGED_SHAPE_FUNCTIONS[key] = out
    DEVICE_VARIANTS.extend(k.module for k in (moment_factors, slope_fits, slope_solves, shape_values))
    return out
