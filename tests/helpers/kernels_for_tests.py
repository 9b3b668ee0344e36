"""Test-only Warp kernels: thin wrappers that expose the ``@wp.func`` smoothing kernels to NumPy, and
an SPH-like gather over a HashGrid. Every kernel takes ``first: int`` first (``i = first + wp.tid()``)
so it can run through :class:`warpfree.device.Launcher`.
"""

import warp as wp

from warpfree.kernels import smoothing as _sm
from warpfree.kernels.smoothing import kernel_dwdr, kernel_grad, kernel_w


@wp.kernel
def eval_w_dwdr(
    first: int,
    kind: int,
    dim: int,
    r: wp.array(dtype=float),
    h: float,
    w: wp.array(dtype=float),
    dwdr: wp.array(dtype=float),
):
    """w[i] = W(r[i], h), dwdr[i] = dW/dr(r[i], h)."""
    i = first + wp.tid()
    w[i] = kernel_w(kind, dim, r[i], h)
    dwdr[i] = kernel_dwdr(kind, dim, r[i], h)


@wp.kernel
def eval_point(
    first: int,
    kind: int,
    dim: int,
    x: wp.array(dtype=wp.vec3),
    h: float,
    w: wp.array(dtype=float),
    grad: wp.array(dtype=wp.vec3),
):
    """w[i] = W(|x_i|, h) and grad[i] = ∇W(x_i) (x_i plays the role of r_ij = x_i - x_j)."""
    i = first + wp.tid()
    rij = x[i]
    r = wp.length(rij)
    w[i] = kernel_w(kind, dim, r, h)
    grad[i] = kernel_grad(kind, dim, rij, r, h)


@wp.kernel
def kernel_sums(
    first: int,
    kind: int,
    dim: int,
    grid: wp.uint64,
    x: wp.array(dtype=wp.vec3),
    query_radius: float,
    h: float,
    radius: float,
    volume: wp.array(dtype=float),
    sum_w: wp.array(dtype=float),
    sum_grad: wp.array(dtype=wp.vec3),
):
    """sum_w[i] = Σ_j V_j W_ij and sum_grad[i] = Σ_j V_j ∇_i W_ij over HashGrid neighbours (j = i included).

    Gather form with a float32 accumulator: each thread writes only row i, in HashGrid order, so the
    result is bitwise independent of the thread count (used by the launcher determinism test too).
    """
    i = first + wp.tid()
    xi = x[i]
    s = float(0.0)
    g = wp.vec3(0.0, 0.0, 0.0)
    for j in wp.hash_grid_query(grid, xi, query_radius):
        rij = xi - x[j]
        r = wp.length(rij)
        if r < radius:
            s += volume[j] * kernel_w(kind, dim, r, h)
            g += volume[j] * kernel_grad(kind, dim, rij, r, h)
    sum_w[i] = s
    sum_grad[i] = g


if hasattr(_sm, "kernel_grad_coef"):

    @wp.kernel
    def eval_grad_coef(
        first: int,
        kind: int,
        dim: int,
        x: wp.array(dtype=wp.vec3),
        h: float,
        coef: wp.array(dtype=float),
        grad: wp.array(dtype=wp.vec3),
    ):
        """coef[i] = (df/dq)/q at q = |x_i|/h and grad[i] = (σ_d/h²) coef · x_i (the fast gradient form)."""
        i = first + wp.tid()
        rij = x[i]
        q = wp.length(rij) / h
        c = _sm.kernel_grad_coef(kind, dim, q)
        coef[i] = c
        grad[i] = rij * (_sm.kernel_sigma(kind, dim, h) * c / (h * h))


from warpfree.kernels.neighbours import NeighbourRows  # noqa: E402
from warpfree.kernels.space import Box, displacement  # noqa: E402


@wp.kernel
def count_within_rows(
    first: int,
    rows: NeighbourRows,
    box: Box,
    query: wp.array(dtype=wp.vec3),
    source: wp.array(dtype=wp.vec3),
    radius: float,
    counts: wp.array(dtype=wp.int32),
):
    """counts[i] = entries j of row i with |r_ij| < radius (minimum image): what a solver loop keeps."""
    i = first + wp.tid()
    n = int(0)
    for c in range(rows.start[i], rows.start[i] + rows.count[i]):
        d = displacement(box, query[i], source[rows.index[c]])
        if wp.dot(d, d) < radius * radius:
            n += 1
    counts[i] = n


@wp.kernel
def gather_weights(
    first: int,
    rows: NeighbourRows,
    box: Box,
    query: wp.array(dtype=wp.vec3),
    source: wp.array(dtype=wp.vec3),
    radius: float,
    out: wp.array(dtype=float),
):
    """out[i] = Σ_j (1 - |r_ij|/R)² over row i within R: a node gathering from the particles near it."""
    i = first + wp.tid()
    s = float(0.0)
    for c in range(rows.start[i], rows.start[i] + rows.count[i]):
        d = displacement(box, query[i], source[rows.index[c]])
        r = wp.length(d)
        if r < radius:
            t = 1.0 - r / radius
            s += t * t
    out[i] = s


from warpfree.kernels.assembly import Triplets, write_triplet  # noqa: E402


@wp.kernel
def interpolation_matrix(
    first: int,
    rows: NeighbourRows,
    box: Box,
    x: wp.array(dtype=wp.vec3),
    volume: wp.array(dtype=float),
    kind: int,
    dim: int,
    h: float,
    t: Triplets,
):
    """M_ij = W(|x_i - x_j|, h) V_j (Mendes (2010) eq. 3.31), one triplet per entry of row i (slot = its CSR position)."""
    i = first + wp.tid()
    for c in range(rows.start[i], rows.start[i] + rows.count[i]):
        j = rows.index[c]
        r = wp.length(displacement(box, x[i], x[j]))
        write_triplet(t, c, i, j, wp.float64(kernel_w(kind, dim, r, h) * volume[j]))


@wp.kernel
def copy_row_counts(first: int, rows: NeighbourRows, out: wp.array(dtype=wp.int32)):
    """out[i] = rows.count[i]: reads an array through a struct argument."""
    i = first + wp.tid()
    out[i] = rows.count[i]
