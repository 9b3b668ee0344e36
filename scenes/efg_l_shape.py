"""EFG Poisson on an L-shaped domain with flux on the re-entrant sides: the L2 error and its rate under refinement.

The manufactured case of ``warpfree/validation/efg_l_shape``: -Δu = s on the L [0, 2]² minus (1, 2]², smooth u,
u prescribed on the outer sides (Lagrange multipliers), the flux ∂u/∂n on the two re-entrant sides (3 Gauss
points per node spacing). Regular nodes at spacing 1/``n``, one background cell per node spacing with ``gauss`` x
``gauss`` points (None: the basis's, ``warpfree.galerkin.quadrature.CELL_ORDER``), the cubic-spline weight,
consistent integration of order ``consistency`` (None: the model's, one above the basis's degree: 2 for the
linear basis, 3 for the quadratic; ``warpfree.galerkin.consistent_integration``). Writes into ``summary.json`` the
relative L2 error (3 x 3 Gauss points on a 40 x 40 grid per unit square) and, with ``refinements`` > 0 (2 by default), the
errors at spacings 1/(n·2^-k) ..., the rates between them, ``checks``: the finest rate against the order 3 of MLS on
regular nodes (:func:`l_shape_checks`), and ``convergence.png`` (the errors against the order-3 line, the rates
with the tolerance band below). The domain is the unit-free L of the manufactured case (lengths in its units).
"""

from __future__ import annotations

import os
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as, require_memory
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, SupportScale
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.galerkin.node_layouts import BYTES_PER_NODE
from warpfree.galerkin.quadrature import QuadraturePoints, cell_order, rectangle_cells, segment_points
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, Natural
from warpfree.io.validation_plots import plot_against_reference
from warpfree.solvers.efg.parameters import CellGauss
from warpfree.solvers.efg.solver import POISSON_UNITS, PoissonSolver
from warpfree.validation import tolerance_check
from warpfree.validation.efg_l_shape import OUTER, SQUARES, exact, exact_gradient, source

NAMES = {"cells": "n", "order": "gauss", "support": "n, d_max"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"n": 4, "refinements": 0}

#: ``warpfree validate --quick``: the default (spacings 1/4, 1/8, 1/16; about 1 s), the rate check's resolution
QUICK = {"n": 16, "refinements": 2}

#: the L2 order EFG keeps on regular nodes here, and the slack on the finest observed rate
ORDER, ORDER_TOLERANCE = 3.0, 0.5
EXACT = "manufactured solution u = sin(1.3x + 0.4) exp(0.7y) (warpfree/validation/efg_l_shape/README.md)"


def l_shape_checks(rates: list[float]) -> dict:
    """The observed L2 rate between the two finest spacings against the order 3 of MLS on regular nodes."""
    return {"l2_rate": tolerance_check(
        rates[-1], ORDER_TOLERANCE, EXACT, reference=ORDER,
        basis="order 3: linear MLS on regular nodes (its minimum is 2) and the quadratic basis (p + 1), with "
              "consistent integration; ±0.5 for the pre-asymptotic scatter between 1/8 and 1/16 (a rate that "
              "falls off is a quadrature defect, README)")}


def l_shape_solver(n: int, basis: MLSBasis = MLSBasis.LINEAR, d_max: float = 2.0, gauss: int | None = None,
                   consistency: int | None = None) -> PoissonSolver:
    """The case's EFG solver (not yet solved) at node spacing 1/n; ``consistency``: the order of consistent
    integration (None: the model's)."""
    order = cell_order(basis, gauss)
    require_memory("cells", 3.0 * (n + 1.0) ** 2, BYTES_PER_NODE, "nodes")
    g = np.arange(2 * n + 1) / n
    x, y = np.meshgrid(g, g, indexing="ij")
    nodes = np.c_[x.ravel(), y.ravel()]
    nodes = nodes[~((nodes[:, 0] > 1 + 1e-12) & (nodes[:, 1] > 1 + 1e-12))]
    parts = [rectangle_cells(lo, hi, (n, n), order) for lo, hi in SQUARES]
    cells = QuadraturePoints(np.concatenate([q.position for q in parts]), np.concatenate([q.weight for q in parts]),
                             np.concatenate([q.cell + k * n * n for k, q in enumerate(parts)]))
    model = MLSModel(nodes, MLSSettings(d_max=d_max, basis=basis))

    def side(a, b):  # a polyline through every boundary node of the side
        return np.linspace(a, b, int(round(np.linalg.norm(b - a) * n)) + 1)

    essential = [Essential(side(OUTER[k], OUTER[k + 1]), lambda p: exact(p)[:, None], (True,))
                 for k in range(len(OUTER) - 1)]
    t = np.arange(n + 1) / n
    flux = lambda p, normal: np.sum(exact_gradient(p) * normal, axis=1)[:, None]  # noqa: E731
    natural = [Natural(segment_points(np.c_[2 - t[:-1], np.ones(n)], np.c_[2 - t[1:], np.ones(n)], 3), flux),
               Natural(segment_points(np.c_[np.ones(n), 1 + t[:-1]], np.c_[np.ones(n), 1 + t[1:]], 3), flux)]
    return PoissonSolver(model, cells, source=source, essential=essential, natural=natural, consistency=consistency)


def l2_error(solver: PoissonSolver) -> float:
    """Relative L2 error of a solved :func:`l_shape_solver` over the L."""
    error = norm = 0.0
    for lo, hi in SQUARES:
        q = rectangle_cells(lo, hi, (40, 40), 3)
        u = exact(q.position)
        error += float(np.sum(q.weight * (solver.field_at(q.position)[0][:, 0] - u) ** 2))
        norm += float(np.sum(q.weight * u ** 2))
    return float(np.sqrt(error / norm))


@checked_parameters
def build(n: Annotated[int, Param("", "node spacings per unit length of the L (spacing 1/n)", "[2, inf)")] = 16,
          basis: Basis = MLSBasis.LINEAR, d_max: SupportScale = 2.0, gauss: CellGauss = None,
          refinements: Annotated[int, Param("", "also solve at n/2, n/4, ..., this many coarser levels, for the rates",
                                            "[0, inf)")] = 2,
          consistency: Annotated[int | None, Param("", "order of the consistent integration (none: one above the "
                                                       "basis's degree)", "[1, 3]")] = None,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """``n``: node spacings per unit length (the L is 2 x 2); ``refinements``: also solve at n/2, n/4, ... (that
    many coarser levels, each a whole number of at least 2) for the rates; ``consistency``: the order of consistent
    integration (None: one above the basis's degree)."""
    gauss = cell_order(basis, gauss)
    params = dict(locals())
    if n >> refinements < 2 or n % (1 << refinements):
        raise ParameterError("refinements", f"n = {n} halved {refinements} times must stay a whole number of at "
                                            f"least 2 spacings per unit")
    with reported_as(**NAMES):
        solver = l_shape_solver(n, basis, d_max, gauss, consistency)

    def accuracy(run, out_dir):
        result = {"l2_error": l2_error(run.solver), "n": n}
        if refinements:
            coarse = []
            for k in range(refinements, 0, -1):
                level = l_shape_solver(n >> k, basis, d_max, gauss, consistency)
                level.solve()
                coarse.append({"n": n >> k, "l2_error": l2_error(level)})
            errors = [c["l2_error"] for c in coarse] + [result["l2_error"]]
            result["levels"] = coarse
            result["rates"] = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:])).tolist()
            result["checks"] = l_shape_checks(result["rates"])
            if out_dir is not None:
                _plot_convergence(os.path.join(out_dir, "convergence.png"), [c["n"] for c in coarse] + [n], errors,
                                  result["rates"], basis)
        return {"l_shape": result}

    return StaticRun(solver, name="efg_l_shape", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames,  # the manufactured case is unit-free
                                          units=dict.fromkeys(POISSON_UNITS, "1")),
                     reported_as=NAMES)


def _plot_convergence(path, ns, errors, rates, basis: MLSBasis):
    """Relative L2 error against the spacing with the order-3 line through the finest (above); the rate of each
    halving, placed at its finer spacing, with the band 3 ± 0.5 (below)."""
    h = 1.0 / np.asarray(ns, dtype=np.float64)
    e = np.asarray(errors)
    rate = np.r_[np.nan, rates]
    plot_against_reference(path, h, {f"EFG, {basis} basis": e}, e[-1] * (h / h[-1]) ** ORDER, {"observed rate": rate},
                           ORDER_TOLERANCE, band_center=ORDER, xlabel="node spacing h (length units of the L)",
                           ylabel="relative L2 error", error_label="rate log2(e(2h) / e(h))", logx=True, logy=True,
                           title="L-shaped domain: L2 error against the manufactured solution",
                           reference_label=f"order {ORDER:g}", tolerance_label=f"{ORDER:g} ± {ORDER_TOLERANCE:g}")
