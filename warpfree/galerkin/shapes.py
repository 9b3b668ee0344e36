"""Shape functions at points, whatever model made them, and what a Galerkin solver needs of that model.

A shape-function model (:class:`ShapeModel`: MLS, ``warpfree.galerkin.mls``; Laplace/NEM, ``warpfree.solvers.nem``)
holds nodes and gives, at any set of points, the nodes whose shape functions do not vanish there and the values
φ_I and gradients ∇φ_I (:class:`ShapeData`: CSR rows, float64). The Galerkin solvers (``warpfree.solvers.efg``) and
the PIC field solve (``warpfree.solvers.pic``) know a model only through this class. u^h(x) = Σ_I φ_I(x) u_I
(:func:`evaluate_nodal`; Rocha 2012, eq. 3.28).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.kernels import galerkin as gk
from warpfree.kernels import neighbours as nk
from warpfree.parameters import Choice

__all__ = ["ShapeFunctions", "ShapeModel", "ShapeData", "evaluate_nodal", "points2d", "vec3_points", "material_array"]


class ShapeFunctions(Choice):
    """The shape functions of a Galerkin solve."""

    EFG = "efg", "element-free Galerkin: MLS shape functions on the nodes' supports"
    NEM = "nem", "natural element method: Laplace shape functions of the nodes' Delaunay triangulation"


class ShapeData:
    """Shape functions at ``n`` points: row i lists the nodes whose support holds point i (``rows``, a
    :class:`~warpfree.kernels.neighbours.NeighbourRows`), ``phi`` and ``dphi`` (float64, ``wp.vec2d``) per entry,
    ``counts`` (host copy) and ``rcond`` per point."""

    def __init__(self, points: np.ndarray, rows: nk.NeighbourRows, counts: np.ndarray, n_entries: int,
                 phi: wp.array, dphi: wp.array, rcond: wp.array, n_nodes: int):
        self.points = points
        self.rows = rows
        self.counts = counts
        self.n_entries = n_entries
        self.phi = phi
        self.dphi = dphi
        self.rcond = rcond
        self.n_nodes = n_nodes

    @property
    def n(self) -> int:
        """The number of evaluation points."""
        return self.points.shape[0]

    def kernel_rows(self) -> gk.ShapeRows:
        """The rows, φ and ∇φ as kernels read them (``kernels/galerkin.py: ShapeRows``)."""
        rows = gk.ShapeRows()
        rows.rows, rows.phi, rows.dphi = self.rows, self.phi, self.dphi
        return rows

    def _csr(self, data: np.ndarray) -> sp.csr_matrix:
        offsets = np.zeros(self.n + 1, dtype=np.int64)
        np.cumsum(self.counts, out=offsets[1:])
        index = self.rows.index.numpy()[: self.n_entries]
        return sp.csr_matrix((data, index, offsets), shape=(self.n, self.n_nodes))

    def matrix(self) -> sp.csr_matrix:
        """Φ (n points × n nodes): u^h(points) = Φ u."""
        return self._csr(self.phi.numpy()[: self.n_entries])

    def gradient_matrices(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(∂Φ/∂x, ∂Φ/∂y): ∇u^h(points) = (Φ_x u, Φ_y u)."""
        d = self.dphi.numpy()[: self.n_entries]
        return self._csr(d[:, 0]), self._csr(d[:, 1])


class ShapeModel(ABC):
    """Nodes and their shape functions, as the Galerkin solvers use them.

    Attributes every model sets: ``launcher`` (device and threads), ``node_count``, ``nodes_np`` ((n, 2) float64
    positions), ``spacing`` ((n,) a node's local spacing), ``reach`` (m: no shape function is nonzero farther than
    this from its node; a distributed solve's ghost depth), ``node_material`` ((n,) int32 Warp array, -1: serves every
    material), ``settings`` (``interpolating``: φ_I(x_J) = δ_IJ, so that essential conditions may be substituted;
    ``basis`` and ``weight``: what the outputs name the method by).
    """

    launcher: Launcher
    node_count: int
    nodes_np: np.ndarray
    spacing: np.ndarray
    reach: float

    @abstractmethod
    def shape_at(self, points, material=None, name: str = "point") -> ShapeData:
        """Shape functions and gradients at ``points`` (n, 2); ``material`` (n,) ints (default -1: sees every node);
        a point the model cannot serve is refused (ParameterError naming ``support``, with the point ``name``)."""

    @abstractmethod
    def describe(self) -> dict:
        """The model's parameters and counts, for ``summary.json``."""

    @property
    def consistency_order(self) -> int:
        """The order n of the variationally consistent integration the solvers use with this model
        (``warpfree.galerkin.consistent_integration``: the Galerkin equations of every field of degree n exact):
        1, the constant correction, unless the model raises it (MLS: one above its basis's degree)."""
        return 1

    def evaluate(self, nodal, shape: ShapeData, components: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(u^h (n, components), ∇u^h (n, components, 2)) at the points of ``shape`` from nodal parameters
        ``nodal`` (node count × components, node-major: u_{cI+k})."""
        return evaluate_nodal(self.launcher, self.node_count, nodal, shape, components)


def points2d(points, name: str) -> np.ndarray:
    """``points`` as a contiguous finite (n, 2) float64 array (extra columns dropped), else ParameterError naming
    ``name``."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < 2 or p.shape[0] == 0:
        raise ParameterError(name, f"must be a non-empty (n, 2) array of points, got shape {p.shape}")
    p = np.ascontiguousarray(p[:, :2])
    if not np.all(np.isfinite(p)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise ParameterError(name, f"point {bad} is not finite: {p[bad].tolist()}")
    return p


def vec3_points(points: np.ndarray, device: str) -> wp.array:
    """(n, 2) points as float32 ``wp.vec3`` (z = 0): the copies a ``wp.HashGrid`` query takes."""
    p3 = np.zeros((points.shape[0], 3), dtype=np.float32)
    p3[:, :2] = points
    return wp.array(p3, dtype=wp.vec3, device=device)


def material_array(values, n: int, name: str, device: str) -> wp.array:
    """(n,) material indices as an int32 Warp array (None: all -1, every material), else ParameterError."""
    m = np.full(n, -1, dtype=np.int32) if values is None else np.asarray(values)
    if m.shape != (n,) or not np.issubdtype(m.dtype, np.integer) or np.any(m < -1):
        raise ParameterError(name, f"must be {n} integers >= -1 (-1: sees / is seen by every material)")
    return wp.array(m.astype(np.int32), dtype=wp.int32, device=device)


def evaluate_nodal(launcher: Launcher, node_count: int, nodal, shape: ShapeData,
                   components: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """u^h_k = Σ_I φ_I u_{cI+k} and its gradient at the points of ``shape`` (any model's shape data): (n,
    components) and (n, components, 2) from ``nodal`` (node count × components, node-major)."""
    dev = launcher.device
    u = np.ascontiguousarray(np.asarray(nodal, dtype=np.float64).reshape(-1))
    if u.size != components * node_count:
        raise ParameterError("nodal", f"needs {components * node_count} values, got {u.size}")
    value = wp.zeros(shape.n * components, dtype=wp.float64, device=dev)
    grad = wp.zeros(shape.n * components, dtype=wp.vec2d, device=dev)
    launcher.launch(gk.evaluate_field, shape.n, [shape.rows, shape.phi, shape.dphi,
                                                 wp.array(u, dtype=wp.float64, device=dev), components, value, grad],
                    once=True)
    return value.numpy().reshape(shape.n, components), grad.numpy().reshape(shape.n, components, 2)
