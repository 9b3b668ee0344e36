"""The fluid pairs from a table's rows against the neighbour grid's: step time against memory.

What it measures
    The 2D and 3D dam breaks built twice in one process, their fluid pairs in a neighbour table (``fluid_pairs="rows"``,
    the default: the candidates within support + skin kept between rebuilds) and read from the neighbour grid at every
    sweep (``"grid"``, no table: ``kernels/wcsph.py``, ``warpfree.neighbours.GridPairs``). Both give bitwise the same
    state (``tests/wcsph/test_fluid_pairs.py``). Timed blocks of steps at the stable step, with a table rebuild every
    ``common.DEVELOPED_REBUILD_EVERY`` steps as in a developed flow, alternately rows then grid, ``--pairs`` times: the
    median seconds a step of each and the median of the pairs' grid/rows ratios; and each one's device memory per
    particle (``warpfree.memory``).

Usage
    python bench/wcsph/fluid_pairs.py            # about 3 minutes on 2 cores
    python bench/wcsph/fluid_pairs.py --quick    # the smaller sizes only
Writes bench/results/fluid_pairs[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent)]
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

#: (scene, spacing dx in m, quick?): the 2D dam break (fluid + wall particles), the 3D one in SPHERIC test 2's tank
CASES = [("dam_break_2d", 0.01, True), ("dam_break_3d", 0.05, True), ("dam_break_3d", 0.035, False)]
STEPS = 20


def one(scene: str, dx: float, pairs: int) -> dict:
    from warpfree.memory import solver_memory

    solvers = {mode: common.build_scene(scene, common.cpu_count(), dx=dx, fluid_pairs=mode).solver
               for mode in ("rows", "grid")}
    dt = min(s.stable_dt() for s in solvers.values())
    times = {mode: [] for mode in solvers}
    for _ in range(pairs):
        for mode, solver in solvers.items():
            times[mode].append(common.time_solver(solver, dt, STEPS, warmup=4, repeats=1)["s_per_step"])
    out = {"scene": scene, "dx": dx, "particles": int(solvers["rows"].work_items),
           "ratio_grid_over_rows": statistics.median(g / r for g, r in zip(times["grid"], times["rows"]))}
    for mode, solver in solvers.items():
        memory = solver_memory(solver)
        out[mode] = {"s_per_step": statistics.median(times[mode]), "s_per_step_all": times[mode],
                     "bytes_per_particle": memory["per_item"],
                     "neighbours_bytes_per_particle": memory["parts"]["neighbours"] / solver.work_items}
    return out


def markdown(result: dict) -> str:
    rows = [[r["scene"], f"{r['dx']}", f"{r['particles']:,}", f"{1e3 * r['rows']['s_per_step']:.2f}",
             f"{1e3 * r['grid']['s_per_step']:.2f}", f"{r['ratio_grid_over_rows']:.2f}",
             f"{r['rows']['bytes_per_particle']:.0f}", f"{r['grid']['bytes_per_particle']:.0f}"] for r in result["cases"]]
    return ("# Fluid pairs from a table's rows or the neighbour grid: step time and memory\n\n"
            f"{result['threads']} threads; {STEPS} steps a block, {result['pairs']} pairs of blocks (rows, grid).\n\n"
            + common.md_table(["scene", "dx (m)", "particles", "rows: ms a step", "grid: ms a step",
                               "grid / rows (median of pairs)", "rows: bytes a particle", "grid: bytes a particle"],
                              rows) + "\n")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="the smaller sizes only")
    p.add_argument("--pairs", type=int, default=3, help="pairs of timed blocks (rows, grid)")
    args = p.parse_args(argv)
    cases = []
    for scene, dx, quick in CASES:
        if args.quick and not quick:
            continue
        cases.append(one(scene, dx, args.pairs))
        print(cases[-1], flush=True)
    result = {"cases": cases, "pairs": args.pairs, "threads": common.cpu_count(), "machine": common.machine_info()}
    common.write_results("fluid_pairs", result, markdown(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
