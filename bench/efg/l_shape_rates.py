"""EFG convergence on a non-convex domain: the L2 rate of a Poisson problem on an L with flux conditions on the
re-entrant sides, per basis and Gauss rule of the background cells.

What it measures
    -Δu = s on the L [0, 2]² minus (1, 2]², u = sin(1.3x + 0.4) e^{0.7y} (smooth: the rate is the method's, not
    the corner's), u prescribed on the outer sides (Lagrange multipliers), the flux ∂u/∂n on the two re-entrant
    sides (3 Gauss points per node spacing), consistent integration. Regular nodes at spacing h = 1/n (n = 4, 8,
    16, 32), one background cell per node spacing with ``order`` x ``order`` Gauss points, the cubic-spline weight.
    Error: the relative L2 error over the L (3 x 3 Gauss points on a 40 x 40 grid per unit square); the rate
    between successive levels. Cases: the linear basis at d_max 2.0 and 3.5, the quadratic at 2.5, each at 2 x 2
    and 3 x 3 points (``--orders`` to change).

Usage
    python bench/efg/l_shape_rates.py             # ~1 min on 2 cores
    python bench/efg/l_shape_rates.py --quick     # n = 4, 8, 16
Writes bench/results/l_shape_rates[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

#: (basis, d_max) of the cases
CASES = (("linear", 2.0), ("linear", 3.5), ("quadratic", 2.5))
SQUARES = (((0.0, 0.0), (1.0, 1.0)), ((1.0, 0.0), (2.0, 1.0)), ((0.0, 1.0), (1.0, 2.0)))
#: the outer boundary, counter-clockwise from the re-entrant corner's upper side
OUTER = np.array([[1.0, 2.0], [0.0, 2.0], [0.0, 0.0], [2.0, 0.0], [2.0, 1.0]])


def exact(p):
    return np.sin(1.3 * p[:, 0] + 0.4) * np.exp(0.7 * p[:, 1])


def exact_gradient(p):
    return np.stack([1.3 * np.cos(1.3 * p[:, 0] + 0.4) * np.exp(0.7 * p[:, 1]), 0.7 * exact(p)], axis=1)


def l_shape_error(n: int, order: int, basis: str, d_max: float) -> float:
    """Relative L2 error of the EFG solution at node spacing 1/n."""
    from warpfree.galerkin.mls import MLSModel, MLSSettings
    from warpfree.galerkin.quadrature import QuadraturePoints, rectangle_cells, segment_points
    from warpfree.solvers.efg.boundary import Essential, Natural
    from warpfree.solvers.efg.solver import PoissonSolver

    g = np.arange(2 * n + 1) / n
    x, y = np.meshgrid(g, g, indexing="ij")
    nodes = np.c_[x.ravel(), y.ravel()]
    nodes = nodes[~((nodes[:, 0] > 1 + 1e-12) & (nodes[:, 1] > 1 + 1e-12))]
    parts = [rectangle_cells(lo, hi, (n, n), order) for lo, hi in SQUARES]
    cells = QuadraturePoints(*(np.concatenate([q.position for q in parts]), np.concatenate([q.weight for q in parts]),
                               np.concatenate([q.cell + k * n * n for k, q in enumerate(parts)])))
    model = MLSModel(nodes, MLSSettings(d_max=d_max, basis=basis))

    def side(a, b):  # a polyline through every boundary node of the side
        return np.linspace(a, b, int(round(np.linalg.norm(b - a) * n)) + 1)

    essential = [Essential(side(OUTER[k], OUTER[k + 1]), lambda p: exact(p)[:, None], (True,))
                 for k in range(len(OUTER) - 1)]
    t = np.arange(n + 1) / n
    flux = lambda p, normal: np.sum(exact_gradient(p) * normal, axis=1)[:, None]  # noqa: E731
    natural = [Natural(segment_points(np.c_[2 - t[:-1], np.ones(n)], np.c_[2 - t[1:], np.ones(n)], 3), flux),
               Natural(segment_points(np.c_[np.ones(n), 1 + t[:-1]], np.c_[np.ones(n), 1 + t[1:]], 3), flux)]
    solver = PoissonSolver(model, cells, source=lambda p: (1.3 ** 2 - 0.7 ** 2) * exact(p), essential=essential,
                           natural=natural)
    solver.solve()
    error = norm = 0.0
    for lo, hi in SQUARES:
        q = rectangle_cells(lo, hi, (40, 40), 3)
        u = exact(q.position)
        error += float(np.sum(q.weight * (solver.field_at(q.position)[0][:, 0] - u) ** 2))
        norm += float(np.sum(q.weight * u ** 2))
    return float(np.sqrt(error / norm))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="n = 4, 8, 16")
    ap.add_argument("--orders", type=int, nargs="+", default=[2, 3], help="Gauss points per cell and axis")
    args = ap.parse_args()
    import warpfree.device

    warpfree.device.use("cpu", 2)
    levels = [4, 8, 16] if args.quick else [4, 8, 16, 32]
    rows = []
    for basis, d_max in CASES:
        for order in args.orders:
            errors = [l_shape_error(n, order, basis, d_max) for n in levels]
            rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:])).tolist()
            rows.append(dict(basis=basis, d_max=d_max, order=order, errors=errors, rates=rates))
            print(f"  {basis} d_max {d_max} {order}x{order}: errors {['%.2e' % e for e in errors]}, "
                  f"rates {np.round(rates, 2).tolist()}", flush=True)
    md = ["## EFG on an L with flux on the re-entrant sides: relative L2 error and rate per refinement", "",
          f"Node spacing 1/n, n = {', '.join(map(str, levels))}; one background cell per node spacing; consistent "
          "integration; the exact solution is smooth.", "",
          "| basis | d_max | Gauss points | errors | rates |", "| --- | --: | --: | --- | --- |"]
    for r in rows:
        md.append(f"| {r['basis']} | {r['d_max']:g} | {r['order']}x{r['order']} | "
                  f"{', '.join('%.2e' % e for e in r['errors'])} | {', '.join('%.2f' % a for a in r['rates'])} |")
    common.write_results("l_shape_rates", {"levels": levels, "rows": rows}, "\n".join(md), quick=args.quick)


if __name__ == "__main__":
    main()
