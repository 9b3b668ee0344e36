"""Does the order of the particles in memory matter, and how much order does a run lose?

What it measures
    1. Step cost of the 2D dam break (dx = 0.006: 55 278 fluid + 8 030 wall particles) with the same fluid
       particles stored in three orders: the lattice order the scenes generate (row after row), a random
       permutation (what a flow that has mixed completely would look like), and sorted by hash-grid cell
       (what a periodic re-sort of the data would restore). Each in a fresh process, median of blocks
       (``bench/common.py: time_solver``, a neighbour-table rebuild forced every 8 steps).
    2. How much order a real run loses: in the default dam break (``scenes/dam_break_2d.py``), for every
       fluid–fluid neighbour pair (i, j) the index distance |i - j|, at t = 0 and after ``--t-late`` s (the
       surge has hit the far wall at t ≈ 0.9 s): the median, and the fraction of pairs farther apart than four
       lattice rows (4 sqrt(N) indices), where the neighbour's data no longer shares cache with the particle's.

    3. (``--late``) The step cost of a late state (the dam break at dx = 0.01 m run to t = 1.2 s) in the order the
       run holds it and sorted again row after row, each restarted at rest from the same positions.

Usage
    python bench/core/particle_order.py            # ~3 min on 2 cores
    python bench/core/particle_order.py --quick
    python bench/core/particle_order.py --late     # part 3, ~3 min: particle_order_late.{json,md}
Writes bench/results/particle_order[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

ORDERS = ("lattice", "random", "cell")


def ordered_fluid(fluid: np.ndarray, order: str, cell: float) -> np.ndarray:
    if order == "lattice":
        return fluid
    perm = np.random.default_rng(0).permutation(len(fluid))
    if order == "random":
        return fluid[perm]
    shuffled = fluid[perm]
    key = np.floor(shuffled[:, 0] / cell).astype(np.int64) * 1_000_000 + np.floor(shuffled[:, 1] / cell).astype(np.int64)
    return shuffled[np.argsort(key, kind="stable")]


def worker(cfg: dict) -> dict:
    """Step cost of the dam break with the fluid stored in ``cfg['order']`` (on ``cfg['device']``, the CPU by
    default)."""
    import warpfree.device
    from warpfree.geometry import lattice_box
    from warpfree.solvers.wcsph import FluidParams, WCSPHModel, WCSPHSolver
    from warpfree.solvers.wcsph.scene_tools import box_walls_2d, hydrostatic_density

    device = cfg.get("device", "cpu")
    warpfree.device.use(device, cfg["threads"] if device == "cpu" else None)
    dx, g, height = cfg["dx"], 9.81, 2.0
    c0 = 10.0 * np.sqrt(2.0 * g * height)
    params = FluidParams(dim=2, dx=dx, c0=c0, alpha=0.1, delta=0.1, gravity=(0.0, -g, 0.0), cfl=0.2,
                         lj_d=2.0 * g * height, lj_r0=0.75 * dx, container_lo=(0.0, 0.0, -1.0),
                         container_hi=(4.0, 4.0, 1.0))
    if "positions" in cfg:  # a late state's positions, in the run's order or sorted again
        fluid = np.load(cfg["positions"])
        if cfg["order"] == "late, sorted again":
            key = np.round(fluid[:, 1] / dx).astype(np.int64) * 1_000_000 + np.round(fluid[:, 0] / dx).astype(np.int64)
            fluid = fluid[np.argsort(key, kind="stable")]
    else:
        fluid = ordered_fluid(lattice_box((0.0, 0.0), (1.0, height), dx), cfg["order"],
                              params.support * (1 + params.skin))
    solver = WCSPHSolver(WCSPHModel(fluid, box_walls_2d(4.0, 4.0, dx, 3), params),
                         density=hydrostatic_density(fluid[:, 1], height, 1000.0, c0, g))
    res = common.time_solver(solver, solver.stable_dt(), cfg["steps"], 8, cfg["repeats"])
    res.update(order=cfg["order"], threads=solver.launcher.threads)
    return res


def index_spread(solver) -> dict:
    table = solver.fluid_fluid
    counts, index, start = table.counts(), table.rows.index.numpy(), table.rows.start.numpy()
    n = len(counts)
    d = np.concatenate([np.abs(index[start[i]: start[i] + counts[i]] - i) for i in range(n)])
    return {"median_index_distance": float(np.median(d)), "fraction_beyond_4_rows": float(np.mean(d > 4 * np.sqrt(n))),
            "n_fluid": n}


def disorder(t_late: float, threads: int) -> dict:
    run = common.build_scene("dam_break_2d", threads, t_end=t_late)
    start = index_spread(run.solver)
    run.run(None, progress=False)
    return {"t0": start, "t_late": t_late, "late": index_spread(run.solver)}


def late_cost(dx: float, t_late: float, threads: int, steps: int, repeats: int, rounds: int) -> dict:
    """3. The step cost of a late state as a run holds it (the fluid in its ids' order, the lattice's of t = 0) and
    sorted again row after row (what a re-sort at a rebuild would give): the dam break at ``dx`` run to ``t_late``,
    its fluid positions restarted at rest in each order (the neighbour structure of the late state, the same in both)."""
    import tempfile

    run = common.build_scene("dam_break_2d", 2, dx=dx, t_end=t_late)
    run.run(None, progress=False)
    positions = run.solver.fluid_positions().astype(np.float32)
    spread = index_spread(run.solver)
    rows = {"late, as held": [], "late, sorted again": []}
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "late.npy")
        np.save(path, positions)
        for r in range(rounds):
            for order in (list(rows) if r % 2 == 0 else list(rows)[::-1]):
                res = common.run_worker(__file__, ["--worker", json.dumps(dict(
                    order=order, dx=dx, threads=threads, steps=steps, repeats=repeats, positions=path))])
                rows[order].append(res)
                print(f"  {order}: {res['median_s'] / res['steps'] * 1e3:.2f} ms/step", flush=True)
    ms = {o: common.median([b for res in v for b in res["block_s"]]) / v[0]["steps"] * 1e3 for o, v in rows.items()}
    return {"dx": dx, "t_late": t_late, "n_fluid": len(positions), "spread": spread, "ms_per_step": ms,
            "sorted_over_held": ms["late, sorted again"] / ms["late, as held"], "runs": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--t-late", type=float, default=None, help="default 1.2 s (quick 0.3)")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--late", action="store_true", help="part 3 alone: a late state's cost, held and sorted again "
                                                        "(dx = 0.01 to t = 1.2 s; writes particle_order_late)")
    args = ap.parse_args(argv)
    if args.worker:
        common.emit_worker_result(worker(json.loads(args.worker)))
        return 0
    if args.late:
        late = late_cost(0.01, args.t_late or 1.2, args.threads, 16, 3, 2)
        md = [f"## A late state's step cost (2D dam break, dx = {late['dx']}, t = {late['t_late']} s: "
              f"{late['n_fluid']} fluid particles, {args.threads} thread(s), CPU)\n",
              common.md_table(["fluid order", "ms/step"], [[o, f"{v:.2f}"] for o, v in late["ms_per_step"].items()]),
              "", f"Sorted again over as held: {late['sorted_over_held']:.3f}; neighbour pairs (i, j) with |i - j| beyond "
              f"four lattice rows as held: {100 * late['spread']['fraction_beyond_4_rows']:.1f}% (median |i - j| "
              f"{late['spread']['median_index_distance']:.0f})."]
        common.write_results("particle_order_late", {"machine": common.machine_info(), **late}, "\n".join(md))
        return 0
    q = args.quick
    dx = 0.02 if q else 0.006
    steps, repeats, rounds = (8, 1, 1) if q else (16, 3, 2)
    rows = {o: [] for o in ORDERS}
    for r in range(rounds):
        for order in (ORDERS if r % 2 == 0 else ORDERS[::-1]):
            res = common.run_worker(__file__, ["--worker", json.dumps(dict(order=order, dx=dx, threads=args.threads,
                                                                           steps=steps, repeats=repeats))])
            rows[order].append(res)
            print(f"  {order}: {res['median_s'] / res['steps'] * 1e3:.1f} ms/step", flush=True)
    summary = []
    for order in ORDERS:
        blocks = [b for res in rows[order] for b in res["block_s"]]
        ms = common.median(blocks) / rows[order][0]["steps"] * 1e3
        rates = {k: common.median([res["phase_s_per_step"].get(k, 0.0) for res in rows[order]]) * 1e3
                 for k in rows[order][0]["phase_s_per_step"]}
        summary.append(dict(order=order, ms_per_step=ms, phase_ms_per_step=rates))
    base = summary[0]["ms_per_step"]
    for row in summary:
        row["relative_to_lattice"] = row["ms_per_step"] / base
    dis = disorder(args.t_late or (0.3 if q else 1.2), 2)
    n = rows["lattice"][0]["work_items"]
    md = [f"## Particle order in memory (2D dam break, dx = {dx}: {n} particles, {args.threads} thread(s), CPU)\n",
          common.md_table(["fluid order", "ms/step", "relative to lattice order", "rates ms/step"],
                          [[r["order"], f"{r['ms_per_step']:.1f}", f"{r['relative_to_lattice']:.2f}",
                            f"{r['phase_ms_per_step'].get('rates', 0):.1f}"] for r in summary]),
          "",
          f"Order lost by a run (default dam break, {dis['t0']['n_fluid']} fluid particles): neighbour pairs (i, j) with "
          f"|i - j| beyond four lattice rows: {100 * dis['t0']['fraction_beyond_4_rows']:.1f}% at t = 0, "
          f"{100 * dis['late']['fraction_beyond_4_rows']:.1f}% at t = {dis['t_late']} s (median |i - j| "
          f"{dis['t0']['median_index_distance']:.0f} and {dis['late']['median_index_distance']:.0f}; a random order has "
          f"about N/3 = {dis['t0']['n_fluid'] // 3})."]
    common.write_results("particle_order", {"machine": common.machine_info(), "dx": dx, "rows": summary,
                                            "runs": rows, "disorder": dis}, "\n".join(md), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
