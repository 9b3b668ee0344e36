"""EFG kernels (Rocha 2012; Marques 2008): the boundary-condition and interface terms of the Galerkin systems, every Gauss
point writing its own slots (race-free, bitwise for any thread count): Lagrange-multiplier coupling, the penalty
method's boundary mass, the symmetric Nitsche terms on material interfaces.

The shape functions come from ``kernels/mls.py``, the stiffness and loads from ``kernels/galerkin.py``. float64.
"""

import warp as wp

from .assembly import Triplets, write_triplet
from .galerkin import ShapeRows


@wp.struct
class MultiplierPieces:
    """The Lagrange multipliers of an essential boundary at its Gauss points: the two end multipliers K of each
    point's piece (``multiplier``, -1: none), their linear hat values N_K there (``value``), the unknowns per node
    (``components``) and the components the boundary prescribes (``constrained[k]`` 1)."""

    multiplier: wp.array(dtype=wp.vec2i)
    value: wp.array(dtype=wp.vec2d)
    components: int
    constrained: wp.vec2i


@wp.kernel
def multiplier_coupling(
    first: int,
    shape: ShapeRows,
    weight: wp.array(dtype=wp.float64),
    pieces: MultiplierPieces,
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """G_{(cI+k),(cK+k)} += -w_g φ_I(x_g) N_K(x_g) (Rocha 2012, eq. 3.36) on an essential boundary: each boundary Gauss
    point lies on one piece (:class:`MultiplierPieces`). Row: unknown of node I; column: multiplier unknown."""
    g = first + wp.tid()
    rows = shape.rows
    start = rows.start[g]
    n = rows.count[g]
    s0 = slot_start[g]
    wg = weight[g]
    mk = pieces.multiplier[g]
    nv = pieces.value[g]
    components = pieces.components
    for a in range(n):
        ia = rows.index[start + a]
        for e in range(2):
            for k in range(components):
                s = s0 + (a * 2 + e) * components + k
                if mk[e] >= 0 and pieces.constrained[k] != 0:
                    write_triplet(out, s, components * ia + k, components * mk[e] + k,
                                  -wg * shape.phi[start + a] * nv[e])


@wp.struct
class InterfaceEntry:
    """One entry of an interface point's two rows: its ``node``, its share of the jump [φ] (+φ^a on side a, -φ^b on
    side b) and of the mean flux ½ k ∇φ·n."""

    node: int
    jump: wp.float64
    flux: wp.float64


@wp.func
def interface_entry(e: int, na: int, sa: int, sb: int, side_a: ShapeRows, side_b: ShapeRows,
                    conductivity_a: wp.float64, conductivity_b: wp.float64, nv: wp.vec2d) -> InterfaceEntry:
    """Entry e of the concatenated rows (side a's ``na`` entries from ``sa``, then side b's from ``sb``)."""
    out = InterfaceEntry()
    half = wp.float64(0.5)
    if e < na:
        out.node = side_a.rows.index[sa + e]
        out.jump = side_a.phi[sa + e]
        out.flux = half * conductivity_a * wp.dot(side_a.dphi[sa + e], nv)
    else:
        out.node = side_b.rows.index[sb + e - na]
        out.jump = -side_b.phi[sb + e - na]
        out.flux = half * conductivity_b * wp.dot(side_b.dphi[sb + e - na], nv)
    return out


@wp.kernel
def interface_terms(
    first: int,
    side_a: ShapeRows,
    side_b: ShapeRows,
    normal: wp.array(dtype=wp.vec2d),
    weight: wp.array(dtype=wp.float64),
    conductivity_a: wp.float64,
    conductivity_b: wp.float64,
    penalty: wp.array(dtype=wp.float64),
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """Symmetric Nitsche terms on a material interface between truncated supports (side a -> b along ``normal``):

        K_IJ += w_g ( -{k ∂φ_J/∂n}[φ_I] - {k ∂φ_I/∂n}[φ_J] + α [φ_I][φ_J] ),  [φ] = φ^a - φ^b,
        {k ∂φ/∂n} = ½ (k_a ∇φ^a + k_b ∇φ^b)·n

    over the entries of both sides' rows (a node on the interface appears in both): the interface term of the weak
    form that domain truncation drops, its symmetric partner and a penalty α_g = β k_max / h_g per point (``penalty``)."""
    g = first + wp.tid()
    sa = side_a.rows.start[g]
    na = side_a.rows.count[g]
    sb = side_b.rows.start[g]
    nb = side_b.rows.count[g]
    n = na + nb
    s0 = slot_start[g]
    wg = weight[g]
    nv = normal[g]
    alpha = penalty[g]
    for e in range(n):
        a = interface_entry(e, na, sa, sb, side_a, side_b, conductivity_a, conductivity_b, nv)
        for f in range(n):
            b = interface_entry(f, na, sa, sb, side_a, side_b, conductivity_a, conductivity_b, nv)
            write_triplet(out, s0 + e * n + f, a.node, b.node,
                          wg * (-b.flux * a.jump - a.flux * b.jump + alpha * a.jump * b.jump))


@wp.kernel
def boundary_mass(
    first: int,
    shape: ShapeRows,
    weight: wp.array(dtype=wp.float64),
    components: int,
    constrained: wp.vec2i,
    slot_start: wp.array(dtype=wp.int32),
    out: Triplets,
):
    """M_{(cI+k),(cJ+k)} += w_g φ_I φ_J on a boundary, for the constrained components k (the penalty method's
    α ∫ φ_I φ_J dΓ, α applied by the caller through ``weight``)."""
    g = first + wp.tid()
    rows = shape.rows
    phi = shape.phi
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
