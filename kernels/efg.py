"""EFG kernels (seeds 003 and 002): the boundary-condition and interface terms of the Galerkin systems, every Gauss
point writing its own slots (race-free, bitwise for any thread count): Lagrange-multiplier coupling, the penalty
method's boundary mass, the symmetric Nitsche terms on material interfaces.

The shape functions come from ``kernels/mls.py``, the stiffness and loads from ``kernels/galerkin.py``. float64.
"""

import warp as wp

from .assembly import Triplets, write_triplet
from .neighbours import NeighbourRows


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
