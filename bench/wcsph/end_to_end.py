"""End to end: warpfree against PySPH 1.0b2 from process start to the same end time (2D dam break), CPU.

What it measures
    The time a user waits: from starting the process to its exit, for the Martin & Moyce dam break run to
    the same physical end time ``--tf`` (default 0.6 s: T = t sqrt(2g/a) = 2.66, past the last experimental
    point at T = 2.5) at the same particle spacing, on 1 and 2 threads. Each (dx, threads) pair is run
    ``--rounds`` times (default 5) alternating ours / PySPH (ours first in even rounds, PySPH first in odd
    ones), one process at a time; reported: median and range of the wall times, steps, particles, and the
    surge-front error max |dZ| of each code against the experiments (``front_errors`` of
    ``warpfree.validation.dam_break_2d``, every data set, points with T <= 2.5).

    ours: ``python -m warpfree.cli run scenes/dam_break_2d.py --no-frames --set dx=D --set t_end=TF
    --threads N --no-progress --out TMP``, the default command without frames: start-up (imports, scene
    build, Warp's kernel cache load), every step, the VTU snapshots every 0.02 s (written by the writer
    process beside the stepping), the front analysis and its plot, summary.json.

    PySPH: its ``dam_break_2d`` example in its own venv through ``bench/wcsph/peers/pysph_dam_break.py`` (the
    process from start to exit: imports, setup with its compiled-code cache warm, the solve with its ~25
    dumps, then our driver's read of the dumps for the front). OMP_NUM_THREADS = threads and ``--openmp``
    when threads > 1.

What differs between the two (documented, not matched)
    * Geometry: the same 1 x 2 column in a 4 x 4 tank, g, rho0, c0 = 10 sqrt(2 g 2a). PySPH's column is
      ``int(1/dx) + 1`` by ``int(2/dx) + 1`` points spanning the block (about dx wider and taller), with 4
      non-staggered wall layers from x = 0 (wall face at dx/2: its front is measured as x_max - dx/2); ours
      is cell-centred (1/dx by 2/dx) with 3 wall layers along the true walls.
    * Model: PySPH's default ``wcsph`` scheme (Wendland quintic, h = 1.3 dx, artificial viscosity 0.1,
      Hughes-Graham wall correction, Ferrari ``update_h``, PEC integrator, dt = 0.3 h/c0 ramped over 50
      steps); ours Wendland C2, h = 1.6 dx, laminar + artificial viscosity 0.1, delta-SPH, Adami dynamic
      walls, kick-drift-kick leapfrog, dt = CFL h/(c0 + max|v|) with the scene's CFL.
    * Outputs: PySPH writes ~25 npz dumps; ours 31 VTU snapshots of fluid and walls and the front plot, no
      frames.

Usage
    python bench/wcsph/end_to_end.py                      # dx 0.025 (the default scene) and 0.02; 1, 2 threads; 5 rounds
    python bench/wcsph/end_to_end.py --quick              # dx 0.05, tf 0.2, 2 rounds
Writes bench/results/end_to_end[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]  # needs PySPH in /work/peers-venv (bench/README.md); without it: an error naming the venv

REPO = common.BENCH.parent
SCENE = REPO / "scenes" / "dam_break_2d.py"


def run_ours(dx: float, threads: int, tf: float) -> dict:
    """One warpfree process from start to exit; its summary's steps, particles and front errors."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "warpfree.cli", "run", str(SCENE), "--no-frames", "--no-progress",
               "--set", f"dx={dx}", "--set", f"t_end={tf}", "--threads", str(threads), "--out", out]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"warpfree failed (rc {proc.returncode}): {proc.stderr[-2000:]}")
        summ = json.loads((Path(out) / "summary.json").read_text())
    model = summ["model"]
    return dict(code="warpfree", dx=dx, threads=threads, process_s=wall, steps=summ["steps"],
                n_fluid=model["n_fluid"], n_boundary=model["n_boundary"], cfl=model["cfl"],
                run_wall_s=summ["wall_s"], front_max_abs=summ["analysis"]["front"]["errors"]["max_abs"],
                loadavg=common.loadavg())


def run_pysph(dx: float, threads: int, tf: float, out_root: str) -> dict:
    """One PySPH process from start to exit (its example, our driver); steps, particles, front errors."""
    from peers.pysph_dam_break import DEFAULT_PYTHON, run_pysph_dam_break

    if not os.path.exists(DEFAULT_PYTHON):
        raise RuntimeError(f"PySPH's venv is missing ({DEFAULT_PYTHON} not found): see bench/README.md")
    res = run_pysph_dam_break(dx, tf, threads, os.path.join(out_root, f"dx{dx}_t{threads}"), timeout=3600)
    front = sorted(res["front"])
    t = np.array([p[0] for p in front])
    x = np.array([p[1] for p in front]) - 0.5 * dx  # measured from its wall face at x = dx/2
    return dict(code="PySPH", dx=dx, threads=threads, process_s=res["subprocess_total_s"], steps=res["steps"],
                n_fluid=res["n_fluid"], n_boundary=res["n_solid"], run_wall_s=res["wall_s"],
                compiled=res["compiled"], front_max_abs=common.dam_break_front_errors(t, x)["max_abs"],
                loadavg=common.loadavg())


def spread(values: list[float]) -> dict:
    return dict(median=common.median(values), min=min(values), max=max(values), runs=values)


def markdown(rows: list[dict], tf: float, rounds: int) -> str:
    out = [f"## warpfree vs PySPH 1.0b2, process start to t = {tf} s (2D dam break, CPU, {rounds} alternating "
           "rounds, medians and ranges)\n"]
    table = []
    for r in rows:
        for code in ("warpfree", "PySPH"):
            c = r[code]
            label = f"warpfree (CFL {c['cfl']})" if code == "warpfree" else "PySPH" + (" (OpenMP)" if r["threads"] > 1 else "")
            table.append([r["dx"], r["threads"], label, f"{c['n_fluid']} + {c['n_boundary']}", c["steps"],
                          f"{c['process_s']['median']:.2f} ({c['process_s']['min']:.2f}-{c['process_s']['max']:.2f})",
                          f"{c['run_wall_s']['median']:.2f}", f"{c['front_max_abs']:.3f}",
                          common.fmt(r["ratio"]) if code == "warpfree" else ""])
    out.append(common.md_table(["dx", "threads", "code", "particles (fluid + boundary)", "steps",
                                "process wall s, median (range)", "solve s (own timer)", "front max abs dZ (T<=2.5)",
                                "PySPH / warpfree, process wall"], table, align="rrlrrrrrr"))
    speedups = [f"{code} at dx = {dx}: {s:.2f}" for (code, dx), s in sorted(thread_speedups(rows).items())]
    out.append("\nTwo threads against one, process wall (medians): " + "; ".join(speedups) + ".")
    out.append("\nRatios > 1: warpfree reaches the end time sooner. 'solve s' is each code's own timer of its "
               "time loop (warpfree: steps and records; PySPH: its 'Run took', with its dumps). PySPH's front is "
               "measured from its wall face (x_max - dx/2).")
    return "\n".join(out)


def thread_speedups(rows: list[dict]) -> dict:
    by = {(r["dx"], r["threads"]): r for r in rows}
    out = {}
    for (dx, t), r in by.items():
        if t != 1 and (dx, 1) in by:
            for code in ("warpfree", "PySPH"):
                out[(code, dx)] = by[(dx, 1)][code]["process_s"]["median"] / r[code]["process_s"]["median"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, nargs="+", default=None)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--tf", type=float, default=None)
    ap.add_argument("--rounds", type=int, default=None)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    dxs = args.dx or ([0.05] if args.quick else [0.025, 0.02])
    tf = args.tf or (0.2 if args.quick else 0.6)
    rounds = args.rounds or (2 if args.quick else 5)
    machine = common.machine_info()
    rows = []
    with tempfile.TemporaryDirectory() as pysph_out:
        for dx in dxs:
            for t in args.threads:
                runs = {"warpfree": [], "PySPH": []}
                for r in range(rounds):
                    for code in (("warpfree", "PySPH") if r % 2 == 0 else ("PySPH", "warpfree")):
                        res = run_ours(dx, t, tf) if code == "warpfree" else run_pysph(dx, t, tf, pysph_out)
                        runs[code].append(res)
                        print(f"  dx={dx} threads={t} round={r} {code}: {res['process_s']:.2f} s, {res['steps']} steps, "
                              f"front {res['front_max_abs']:.3f}, load {res['loadavg']}", flush=True)
                row = dict(dx=dx, threads=t, raw=runs)
                for code, rs in runs.items():
                    row[code] = dict(rs[0], process_s=spread([x["process_s"] for x in rs]),
                                     run_wall_s=spread([x["run_wall_s"] for x in rs]))
                row["ratio"] = row["PySPH"]["process_s"]["median"] / row["warpfree"]["process_s"]["median"]
                rows.append(row)
    data = dict(machine=machine, tf=tf, rounds=rounds, rows=rows,
                thread_speedups={f"{c} dx={dx}": s for (c, dx), s in thread_speedups(rows).items()})
    md = markdown(rows, tf, rounds)
    common.write_results("end_to_end", data, md, quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
