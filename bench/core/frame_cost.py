"""A frame against the steps between two frames, on the default scene (2D dam break), CPU.

What it measures
    The default run writes a frame every ``output_interval`` (0.02 s of simulated time). A frame is drawn by
    the writer process beside the stepping, so it must cost less than the steps it sits beside, or the run
    waits for it. Both are timed here in one process at the same state (the default scene stepped to
    ``--t`` = 0.3 s, the column collapsing): the frame as the writer draws it (``render_frame`` with the
    run's arguments, its figure warm: the median of ``--repeats`` frames after a first one), and the steps
    between two frames (the step count over one output interval times the median step time, on 1 and 2
    threads). The frame's parts are reported too: the disc image (``_splat``) and the rest (Matplotlib's axes,
    colour bar, title, PNG encoding).

Usage
    python bench/core/frame_cost.py            # ~1 min on 2 cores
    python bench/core/frame_cost.py --quick    # smoke run: t = 0.05 s, 2 repeats
Writes bench/results/frame_cost[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]


def worker(cfg: dict) -> dict:
    """Step the default scene to cfg["t"], then time steps (and, on one thread, frames)."""
    import tempfile

    from warpfree.io import frames

    run = common.build_scene("dam_break_2d", cfg["threads"], frames=False, vtk=False)
    s = run.solver
    t = 0.0
    while t < cfg["t"]:
        dt = s.stable_dt()
        s.step(dt)
        t += dt
    steps_per_frame = run.output_interval / s.stable_dt()
    step_s = []
    for _ in range(cfg["repeats"]):
        t0 = time.perf_counter()
        for _ in range(50):
            s.step(s.stable_dt())
            s.problem()
        step_s.append((time.perf_counter() - t0) / 50)
    out = dict(threads=cfg["threads"], t=cfg["t"], steps_per_frame=steps_per_frame,
               step_s=statistics.median(step_s), step_s_runs=step_s)
    out["steps_between_frames_s"] = out["step_s"] * steps_per_frame
    if cfg["frames"]:
        sets = s.output_sets()
        run._frame_set, run._frame_field = "fluid", "speed"
        with tempfile.TemporaryDirectory() as d:
            from warpfree.run import RunDirectory

            job = run._frame_job(RunDirectory(d), sets, 0, "dam_break_2d  t = 0.3000 s")[1]
            frames.render_frame(**job)  # the figure is built once per run
            frame_s, splat_s = [], []
            original = frames._splat

            def timed_splat(*args, **kwargs):
                t0 = time.perf_counter()
                img = original(*args, **kwargs)
                splat_s.append(time.perf_counter() - t0)
                return img

            frames._splat = timed_splat
            for _ in range(cfg["repeats"]):
                t0 = time.perf_counter()
                frames.render_frame(**job)
                frame_s.append(time.perf_counter() - t0)
            frames._splat = original
        out.update(frame_s=statistics.median(frame_s), frame_s_runs=frame_s, splat_s=statistics.median(splat_s))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: t = 0.05 s, 2 repeats (unless given)")
    ap.add_argument("--t", type=float, default=None, help="default 0.3 s; quick 0.05 s")
    ap.add_argument("--repeats", type=int, default=None, help="default 7; quick 2")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        common.emit_worker_result(worker(json.loads(args.worker)))
        return 0
    args.t = args.t if args.t is not None else (0.05 if args.quick else 0.3)
    args.repeats = args.repeats or (2 if args.quick else 7)
    rows = [common.run_worker(__file__, ["--worker", json.dumps(dict(threads=t, t=args.t, repeats=args.repeats,
                                                                     frames=t == 1))]) for t in (1, 2)]
    frame = rows[0]
    table = [[r["threads"], f"{r['steps_per_frame']:.0f}", f"{1e3 * r['step_s']:.2f}",
              f"{r['steps_between_frames_s']:.3f}", f"{frame['frame_s']:.3f}",
              f"{frame['frame_s'] / r['steps_between_frames_s']:.2f}"] for r in rows]
    md = "\n".join([
        f"## A frame against the steps between two frames (default scene, t = {args.t} s, CPU)\n",
        common.md_table(["threads", "steps per frame interval", "ms per step", "steps between frames, s",
                         "one frame, s", "frame / steps"], table, align="rrrrrr"),
        f"\nThe frame (median of {args.repeats}, figure warm): {frame['frame_s']:.3f} s, of which the disc image "
        f"{frame['splat_s']:.3f} s and Matplotlib's axes, colour bar, title and PNG encoding the rest. "
        "frame / steps < 1: the writer process keeps up with the stepping."])
    common.write_results("frame_cost", {"rows": rows}, md, quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
