"""Boundary-condition and interface terms of the EFG systems (Warp kernels, ``kernels/efg.py``), each Gauss point
writing its own slots, summed on the host (``warpfree.sparse``):

- :func:`multiplier_matrix`: G = -Σ_g w_g φ_I N_K (Rocha 2012, eq. 3.36), Lagrange multipliers N_K linear on a polyline
- :func:`boundary_mass_matrix`: Σ_g w_g φ_I φ_J on a boundary (the penalty method)
- :func:`interface_matrix`: the symmetric Nitsche terms on a material interface between truncated supports

Unknowns node-major as in ``warpfree.galerkin.assembly``. float64.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.errors import ParameterError
from warpfree.galerkin.assembly import per_point, slot_starts
from warpfree.galerkin.shapes import ShapeData, ShapeModel
from warpfree.kernels import efg as ek
from warpfree.sparse import TripletBuffer, to_csr

__all__ = ["multiplier_matrix", "boundary_mass_matrix", "interface_matrix"]


def _mask(constrained, components: int) -> wp.vec2i:
    c = tuple(bool(x) for x in constrained)
    if len(c) != components or not any(c):
        raise ParameterError("constrained", f"must give {components} flags, at least one true, got {constrained!r}")
    return wp.vec2i(int(c[0]), int(c[1]) if components > 1 else 0)


def multiplier_matrix(model: ShapeModel, shape: ShapeData, weight, multiplier, multiplier_value, components: int,
                      constrained, n_multipliers: int) -> sp.csr_matrix:
    """G (components·N, components·n_multipliers): G_{(cI+k),(cK+k)} = -Σ_g w_g φ_I(x_g) N_K(x_g) for the
    constrained components k; ``multiplier`` (n, 2) the two multipliers K of point g's piece, ``multiplier_value``
    (n, 2) their hat values N_K(x_g)."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    mk = np.asarray(multiplier, dtype=np.int32).reshape(n, 2)
    nv = per_point(multiplier_value, n, "multiplier_value", 2)
    starts, total = slot_starts(2 * components * shape.counts, dev)
    slots = TripletBuffer(total, dev)
    pieces = ek.MultiplierPieces()
    pieces.multiplier = wp.array(mk, dtype=wp.vec2i, device=dev)
    pieces.value = wp.array(nv, dtype=wp.vec2d, device=dev)
    pieces.components, pieces.constrained = components, _mask(constrained, components)
    model.launcher.launch(ek.multiplier_coupling, n, [shape.kernel_rows(), w, pieces, starts, slots.triplets],
                          once=True)
    return to_csr(slots, (components * model.node_count, components * n_multipliers))


def interface_matrix(model: ShapeModel, side_a: ShapeData, side_b: ShapeData, normal, weight, conductivity_a: float,
                     conductivity_b: float, penalty) -> sp.csr_matrix:
    """(N, N) symmetric Nitsche terms on an interface (``kernels/efg.py: interface_terms``): ``side_a`` / ``side_b``
    the shape functions at the interface points seen from each material, ``normal`` from a to b, ``penalty`` α per
    point (1/m · conductivity)."""
    dev, n = model.launcher.device, side_a.n
    starts, total = slot_starts((side_a.counts + side_b.counts) ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.interface_terms, n, [side_a.kernel_rows(), side_b.kernel_rows(),
                                                  wp.array(np.asarray(normal, np.float64), dtype=wp.vec2d, device=dev),
                                                  wp.array(per_point(weight, n, "weight"), dtype=wp.float64,
                                                           device=dev),
                                                  float(conductivity_a), float(conductivity_b),
                                                  wp.array(per_point(penalty, n, "penalty"), dtype=wp.float64,
                                                           device=dev), starts,
                                                  slots.triplets], once=True)
    return to_csr(slots, (model.node_count, model.node_count))


def boundary_mass_matrix(model: ShapeModel, shape: ShapeData, weight, components: int, constrained) -> sp.csr_matrix:
    """M (components·N, components·N): Σ_g w_g φ_I φ_J for the constrained components."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    starts, total = slot_starts(components * shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.boundary_mass, n, [shape.kernel_rows(), w, components, _mask(constrained, components),
                                                starts, slots.triplets], once=True)
    return to_csr(slots, (components * model.node_count, components * model.node_count))
