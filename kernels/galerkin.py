"""Galerkin assembly kernels on shape-function rows (any shape model: MLS, NEM), shared by EFG and PIC: stiffness per
Gauss point into slots or gathered by node rows, loads, consistent test gradients, smoothed (nodally integrated)
gradients, field evaluation.

Each bilinear form is written once, as a ``wp.func`` of one (test node, trial node) pair at one Gauss point
(:func:`conduction_form`, :func:`elastic_form`); two race-free assembly strategies call it, bitwise the same for any
thread count: every Gauss point writes its own slots (triplets, summed on the host by ``warpfree.sparse``), or every
node gathers the Gauss points in its support and adds each pair into its own row of the matrix's pattern (no
triplets). Unknowns are node-major: component k of node I is unknown ``components·I + k``.

Precision: float64 (the shape functions' precision, ``kernels/mls.py``). Units: the caller's.
"""

import warp as wp

from .assembly import Loads, Triplets, write_load, write_triplet
from .neighbours import NeighbourRows
from .space import Box2d, offset2d

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("conduction_rows", "elastic_rows")


@wp.struct
class ShapeRows:
    """Shape functions at a set of points as kernels read them (``ShapeData.kernel_rows()``): each point's ``rows``
    of nodes, and φ_I (``phi``) and ∇φ_I (``dphi``) per row entry."""

    rows: NeighbourRows
    phi: wp.array(dtype=wp.float64)
    dphi: wp.array(dtype=wp.vec2d)


# --- the forms: the integrand of each bilinear form for a test node I and a trial node J at one Gauss point ------


@wp.func
def conduction_form(test: wp.vec2d, trial: wp.vec2d) -> wp.float64:
    """∇ψ_I·∇φ_J (Marques 2008, eq. 3.9, per unit w_g k_g): ``test`` ∇ψ_I, ``trial`` ∇φ_J (1/m each)."""
    return test[0] * trial[0] + test[1] * trial[1]


@wp.func
def elastic_form(test: wp.vec2d, trial: wp.vec2d, dm: wp.mat33d) -> wp.mat22d:
    """B̂_Iᵀ D B_J (Rocha 2012, eq. 3.35, per unit w_g), B = [[φ,x 0] [0 φ,y] [φ,y φ,x]] (engineering shear strain),
    B̂_I from the test gradient ``test``, B_J from the trial gradient ``trial``, ``dm`` D (Voigt): the 2 x 2 block whose
    row is the component of the test node I and column the component of the trial node J (units of D / m²)."""
    # D B_J (3 x 2), columns for u_x and u_y of J
    c0 = wp.vec3d(dm[0, 0] * trial[0] + dm[0, 2] * trial[1], dm[1, 0] * trial[0] + dm[1, 2] * trial[1],
                  dm[2, 0] * trial[0] + dm[2, 2] * trial[1])
    c1 = wp.vec3d(dm[0, 1] * trial[1] + dm[0, 2] * trial[0], dm[1, 1] * trial[1] + dm[1, 2] * trial[0],
                  dm[2, 1] * trial[1] + dm[2, 2] * trial[0])
    return wp.mat22d(test[0] * c0[0] + test[1] * c0[2], test[0] * c1[0] + test[1] * c1[2],
                     test[1] * c0[1] + test[0] * c0[2], test[1] * c1[1] + test[0] * c1[2])


# --- every Gauss point writes its own slots ---------------------------------------------------------------------


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
    """K_IJ += w_g :func:`conduction_form` (``weight`` holds w_g |J| k_g; ``test_dphi``: ∇ψ, corrected for consistent
    integration, or ∇φ itself) for every pair (I, J) of Gauss point g's row, slot ``slot_start[g] + a·n + b``."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    for a in range(n):
        t = test_dphi[start + a]
        ia = rows.index[start + a]
        for b in range(n):
            q = dphi[start + b]
            write_triplet(out, s0 + a * n + b, ia, rows.index[start + b], wg * conduction_form(t, q))


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
    """K_IJ += w_g :func:`elastic_form` (``weight`` w_g |J|, ``material`` D per point) for every pair (I, J) of Gauss
    point g's row; unknowns (u_x, u_y) of node I at 2I, 2I + 1; four slots per pair, ``slot_start[g] + 4 (a·n + b)``."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    dm = material[g]
    for a in range(n):
        t = test_dphi[start + a]
        ia = rows.index[start + a]
        for b in range(n):
            q = dphi[start + b]
            ib = rows.index[start + b]
            block = wg * elastic_form(t, q, dm)
            s = s0 + 4 * (a * n + b)
            write_triplet(out, s, 2 * ia, 2 * ib, block[0, 0])
            write_triplet(out, s + 1, 2 * ia, 2 * ib + 1, block[0, 1])
            write_triplet(out, s + 2, 2 * ia + 1, 2 * ib, block[1, 0])
            write_triplet(out, s + 3, 2 * ia + 1, 2 * ib + 1, block[1, 1])


@wp.kernel
def corrected_gradients(
    first: int,
    rows: NeighbourRows,
    dphi: wp.array(dtype=wp.vec2d),
    points: wp.array(dtype=wp.vec2d),
    point_material: wp.array(dtype=wp.int32),
    materials: int,
    nodes: wp.array(dtype=wp.vec2d),
    spacing: wp.array(dtype=wp.float64),
    box: Box2d,
    terms: int,
    coefficient: wp.array(dtype=wp.vec2d),
    out: wp.array(dtype=wp.vec2d),
):
    """∇ψ_I(x_g) = ∇φ_I(x_g) + Σ_p c_{I,m,p} q_p(r) at every entry of point g's row (variationally consistent
    integration): m the point's material (``materials`` regions), r = (x_g - x_I)/h_I (minimum image, ``box``),
    q = (1, r_x, r_y, r_x², r_x r_y, r_y²) of which the first ``terms`` (1, 3 or 6), ``coefficient`` (c per node,
    region and term: index (I·materials + m)·terms + p). float64."""
    g = first + wp.tid()
    start = rows.start[g]
    m = point_material[g]
    x = points[g]
    for a in range(rows.count[g]):
        node = rows.index[start + a]
        base = (node * materials + m) * terms
        value = dphi[start + a] + coefficient[base]
        if terms > 1:
            r = offset2d(box, x, nodes[node]) / spacing[node]
            value = value + r[0] * coefficient[base + 1] + r[1] * coefficient[base + 2]
            if terms > 3:
                value = value + (r[0] * r[0]) * coefficient[base + 3] + (r[0] * r[1]) * coefficient[base + 4] \
                    + (r[1] * r[1]) * coefficient[base + 5]
        out[start + a] = value


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
    traction component k at index components·g + k): Rocha (2012), eq. 3.36 f_I, Marques (2008), eq. 3.9 b_j."""
    g = first + wp.tid()
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    for a in range(n):
        ia = rows.index[start + a]
        for k in range(components):
            write_load(out, s0 + components * a + k, components * ia + k, phi[start + a] * value[components * g + k])


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
    """u^h_k(x_i) = Σ_I φ_I(x_i) u_{cI+k} and its gradient Σ_I ∇φ_I u_{cI+k} (Rocha 2012, eq. 3.28), k < components."""
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


# --- by node rows: each node gathers its Gauss points (no triplet sum) -------------------------------------------


@wp.struct
class NodeGather:
    """What a node-row assembly reads besides the shape functions: each node's row ``entries`` (the shape-row entries
    that hold it, in Gauss-point order), ``entry_point`` (entry -> Gauss point) and the matrix pattern (CSR,
    ``pattern_start``/``pattern_cols``, sorted columns)."""

    entries: NeighbourRows
    entry_point: wp.array(dtype=wp.int32)
    pattern_start: wp.array(dtype=wp.int32)
    pattern_cols: wp.array(dtype=wp.int32)


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
    gather: NodeGather,
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    values: wp.array(dtype=wp.float64),
):
    """Row I of K_IJ = Σ_g w_g :func:`conduction_form` (Marques 2008, eq. 3.9): node I gathers the Gauss points g in
    its support (``gather.entries``: the row entries that hold I, in Gauss-point order; ``gather.entry_point``:
    entry -> g) and adds each pair into its slot of the CSR pattern (:class:`NodeGather`)."""
    i = first + wp.tid()
    pattern_cols = gather.pattern_cols
    node_entries = gather.entries
    lo = gather.pattern_start[i]
    hi = gather.pattern_start[i + 1]
    for k in range(node_entries.count[i]):
        e = node_entries.index[node_entries.start[i] + k]
        g = gather.entry_point[e]
        t = test_dphi[e]
        wg = weight[g]
        s = rows.start[g]
        for b in range(rows.count[g]):
            q = dphi[s + b]
            pos = pattern_position(pattern_cols, lo, hi, rows.index[s + b])
            values[pos] = values[pos] + wg * conduction_form(t, q)


@wp.kernel
def elastic_rows(
    first: int,
    rows: NeighbourRows,
    gather: NodeGather,
    test_dphi: wp.array(dtype=wp.vec2d),
    dphi: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    material: wp.array(dtype=wp.mat33d),
    values: wp.array(dtype=wp.mat22d),
):
    """Block row I of K_IJ = Σ_g w_g :func:`elastic_form` (Rocha 2012, eq. 3.35), 2 x 2 blocks (row: component of the
    test node I, column: of the trial node J), gathered as in :func:`conduction_rows`."""
    i = first + wp.tid()
    pattern_cols = gather.pattern_cols
    node_entries = gather.entries
    lo = gather.pattern_start[i]
    hi = gather.pattern_start[i + 1]
    for k in range(node_entries.count[i]):
        e = node_entries.index[node_entries.start[i] + k]
        g = gather.entry_point[e]
        t = test_dphi[e]
        wg = weight[g]
        dm = material[g]
        s = rows.start[g]
        for b in range(rows.count[g]):
            q = dphi[s + b]
            pos = pattern_position(pattern_cols, lo, hi, rows.index[s + b])
            values[pos] = values[pos] + wg * elastic_form(t, q, dm)


# --- stabilized conforming nodal integration: smoothed gradients per cell ----------------------------------------


@wp.func
def row_holds(index: wp.array(dtype=wp.int32), lo: int, hi: int, node: int) -> bool:
    """Does ``index[lo:hi]`` hold ``node``?"""
    found = bool(False)
    for k in range(lo, hi):
        if index[k] == node:
            found = True
    return found


@wp.kernel
def smoothed_gradient_rows(
    first: int,
    centre: ShapeRows,
    boundary: ShapeRows,
    cell_first_point: wp.array(dtype=wp.int32),
    flux: wp.array(dtype=wp.vec2d),
    fill: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    dphi: wp.array(dtype=wp.vec2d),
):
    """Smoothed gradients of cell c (Chen, Wu, Yoon & You 2001, IJNME 50:435, eq 21): ∇̃φ_I(c) =
    (1/A_c) ∮_{∂Ω_c} φ_I n dΓ = Σ_{b ∈ ∂Ω_c} φ_I(x_b) ``flux[b]``, ``flux[b]`` = w_b n_b / A_c (1/m), over the cell's
    boundary points ``cell_first_point[c] .. cell_first_point[c + 1] - 1`` (their ``boundary`` rows are contiguous).
    The row is the union of the centre point's row (φ_I(x_c) kept as the row's value, for loads and u^h at the cell's
    point) and the boundary points' rows (φ = 0 where only they list a node). ``fill`` 0 writes the row's size into
    ``rows.count``; 1 writes node ids, φ and ∇̃φ at ``rows.start[c]``. Gather form: thread c writes only its row."""
    c = first + wp.tid()
    cs = centre.rows.start[c]
    ce = cs + centre.rows.count[c]
    p0 = cell_first_point[c]
    p1 = cell_first_point[c + 1]
    bs = int(0)
    be = int(0)
    if p1 > p0:
        bs = boundary.rows.start[p0]
        be = boundary.rows.start[p1 - 1] + boundary.rows.count[p1 - 1]
    base = rows.start[c]
    count = int(0)
    for k in range(cs, ce):
        if fill == 1:
            rows.index[base + count] = centre.rows.index[k]
            phi[base + count] = centre.phi[k]
            dphi[base + count] = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
        count += 1
    for k in range(bs, be):
        node = boundary.rows.index[k]
        if not row_holds(centre.rows.index, cs, ce, node) and not row_holds(boundary.rows.index, bs, k, node):
            if fill == 1:
                rows.index[base + count] = node
                phi[base + count] = wp.float64(0.0)
                dphi[base + count] = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
            count += 1
    if fill == 0:
        rows.count[c] = count
        return
    for p in range(p0, p1):
        fp = flux[p]
        rs = boundary.rows.start[p]
        for a in range(boundary.rows.count[p]):
            node = boundary.rows.index[rs + a]
            value = boundary.phi[rs + a]
            for s in range(count):
                if rows.index[base + s] == node:
                    dphi[base + s] = dphi[base + s] + value * fp


# --- layout quality ---------------------------------------------------------------------------------------------


@wp.kernel
def lebesgue_constants(
    first: int,
    rows: NeighbourRows,
    phi: wp.array(dtype=wp.float64),
    lebesgue: wp.array(dtype=wp.float64),
):
    """Per point, the Lebesgue constant Λ = Σ_I |φ_I| of its shape functions: 1 where all are positive, else the
    factor by which the approximation can amplify the nodal values' errors. One thread a point, its row in order."""
    i = first + wp.tid()
    start = rows.start[i]
    total = wp.float64(0.0)
    for k in range(rows.count[i]):
        total += wp.abs(phi[start + k])
    lebesgue[i] = total
