"""What a frame costs on the default scene (2D dam break), CPU: by part, before and after, and in a whole run.

What it measures
    1. One frame, by part, in one process at one state (the default scene stepped to ``--t`` = 0.3 s, the column
       collapsing), drawn as the writer draws it (``render_frame`` with the run's arguments, warm: the median of
       ``--repeats`` frames after a first one), by the renderer of this tree (after) and by that of the commit
       ``--baseline`` (before; its ``warpfree/io/frames.py`` read with ``git show`` and drawn with the arguments its
       run shell gave). Parts after: the discs' cover of the sub-pixels (``_cover``), the panel's pixels (their colours
       over the panel's background, averaged to pixels, the layers over them: ``_panel_pixels`` less ``_cover``), the
       template and the title (``_compose``), the PNG encoding (``write_png``), the rest (colours, sorting, checks). Parts before: the disc image (``_splat``) and Matplotlib (axes, colour bar, title,
       PNG encoding). Times are the drawing thread's CPU seconds (``time.thread_time``), which a busy machine changes
       less than wall time; the wall time of the frames is given beside them.
    2. The steps between two frames (the step count over one output interval times the median step time, on 1 and
       2 threads): a frame must cost less than them, or the writer process competes with the stepping for the cores.
    3. With ``--whole-run`` (on a quiet machine; ~5 min): the default scene run from the
       command line with frames and without (``--no-frames``), on 2 threads, alternated ``--runs`` times each (side
       by side: both see the same machine), VTU written in both; the ratio of their medians, of the run's whole time
       (``summary.json``'s ``total_s``: set-up, steps, outputs, analysis) and of the process's wall time. Target:
       with frames at most 1.15x without.

Usage
    python bench/core/frame_cost.py                # parts 1 and 2, ~1 min on 2 cores
    python bench/core/frame_cost.py --whole-run    # and part 3
    python bench/core/frame_cost.py --quick        # smoke run: t = 0.05 s, 2 repeats
Writes bench/results/frame_cost[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

#: the last commit whose frames Matplotlib drew whole for every frame (the "before" of the template renderer)
BASELINE = "e24bdcd"
#: the arguments the baseline's run shell gave ``render_frame``
BASELINE_JOB_KEYS = ("path", "points", "values", "dim", "field_name", "bounds", "boundary_points", "solid_points",
                     "title")


def _baseline_frames(revision: str):
    """The ``warpfree.io.frames`` module of ``revision`` (None when git cannot show it), as a module of its own."""
    proc = subprocess.run(["git", "show", f"{revision}:warpfree/io/frames.py"], cwd=common.ROOT, capture_output=True,
                          text=True)
    if proc.returncode:
        return None
    folder = Path(tempfile.mkdtemp(prefix="frames_baseline_"))
    path = folder / "frames_baseline.py"
    path.write_text(proc.stdout, encoding="utf-8")
    # named inside warpfree.io, so that its relative imports (..errors) resolve as they did
    spec = importlib.util.spec_from_file_location("warpfree.io._frames_baseline", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@contextlib.contextmanager
def _timing(module, names: list[str], seconds: dict[str, list[float]]):
    """Time every call of the functions ``names`` of ``module`` (each call's CPU seconds of this thread appended to
    ``seconds[name]``)."""
    originals = {name: getattr(module, name) for name in names}

    def timed(name, fn):
        def wrapper(*args, **kwargs):
            t0 = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                seconds.setdefault(name, []).append(time.thread_time() - t0)
        return wrapper

    for name, fn in originals.items():
        setattr(module, name, timed(name, fn))
    try:
        yield
    finally:
        for name, fn in originals.items():
            setattr(module, name, fn)


#: frames drawn before the timed ones: the first builds the series' figure or template, the next let the allocator
#: settle (its first large arrays of each size are fresh pages)
WARM_FRAMES = 4


def _frame_parts(render, kwargs: dict, repeats: int, module, parts: list[str]) -> dict:
    """Median CPU seconds of the drawing thread for a warm frame and for each part (per frame), over ``repeats``
    frames after :data:`WARM_FRAMES`; and the frames' median wall time."""
    for _ in range(WARM_FRAMES):
        render(**kwargs)
    seconds: dict[str, list[float]] = {}
    totals, walls = [], []
    with _timing(module, parts, seconds):
        for _ in range(repeats):
            t0, w0 = time.thread_time(), time.perf_counter()
            render(**kwargs)
            totals.append(time.thread_time() - t0)
            walls.append(time.perf_counter() - w0)
    parts_s = {}
    for name in parts:  # each part's calls summed per frame (a frame makes the same calls every time)
        calls = seconds.get(name, [])
        per_frame = len(calls) // repeats
        parts_s[name] = statistics.median(sum(calls[i * per_frame:(i + 1) * per_frame]) for i in range(repeats))
    return {"frame_s": statistics.median(totals), "frame_s_runs": totals, "frame_wall_s": statistics.median(walls),
            "parts_s": parts_s}


def worker(cfg: dict) -> dict:
    """Step the default scene to cfg["t"], then time steps (and, on one thread, frames before and after)."""
    from warpfree.io import frames
    from warpfree.run import RunDirectory

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
            job = run._frame_job(RunDirectory(d), sets, 0, run.frame_title())[1]
            after = _frame_parts(frames.render_frame, job, cfg["repeats"], frames,
                                 ["_cover", "_panel_pixels", "_compose", "write_png"])
            p = after["parts_s"]
            p["_panel_pixels"] -= p["_cover"]  # the colours and layers alone
            p["rest"] = after["frame_s"] - sum(p.values())
            out["after"] = after
            baseline = _baseline_frames(cfg["baseline"])
            if baseline is not None:
                old_job = {k: job[k] for k in BASELINE_JOB_KEYS}
                before = _frame_parts(baseline.render_frame, old_job, cfg["repeats"], baseline, ["_splat"])
                before["parts_s"]["matplotlib"] = before["frame_s"] - before["parts_s"]["_splat"]
                out["before"] = before
    return out


def whole_runs(count: int) -> dict:
    """The default scene from the command line with frames and without, alternated ``count`` times each on 2
    threads: each run's ``total_s`` (summary.json) and process wall time."""
    rows = {"frames": [], "no_frames": []}
    with tempfile.TemporaryDirectory() as d:
        for k in range(count):
            for kind, flag in (("frames", "--frames"), ("no_frames", "--no-frames")):
                out = Path(d) / f"{kind}_{k}"
                t0 = time.perf_counter()
                subprocess.run([common.PYTHON, "-m", "warpfree", "run", "dam_break_2d", "--out", str(out),
                                "--threads", "2", "--no-progress", flag], cwd=common.ROOT, check=True,
                               capture_output=True)
                wall = time.perf_counter() - t0
                summary = json.loads((out / "summary.json").read_text())
                rows[kind].append({"total_s": summary["total_s"], "process_s": wall})
    median = {kind: {key: statistics.median(r[key] for r in runs) for key in ("total_s", "process_s")}
              for kind, runs in rows.items()}
    return {"runs": rows, "median": median,
            "ratio_total": median["frames"]["total_s"] / median["no_frames"]["total_s"],
            "ratio_process": median["frames"]["process_s"] / median["no_frames"]["process_s"]}


def _parts_table(frame: dict) -> str:
    after, before = frame["after"], frame.get("before")
    names = {"_cover": "disc image: the discs' cover", "_panel_pixels": "disc image: colours, layers",
             "_compose": "template and title", "write_png": "PNG encoding", "rest": "colours, sorting, checks"}
    rows = [[label, "", f"{1e3 * after['parts_s'][key]:.1f}"] for key, label in names.items()]
    if before is not None:
        rows = [["disc image (before: `_splat`)", f"{1e3 * before['parts_s']['_splat']:.1f}", ""],
                ["Matplotlib: axes, colour bar, title, PNG (before)", f"{1e3 * before['parts_s']['matplotlib']:.1f}",
                 ""]] + rows
    rows.append(["**one frame**", f"**{1e3 * before['frame_s']:.1f}**" if before else "n/a",
                 f"**{1e3 * after['frame_s']:.1f}**"])
    return common.md_table(["part", "before, ms CPU", "after, ms CPU"], rows, align="lrr")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: t = 0.05 s, 2 repeats (unless given)")
    ap.add_argument("--t", type=float, default=None, help="default 0.3 s; quick 0.05 s")
    ap.add_argument("--repeats", type=int, default=None, help="default 9; quick 2")
    ap.add_argument("--baseline", default=BASELINE, help=f"the commit whose renderer is 'before' (default {BASELINE})")
    ap.add_argument("--whole-run", action="store_true", help="also the default scene with and without frames")
    ap.add_argument("--runs", type=int, default=5, help="--whole-run: runs of each kind, alternated (default 5)")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        common.emit_worker_result(worker(json.loads(args.worker)))
        return 0
    args.t = args.t if args.t is not None else (0.05 if args.quick else 0.3)
    args.repeats = args.repeats or (2 if args.quick else 9)
    rows = [common.run_worker(__file__, ["--worker", json.dumps(dict(threads=t, t=args.t, repeats=args.repeats,
                                                                     frames=t == 1, baseline=args.baseline))])
            for t in (1, 2)]
    frame = rows[0]
    after = frame["after"]["frame_s"]
    before = frame["before"]["frame_s"] if "before" in frame else None
    steps = [[r["threads"], f"{r['steps_per_frame']:.0f}", f"{1e3 * r['step_s']:.2f}",
              f"{r['steps_between_frames_s']:.3f}", f"{after / r['steps_between_frames_s']:.3f}",
              f"{before / r['steps_between_frames_s']:.3f}" if before else "n/a"] for r in rows]
    data = {"rows": rows, "baseline": args.baseline}
    md = [f"## One frame by part, before ({args.baseline}) and after (default scene, t = {args.t} s, CPU)\n",
          _parts_table(frame),
          f"\nCPU time of the drawing thread, median of {args.repeats} frames each after {WARM_FRAMES} untimed ones "
          "(the first builds the figure or template), in one process, the renderers side by side (wall time: "
          f"{1e3 * frame['after']['frame_wall_s']:.1f} ms after"
          + (f", {1e3 * frame['before']['frame_wall_s']:.1f} ms before" if before else "") + ")."
          + (f" After / before: {after / before:.2f}." if before else ""),
          "\n## A frame against the steps between two frames\n",
          common.md_table(["threads", "steps per frame interval", "ms per step", "steps between frames, s",
                           "frame / steps, after", "frame / steps, before"], steps, align="rrrrrr")]
    if args.whole_run:
        whole = whole_runs(args.runs)
        data["whole_run"] = whole
        m = whole["median"]
        md += ["\n## The default scene with and without frames (2 threads, runs alternated)\n",
               common.md_table(["", "with frames, s", "without, s", "ratio"], [
                   ["whole time (summary `total_s`)", f"{m['frames']['total_s']:.2f}",
                    f"{m['no_frames']['total_s']:.2f}", f"**{whole['ratio_total']:.3f}**"],
                   ["process wall time", f"{m['frames']['process_s']:.2f}", f"{m['no_frames']['process_s']:.2f}",
                    f"{whole['ratio_process']:.3f}"]], align="lrrr"),
               f"\nMedians of {args.runs} runs each; target: at most 1.15."]
    else:
        md += ["\nThe whole-run ratio (with frames / without) is measured with `--whole-run`, on a quiet machine."]
    common.write_results("frame_cost", data, "\n".join(md), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
