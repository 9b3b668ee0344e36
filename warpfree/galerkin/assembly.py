"""Galerkin assembly on any shape model's Gauss points (Warp kernels, ``kernels/galerkin.py``), shared by EFG and the
PIC field solve: stiffness matrices and load vectors.

Each bilinear form is one ``wp.func`` of a (test node, trial node) pair at a Gauss point (``kernels/galerkin.py``:
``conduction_form``, ``elastic_form``), which two race-free assembly strategies call, both bitwise the same for any
thread count:

- node rows (stiffness, the default): the pattern of K (node pairs that share a Gauss point, SᵀS of the rows'
  0/1 matrix S) is built once per shape data (:class:`NodeRows`), and each node gathers the Gauss points in its
  support and adds every pair into its own row of the pattern (no triplets to sum);
- triplets: each Gauss point owns ``slots(n_g)`` consecutive slots (n_g: the nodes in its row) and
  ``warpfree.sparse`` sums the duplicates on the host (loads, and stiffness with ``gather=False``).

Unknowns are node-major: component k of node I is unknown ``components·I + k``.

- :func:`conduction_matrix`: K_IJ = Σ_g w_g k_g ∇ψ_I·∇φ_J (Marques 2008, eq. 3.9, with the material's k)
- :func:`elastic_matrix`: K_IJ = Σ_g w_g B̂_Iᵀ D_g B_J (Rocha 2012, eq. 3.35)
- :func:`load_vector`: f_{cI+k} = Σ_g φ_I(x_g) v_{g,k} (sources, fluxes, tractions; Rocha 2012, eq. 3.36)

∇ψ: the test gradients, ∇φ or the variationally consistent ones (``warpfree.galerkin.consistent_integration``).
float64 (the shape functions', ``kernels/mls.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels import galerkin as gk
from warpfree.neighbours import host_rows
from warpfree.progress import announced
from warpfree.sparse import LoadBuffer, TripletBuffer, load_vector as _sum_loads, to_csr

from .shapes import ShapeData, ShapeModel

__all__ = ["conduction_matrix", "elastic_matrix", "load_vector", "NodeRows", "node_rows", "slot_starts", "per_point"]


def slot_starts(slots_per_point: np.ndarray, device: str) -> tuple[wp.array, int]:
    """The first triplet slot of each point (exclusive prefix sum of ``slots_per_point``) as an int64 Warp array on
    ``device``, and the slot total."""
    per = np.asarray(slots_per_point, dtype=np.int64)
    starts = np.zeros(per.size, dtype=np.int64)
    np.cumsum(per[:-1], out=starts[1:])
    total = int(per.sum())
    if total >= 2**31:
        raise ParameterError("d_max", f"assembly needs {total} slots, beyond the int32 index range: fewer Gauss "
                                      "points per cell or a smaller d_max")
    return wp.array(starts.astype(np.int32), dtype=wp.int32, device=device), total


def per_point(values, n: int, name: str, width: int | None = None) -> np.ndarray:
    """``values`` as float64 of shape (n,) (or (n, width)), or ParameterError naming ``name``."""
    v = np.asarray(values, dtype=np.float64)
    shape = (n,) if width is None else (n, width)
    if v.shape != shape:
        raise ParameterError(name, f"must have shape {shape}, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, "must be finite")
    return np.ascontiguousarray(v)


class NodeRows:
    """What the gather assembly needs from a ShapeData: for each node the row entries that hold it (in Gauss-point
    order), entry -> Gauss point, and K's pattern (CSR, sorted columns). Built once per ShapeData (host, set-up)."""

    def __init__(self, model: ShapeModel, shape: ShapeData):
        dev = model.launcher.device
        index = shape.rows.index.numpy()[: shape.n_entries].astype(np.int64)
        point = np.repeat(np.arange(shape.n, dtype=np.int64), shape.counts)
        order = np.argsort(index, kind="stable")          # node-major, Gauss points ascending within a node
        self.entries = host_rows(np.bincount(index, minlength=model.node_count), order, dev)
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
        self.gather = gk.NodeGather()
        self.gather.entries, self.gather.entry_point = self.entries, self.entry_point
        self.gather.pattern_start, self.gather.pattern_cols = self.pattern_start, self.pattern_cols

    @property
    def nnz(self) -> int:
        """The number of stored node pairs (entries of the matrix pattern)."""
        return int(self.indices.size)


def node_rows(model: ShapeModel, shape: ShapeData) -> NodeRows:
    """The shape data's :class:`NodeRows`, built on first use and kept on it."""
    if getattr(shape, "_node_rows", None) is None:
        shape._node_rows = NodeRows(model, shape)
    return shape._node_rows


@announced("conduction matrix assembled")
def conduction_matrix(model: ShapeModel, shape: ShapeData, weight, test_dphi: wp.array | None = None,
                      gather: bool = True) -> sp.csr_matrix:
    """(N, N) K from Gauss points ``shape`` with ``weight`` = w_g |J_g| k_g (conductivity or permittivity);
    ``test_dphi``: corrected test gradients (default ∇φ: symmetric K); ``gather``: node rows, else triplets."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    test = shape.dphi if test_dphi is None else test_dphi
    if gather:
        nr = node_rows(model, shape)
        values = wp.zeros(max(nr.nnz, 1), dtype=wp.float64, device=dev)
        model.launcher.launch(gk.conduction_rows, model.node_count, [shape.rows, nr.gather, test, shape.dphi, w,
                                                                     values], once=True)
        return sp.csr_matrix((values.numpy()[: nr.nnz], nr.indices, nr.indptr),
                             shape=(model.node_count, model.node_count))
    starts, total = slot_starts(shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(gk.conduction_stiffness, n, [shape.rows, test, shape.dphi, w, starts, slots.triplets],
                          once=True)
    return to_csr(slots, (model.node_count, model.node_count))


@announced("stiffness matrix assembled")
def elastic_matrix(model: ShapeModel, shape: ShapeData, weight, material,
                   test_dphi: wp.array | None = None, gather: bool = True) -> sp.csr_matrix:
    """(2N, 2N) K from Gauss points ``shape``: ``weight`` w_g |J_g|, ``material`` (n, 3, 3) D per point (Voigt,
    engineering shear strain); ``test_dphi``, ``gather`` as for :func:`conduction_matrix`."""
    dev, n = model.launcher.device, shape.n
    w = wp.array(per_point(weight, n, "weight"), dtype=wp.float64, device=dev)
    d = np.asarray(material, dtype=np.float64)
    if d.shape != (n, 3, 3) or not np.all(np.isfinite(d)):
        raise ParameterError("material", f"must be finite with shape ({n}, 3, 3), got {d.shape}")
    dm = wp.array(np.ascontiguousarray(d), dtype=wp.mat33d, device=dev)
    test = shape.dphi if test_dphi is None else test_dphi
    if gather:
        nr = node_rows(model, shape)
        values = wp.zeros(max(nr.nnz, 1), dtype=wp.mat22d, device=dev)
        model.launcher.launch(gk.elastic_rows, model.node_count, [shape.rows, nr.gather, test, shape.dphi, w, dm,
                                                                  values], once=True)
        blocks = values.numpy()[: nr.nnz]
        return sp.bsr_matrix((blocks, nr.indices, nr.indptr),
                             shape=(2 * model.node_count, 2 * model.node_count)).tocsr()
    starts, total = slot_starts(4 * shape.counts ** 2, dev)
    slots = TripletBuffer(total, dev)
    model.launcher.launch(gk.elastic_stiffness, n, [shape.rows, test, shape.dphi, w, dm, starts, slots.triplets],
                          once=True)
    return to_csr(slots, (2 * model.node_count, 2 * model.node_count))


def load_vector(model: ShapeModel, shape: ShapeData, value) -> np.ndarray:
    """f (components·N,) with f_{cI+k} = Σ_g φ_I(x_g) value[g, k]; ``value`` (n, components) holds w_g |J_g| times
    the source, flux or traction."""
    dev, n = model.launcher.device, shape.n
    v = np.asarray(value, dtype=np.float64)
    v = v.reshape(n, -1) if v.ndim == 1 else v
    c = v.shape[1]
    v = per_point(v, n, "value", c)
    starts, total = slot_starts(c * shape.counts, dev)
    slots = LoadBuffer(total, dev)
    model.launcher.launch(gk.point_loads, n, [shape.rows, shape.phi, wp.array(v.reshape(-1), dtype=wp.float64,
                                                                             device=dev), c, starts, slots.loads],
                          once=True)
    return _sum_loads(slots, c * model.node_count)
