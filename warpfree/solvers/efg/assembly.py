"""Gauss-point assembly of EFG matrices and load vectors (Warp kernels into per-point slots, summed on the host).

Two race-free forms, both bitwise the same for any thread count (``kernels/efg.py``):

- triplets: each Gauss point owns ``slots(n_g)`` consecutive slots (n_g: the nodes in its row) and
  ``warpfree.sparse`` sums the duplicates on the host (loads, boundary matrices, and stiffness with
  ``gather=False``);
- node rows (stiffness, the default): the pattern of K (node pairs that share a Gauss point, SᵀS of the rows'
  0/1 matrix S) is built once, and each node gathers the Gauss points in its support and adds every pair into
  its own row of the pattern. At 637 nodes with d_max 3.5 (38.6 nodes per Gauss point) the stiffness is 14.1 M
  triplets, whose host sum (COO -> CSR) took 1.6 s of the 1.8 s assembly; the gather writes no triplets.

Unknowns are node-major: component k of node I is unknown ``components·I + k``.

- :func:`conduction_matrix`: K_IJ = Σ_g w_g k_g ∇φ_I·∇φ_J (seed 002 eq 3.9, with the material's k)
- :func:`elastic_matrix`: K_IJ = Σ_g w_g B_Iᵀ D_g B_J (seed 003 eq 3.35)
- :func:`load_vector`: f_{cI+k} = Σ_g φ_I(x_g) v_{g,k} (sources, fluxes, tractions; seed 003 eq 3.36)
- :func:`multiplier_matrix`: G = -Σ_g w_g φ_I N_K (seed 003 eq 3.36), Lagrange multipliers N_K linear on a polyline
- :func:`boundary_mass_matrix`: Σ_g w_g φ_I φ_J on a boundary (the penalty method)
- :func:`consistent_test_gradients`: variationally consistent integration (Chen, Hillman & Rüter 2013, IJNME
  95:387): Gauss quadrature of rational MLS functions breaks the discrete divergence theorem
  Σ_g w_g ∇φ_I(x_g) = Σ_b w_b φ_I(x_b) n_b, and with it the linear patch test (errors 1e-5..1e-3 with 2x2 to 6x6
  points). Test gradients ∇ψ_I = ∇φ_I + ξ_I with ξ_I = (Σ_b w_b φ_I n_b - Σ_g w_g ∇φ_I) / Σ_{g ∈ supp I} w_g restore
  it exactly; the stiffness Σ_g w_g ∇ψ_I·k ∇φ_J is then non-symmetric (Petrov-Galerkin) and linear fields are
  reproduced to round-off.

float64 (see ``kernels/efg.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels import efg as ek
from warpfree.kernels import neighbours as nk
from warpfree.sparse import LoadBuffer, TripletBuffer, load_vector as _sum_loads, to_csr

from .model import EFGModel, ShapeData

__all__ = ["conduction_matrix", "elastic_matrix", "load_vector", "multiplier_matrix", "boundary_mass_matrix",
           "consistent_test_gradients", "interface_matrix"]


def _slot_starts(slots_per_point: np.ndarray, device: str) -> tuple[wp.array, int]:
    per = np.asarray(slots_per_point, dtype=np.int64)
    starts = np.zeros(per.size, dtype=np.int64)
    np.cumsum(per[:-1], out=starts[1:])
    total = int(per.sum())
    if total >= 2**31:
        raise ParameterError("d_max", f"assembly needs {total} slots, beyond the int32 index range: fewer Gauss "
                                      "points per cell or a smaller d_max")
    return wp.array(starts.astype(np.int32), dtype=wp.int32, device=device), total


def _per_point(values, n: int, name: str, width: int | None = None) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64)
    shape = (n,) if width is None else (n, width)
    if v.shape != shape:
        raise ParameterError(name, f"must have shape {shape}, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, "must be finite")
    return np.ascontiguousarray(v)


def consistent_test_gradients(model: EFGModel, shape: ShapeData, weight, boundary: list,
                              point_material=None) -> tuple[wp.array, np.ndarray]:
    """(∇ψ per entry of ``shape``, ξ (N, materials, 2)) (module docstring), one correction per node and material
    region: ``point_material`` (n,) the Gauss points' regions 0..M-1 (None: one region); ``boundary``: (ShapeData,
    weights (m,), outward normals (m, 2), region) for every piece that closes a region (outer boundary and both
    sides of every interface), the same points the boundary integrals use. Per region m the discrete divergence
    theorem Σ_{g ∈ m} w_g ∇ψ_I = Σ_{b ∈ ∂m} w_b φ_I n_b then holds, so piecewise-linear fields with flux
    continuity are reproduced too."""
    w = np.asarray(weight, dtype=np.float64)
    n_nodes = model.node_count
    region = np.zeros(shape.n, dtype=np.int64) if point_material is None else np.asarray(point_material, np.int64)
    regions = int(region.max()) + 1 if region.size else 1
    index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
    entry_region = np.repeat(region, shape.counts)
    key = index * regions + entry_region
    size = n_nodes * regions
    entry_weight = np.repeat(w, shape.counts)
    d = shape.dphi.numpy()[: shape.n_entries]
    volume = np.bincount(key, weights=entry_weight, minlength=size)
    integral = np.stack([np.bincount(key, weights=entry_weight * d[:, k], minlength=size) for k in range(2)], axis=1)
    target = np.zeros((size, 2))
    for bshape, bw, normal, piece_region in boundary:
        phi = bshape.phi.numpy()[: bshape.n_entries]
        b_index = bshape.rows.index.numpy()[: bshape.n_entries].astype(np.int64)
        flux = (np.asarray(bw)[:, None] * np.asarray(normal))
        b_flux = np.repeat(flux, bshape.counts, axis=0) * phi[:, None]
        b_key = b_index * regions + max(int(piece_region), 0)
        for k in range(2):
            target[:, k] += np.bincount(b_key, weights=b_flux[:, k], minlength=size)
    covered = volume > 0
    xi = np.zeros((size, 2))
    xi[covered] = (target[covered] - integral[covered]) / volume[covered, None]
    dev = model.launcher.device
    out = wp.zeros_like(shape.dphi)
    model.launcher.launch(ek.corrected_gradients, shape.n, [shape.rows, shape.dphi,
                                                            wp.array(region.astype(np.int32), dtype=wp.int32,
                                                                     device=dev), regions,
                                                            wp.array(xi, dtype=wp.vec2d, device=dev), out], once=True)
    return out, xi.reshape(n_nodes, regions, 2)


class NodeRows:
    """What the gather assembly needs from a ShapeData: for each node the row entries that hold it (in Gauss-point
    order), entry -> Gauss point, and K's pattern (CSR, sorted columns). Built once per ShapeData (host, set-up)."""

    def __init__(self, model: EFGModel, shape: ShapeData):
        dev = model.launcher.device
        index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
        point = np.repeat(np.arange(shape.n, dtype=np.int64), shape.counts)
        order = np.argsort(index, kind="stable")          # node-major, Gauss points ascending within a node
        count = np.bincount(index, minlength=model.node_count)
        start = np.zeros(model.node_count, dtype=np.int64)
        np.cumsum(count[:-1], out=start[1:])
        self.entries = nk.NeighbourRows()
        self.entries.start = wp.array(start.astype(np.int32), dtype=wp.int32, device=dev)
        self.entries.count = wp.array(count.astype(np.int32), dtype=wp.int32, device=dev)
        self.entries.index = wp.array(order.astype(np.int32) if order.size else np.zeros(1, np.int32),
                                      dtype=wp.int32, device=dev)
        self.entry_point = wp.array(point.astype(np.int32) if point.size else np.zeros(1, np.int32),
                                    dtype=wp.int32, device=dev)
        s = sp.csr_matrix((np.ones(index.size), index, np.r_[0, np.cumsum(shape.counts)]),
                          shape=(shape.n, model.node_count))
        pattern = (s.T @ s).tocsr()
        pattern.sort_indices()
        self.indptr, self.indices = pattern.indptr.astype(np.int32), pattern.indices.astype(np.int32)
        self.pattern_start = wp.array(self.indptr, dtype=wp.int32, device=dev)
        self.pattern_cols = wp.array(self.indices if self.indices.size else np.zeros(1, np.int32), dtype=wp.int32,
                                     device=dev)

    @property
    def nnz(self) -> int:
        return int(self.indices.size)


def node_rows(model: EFGModel, shape: ShapeData) -> NodeRows:
    """The shape data's :class:`NodeRows`, built on first use and kept on it."""
    if getattr(shape, "_node_rows", None) is None:
        shape._node_rows = NodeRows(model, shape)
    return shape._node_rows


def conduction_matrix(model: EFGModel, shape: ShapeData, weight, test_dphi: wp.array | None = None,
                      gather: bool = True) -> sp.csr_matrix:
    """(N, N) K from Gauss points ``shape`` with ``weight`` = w_g |J_g| k_g (conductivity or permittivity);
    ``test_dphi``: corrected test gradients (default ∇φ: symmetric K); ``gather``: node rows, else triplets."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(_per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    test = shape.dphi if test_dphi is None else test_dphi
    if gather:
        nr = node_rows(model, shape)
        values = wp.zeros(max(nr.nnz, 1), dtype=wp.float64, device=dev)
        model.launcher.launch(ek.conduction_rows, model.node_count, [shape.rows, nr.entries, nr.entry_point, test,
                                                                     shape.dphi, w, nr.pattern_start, nr.pattern_cols,
                                                                     values], once=True)
        return sp.csr_matrix((values.numpy()[: nr.nnz], nr.indices, nr.indptr),
                             shape=(model.node_count, model.node_count))
    starts, total = _slot_starts(shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.conduction_stiffness, n, [shape.rows, test, shape.dphi, w, starts, slots.triplets],
                          once=True)
    return to_csr(slots, (model.node_count, model.node_count))


def elastic_matrix(model: EFGModel, shape: ShapeData, weight, material,
                   test_dphi: wp.array | None = None, gather: bool = True) -> sp.csr_matrix:
    """(2N, 2N) K from Gauss points ``shape``: ``weight`` w_g |J_g|, ``material`` (n, 3, 3) D per point (Voigt,
    engineering shear strain); ``test_dphi``, ``gather`` as for :func:`conduction_matrix`."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(_per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    d = np.asarray(material, dtype=np.float64)
    if d.shape != (n, 3, 3) or not np.all(np.isfinite(d)):
        raise ParameterError("material", f"must be finite with shape ({n}, 3, 3), got {d.shape}")
    dm = wp.array(np.ascontiguousarray(d), dtype=wp.mat33d, device=dev)
    test = shape.dphi if test_dphi is None else test_dphi
    if gather:
        nr = node_rows(model, shape)
        values = wp.zeros(max(nr.nnz, 1), dtype=wp.mat22d, device=dev)
        model.launcher.launch(ek.elastic_rows, model.node_count, [shape.rows, nr.entries, nr.entry_point, test,
                                                                  shape.dphi, w, dm, nr.pattern_start, nr.pattern_cols,
                                                                  values], once=True)
        blocks = values.numpy()[: nr.nnz]
        return sp.bsr_matrix((blocks, nr.indices, nr.indptr),
                             shape=(2 * model.node_count, 2 * model.node_count)).tocsr()
    starts, total = _slot_starts(4 * shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.elastic_stiffness, n, [shape.rows, test, shape.dphi, w, dm, starts, slots.triplets],
                          once=True)
    return to_csr(slots, (2 * model.node_count, 2 * model.node_count))


def load_vector(model: EFGModel, shape: ShapeData, value) -> np.ndarray:
    """f (components·N,) with f_{cI+k} = Σ_g φ_I(x_g) value[g, k]; ``value`` (n, components) holds w_g |J_g| times
    the source, flux or traction."""
    dev, n = model.launcher.device, shape.n
    v = np.asarray(value, dtype=np.float64)
    v = v.reshape(n, -1) if v.ndim == 1 else v
    c = v.shape[1]
    v = _per_point(v, n, "value", c)
    starts, total = _slot_starts(c * shape.counts, dev)
    slots = LoadBuffer(total, dev)
    model.launcher.launch(ek.point_loads, n, [shape.rows, shape.phi, wp.array(v.reshape(-1), dtype=wp.float64,
                                                                             device=dev), c, starts, slots.loads],
                          once=True)
    return _sum_loads(slots, c * model.node_count)


def _mask(constrained, components: int) -> wp.vec2i:
    c = tuple(bool(x) for x in constrained)
    if len(c) != components or not any(c):
        raise ParameterError("constrained", f"must give {components} flags, at least one true, got {constrained!r}")
    return wp.vec2i(int(c[0]), int(c[1]) if components > 1 else 0)


def multiplier_matrix(model: EFGModel, shape: ShapeData, weight, multiplier, multiplier_value, components: int,
                      constrained, n_multipliers: int) -> sp.csr_matrix:
    """G (components·N, components·n_multipliers): G_{(cI+k),(cK+k)} = -Σ_g w_g φ_I(x_g) N_K(x_g) for the
    constrained components k; ``multiplier`` (n, 2) the two multipliers K of point g's piece, ``multiplier_value``
    (n, 2) their hat values N_K(x_g)."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(_per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    mk = np.asarray(multiplier, dtype=np.int32).reshape(n, 2)
    nv = _per_point(multiplier_value, n, "multiplier_value", 2)
    starts, total = _slot_starts(2 * components * shape.counts, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.multiplier_coupling, n, [shape.rows, shape.phi, w,
                                                      wp.array(mk, dtype=wp.vec2i, device=dev),
                                                      wp.array(nv, dtype=wp.vec2d, device=dev), components,
                                                      _mask(constrained, components), starts, slots.triplets],
                          once=True)
    return to_csr(slots, (components * model.node_count, components * n_multipliers))


def interface_matrix(model: EFGModel, side_a: ShapeData, side_b: ShapeData, normal, weight, conductivity_a: float,
                     conductivity_b: float, penalty: float) -> sp.csr_matrix:
    """(N, N) symmetric Nitsche terms on an interface (``kernels/efg.py: interface_terms``): ``side_a`` / ``side_b``
    the shape functions at the interface points seen from each material, ``normal`` from a to b."""
    dev, n = model.launcher.device, side_a.n
    starts, total = _slot_starts((side_a.counts + side_b.counts) ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.interface_terms, n, [side_a.rows, side_a.phi, side_a.dphi, side_b.rows, side_b.phi,
                                                  side_b.dphi, wp.array(np.asarray(normal, np.float64), dtype=wp.vec2d,
                                                                        device=dev),
                                                  wp.array(_per_point(weight, n, "weight"), dtype=wp.float64,
                                                           device=dev),
                                                  float(conductivity_a), float(conductivity_b), float(penalty), starts,
                                                  slots.triplets], once=True)
    return to_csr(slots, (model.node_count, model.node_count))


def boundary_mass_matrix(model: EFGModel, shape: ShapeData, weight, components: int, constrained) -> sp.csr_matrix:
    """M (components·N, components·N): Σ_g w_g φ_I φ_J for the constrained components."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(_per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    starts, total = _slot_starts(components * shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(ek.boundary_mass, n, [shape.rows, shape.phi, w, components, _mask(constrained, components),
                                                starts, slots.triplets], once=True)
    return to_csr(slots, (components * model.node_count, components * model.node_count))
