"""PIC field solve on the device (``warpfree.solvers.pic.device_solve``): the dense map's product, the gauge and load
of the periodic Krylov solve, and the nodal field of the momentum gather; and the step report's terms
(``warpfree.solvers.pic.history``). float64 (the field solve's precision);
every kernel a gather (thread i writes row i), and the step report's small puts (one thread)."""

import warp as wp


@wp.kernel
def dense_apply(first: int, matrix: wp.array2d(dtype=wp.float64), x: wp.array(dtype=wp.float64),
                offset: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    """out_i = offset_i + Σ_j M_ij x_j (row i of a dense map)."""
    i = first + wp.tid()
    s = offset[i]
    for j in range(x.shape[0]):
        s = s + matrix[i, j] * x[j]
    out[i] = s


@wp.kernel
def periodic_load(first: int, charge: wp.array(dtype=wp.float64), node_integral: wp.array(dtype=wp.float64),
                  charge_sum: wp.array(dtype=wp.float64), inv_area: wp.float64, load: wp.array(dtype=wp.float64)):
    """The consistent load of the singular periodic K: b_I - λ m_I with b = Q + ρ_bg m and λ = Σb/Σm =
    ΣQ/A + ρ_bg (Σ_I m_I = the box's area A), i.e. Q_I - (ΣQ/A) m_I: the background drops out. Node 0 is pinned
    (u_0 = 0: its row of the pinned K is the identity), so its load is 0."""
    i = first + wp.tid()
    if i == 0:
        load[i] = wp.float64(0.0)
    else:
        load[i] = charge[i] - charge_sum[0] * inv_area * node_integral[i]


@wp.kernel
def net_density(first: int, charge_sum: wp.array(dtype=wp.float64), inv_area: wp.float64, background: wp.float64,
                net: wp.array(dtype=wp.float64)):
    """λ = ΣQ/A + ρ_bg, the net charge density (``PlasmaPoisson.solve``'s multiplier in a periodic box)."""
    net[0] = charge_sum[0] * inv_area + background


@wp.kernel
def remove_mean(first: int, u: wp.array(dtype=wp.float64), weighted_sum: wp.array(dtype=wp.float64),
                inv_area: wp.float64):
    """u_I -= (Σ_J m_J u_J)/A: the gauge ∫u = 0 of ``PlasmaPoisson`` (K's null space is the constants)."""
    i = first + wp.tid()
    u[i] = u[i] - weighted_sum[0] * inv_area


@wp.kernel
def nodal_field(first: int, gx: wp.array(dtype=wp.float64), gy: wp.array(dtype=wp.float64),
                inv_mass: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.vec2d)):
    """E_I = -(G_x u, G_y u)_I / m_I: the lumped projection of -∇u^h (``PlasmaPoisson.nodal_field``)."""
    i = first + wp.tid()
    out[i] = wp.vec2d(-gx[i] * inv_mass[i], -gy[i] * inv_mass[i])


@wp.kernel
def pack_field(first: int, stacked: wp.array(dtype=wp.float64), n: int, out: wp.array(dtype=wp.vec2d)):
    """E_I = (stacked[N + I], stacked[2N + I]) from a dense map's stacked output [u; E_x; E_y]."""
    i = first + wp.tid()
    out[i] = wp.vec2d(stacked[n + i], stacked[2 * n + i])


@wp.kernel
def add_transposed(first: int, sx: wp.array(dtype=wp.float64), sy: wp.array(dtype=wp.float64),
                   field: wp.array(dtype=wp.vec2d)):
    """E_I ← ½ (E_I - (S G_x M⁻¹ Q, S G_y M⁻¹ Q)_I): the antisymmetric part's second term."""
    i = first + wp.tid()
    field[i] = wp.float64(0.5) * (field[i] - wp.vec2d(sx[i], sy[i]))


@wp.kernel
def product(first: int, a: wp.array(dtype=wp.float64), b: wp.array(dtype=wp.float64),
            out: wp.array(dtype=wp.float64)):
    """a_I b_I: m_I u_I (the gauge), Q_I / m_I (with 1/m), u_I (K u)_I and the modes' C_kI u_I (summed for the
    report)."""
    i = first + wp.tid()
    out[i] = a[i] * b[i]


@wp.kernel
def put(first: int, value: wp.array(dtype=wp.float64), scale: wp.float64, slot: int,
        report: wp.array(dtype=wp.float64)):
    """report[slot] = scale × value[0] (a reduction's result into the step report)."""
    report[slot] = scale * value[0]


@wp.kernel
def put_vector(first: int, value: wp.array(dtype=wp.vec2d), slot: int, report: wp.array(dtype=wp.float64)):
    """report[slot], report[slot + 1] = value[0] (a vector sum into the step report)."""
    report[slot] = value[0][0]
    report[slot + 1] = value[0][1]


@wp.kernel
def put_flag(first: int, value: wp.array(dtype=wp.int32), slot: int, report: wp.array(dtype=wp.float64)):
    """report[slot] = value[0] (a flag's maximum into the step report)."""
    report[slot] = wp.float64(value[0])


@wp.kernel
def copy_values(first: int, source: wp.array(dtype=wp.float64), count: int, slot: int,
                report: wp.array(dtype=wp.float64)):
    """report[slot + k] = source[k] for k < count (the field terms of x^n into the row of time n)."""
    for k in range(count):
        report[slot + k] = source[k]


@wp.kernel
def take(first: int, source: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    """out_i = source_i (the potential's rows of the dense map's stacked product; a launch, so a graph records it)."""
    i = first + wp.tid()
    out[i] = source[i]
