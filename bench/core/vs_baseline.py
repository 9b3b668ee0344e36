"""This tree against an earlier commit of warpfree, side by side in one run: step cost per thread count.

What it measures
    Seconds per step and particle-steps/s (fluid + boundary) of the dam breaks in this tree ("new") and in a
    worktree of another commit ("baseline", e.g. the commit before the core reshaping), at 1 and 2 threads:

    * ``2d``: ``scenes/dam_break_2d.py`` at dx = 0.006 (63 308 particles) with the scene's physics: laminar and
      artificial viscosity, δ-SPH, dynamic walls with the Lennard-Jones safety net;
    * ``2d_plain``: the same with every optional term off (alpha = 0, delta = 0, mu = 0, wall_safety = 0):
      the baseline skips them with run-time branches, this tree compiles them out;
    * ``3d``: ``scenes/dam_break_3d.py`` at dx = 0.035 (56 939 particles), the scene's physics.

    Same-physics rows show what the new core costs (struct parameters, kernel factories, the step report and
    its device reduction in place of three host reads); the plain rows show what compiling the unused terms
    out saves over the baseline's run-time switches.

How
    Each measurement is a fresh process of the tree's own Python (``--baseline-python``, default
    ``<baseline>/.venv/bin/python``) running this file's worker, which builds the scene from that tree's
    ``scenes/`` and times ``--repeats`` blocks of ``--steps`` steps after ``--warmup`` steps, every step
    followed by the solver's problem check (its read-back), with one ``dt`` (the stable step at t = 0) for
    both trees and a neighbour-table rebuild forced every 7 steps in both (the baseline harness's developed-flow
    interval), so both trees do the same work. Rounds alternate the order (new, baseline / baseline, new) and
    the thread counts; the figure is the median over all blocks of a row.

    ``--end-to-end``: instead, the default command ``warpfree run scenes/dam_break_2d.py`` (frames and VTU
    files included) in each tree, whole process wall time, alternating, ``--rounds`` times (default 3), with
    each run's own split of its time (steps, outputs on the stepping thread) from its ``summary.json``.

Usage
    git worktree add /tmp/baseline <commit> && python3 -m venv /tmp/baseline/.venv \\
        && /tmp/baseline/.venv/bin/pip install -e /tmp/baseline
    python bench/core/vs_baseline.py --baseline /tmp/baseline            # ~8 min on 2 cores
    python bench/core/vs_baseline.py --baseline /tmp/baseline --quick    # small sizes
    python bench/core/vs_baseline.py --baseline /tmp/baseline --end-to-end   # ~5 min
Writes bench/results/vs_baseline[_quick].{json,md,png} (end to end: vs_baseline_end_to_end.{json,md}).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "needs --baseline DIR, a worktree of another commit with its own venv (see Usage)"

PLAIN = {"alpha": 0.0, "delta": 0.0, "mu": 0.0, "wall_safety": 0.0}
CASES = {
    # name: (scene, full params, quick params)
    "2d": ("dam_break_2d", {"dx": 0.006}, {"dx": 0.02}),
    "2d_plain": ("dam_break_2d", {"dx": 0.006, **PLAIN}, {"dx": 0.02, **PLAIN}),
    "3d": ("dam_break_3d", {"dx": 0.035}, {"dx": 0.07}),
}
REBUILD_EVERY = 7
TAG = "@@BASELINE_RESULT@@"


# -- the worker: runs inside either tree ---------------------------------------------------------------
def worker(cfg: dict) -> dict:
    """Time ``cfg['steps']``-step blocks of the scene in the tree at ``cfg['root']`` (old or new API)."""
    import warpfree.device
    try:
        from warpfree.scene_loader import load_scene
    except ImportError:  # a tree from before the scene loader had its own module
        from warpfree.cli import load_scene

    warpfree.device.use("cpu", cfg["threads"])
    module = load_scene(os.path.join(cfg["root"], "scenes", cfg["scene"] + ".py"))
    run = module.build(t_end=10.0, frames=False, vtk=False, **cfg["params"])
    s = run.solver
    new_api = hasattr(s, "moving_neighbours")
    dt = cfg.get("dt") or s.stable_dt()
    if new_api:
        def rebuild():
            with s.phases("neighbours"):
                s.moving_neighbours.rebuild()
        problem = s.problem
        n = s.work_items
        timings = s.phases.as_dict
    else:
        import warp as wp

        def rebuild():
            wp.copy(s.x_built, s.fluid.x)
            s.build_lists()
        problem = lambda: s.problem  # noqa: E731 - the old API's attribute
        n = s.n
        timings = lambda: dict(s.timings)  # noqa: E731
    count = [0]

    def step():
        if count[0] % REBUILD_EVERY == 0:
            rebuild()
        count[0] += 1
        s.step(dt)
        if problem():
            raise RuntimeError(problem())

    for _ in range(cfg["warmup"]):
        step()
    before = timings()
    blocks = []
    for _ in range(cfg["repeats"]):
        t0 = time.perf_counter()
        for _ in range(cfg["steps"]):
            step()
        blocks.append(time.perf_counter() - t0)
    after = timings()
    total = cfg["steps"] * cfg["repeats"]
    return {"dt": dt, "n_particles": n, "blocks_s": blocks, "threads": s.launcher.threads,
            "phase_s_per_step": {k: (after[k] - before.get(k, 0.0)) / total for k in after}}


def run_worker(python: str, root: str, cfg: dict) -> dict:
    cfg = dict(cfg, root=root)
    env = dict(os.environ, WARPFREE_VERBOSE="0")
    env.pop("PYTHONPATH", None)
    proc = subprocess.run([python, __file__, "--worker", json.dumps(cfg)], capture_output=True, text=True, env=env,
                          cwd=root, timeout=1800)
    for line in proc.stdout.splitlines()[::-1]:
        if line.startswith(TAG):
            return json.loads(line[len(TAG):])
    raise RuntimeError(f"worker in {root} failed (rc={proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}")


# -- the driver -------------------------------------------------------------------------------------------
def compare(name: str, params: dict, trees: dict, threads: list[int], args) -> dict:
    scene = CASES[name][0]
    blocks = {(tree, t): [] for tree in trees for t in threads}
    phases = {(tree, t): [] for tree in trees for t in threads}
    dt, n = None, None
    for r in range(args.rounds):
        for t in (threads if r % 2 == 0 else threads[::-1]):
            for tree in (list(trees) if r % 2 == 0 else list(trees)[::-1]):
                python, root = trees[tree]
                cfg = dict(scene=scene, params=params, threads=t, steps=args.steps, warmup=args.warmup,
                           repeats=args.repeats, dt=dt)
                res = run_worker(python, root, cfg)
                dt, n = res["dt"], res["n_particles"]
                blocks[(tree, t)].extend(res["blocks_s"])
                phases[(tree, t)].append(res["phase_s_per_step"])
                print(f"  {name} {tree} threads={t} round={r}: "
                      f"{statistics.median(res['blocks_s']) / args.steps * 1e3:.2f} ms/step", flush=True)
    rows = []
    for t in threads:
        for tree in trees:
            med = statistics.median(blocks[(tree, t)])
            ph = {k: statistics.median([p.get(k, 0.0) for p in phases[(tree, t)]]) for k in phases[(tree, t)][0]}
            rows.append(dict(tree=tree, threads=t, ms_per_step=med / args.steps * 1e3,
                             particle_steps_per_s=n * args.steps / med, blocks_s=blocks[(tree, t)],
                             phase_ms_per_step={k: v * 1e3 for k, v in ph.items()}))
        new, old = rows[-2], rows[-1]
        new["ratio_vs_baseline"] = new["particle_steps_per_s"] / old["particle_steps_per_s"]
        for tree in trees:  # run-to-run noise: spread of the blocks of each row
            row = next(x for x in rows if x["tree"] == tree and x["threads"] == t)
            b = sorted(row["blocks_s"])
            row["block_spread"] = (b[-1] - b[0]) / statistics.median(b)
    return dict(case=name, scene=scene, params=params, dt=dt, n_particles=n, steps_per_block=args.steps,
                rounds=args.rounds, repeats=args.repeats, rows=rows)


def end_to_end(trees: dict, rounds: int, baseline_rev: str) -> int:
    """The default command in each tree, whole process, alternating; wall time and the run's own phases."""
    import tempfile

    walls = {tree: [] for tree in trees}
    phases = {tree: [] for tree in trees}
    for r in range(rounds):
        for tree in (list(trees) if r % 2 == 0 else list(trees)[::-1]):
            python, root = trees[tree]
            with tempfile.TemporaryDirectory() as out:
                env = dict(os.environ, WARPFREE_VERBOSE="0")
                env.pop("PYTHONPATH", None)
                t0 = time.perf_counter()
                subprocess.run([python, "-m", "warpfree.cli", "run", "scenes/dam_break_2d.py", "--out", out,
                                "--no-progress"], cwd=root, env=env, check=True, capture_output=True)
                walls[tree].append(time.perf_counter() - t0)
                summary = json.load(open(os.path.join(out, "summary.json")))
            phases[tree].append(summary.get("phases_s") or summary.get("wall_s_per_phase"))
            print(f"  {tree} round={r}: {walls[tree][-1]:.1f} s", flush=True)
    rows = []
    for tree in trees:
        ph = {k: statistics.median([p[k] for p in phases[tree]]) for k in ("step", "output")}
        rows.append(dict(tree=tree, wall_s=statistics.median(walls[tree]), walls_s=walls[tree], step_s=ph["step"],
                         output_s=ph["output"]))
    ratio = rows[0]["wall_s"] / rows[1]["wall_s"]
    md = (f"## The default scene, whole process: this tree against `{baseline_rev}`, CPU\n\n"
          "`warpfree run scenes/dam_break_2d.py` (frames and VTU included), median of "
          f"{rounds} alternating runs each.\n\n"
          + common.md_table(["tree", "wall s (process)", "runs", "steps s (summary)", "output s on the stepping thread"],
                            [[r["tree"], f"{r['wall_s']:.1f}", ", ".join(f"{w:.1f}" for w in r["walls_s"]),
                              f"{r['step_s']:.1f}", f"{r['output_s']:.1f}"] for r in rows])
          + f"\n\nnew / baseline wall time: {ratio:.2f}.")
    common.write_results("vs_baseline_end_to_end", {"machine": common.machine_info(), "baseline": baseline_rev,
                                                    "rows": rows, "ratio": ratio}, md)
    return 0


def markdown(cases: list[dict], baseline_rev: str) -> str:
    out = [f"## This tree against the baseline (`{baseline_rev}`), same steps, CPU\n"]
    for c in cases:
        params = ", ".join(f"{k} = {v}" for k, v in c["params"].items())
        out.append(f"**{c['case']}** (`{c['scene']}`, {params}: {c['n_particles']} particles, dt = {c['dt']:.4g} s; "
                   f"median of {c['rounds'] * c['repeats']} blocks of {c['steps_per_block']} steps per row)\n")
        table = []
        for r in c["rows"]:
            ph = r["phase_ms_per_step"]
            table.append([r["tree"], r["threads"], f"{r['ms_per_step']:.2f}", common.fmt_rate(r["particle_steps_per_s"]),
                          common.fmt(r.get("ratio_vs_baseline")), f"{100 * r['block_spread']:.0f}%",
                          " / ".join(f"{k} {v:.2f}" for k, v in sorted(ph.items()))])
        out.append(common.md_table(["tree", "threads", "ms/step", "particle-steps/s", "new / baseline",
                                    "block spread (max-min)/median", "ms/step per phase"], table, align="llrrrrl"))
        out.append("")
    out.append("Ratios > 1: this tree is faster. The block spread is the run-to-run noise of a row.")
    return "\n".join(out)


def plot(cases: list[dict]):
    fig, ax = common.new_figure(figsize=(8, 4))
    labels, ratios = [], []
    for c in cases:
        for r in c["rows"]:
            if "ratio_vs_baseline" in r:
                labels.append(f"{c['case']}\n{r['threads']} thr")
                ratios.append(r["ratio_vs_baseline"])
    ax.bar(range(len(ratios)), ratios, color="C0")
    ax.axhline(1.0, color="k", lw=1)
    ax.set_xticks(range(len(ratios)))
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_ylabel("particle-steps/s, new / baseline")
    ax.set_title("Step cost against the baseline commit (same steps)")
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="a worktree of the baseline commit, with warpfree installed in its venv")
    ap.add_argument("--baseline-python", default=None, help="default: <baseline>/.venv/bin/python")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="default: 1 and all cores")
    ap.add_argument("--steps", type=int, default=None, help="steps per block (default 21; quick 7)")
    ap.add_argument("--warmup", type=int, default=7)
    ap.add_argument("--repeats", type=int, default=None, help="blocks per worker (default 3; quick 1)")
    ap.add_argument("--rounds", type=int, default=None, help="default 4; quick 1")
    ap.add_argument("--end-to-end", action="store_true", help="the default command in each tree, whole process")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(TAG + json.dumps(worker(json.loads(args.worker))), flush=True)
        return 0
    if not args.baseline:
        ap.error("--baseline is required")
    q = args.quick
    args.steps = args.steps or (7 if q else 21)
    args.repeats = args.repeats or (1 if q else 3)
    args.rounds = args.rounds or (1 if q else 4)
    threads = sorted(set(args.threads or {1, common.cpu_count()}))
    base = str(Path(args.baseline).resolve())
    trees = {"new": (sys.executable, str(common.ROOT)),
             "baseline": (args.baseline_python or os.path.join(base, ".venv", "bin", "python"), base)}
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=base, capture_output=True, text=True).stdout.strip()
    if args.end_to_end:
        return end_to_end(trees, args.rounds or 3, rev)
    machine = common.machine_info()
    cases = []
    for name in args.cases:
        params = CASES[name][2 if q else 1]
        print(f"{name}: {params}", flush=True)
        cases.append(compare(name, params, trees, threads, args))
    common.write_results("vs_baseline", {"machine": machine, "baseline": {"path": base, "git": rev}, "cases": cases},
                         markdown(cases, rev), plot(cases), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
