"""How well a node layout serves the points where its shape functions are evaluated: the report a Galerkin solve
makes before it assembles, and the limits past which the solve is refused (by name, at the place it would be wrong).

Per point x (a Gauss point): how many nodes serve it, the moment matrix's scaled pivot (MLS, ``rcond``), and the
Lebesgue constant of its shape functions Λ(x) = Σ_I |φ_I(x)|, the factor by which the approximation can amplify what
it is given: |u(x) - u^h(x)| ≤ (1 + Λ(x)) min_p max_{supports at x} |u - p| over the polynomials p of the basis
(Wendland 2005, *Scattered Data Approximation*, ch. 4; Mirzaei 2015, J. Comput. Appl. Math. 282). Λ = 1 where every φ_I ≥ 0; a layout
whose spacing jumps within one support, or whose nodes are stretched or near a line for the basis, makes the fit
ill-posed there and Λ large. Per node: how many points its support holds (none: its row of the system is empty).

Measured (``bench/efg/layout_quality.py``, ``bench/results/layout_quality.md``): every shipped EFG scene's Gauss
points have Λ ≤ 1.5 (1.8-1.9 on Cook's membrane's random layouts); on a plate with an elliptical hole (exact
stresses, ``scenes/efg_plate_hole.py``), uniform, graded and 2:1 stretched layouts give 1.1-1.2 with the linear basis
at d_max 2 (1.7 stretched 4:1), 1.4-1.5 with the quadratic at d_max 3, and a spacing that jumps 4x 3.1-3.4 with
errors as at 2x. The layouts that came out wrong had Λ ≥ 5.6: a spacing that jumps 8x (linear basis, d_max 2: Λ 13,
tip stress +15 %; d_max 1.6: Λ 60, an energy error of 48; quadratic, d_max 3: Λ 9.4, energy error 0.12 against
8.4e-3 at a 4x jump), and the quadratic basis at d_max 2 on every layout (Λ 5.6 to 145: twice d_max 3's energy
error, the tip stress 5.0 % then 6.7 % off at spacings 0.05, 0.025 on uniform layouts). Λ sees an ill-posed fit,
not a layout too coarse for the solution: a 3:1 stretch put 0.15 across the tip, whose radius of curvature is
0.125, and its stress came out 22 % low at Λ 1.5 (refining there is the cure).
Host NumPy on the kernel's per-point Λ (``kernels/galerkin.py: lebesgue_constants``), float64.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels import galerkin as gk
from warpfree.parallel import world as ranks_of_run

from .shapes import ShapeData, ShapeModel

__all__ = ["LayoutReport", "layout_report", "LEBESGUE_LIMIT", "SPREAD_LIMIT"]

#: the largest Lebesgue constant Σ|φ_I| admitted at a Gauss point (module docstring: ≤ 3.4 on every layout measured
#: that solved well, ≥ 5.6 on every one whose fit went wrong)
LEBESGUE_LIMIT = 5.0
#: the spread of the spacings around a point (largest / smallest) beyond which the refusal blames the grading (an 8x
#: jump in spacing: 8; uniform and smoothly graded layouts: up to 2.4, at their boundaries)
SPREAD_LIMIT = 3.0


@dataclass(frozen=True)
class LayoutReport:
    """A layout's quality at the points it serves (module docstring), over every rank's own points: ``points``,
    ``nodes``; the fewest and the mean nodes serving a point (``support_min``, ``support_mean``); the smallest scaled
    pivot of the moment matrices (``rcond_min``); the largest and mean Lebesgue constant (``lebesgue_max``,
    ``lebesgue_mean``), where the largest is (``worst_point``, its index among all the points; ``worst_position``),
    the nodes serving it (``worst_count``) and the spread of the spacings around it (``worst_spread``: the largest over
    the smallest of the nodes' within the reach of those serving it); the nodes whose support holds no point
    (``unserved_nodes``, the first ``first_unserved``, -1 if none)."""

    points: int
    nodes: int
    support_min: int
    support_mean: float
    rcond_min: float
    lebesgue_max: float
    lebesgue_mean: float
    worst_point: int
    worst_position: tuple[float, float]
    worst_count: int
    worst_spread: float
    unserved_nodes: int
    first_unserved: int

    def describe(self) -> dict:
        """The report for ``summary.json``."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def check(self, model: ShapeModel, name: str = "Gauss point") -> None:
        """Refuse (ParameterError naming ``nodes``) a node whose support holds no point, or a point whose Λ exceeds
        :data:`LEBESGUE_LIMIT`, saying where and why."""
        if self.unserved_nodes:
            i = self.first_unserved
            x = model.nodes_np[i]
            raise ParameterError("nodes", f"node {i} at ({x[0]:.6g}, {x[1]:.6g}) serves no {name} ({self.unserved_nodes} "
                                          "such nodes): it stands outside the integration cells, or they leave a gap "
                                          "around it, so its row of the system is empty; remove it or cover it")
        if self.lebesgue_max > LEBESGUE_LIMIT:
            x, y = self.worst_position
            d_max = getattr(getattr(model, "settings", None), "d_max", None)
            remedy = f" or raise d_max (now {d_max:g})" if d_max is not None else ""
            if self.worst_spread > SPREAD_LIMIT:
                why = (f"the node spacing changes {self.worst_spread:.1f}x within the reach of the {self.worst_count} "
                       f"nodes serving it: grade the layout more gently{remedy}")
            else:
                why = (f"its {self.worst_count} nodes sit badly for the fit (stretched, or near a line): add nodes "
                       f"around it{remedy}")
            raise ParameterError("nodes", f"the shape functions at {name} {self.worst_point} ({x:.6g}, {y:.6g}) "
                                          f"amplify the nodal values' errors up to Λ = Σ|φ_I| = "
                                          f"{self.lebesgue_max:.3g} (at most {LEBESGUE_LIMIT:g}): {why}")


def _spread(model: ShapeModel, point: np.ndarray, serving: np.ndarray) -> float:
    """The largest over the smallest local spacing of the nodes as near ``point`` as the farthest of the nodes
    ``serving`` it (all nodes, serving or not: where the spacing jumps, the fine nodes' supports miss a point the
    coarse nodes serve)."""
    if serving.size == 0:
        return 1.0
    distance = np.linalg.norm(model.nodes_np - point, axis=1)
    near = distance <= distance[serving].max()
    return float(np.max(model.spacing[near]) / np.min(model.spacing[near]))


def layout_report(model: ShapeModel, shape: ShapeData, own: np.ndarray | None = None,
                  ids: np.ndarray | None = None, world=None) -> LayoutReport:
    """The report of ``model``'s layout at the points of ``shape``: ``own`` (bool per point) the points this rank
    owns (default all), ``ids`` their indices among all the points (default 0..n-1); ``world`` the ranks (default
    the run's): every rank gets the same report."""
    world = world or ranks_of_run()
    n = shape.n
    own = np.ones(n, dtype=bool) if own is None else np.asarray(own, dtype=bool)
    ids = np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids, dtype=np.int64)
    lebesgue = wp.zeros(max(n, 1), dtype=wp.float64, device=model.launcher.device)
    if n:
        model.launcher.launch(gk.lebesgue_constants, n, [shape.rows, shape.phi, lebesgue], once=True)
    lam = lebesgue.numpy()[:n][own]
    counts = np.asarray(shape.counts)[:n]
    rcond = shape.rcond.numpy()[:n][own] if shape.rcond is not None else np.ones(0)
    index = shape.rows.index.numpy()[: shape.n_entries]
    served = world.allreduce(np.bincount(index[np.repeat(own, counts)], minlength=model.node_count), "sum")
    points = int(world.allreduce(int(own.sum()), "sum"))
    local_max = float(lam.max()) if lam.size else -np.inf
    lam_max = float(world.allreduce(local_max, "max"))
    mine = lam.size > 0 and local_max == lam_max
    holder = int(world.allreduce(world.rank if mine else -1, "max"))
    worst = np.zeros(5)
    if world.rank == holder:
        at = int(np.flatnonzero(own)[int(np.argmax(lam))])
        first = int(np.sum(counts[:at]))
        worst[:] = (ids[at], shape.points[at, 0], shape.points[at, 1], counts[at],
                    _spread(model, shape.points[at], index[first:first + counts[at]]))
    worst = world.allreduce(worst, "sum")
    unserved = np.flatnonzero(served == 0)
    return LayoutReport(
        points=points, nodes=int(model.node_count),
        support_min=int(world.allreduce(int(counts[own].min()) if own.any() else np.iinfo(np.int64).max, "min")),
        support_mean=float(world.allreduce(int(counts[own].sum()), "sum")) / max(points, 1),
        rcond_min=float(world.allreduce(float(rcond.min()) if rcond.size else np.inf, "min")),
        lebesgue_max=lam_max, lebesgue_mean=float(world.allreduce(float(lam.sum()), "sum")) / max(points, 1),
        worst_point=int(worst[0]), worst_position=(float(worst[1]), float(worst[2])), worst_count=int(worst[3]),
        worst_spread=float(worst[4]), unserved_nodes=int(unserved.size),
        first_unserved=int(unserved[0]) if unserved.size else -1)
