"""EFG against the natural element method on random nodes (Rocha 2012, §5): error against node count, beam and cylinder.

What it measures
    For the Timoshenko beam (``scenes/efg_timoshenko.py``) and the thick cylinder (``scenes/efg_cylinder.py``) on
    random layouts (one random node per sub-cell, boundary nodes on the boundary; seeds 1..``--seeds``) and, for
    reference, the regular layout: the relative energy-norm error and the monitored displacement's error (beam:
    u_y(L, 0); cylinder: u_r at r = a, mean over the arc's nodes) of
    * EFG: linear basis, cubic spline, d_max 3.5 (beam) / 2.5 (cylinder), 2 x 2 Gauss points per background cell,
      Lagrange multipliers, consistent integration;
    * NEM: Laplace shape functions on the same nodes, Delaunay triangles with 3 Gauss points (the thesis's rule),
      direct substitution; plain quadrature (``nem_random``, the thesis's), consistent integration
      (``nem_random_consistent``) and stabilized conforming nodal integration on the Voronoi cells (``*_scni``, the
      scenes' default; its energy-norm error is that of the smoothed strains at the nodes, cell areas as weights);
      on the cylinder the domain is the polygon through the boundary nodes (straight
      chords on the arcs, as straight-sided finite elements).
    Wall times of the whole solve are recorded beside (one run each; bench/efg/efg_vs_fem.py times carefully).

Usage
    python bench/efg/efg_vs_nem.py            # ~1 min on 2 cores
    python bench/efg/efg_vs_nem.py --quick
Writes bench/results/efg_vs_nem[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
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
sys.path.insert(0, str(ROOT / "scenes"))


def solve(case: str, n: int, model: str, layout: str, seed: int, integration: str | None = None) -> dict:
    import efg_cylinder
    import efg_timoshenko

    t0 = time.perf_counter()
    if case == "beam":
        s = efg_timoshenko.beam_solver(4 * n, n, layout=layout, seed=seed, model=model, integration=integration)
        s.solve()
        e = efg_timoshenko.beam_errors(s)
        monitored = e["tip_rel_error"]
    else:
        s = efg_cylinder.cylinder_solver(n, n, layout=layout, seed=seed, model=model, integration=integration)
        s.solve()
        e = efg_cylinder.cylinder_errors(s)
        monitored = e["u_r_inner_rel_error"]
    return {"n": n, "nodes": e["nodes"], "seed": seed, "energy_norm_error": e["energy_norm_error"],
            "displacement_rel_error": monitored, "wall_s": time.perf_counter() - t0}


def run_case(case: str, args) -> dict:
    levels = ([3, 6, 12, 24] if case == "beam" else [4, 8, 16, 32])[: 2 if args.quick else None]
    out = {}
    series = {"efg_random": ("efg", "random", None), "efg_regular": ("efg", "regular", None),
              "nem_random": ("nem", "random", "gauss"), "nem_random_consistent": ("nem", "random", "consistent"),
              "nem_random_scni": ("nem", "random", "scni"), "nem_regular": ("nem", "regular", "gauss"),
              "nem_regular_scni": ("nem", "regular", "scni")}
    for key, (model, layout, integration) in series.items():
        seeds = range(1, args.seeds + 1) if layout == "random" else [0]
        rows = [solve(case, n, model, layout, seed, integration) for n in levels for seed in seeds]
        out[key] = rows
        for n in levels:
            sel = [r for r in rows if r["n"] == n]
            print(f"  {case} {key} nodes={sel[0]['nodes']}: energy "
                  f"{np.mean([r['energy_norm_error'] for r in sel]):.2e}, displacement "
                  f"{np.mean([abs(r['displacement_rel_error']) for r in sel]):.2e}", flush=True)
    return out


def _summary(rows: list[dict]) -> list[dict]:
    out = []
    for n in sorted({r["n"] for r in rows}):
        sel = [r for r in rows if r["n"] == n]
        out.append({"nodes": sel[0]["nodes"], "energy_mean": float(np.mean([r["energy_norm_error"] for r in sel])),
                    "energy_max": float(np.max([r["energy_norm_error"] for r in sel])),
                    "displacement_mean_abs": float(np.mean([abs(r["displacement_rel_error"]) for r in sel])),
                    "wall_s": float(np.median([r["wall_s"] for r in sel]))})
    return out


def markdown(result: dict) -> str:
    lines = ["# EFG against NEM on random nodes", "", f"Machine: {result['machine'].get('cpu')}; seeds per random "
             f"level: {result['seeds']}.", ""]
    for case in ("beam", "cylinder"):
        lines += [f"## {case}", ""]
        rows = []
        for key, runs in result[case].items():
            for r in _summary(runs):
                rows.append([key, r["nodes"], f"{r['energy_mean']:.3e}", f"{r['energy_max']:.3e}",
                             f"{r['displacement_mean_abs']:.2e}", common.fmt(r["wall_s"])])
        lines.append(common.md_table(["method, layout", "nodes", "energy-norm error (mean)", "(largest)",
                                      "|displacement error| (mean)", "wall s"], rows))
        lines.append("")
    return "\n".join(lines) + "\n"


def plot(result: dict):
    fig, axes = common.new_figure(1, 2, figsize=(10, 4))
    styles = {"efg_random": "o-", "nem_random": "s-", "nem_random_consistent": "^-", "nem_random_scni": "d-",
              "efg_regular": "o:", "nem_regular": "s:", "nem_regular_scni": "d:"}
    for ax, case in zip(axes, ("beam", "cylinder")):
        for key, runs in result[case].items():
            s = _summary(runs)
            ax.loglog([r["nodes"] for r in s], [r["energy_mean"] for r in s], styles[key], label=key.replace("_", " "))
        ax.set_xlabel("nodes")
        ax.set_ylabel("relative energy-norm error")
        ax.set_title(f"{case}: EFG and NEM")
        ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--seeds", type=int, default=3)
    args = p.parse_args(argv)
    from warpfree import device

    device.use("cpu", None)
    if args.quick:
        args.seeds = 1
    result = {"machine": common.machine_info(), "seeds": args.seeds}
    for case in ("beam", "cylinder"):
        result[case] = run_case(case, args)
    common.write_results("efg_vs_nem", result, markdown(result), plot(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
