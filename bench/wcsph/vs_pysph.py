"""Our 2D dam break against PySPH 1.0b2's ``dam_break_2d`` example, side by side in one run, CPU.

What it measures
    For each particle spacing (default dx = 0.03 and 0.02; quick: 0.05) and each thread count
    (default 1 and all cores), both codes run the Martin & Moyce dam break (column a = 1 wide, 2a high,
    tank 4a x 4a, g = 9.81, rho0 = 1000, c0 = 10 sqrt(2 g 2a)) from t = 0 to the same ``--tf``
    (default 0.6 s, i.e. T = t sqrt(2g/a) = 2.66, which covers the experimental points with T <= 2.5).
    Reported per code: particles (fluid + boundary, and fluid), steps, wall time of the run,
    particle-steps/s (all particles and fluid only) and the surge-front error max |dZ| against the
    experiments (Martin & Moyce 1952, Koshizuka & Oka 1996, points with T <= 2.5; ``front_errors`` of
    ``warpfree.validation.dam_break``). Ratios: ours / PySPH particle-steps/s, and PySPH wall / our wall
    to the same tf (> 1: ours is faster to the same physical time).

    Target: >= 1.5x PySPH's particle-steps/s at equal threads, with a front error no worse.

How
    ours: a fresh subprocess (``bench/common.py: dam_break_2d_run``) calls ``warpfree.device.use('cpu', threads)``, builds
    ``scenes/dam_break_2d.py`` (dx, t_end = tf; no frames/VTU; kernels load during the build, so no
    compilation is timed) and runs ``Simulation.run`` in memory: the wall time is the run's own
    ``wall_s`` (all steps plus the probe/diagnostic records every 0.02 s), steps = its step count.
    The front is the largest fluid x (wall face at x = 0).

    PySPH: ``bench/wcsph/peers/pysph_dam_break.py`` runs the example in its own venv (/work/peers-venv) in
    a subprocess with OMP_NUM_THREADS = threads and ``--openmp`` when threads > 1; wall time = PySPH's
    own "Run took" (excludes setup and Cython compilation, includes its ~25 npz dumps, whose time is
    also reported), steps = ``solver.count`` (PEC integrator: one force evaluation per step, as ours).
    The front is the largest fluid x in each dump. PySPH's innermost wall particles sit at x = 0 and
    its first fluid column at x = dx, so its wall face is at x = dx/2: the front is measured from there
    (``x_max - dx/2``, same convention as ours); the example's own plot uses the raw ``x_max``, whose
    error is reported too. Its fluid block is get_2d_block (int(1/dx)+1 points across 1 and 2, i.e. a
    column ~dx wider and taller than ours).

    The two codes do not take the same time step: PySPH's adaptive dt is 0.3 h / c0 (ramped up over 50
    steps), ours the scene's ``cfl`` x h / (c0 + max|v|) (the CFL condition; the scene's default, reported
    in the table), so the step counts to the same tf differ; particle-steps/s compares the cost of a
    step, the wall-time ratio the cost of the simulation. ``--ours-cfl 0.1 0.3`` adds rows of ours at
    other CFL numbers.

    Runs alternate ours / PySPH per (dx, threads). ``--repeats`` repeats every run and reports the
    median wall time. If PySPH cannot run, the table says so and our rows are still reported.

Usage
    python bench/wcsph/vs_pysph.py              # full: dx 0.03, 0.02; threads 1, 2 (~5 min on 2 cores)
    python bench/wcsph/vs_pysph.py --quick      # dx 0.05, tf 0.15 (~40 s)
    python bench/wcsph/vs_pysph.py --dx 0.03 --threads 1 2 --tf 0.6 --ours-cfl 0.1 0.2
Writes bench/results/vs_pysph[_quick].{json,md,png}; PySPH's dumps go to a temporary folder.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]  # PySPH in /work/peers-venv (bench/README.md); without it: ours only, the error in the table

A, G, T_MAX = common.DAM_BREAK_A, common.DAM_BREAK_G, common.DAM_BREAK_T_MAX


def front_err(t, x) -> dict:
    return common.dam_break_front_errors(t, x)


def run_ours(dx, threads, tf, cfl=None) -> dict:
    cfg = dict(dx=dx, threads=threads, tf=tf, cfl=cfl)
    return common.run_worker(common.BENCH / "_worker.py", ["dam_break_2d_run", json.dumps(cfg)])


def run_pysph(dx, threads, tf, out_root) -> dict:
    from peers.pysph_dam_break import DEFAULT_PYTHON, run_pysph_dam_break

    if not os.path.exists(DEFAULT_PYTHON):
        raise RuntimeError(f"PySPH's venv is missing ({DEFAULT_PYTHON} not found)")
    out = os.path.join(out_root, f"dx{dx}_t{threads}")
    res = run_pysph_dam_break(dx, tf, threads, out, timeout=3600)
    t = np.array([p[0] for p in res["front"]])
    x = np.array([p[1] for p in res["front"]])
    order = np.argsort(t)
    t, x = t[order], x[order]
    res["front_reference"] = "x_max - dx/2 (PySPH's wall face at dx/2)"
    res["errors"] = front_err(t, x - 0.5 * dx)
    res["errors_raw_xmax"] = front_err(t, x)
    res["loadavg"] = common.loadavg()
    return res


def summarise(runs: list[dict]) -> dict:
    """Median wall over repeats; counts, steps and fronts from the first run."""
    r = dict(runs[0])
    r["wall_s_runs"] = [x["wall_s"] for x in runs]
    r["wall_s"] = common.median(r["wall_s_runs"])
    r.update(common.particle_throughput(r["n_particles"], r["n_fluid"], r["steps"], r["wall_s"]))
    return r


def markdown(rows: list[dict], pysph_error: str | None, tf: float) -> str:
    out = [f"## Ours vs PySPH 1.0b2 `dam_break_2d`, CPU (tf = {tf} s, T = {tf * math.sqrt(2 * G / A):.2f})\n"]
    table = []
    for r in rows:
        o, p = r["ours"], r.get("pysph")
        err_o = o["errors"]["max_abs"]
        table.append([r["dx"], r["threads"], f"ours (CFL {o['cfl']})", f"{o['n_fluid']} + {o['n_boundary']}",
                      o["steps"], f"{o['wall_s']:.1f}", common.fmt_rate(o["particle_steps_per_s"]),
                      common.fmt_rate(o["fluid_particle_steps_per_s"]), f"{err_o:.3f}",
                      common.fmt(r.get("ratio_pps")), common.fmt(r.get("ratio_fluid_pps")),
                      common.fmt(r.get("ratio_wall_to_tf"))])
        if p is not None and r.get("print_pysph", True):
            table.append([r["dx"], r["threads"], "PySPH" + (" (OpenMP)" if p.get("openmp") else ""),
                          f"{p['n_fluid']} + {p['n_solid']}", p["steps"], f"{p['wall_s']:.1f}",
                          common.fmt_rate(p["particle_steps_per_s"]), common.fmt_rate(p["fluid_particle_steps_per_s"]),
                          f"{p['errors']['max_abs']:.3f} ({p['errors_raw_xmax']['max_abs']:.3f} raw)",
                          "", "", ""])
    out.append(common.md_table(["dx", "threads", "code", "particles (fluid + boundary)", "steps", "wall s",
                                "particle-steps/s (all)", "particle-steps/s (fluid)", "front max abs dZ (T<=2.5)",
                                "ratio ours/PySPH p-steps/s (all)", "ratio (fluid)",
                                "wall-time ratio PySPH/ours to tf"], table, align="rrlrrrrrrrrr"))
    out.append("")
    if pysph_error:
        out.append(f"**PySPH not run:** {pysph_error}\n")
    out.append("Ratios > 1 favour ours. PySPH's front is measured from its wall face (x_max - dx/2, like ours); "
               "'raw' is its example's own x_max. PySPH steps with dt = 0.3 h/c0, ours with the CFL number shown "
               "(dt = CFL h/(c0 + max|v|)), so the particle-steps/s ratio and the wall-time ratio differ. "
               "Target: ratio >= 1.5 at equal threads with a front error no worse.")
    return "\n".join(out)


def plot(rows: list[dict], tf: float):
    fig, (a1, a2) = common.new_figure(1, 2, figsize=(11, 4.2))
    from warpfree.validation.dam_break_2d import DATASETS

    shown = set()
    for i, r in enumerate(rows):
        if r["threads"] != rows[0]["threads"]:
            continue
        o, p = r["ours"], r.get("pysph")
        fac = math.sqrt(2 * G / A)
        t, x = np.array(o["front"]).T
        key = ("ours", r["dx"], o["cfl"])
        if key not in shown:
            a1.plot(t * fac, x / A, "-", color=f"C{i}", label=f"ours dx={r['dx']} CFL {o['cfl']}")
            shown.add(key)
        if p is not None and ("pysph", r["dx"]) not in shown:
            f = np.array(sorted(p["front"]))
            a1.plot(f[:, 0] * fac, (f[:, 1] - 0.5 * r["dx"]) / A, "--", color=f"C{i}", label=f"PySPH dx={r['dx']}")
            shown.add(("pysph", r["dx"]))
    for (name, data), m in zip(DATASETS.items(), ("o", "s")):
        a1.plot(data[:, 0], data[:, 1], m, color="k", mfc="none", label=name)
    a1.axvline(T_MAX, color="0.6", ls=":")
    a1.set_xlim(0, tf * math.sqrt(2 * G / A) + 0.1)
    zmax = max(float(np.max(np.array(r["ours"]["front"])[:, 1])) for r in rows) / A
    a1.set_ylim(0.9, zmax + 0.4)
    a1.set_xlabel("T = t sqrt(2g/a)")
    a1.set_ylabel("Z = x_front / a")
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3)
    labels, ours_v, py_v = [], [], []
    for r in rows:
        labels.append(f"dx={r['dx']}\n{r['threads']}T\nCFL {r['ours']['cfl']}")
        ours_v.append(r["ours"]["particle_steps_per_s"])
        py_v.append(r["pysph"]["particle_steps_per_s"] if r.get("pysph") else 0.0)
    xs = np.arange(len(labels))
    a2.bar(xs - 0.2, ours_v, 0.4, label="ours")
    a2.bar(xs + 0.2, py_v, 0.4, label="PySPH")
    a2.set_xticks(xs)
    a2.set_xticklabels(labels, fontsize=7)
    a2.set_ylabel("particle-steps / s (fluid + boundary)")
    a2.legend()
    a2.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--dx", nargs="+", type=float, default=None, help="default 0.03 0.02; quick 0.05")
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="default 1 and all cores")
    ap.add_argument("--tf", type=float, default=None, help="default 0.6 s; quick 0.15 s")
    ap.add_argument("--ours-cfl", nargs="+", type=float, default=[None],
                    help="CFL numbers for our runs (default: the scene's)")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--no-pysph", action="store_true", help="report ours only")
    args = ap.parse_args(argv)
    q = args.quick
    dxs = args.dx or ([0.05] if q else [0.03, 0.02])
    threads = sorted(set(args.threads or {1, common.cpu_count()}))
    tf = args.tf or (0.15 if q else 0.6)
    machine = common.machine_info()
    pysph_error = "skipped (--no-pysph)" if args.no_pysph else None
    out_root = tempfile.mkdtemp(prefix="warpfree_bench_pysph_")
    rows = []
    for dx in dxs:
        for th in threads:
            pysph_runs, ours_runs = [], {c: [] for c in args.ours_cfl}
            for rep in range(args.repeats):
                for c in args.ours_cfl:
                    o = run_ours(dx, th, tf, c)
                    ours_runs[c].append(o)
                    print(f"  ours dx={dx} threads={th} cfl={o['cfl']}: {o['steps']} steps, {o['wall_s']:.1f} s, "
                          f"front err {o['errors']['max_abs']:.3f} (load {o['loadavg']})", flush=True)
                if pysph_error is None:
                    try:
                        p = run_pysph(dx, th, tf, out_root)
                        pysph_runs.append(p)
                        print(f"  PySPH dx={dx} threads={th}: {p['steps']} steps, {p['wall_s']:.1f} s, front err "
                              f"{p['errors']['max_abs']:.3f} (load {p['loadavg']})", flush=True)
                    except Exception as exc:  # PySPH missing or failing: say so, keep ours
                        pysph_error = f"{type(exc).__name__}: {str(exc)[-1500:]}"
                        print("  PySPH failed: " + pysph_error, flush=True)
            p = summarise(pysph_runs) if pysph_runs else None
            for k, c in enumerate(args.ours_cfl):
                o = summarise(ours_runs[c])
                row = dict(dx=dx, threads=th, ours=o, pysph=p, print_pysph=(k == len(args.ours_cfl) - 1))
                if p is not None:
                    row["ratio_pps"] = o["particle_steps_per_s"] / p["particle_steps_per_s"]
                    row["ratio_fluid_pps"] = o["fluid_particle_steps_per_s"] / p["fluid_particle_steps_per_s"]
                    row["ratio_wall_to_tf"] = p["wall_s"] / o["wall_s"]
                    row["target_met"] = bool(row["ratio_pps"] >= 1.5
                                             and o["errors"]["max_abs"] <= p["errors"]["max_abs"])
                rows.append(row)
    md = markdown(rows, pysph_error, tf)
    common.write_results("vs_pysph", {"machine": machine, "tf": tf, "rows": rows, "pysph_error": pysph_error,
                                      "pysph_out_dir": out_root,
                                      "target": ">= 1.5x PySPH particle-steps/s at equal threads, front error "
                                                "no worse"}, md, plot(rows, tf), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
