"""EFG benchmarks: the Gauss point -> node search, and assembly throughput against the thread count.

What it measures
    * ``search`` (Rocha's (2012) k-d tree study, done with a hash grid): the rows of the nodes whose support holds
      each Gauss point (random nodes, one per sub-cell of an n x n grid of the unit square, d_max = 2, 2 x 2
      Gauss points per cell) for 1e2 .. 1e5 nodes, three ways: the ``wp.HashGrid`` kernel the solver uses,
      the brute-force kernel (every node tested; up to 2e4 nodes) and SciPy's k-d tree (``cKDTree.
      query_ball_point`` at the largest support radius, then each node's own radius tested in NumPy). The rows
      of the three are checked equal. Times are medians of ``--repeats`` runs after one warm-up (kernel loads).
    * ``assembly``: the Timoshenko beam (``scenes/efg_timoshenko.py``, 192 x 48 cells: 9 457 nodes, 36 864 Gauss
      points, d_max 3.5) per thread count in fresh subprocesses, alternating order over ``--rounds``: Gauss
      points per second of the phases "shape functions" and "assembly" (the stiffness by node-row gather), and of
      the triplet assembly built first, beside the compute-bound control kernel of
      ``bench/core/thread_sweep.py`` in the same run.

Usage
    python bench/efg/efg_bench.py              # both, ~3 min on 2 cores
    python bench/efg/efg_bench.py --quick      # smoke run
Writes bench/results/efg_bench[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

ROOT = common.ROOT


def _square_case(n_cells: int):
    from warpfree.galerkin.node_layouts import random_grid_nodes
    from warpfree.galerkin.mls import MLSModel, MLSSettings
    from warpfree.galerkin.quadrature import rectangle_cells

    nodes = random_grid_nodes((0.0, 0.0), (1.0, 1.0), (n_cells, n_cells), seed=0).position
    model = MLSModel(nodes, MLSSettings(d_max=2.0))
    return model, rectangle_cells((0.0, 0.0), (1.0, 1.0), (n_cells, n_cells), 2).position


def _rows(points, rows, counts, total):
    index = rows.index.numpy()[:total]
    return [np.sort(r) for r in np.split(index, np.cumsum(counts)[:-1])]


def _kdtree_pairs(model, points):
    """(point, node) pairs by SciPy's k-d tree: a ball query at the largest support radius, then each node's own
    radius tested (vectorised)."""
    from scipy.spatial import cKDTree

    hits = cKDTree(model.nodes_np).query_ball_point(points, float(model.support_np[:, 0].max()))
    point = np.repeat(np.arange(len(points)), [len(h) for h in hits])
    node = np.fromiter((j for h in hits for j in h), dtype=np.int64, count=point.size)
    keep = np.linalg.norm(model.nodes_np[node] - points[point], axis=1) < model.support_np[node, 0]
    return point[keep], node[keep]


def _kdtree_rows(model, points):
    point, node = _kdtree_pairs(model, points)
    order = np.lexsort((node, point))
    counts = np.bincount(point, minlength=len(points))
    return np.split(node[order], np.cumsum(counts)[:-1])


def _median_time(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def search(args) -> list[dict]:
    from warpfree import device

    device.use("cpu", common.cpu_count())
    sizes = [10, 32, 100, 316] if not args.quick else [10, 32]
    rows_out = []
    for n_cells in sizes:
        model, points = _square_case(n_cells - 1)
        grid_rows = _rows(points, *model.support_rows(points)[2:])
        row = {"nodes": model.node_count, "gauss_points": len(points), "pairs": int(sum(len(r) for r in grid_rows))}
        row["hashgrid_s"] = _median_time(lambda: model.support_rows(points), args.repeats)
        kd = _kdtree_rows(model, points)
        row["kdtree_s"] = _median_time(lambda: _kdtree_pairs(model, points), max(1, args.repeats // 2))
        row["equal_kdtree"] = all(np.array_equal(a, b) for a, b in zip(grid_rows, kd))
        if model.node_count <= 20_000:
            brute = _rows(points, *model.support_rows(points, brute_force=True)[2:])
            row["brute_s"] = _median_time(lambda: model.support_rows(points, brute_force=True),
                                          max(1, args.repeats // 2))
            row["equal_brute"] = all(np.array_equal(a, b) for a, b in zip(grid_rows, brute))
        print(f"  search {row}", flush=True)
        rows_out.append(row)
    return rows_out


def worker_assembly(cfg: dict) -> dict:
    from warpfree import device

    device.use("cpu", cfg["threads"])
    sys.path.insert(0, str(ROOT / "scenes"))
    import efg_timoshenko
    from warpfree.galerkin import assembly

    solver = efg_timoshenko.beam_solver(cfg["cells_x"], cfg["cells_y"])
    model, cells = solver.model, solver.cells
    material = np.broadcast_to(solver.D, (cells.position.shape[0], 3, 3))
    model.shape_at(cells.position)  # warm-up: kernel loads
    out = {"threads": solver.launcher.threads, "gauss_points": int(cells.position.shape[0]),
           "nodes": model.node_count, "shape_s": [], "gather_s": [], "triplets_s": [], "loadavg": common.loadavg()}
    for _ in range(cfg["repeats"]):
        t0 = time.perf_counter()
        shape = model.shape_at(cells.position)
        out["shape_s"].append(time.perf_counter() - t0)
        assembly.node_rows(model, shape)
        t0 = time.perf_counter()
        assembly.elastic_matrix(model, shape, cells.weight, material)
        out["gather_s"].append(time.perf_counter() - t0)
    if cfg["triplets"]:
        t0 = time.perf_counter()
        assembly.elastic_matrix(model, shape, cells.weight, material, gather=False)
        out["triplets_s"].append(time.perf_counter() - t0)
    out["entries_per_point"] = float(np.mean(shape.counts))
    return out


def assembly_sweep(args) -> dict:
    import thread_sweep

    threads = list(range(1, common.cpu_count() + 1))
    cells = (48, 12) if args.quick else (192, 48)
    samples = {t: [] for t in threads}
    control = {t: [] for t in threads}
    for r in range(args.rounds):
        for t in (threads if r % 2 == 0 else threads[::-1]):
            cfg = dict(threads=t, cells_x=cells[0], cells_y=cells[1], repeats=args.repeats, triplets=r == 0)
            res = common.run_worker(__file__, ["--worker", json.dumps(cfg)])
            samples[t].append(res)
            ctl = common.run_worker(str(common.BENCH / "core" / "thread_sweep.py"),
                                    ["--worker", json.dumps(dict(scene="control", params={}, threads=t, steps=3,
                                                                 warmup=1, repeats=3, n=16384,
                                                                 iters=500 if args.quick else 2000))])
            control[t].extend(ctl["block_s"])
            print(f"  assembly threads={t} round={r}: shape {np.median(res['shape_s']):.3f} s, gather "
                  f"{np.median(res['gather_s']):.3f} s, triplets {res['triplets_s']}", flush=True)
    del thread_sweep
    rows = []
    for t in threads:
        shape_s = common.median([x for s in samples[t] for x in s["shape_s"]])
        gather_s = common.median([x for s in samples[t] for x in s["gather_s"]])
        trip = [x for s in samples[t] for x in s["triplets_s"]]
        g = samples[t][0]["gauss_points"]
        rows.append(dict(threads=t, shape_s=shape_s, gather_s=gather_s,
                         triplets_s=common.median(trip) if trip else None,
                         gauss_points_per_s=g / (shape_s + gather_s), control_block_s=common.median(control[t])))
    for row in rows:
        row["speedup"] = rows[0]["gauss_points_per_s"] and row["gauss_points_per_s"] / rows[0]["gauss_points_per_s"]
        row["control_speedup"] = rows[0]["control_block_s"] / row["control_block_s"]
    first = samples[threads[0]][0]
    return dict(cells=cells, nodes=first["nodes"], gauss_points=first["gauss_points"],
                entries_per_point=first["entries_per_point"], rows=rows)


def markdown(result: dict) -> str:
    machine = result["machine"]
    out = ["# EFG benchmarks", "", f"Machine: {machine.get('cpu')}, {machine.get('cores')} cores.", "",
           "## Gauss point -> node search (random nodes, d_max 2, 2 x 2 Gauss points per cell)", ""]
    rows = [[r["nodes"], r["gauss_points"], r["pairs"], common.fmt(r["hashgrid_s"]), common.fmt(r.get("brute_s")),
             common.fmt(r["kdtree_s"]), r["equal_kdtree"] and r.get("equal_brute", True)] for r in result["search"]]
    out.append(common.md_table(["nodes", "Gauss points", "pairs", "HashGrid s", "brute force s", "k-d tree s",
                                "rows equal"], rows))
    a = result["assembly"]
    out += ["", f"## Assembly, Timoshenko beam {a['cells'][0]} x {a['cells'][1]} cells: {a['nodes']} nodes, "
                f"{a['gauss_points']} Gauss points, {a['entries_per_point']:.1f} nodes per point", ""]
    rows = [[r["threads"], common.fmt(r["shape_s"]), common.fmt(r["gather_s"]), common.fmt(r["triplets_s"]),
             common.fmt_rate(r["gauss_points_per_s"]), common.fmt(r["speedup"]), common.fmt(r["control_speedup"])]
            for r in a["rows"]]
    out.append(common.md_table(["threads", "shape functions s", "stiffness (gather) s", "stiffness (triplets) s",
                                "Gauss points/s", "speed-up", "control speed-up"], rows))
    return "\n".join(out) + "\n"


def plot(result: dict):
    fig, ax = common.new_figure(figsize=(5, 4))
    s = result["search"]
    n = [r["nodes"] for r in s]
    ax.loglog(n, [r["hashgrid_s"] for r in s], "o-", label="HashGrid (Warp)")
    ax.loglog(n, [r["kdtree_s"] for r in s], "s-", label="k-d tree (SciPy)")
    b = [(r["nodes"], r["brute_s"]) for r in s if "brute_s" in r]
    ax.loglog(*zip(*b), "^-", label="brute force (Warp)")
    ax.set_xlabel("nodes")
    ax.set_ylabel("search time (s)")
    ax.set_title("EFG Gauss point -> node search")
    ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--worker")
    args = p.parse_args(argv)
    if args.worker:
        common.emit_worker_result(worker_assembly(json.loads(args.worker)))
        return 0
    if args.quick:
        args.repeats, args.rounds = 2, 1
    result = {"machine": common.machine_info(), "search": search(args), "assembly": assembly_sweep(args)}
    common.write_results("efg_bench", result, markdown(result), plot(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
