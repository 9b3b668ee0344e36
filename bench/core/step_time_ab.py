"""The stepping time of scenes on two versions of warpfree, run in turn (A B A B ...): did a change slow the steps?

What it measures
    Each scene runs at its default parameters (or ``--set`` ones) from the command line, in each version's tree
    assembled as ``bench/compare_commits.py`` assembles it (``git archive`` of a revision, or ``.`` for the working
    tree; never an installed copy), frames off, alternately A then B, ``--runs`` times each. The figure is the run's
    own ``phases_s.step`` from ``summary.json`` (the time loop's steps, set-up and outputs excluded): median, min and
    max per side, and the median of the B/A ratios taken pair by pair (pairing keeps a drift of the machine's speed
    out of the ratio).

Usage
    python bench/core/step_time_ab.py 45de2de . --scenes dam_break_2d,em_cavity_2d,pic_two_stream --runs 3
    python bench/core/step_time_ab.py 45de2de . --scenes em_cavity_2d --set cells_per_radius=60 \
        --name step_time_ab_spem
Writes bench/results/step_time_ab.{json,md} (or ``--name``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402
import compare_commits as cc  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "compares two revisions named on the command line"


def step_seconds(side: Path, scene: str, params: dict, out: Path, threads: int) -> float:
    code, tail = cc.run_scene(side, scene, {**params, "frames": False}, out, threads)
    if code != 0:
        raise SystemExit(f"{scene} failed on {side}:\n{tail}")
    return float(json.loads((out / "summary.json").read_text())["phases_s"]["step"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", help="revision A (the control)")
    ap.add_argument("b", nargs="?", default=".", help="revision B (default: the working tree)")
    ap.add_argument("--scenes", required=True, help="comma-separated scene names")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE for every scene (as warpfree run)")
    ap.add_argument("--name", default="step_time_ab", help="results file stem under bench/results")
    args = ap.parse_args(argv)
    params = dict(item.split("=", 1) for item in args.set)
    rows = []
    with tempfile.TemporaryDirectory(prefix="step_ab_") as tmp:
        root = Path(tmp)
        sides = [root / "a", root / "b"]
        cc.stage(args.a, sides[0])
        cc.stage(args.b, sides[1])
        for scene in args.scenes.split(","):
            times = {"a": [], "b": []}
            for k in range(args.runs):
                for name, side in zip("ab", sides):
                    times[name].append(step_seconds(side, scene, params, root / f"{scene}_{name}_{k}", args.threads))
            ratios = [b / a for a, b in zip(times["a"], times["b"])]
            rows.append({"scene": scene, "a_s": times["a"], "b_s": times["b"],
                         "a_median_s": statistics.median(times["a"]), "b_median_s": statistics.median(times["b"]),
                         "ratio_median": statistics.median(ratios)})
            print(f"{scene}: A {rows[-1]['a_median_s']:.3f} s, B {rows[-1]['b_median_s']:.3f} s, "
                  f"B/A {rows[-1]['ratio_median']:.3f}", flush=True)
    result = {"a": args.a, "b": args.b, "runs": args.runs, "threads": args.threads, "params": params, "rows": rows}
    lines = [f"# Step time, {args.a} (A) against {args.b} (B), {args.threads} threads, {args.runs} runs each "
             "in turn", "", "Each figure is the time loop's steps alone (`phases_s.step`), frames off.", "",
             "| scene | A median (s) | A min-max | B median (s) | B min-max | B/A (pairwise median) |",
             "| :-- | --: | --: | --: | --: | --: |"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['a_median_s']:.3f} | {min(r['a_s']):.3f}-{max(r['a_s']):.3f} | "
                     f"{r['b_median_s']:.3f} | {min(r['b_s']):.3f}-{max(r['b_s']):.3f} | {r['ratio_median']:.3f} |")
    common.write_results(args.name, result, "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
