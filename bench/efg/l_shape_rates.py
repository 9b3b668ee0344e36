"""EFG convergence on a non-convex domain: the L2 rate of a Poisson problem on an L with flux conditions on the
re-entrant sides, per basis and Gauss rule of the background cells.

What it measures
    The case ``warpfree.validation.efg_l_shape`` as ``scenes/efg_l_shape.py`` builds it: -Δu = s on the L
    [0, 2]² minus (1, 2]², smooth u, u prescribed on the outer sides (Lagrange multipliers), the flux ∂u/∂n on the
    two re-entrant sides, consistent integration of the solver's default order (one above the basis's degree: 2
    linear, 3 quadratic) and, for comparison, of the basis's own order (1 linear, 2 quadratic). Regular nodes at
    spacing h = 1/n (n = 4, 8, 16, 32), one background cell per node spacing with ``order`` x ``order`` Gauss
    points, the cubic-spline weight. Error: the relative L2 error over the L (3 x 3 Gauss points on a 40 x 40 grid
    per unit square); the rate between successive levels. Cases: the linear basis at d_max 2.0, 2.5 and 3.5, the
    quadratic at 2.5, each at 2 x 2 and 3 x 3 points (``--orders`` to change).

Usage
    python bench/efg/l_shape_rates.py             # ~2 min on 2 cores
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

#: (basis, d_max, consistency order: None the solver's default) of the cases
CASES = (("linear", 2.0, None), ("linear", 2.5, None), ("linear", 2.5, 1), ("linear", 3.5, None),
         ("linear", 3.5, 1), ("quadratic", 2.5, None), ("quadratic", 2.5, 2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="n = 4, 8, 16")
    ap.add_argument("--orders", type=int, nargs="+", default=[2, 3], help="Gauss points per cell and axis")
    args = ap.parse_args()
    import warpfree.device
    sys.path.insert(0, str(common.ROOT / "scenes"))
    import efg_l_shape

    warpfree.device.use("cpu", 2)
    levels = [4, 8, 16] if args.quick else [4, 8, 16, 32]
    rows = []
    for basis, d_max, consistency in CASES:
        for order in args.orders:
            errors = []
            for n in levels:
                solver = efg_l_shape.l_shape_solver(n, basis, d_max, order, consistency)
                solver.solve()
                errors.append(efg_l_shape.l2_error(solver))
            rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:])).tolist()
            rows.append(dict(basis=basis, d_max=d_max, order=order, consistency=solver.consistency_order,
                             default=consistency is None, errors=errors, rates=rates))
            print(f"  {basis} d_max {d_max} {order}x{order} consistency {solver.consistency_order}: errors "
                  f"{['%.2e' % e for e in errors]}, rates {np.round(rates, 2).tolist()}", flush=True)
    md = ["## EFG on an L with flux on the re-entrant sides: relative L2 error and rate per refinement", "",
          f"Node spacing 1/n, n = {', '.join(map(str, levels))}; one background cell per node spacing; consistent "
          "integration of the order given (the default: one above the basis's degree); the exact solution is "
          "smooth.", "",
          "| basis | d_max | Gauss points | consistency order | errors | rates |",
          "| --- | --: | --: | --: | --- | --- |"]
    for r in rows:
        label = f"{r['consistency']}" + (" (default)" if r["default"] else "")
        md.append(f"| {r['basis']} | {r['d_max']:g} | {r['order']}x{r['order']} | {label} | "
                  f"{', '.join('%.2e' % e for e in r['errors'])} | {', '.join('%.2f' % a for a in r['rates'])} |")
    common.write_results("l_shape_rates", {"levels": levels, "rows": rows}, "\n".join(md), quick=args.quick)


if __name__ == "__main__":
    main()
