"""The MLS model: nodes, their supports and MLS shape functions at any set of points (Rocha 2012; Marques 2008), the shape
functions of EFG and of the PIC field solve.

An :class:`MLSModel` (a :class:`~warpfree.galerkin.shapes.ShapeModel`) holds what does not change once built: the nodes (float64), their materials, the MLS
settings (:class:`MLSSettings`), each node's support (half-widths R_I = d_max · c_I, with c_I the distance to its
``rank``-th nearest node, Rocha 2012, §4.1.1 and eq. 3.33; Marques 2008, eq. 4.1) and a ``wp.HashGrid`` over the nodes.
:meth:`MLSModel.shape_at` gives the shape functions and their gradients at any points (Gauss points, plotting
points, plasma particles) as a :class:`ShapeData`: CSR rows of the nodes whose support holds each point, with
φ_I and ∇φ_I per entry. Another solver (the PIC field solve) holds the model and asks it for shape data.

Periodic boxes (the PIC field solve): give ``space`` a :class:`~warpfree.space.Space` with periodic axes. The node
HashGrid then holds the nodes' periodic images (``warpfree.neighbours``), and every offset x - x_I is the minimum
image (``kernels/space.py: offset2d``), so supports, shape functions and assembled matrices wrap around the box: a
node near one face serves points near the opposite face, as its image would.

A point whose moment matrix cannot be inverted (fewer nodes than basis terms, or nodes on a line for the linear
basis) is refused with its position and node count, never inverted blindly (``kernels/mls.py`` has the
algebra; float64 throughout, see there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError, require_integer, require_positive
from warpfree.kernels import mls as mk
from warpfree.neighbours import NeighbourGrid, empty_rows, lay_out_rows
from warpfree.parameters import Choice, Param
from warpfree.progress import announced, group_digits
from warpfree.space import Space

from .shapes import ShapeData, ShapeModel, material_array, points2d, vec3_points

__all__ = ["MLSSettings", "MLSModel", "MLSBasis", "MLSWeight", "SupportShape", "Basis", "Weight", "SupportScale",
           "BASES", "DEGREES", "WEIGHTS", "RCOND_LIMIT"]


class MLSBasis(Choice):
    """The MLS basis p(x)."""

    LINEAR = "linear", "linear basis (1, x, y)"
    QUADRATIC = "quadratic", "quadratic basis (1, x, y, x², xy, y²)"


class MLSWeight(Choice):
    """The MLS weight function w(r), r = |x - x_I| / R_I."""

    CUBIC_SPLINE = "cubic_spline", "cubic spline: 2/3 - 4r² + 4r³ to r = 1/2, 4/3 - 4r + 4r² - 4r³/3 beyond"
    QUARTIC = "quartic", "quartic 1 - 6r² + 8r³ - 3r⁴"
    GAUSSIAN = "gaussian", "Gaussian exp(-(r/0.4)²), shifted to vanish at r = 1"
    SINGULAR = "singular", "cubic spline / (r² + ε²): interpolating shape functions, φ_I(x_J) = δ_IJ"


class SupportShape(Choice):
    """The shape of a node's support."""

    CIRCULAR = "circular", "a disc of radius R_I"
    RECTANGULAR = "rectangular", "a square of half-width R_I, tensor-product weight w(|Δx|/R_I) w(|Δy|/R_I)"


#: basis terms m by basis
BASES = {MLSBasis.LINEAR: 3, MLSBasis.QUADRATIC: 6}
#: the polynomial degree each basis reproduces exactly
DEGREES = {MLSBasis.LINEAR: 1, MLSBasis.QUADRATIC: 2}
#: the weight ids of the kernels (``kernels/mls.py``)
WEIGHTS = {MLSWeight.CUBIC_SPLINE: 0, MLSWeight.QUARTIC: 1, MLSWeight.GAUSSIAN: 2, MLSWeight.SINGULAR: 3}

#: scene parameters of the MLS model, declared once (EFG and PIC scenes)
Basis = Annotated[MLSBasis, Param("", "MLS basis p(x)")]
Weight = Annotated[MLSWeight, Param("", "MLS weight function w(r)")]
SupportScale = Annotated[float, Param("c_I", "support radius R_I = d_max c_I, c_I the distance from node I to its 4th "
                                             "nearest node", "(1, inf)")]

#: smallest admitted pivot of the Jacobi-scaled moment matrix: below it the fit is ill-posed (nodes on a line,
#: a point at the edge of too few supports) and the shape functions would carry its rounding error, 1e-16/rcond
RCOND_LIMIT = 1e-10


@dataclass(frozen=True)
class MLSSettings:
    """MLS shape functions: ``basis`` "linear" (1, x, y) or "quadratic"; ``weight`` "cubic_spline" (Rocha 2012 eq
    3.32), "quartic" (3.30), "gaussian" (3.31) or "singular" (interpolating, Marques 2008, §3.5); ``d_max`` the support
    scale (Rocha 2012, eq. 3.33: R_I = d_max c_I; the thesis uses 3.5 for the beam, 2.5 for the cylinder, 1.8 for
    Cook); ``support`` "circular" or "rectangular" (tensor-product weight, Marques 2008, eq. 3.23); ``rank``: c_I is the
    distance from node I to its rank-th nearest node (4: the grid spacing inside a regular 2D grid)."""

    basis: MLSBasis = MLSBasis.LINEAR
    weight: MLSWeight = MLSWeight.CUBIC_SPLINE
    d_max: float = 2.0
    support: SupportShape = SupportShape.CIRCULAR
    rank: int = 4

    def __post_init__(self):
        object.__setattr__(self, "basis", MLSBasis.of("basis", self.basis))
        object.__setattr__(self, "weight", MLSWeight.of("weight", self.weight))
        object.__setattr__(self, "support", SupportShape.of("support", self.support))
        d = require_positive("d_max", self.d_max)
        if d <= 1.0:
            raise ParameterError("d_max", f"must be > 1 (a support no wider than the distance to the nearest nodes "
                                          f"cannot hold the {BASES[self.basis]} nodes the basis needs), got {d}")
        require_integer("rank", self.rank, minimum=1, maximum=mk.MAX_RANK)

    @property
    def terms(self) -> int:
        """The number of basis terms m (linear 3, quadratic 6 in 2D)."""
        return BASES[self.basis]

    def params(self) -> mk.MLSParams:
        """The settings as the kernels read them (``kernels/mls.py: MLSParams``)."""
        p = mk.MLSParams()
        p.terms = self.terms
        p.weight = WEIGHTS[self.weight]
        p.rectangular = int(self.support is SupportShape.RECTANGULAR)
        return p

    def kernel_key(self) -> tuple[int, int, bool]:
        """(basis terms, weight id, rectangular): what the MLS kernels are compiled for (``kernels/mls.py``)."""
        return self.terms, WEIGHTS[self.weight], self.support is SupportShape.RECTANGULAR

    @property
    def interpolating(self) -> bool:
        """φ_I(x_J) = δ_IJ (the singular weight): essential conditions by direct substitution."""
        return self.weight is MLSWeight.SINGULAR


class MLSModel(ShapeModel):
    """Nodes, supports and shape functions (module docstring).

    nodes: (n, 2) positions; settings: :class:`MLSSettings`; node_material: (n,) ints, -1 for a node that serves
    every material (on an interface, or a one-material model: the default); launcher: the device and threads;
    space: a 2D :class:`~warpfree.space.Space` (default free; periodic axes need every node inside the box and a
    side of at least twice the widest support).
    """

    @announced(lambda self, nodes, *a, **k: f"MLS model made ({group_digits(len(nodes))} nodes)")
    def __init__(self, nodes, settings: MLSSettings | None = None, node_material=None,
                 launcher: Launcher | None = None, space: Space | None = None):
        self.settings = settings or MLSSettings()
        self.launcher = launcher or current_launcher()
        self.space = space or Space.free(2)
        if self.space.dim != 2:
            raise ParameterError("space", f"the MLS model is 2D, got a {self.space.dim}D space")
        self.box = self.space.box2d
        dev = self.launcher.device
        self.nodes_np = points2d(nodes, "nodes")
        if self.space.is_periodic:
            self._require_inside(self.nodes_np, "nodes", "node")
        n = self.node_count = self.nodes_np.shape[0]
        if n < self.settings.terms:
            raise ParameterError("nodes", f"{n} nodes cannot carry the {self.settings.basis} basis "
                                          f"({self.settings.terms} terms)")
        self.nodes = wp.array(self.nodes_np, dtype=wp.vec2d, device=dev)
        self.nodes32 = vec3_points(self.nodes_np, dev)
        self.node_material = material_array(node_material, n, "node_material", dev)
        self.spacing = self._rank_distance()
        half = self.settings.d_max * self.spacing
        self.support_np = np.stack([half, half], axis=1)
        self.support = wp.array(self.support_np, dtype=wp.vec2d, device=dev)
        reach = float(np.max(half)) * (math.sqrt(2.0) if self.settings.support is SupportShape.RECTANGULAR else 1.0)
        # the query radius must cover every support; float32 positions: widen by a rounding margin
        self.reach = reach * (1.0 + 1e-5)
        for a in range(2):
            if self.space.periodic[a] and self.space.length[a] < 2.0 * self.reach:
                raise ParameterError("d_max", f"supports reach {self.reach:.6g}, more than half the periodic side "
                                              f"along {'xy'[a]} ({self.space.length[a]:.6g}): a node would meet a "
                                              f"point through two images; lower d_max (now {self.settings.d_max}) "
                                              "or enlarge the box")
        self.grid = NeighbourGrid(self.launcher, self.reach, self.space, self.nodes32)
        self._params = self.settings.params()

    def node_set(self) -> mk.NodeSet:
        """The nodes as kernels read them (``kernels/mls.py: NodeSet``)."""
        ns = mk.NodeSet()
        ns.grid = self.grid.id
        ns.grid_points = self.grid.points
        ns.source_id = self.grid.source_id
        ns.box = self.box
        ns.reach = self.reach
        ns.nodes = self.nodes
        ns.nodes32 = self.nodes32
        ns.support = self.support
        ns.params = self._params
        return ns

    def _require_inside(self, p: np.ndarray, parameter: str, name: str) -> None:
        """Refuse points outside the periodic box (lower <= x < upper along its periodic axes)."""
        for a in range(2):
            if self.space.periodic[a]:
                lo, hi = self.space.lower[a], self.space.upper[a]
                bad = np.flatnonzero((p[:, a] < lo) | (p[:, a] >= hi))
                if bad.size:
                    i = int(bad[0])
                    raise ParameterError(parameter, f"{name} {i} at {p[i].tolist()} lies outside the periodic box "
                                                    f"along {'xy'[a]} ([{lo:.6g}, {hi:.6g})); {bad.size} such")

    def _rank_distance(self) -> np.ndarray:
        """c_I: distance from each node to its rank-th nearest node (a Warp kernel over a HashGrid; the radius
        doubles until every node has ``rank`` others inside it)."""
        x = self.nodes_np
        extent = np.ptp(x, axis=0)
        area = max(float(np.prod(extent[extent > 0])) if np.any(extent > 0) else 1.0, 1e-300)
        radius = 2.5 * math.sqrt(area / x.shape[0]) * math.sqrt(self.settings.rank)
        if not np.any(extent > 0):
            raise ParameterError("nodes", "all nodes coincide")
        distance = wp.zeros(x.shape[0], dtype=wp.float64, device=self.launcher.device)
        room = 0.5 * min((self.space.length[a] for a in range(2) if self.space.periodic[a]), default=math.inf)
        for _ in range(60):
            radius = min(radius, room)
            grid = NeighbourGrid(self.launcher, radius, self.space, self.nodes32)
            self.launcher.launch(mk.kth_nearest, x.shape[0], [grid.id, grid.points, grid.source_id, self.box,
                                                              self.nodes32, self.nodes, self.settings.rank, radius,
                                                              distance], once=True)
            d = distance.numpy()
            if np.all(d >= 0) or radius >= room:
                break
            radius *= 2.0
        if np.any(d < 0):
            raise ParameterError("nodes", f"fewer than rank + 1 = {self.settings.rank + 1} nodes within half the "
                                          "periodic box: too few nodes for the MLS supports")
        if np.any(d <= 0):
            bad = int(np.flatnonzero(d <= 0)[0])
            raise ParameterError("nodes", f"node {bad} at {x[bad].tolist()} coincides with its "
                                          f"{self.settings.rank}-th nearest node (duplicate nodes)")
        return d

    def support_rows(self, points, material=None, name: str = "point", brute_force: bool = False):
        """(float64 points, rows, counts, entries): for each point the nodes whose support holds it and whose
        material it sees (``kernels/mls.py: support_rows``; ``brute_force``: every node tested, for checks and the
        search benchmark)."""
        p = points2d(points, name)
        if self.space.is_periodic:
            self._require_inside(p, "points", name)
        n, dev, L = p.shape[0], self.launcher.device, self.launcher
        points64 = wp.array(p, dtype=wp.vec2d, device=dev)
        mat = material_array(material, n, "material", dev)
        rows = empty_rows(n, dev)
        if brute_force:
            kernel, args = mk.support_rows_brute, [self.node_count, self.box, points64, mat, self.nodes, self.support,
                                                    self.node_material, self._params]
        else:
            kernel, args = mk.support_rows, [self.grid.id, self.grid.points, self.grid.source_id, self.box, self.reach,
                                             vec3_points(p, dev), points64, mat, self.nodes,
                                             self.support, self.node_material, self._params]
        L.launch(kernel, n, args + [0, rows], once=True)
        counts, total = lay_out_rows(rows, n, "d_max")
        L.launch(kernel, n, args + [1, rows], once=True)
        return p, points64, rows, counts, total

    @announced(lambda self, points, *a, **k: f"MLS shape functions at {group_digits(len(points))} points")
    def shape_at(self, points, material=None, name: str = "point", staged: bool | None = None) -> ShapeData:
        """Shape functions and gradients at ``points`` (n, 2); ``material`` (n,) ints (default -1: sees every
        node). ``staged``: the shape functions in four kernels (``kernels/mls.py: staged_shape_functions``, the
        quadratic basis's form on a GPU, within its register budget) instead of one; bitwise the same results;
        default: staged for the quadratic basis off the CPU. Raises ParameterError('support') naming the first
        point whose fit is ill-posed."""
        p, points64, rows, counts, total = self.support_rows(points, material, name)
        n, dev, L = p.shape[0], self.launcher.device, self.launcher
        phi = wp.zeros(max(total, 1), dtype=wp.float64, device=dev)
        dphi = wp.zeros(max(total, 1), dtype=wp.vec2d, device=dev)
        rcond = wp.zeros(n, dtype=wp.float64, device=dev)
        key = self.settings.kernel_key()
        if staged is None:
            staged = not L.is_cpu and self.settings.terms == mk.MAX_TERMS
        if staged:
            kernels = mk.staged_shape_functions(*key)
            fits = wp.zeros(n * kernels.size, dtype=wp.float64, device=dev)
            args = [self.box, points64, rows, self.nodes, self.support, rcond, fits]
            L.launch(kernels.moment_factors, n, args, once=True)
            for axis in (0, 1):
                L.launch(kernels.slope_fits, n, args + [axis], once=True)
            L.launch(kernels.slope_solves, n, [rcond, fits], once=True)
            L.launch(kernels.shape_values, n, args + [phi, dphi], once=True)
        else:
            L.launch(mk.shape_functions_kernel(*key), n,
                     [self.box, points64, rows, self.nodes, self.support, self._params, phi, dphi, rcond], once=True)
        self._check(p, counts, rcond.numpy(), name)
        return ShapeData(p, rows, counts, total, phi, dphi, rcond, self.node_count)

    def _check(self, p: np.ndarray, counts: np.ndarray, rcond: np.ndarray, name: str) -> None:
        terms = self.settings.terms
        few = np.flatnonzero(counts < terms)
        if few.size:
            i = int(few[0])
            raise ParameterError("support", f"{name} {i} at ({p[i, 0]:.6g}, {p[i, 1]:.6g}) lies in the support of "
                                            f"{counts[i]} node(s); the {self.settings.basis} basis needs at least "
                                            f"{terms} ({few.size} such points): raise d_max (now "
                                            f"{self.settings.d_max}) or add nodes there")
        bad = np.flatnonzero(~(rcond >= RCOND_LIMIT))
        if bad.size:
            i = int(bad[np.argmin(rcond[bad])])
            raise ParameterError("support", f"the moment matrix at {name} {i} ({p[i, 0]:.6g}, {p[i, 1]:.6g}), "
                                            f"{counts[i]} nodes, is ill-conditioned (scaled pivot {rcond[i]:.1e} < "
                                            f"{RCOND_LIMIT:.0e}; nodes on a line?) at {bad.size} point(s): raise "
                                            f"d_max (now {self.settings.d_max}) or move nodes")

    @property
    def consistency_order(self) -> int:
        """One above the basis's degree p (``warpfree.galerkin.consistent_integration``): at order p the Galerkin
        equations of the solution's degree-(p + 1) part stay off by O(h^p) summed along the boundary, a flux error
        that a natural boundary passes to the solution (an L2 rate of p, not p + 1)."""
        return DEGREES[self.settings.basis] + 1

    def describe(self) -> dict:
        """The model for ``summary.json``: node count, basis, weight, d_max, support shape and radii."""
        s = self.settings
        return {"nodes": self.node_count, "basis": s.basis, "weight": s.weight, "d_max": s.d_max,
                "support": s.support, "rank": s.rank, "support_radius_min": float(self.support_np[:, 0].min()),
                "support_radius_max": float(self.support_np[:, 0].max())}
