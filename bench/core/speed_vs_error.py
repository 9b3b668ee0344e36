"""Speed against error: a scene at several resolutions, its error against its reference against wall time.

What it measures
    A scene run at several values of its resolution parameter; per value: work items per step (in the
    solver's unit), steps, wall time of the run, throughput, and the error the scene's own analysis
    reports against its reference (a key of ``summary["analysis"]``). Built-in cases:

    * ``dam_break_2d`` (default): ``scenes/dam_break_2d.py`` at dx = 0.05, 0.04, 0.03, 0.02 (quick: 0.1,
      0.08, 0.06) from t = 0 to T = 2.5 (t = 2.5 / sqrt(2 g / a) = 0.564 s); error: the surge-front max |ΔZ|
      over the experimental points with T <= 2.5 (``warpfree.validation.dam_break_2d``), also per data set;
    * ``heat``: ``scenes/heat_conduction_2d.py`` at n = 20, 40, 80 particles per side (quick: 10, 20);
      error: the largest amplitude error of the decaying sine mode against exp(-α k² t), relative to A;
    * ``taylor_green`` (n = 25, 50, 100), ``poiseuille`` (n = 10, 20, 40, 80) and ``standing_wave``
      (dx = 0.08, 0.04, 0.02; the wall time is the run's, the relaxation and settling are part of the build);
    * any scene: ``--scene PATH --param NAME --values ... --error analysis.key.path [--set name=value]``.

How
    Each run is a fresh subprocess (``bench/common.py: scene_run``): ``warpfree.device.use('cpu', threads)``
    (default: all cores), build (kernels load here, not timed), then the scene's run into a temporary
    directory with frames and VTU off; the wall time is the run's own ``wall_s`` (steps, probe and
    diagnostic records; not the build, not the analysis). The median of ``--repeats`` runs per value
    (default 3).

Usage
    python bench/core/speed_vs_error.py                  # dam break, full: ~5 min on 2 cores
    python bench/core/speed_vs_error.py --case heat
    python bench/core/speed_vs_error.py --quick          # ~30 s
    python bench/core/speed_vs_error.py --values 0.05 0.03 0.02 0.015 --threads 2
Writes bench/results/speed_vs_error[_<case>][_quick].{json,md,png} (PNG: error against wall time and
against work items per step).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[], ["--case", "heat"], ["--case", "poiseuille"], ["--case", "taylor_green"], ["--case", "standing_wave"]]

T_END = common.DAM_BREAK_T_MAX / math.sqrt(2 * common.DAM_BREAK_G / common.DAM_BREAK_A)

CASES = {
    "dam_break_2d": dict(
        scene="dam_break_2d", param="dx", values=[0.05, 0.04, 0.03, 0.02], quick=[0.1, 0.08, 0.06],
        params={"t_end": T_END}, error="front.errors.max_abs", label="front max abs(ΔZ), T ≤ 2.5", tolerance=0.15,
        extra={f"vs {name}": f"front.errors.{name}.max_abs" for name in (
            "Martin & Moyce 1952", "Koshizuka & Oka 1996", "Koshizuka & Oka 1996 (DualSPHysics digitisation)")}),
    "heat": dict(
        scene="heat_conduction_2d", param="n", values=[20, 40, 80], quick=[10, 20], params={},
        error="decay.max_amplitude_error", label="max abs(A - A exp(-α k² t)) / A", tolerance=None,
        extra={"decay-rate error": "decay.rate_rel_error"}),
    "taylor_green": dict(
        scene="taylor_green_2d", param="n", values=[25, 50, 100], quick=[12, 25], params={},
        error="taylor_green.energy_error", label="energy error at t_e: (E/E0) / exp(-4νk²t) - 1", tolerance=None,
        extra={"velocity L2 error at t_e": "taylor_green.velocity_l2_error",
               "energy error at t_e/10": "taylor_green.early.energy_error",
               "velocity L2 error at t_e/10": "taylor_green.early.velocity_l2_error"}),
    "standing_wave": dict(
        scene="standing_wave_2d", param="dx", values=[0.08, 0.04, 0.02], quick=[0.08], params={},
        error="standing_wave.frequency_error", label="frequency error ω'/ω - 1 against ω² = g k tanh(kd)",
        tolerance=None, extra={"decay rate (1/s)": "standing_wave.decay_rate",
                               "amplitude ratio": "standing_wave.amplitude_ratio"}),
    "poiseuille": dict(
        scene="poiseuille_2d", param="n", values=[10, 20, 40, 80], quick=[10, 20], params={},
        error="poiseuille.error_max", label="max abs(binned u - series) / u_c, t = 0.0225-0.225 s", tolerance=None,
        extra={f"at t = {t} s": f"poiseuille.anchors.{key}.error_max"
               for t, key in ((0.0225, "t0225"), (0.045, "t045"), (0.1125, "t1125"), (0.225, "t225"))}),
}


def lookup(analysis: dict, path: str):
    """``analysis["a"]["b"]`` for the path "a.b" (keys may contain spaces and '&', not dots)."""
    node = analysis
    for part in path.split("."):
        node = node[part]
    return node


def markdown(case: dict, rows: list[dict], threads: int) -> str:
    table = []
    for r in rows:
        table.append([r["value"], r["work_items"], r["steps"], f"{r['wall_s']:.2f}", common.fmt_rate(r["work_per_s"]),
                      f"{r['error']:.3g}", *[f"{r['extra'][k]:.3g}" for k in case["extra"]]])
    head = [case["param"], f"{rows[0]['work_unit'].split('-')[0]}s per step", "steps", "wall s", rows[0]["unit"],
            case["label"], *case["extra"]]
    return (f"## Speed vs error: `{case['scene']}` ({', '.join(f'{k} = {v:.4g}' for k, v in case['params'].items())}),"
            f" {threads} thread(s), CPU\n\n" + common.md_table(head, table))


def plot(case: dict, rows: list[dict], threads: int):
    fig, (a1, a2) = common.new_figure(1, 2, figsize=(10, 4))
    e = [abs(r["error"]) for r in rows]
    for ax, xs, xl in ((a1, [r["wall_s"] for r in rows], "wall time of the run (s)"),
                       (a2, [r["work_items"] for r in rows], f"{rows[0]['work_unit'].split('-')[0]}s per step")):
        ax.plot(xs, e, "o-")
        for r, xv, ev in zip(rows, xs, e):
            ax.annotate(f"{case['param']}={r['value']}", (xv, ev), textcoords="offset points", xytext=(4, 4), fontsize=8)
        ax.set_xscale("log")
        ax.set_xlabel(xl)
        ax.set_ylabel(case["label"])
        if case["tolerance"]:
            ax.axhline(case["tolerance"], color="0.5", ls=":", label=f"tolerance {case['tolerance']}")
            ax.legend(fontsize=8)
        else:
            ax.set_yscale("log")
        ax.grid(alpha=0.3, which="both")
    a1.set_title(f"{case['scene']}: error vs wall time ({threads} thread(s), CPU)")
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--case", default="dam_break_2d", choices=sorted(CASES))
    ap.add_argument("--scene", default=None, help="any scene (with --param, --values and --error)")
    ap.add_argument("--param", default=None, help="the scene's resolution parameter")
    ap.add_argument("--values", nargs="+", default=None, help="its values")
    ap.add_argument("--error", default=None, help="the error's key path in summary['analysis'], e.g. decay.rate_rel_error")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--threads", type=int, default=None, help="default: all cores")
    ap.add_argument("--repeats", type=int, default=None, help="runs per value (default 3; quick 1)")
    args = ap.parse_args(argv)
    q = args.quick
    if args.scene:
        if not (args.param and args.values and args.error):
            ap.error("--scene needs --param, --values and --error")
        case = dict(scene=args.scene, param=args.param, values=None, quick=None, params={}, error=args.error,
                    label=args.error, tolerance=None, extra={})
        name = Path(args.scene).stem
    else:
        case, name = dict(CASES[args.case]), args.case
    case["params"] = {**case["params"], **common.parse_sets(case["scene"], args.overrides)}
    typed = common.parse_sets(case["scene"], [f"{case['param']}={v}" for v in args.values]) if args.values else None
    values = ([common.parse_sets(case["scene"], [f"{case['param']}={v}"])[case["param"]] for v in args.values]
              if typed is not None else (case["quick"] if q else case["values"]))
    args.repeats = args.repeats or (1 if q else 3)
    threads = args.threads or common.cpu_count()
    machine = common.machine_info()
    rows = []
    for value in values:
        runs = []
        for _ in range(args.repeats):
            cfg = dict(scene=case["scene"], threads=threads, params={**case["params"], case["param"]: value})
            r = common.run_worker(common.BENCH / "_worker.py", ["scene_run", json.dumps(cfg)])
            r["error"] = lookup(r["analysis"], case["error"])
            r["extra"] = {k: lookup(r["analysis"], path) for k, path in case["extra"].items()}
            runs.append(r)
            print(f"  {case['param']}={value}: {r['work_items']} items, {r['steps']} steps, {r['wall_s']:.2f} s, "
                  f"error {r['error']:.3g} (load {r['loadavg']})", flush=True)
        row = dict(runs[0], value=value)
        row["wall_s_runs"] = [x["wall_s"] for x in runs]
        row["wall_s"] = common.median(row["wall_s_runs"])
        row.update(common.throughput(row, row["steps"], row["wall_s"]))
        rows.append(row)
    stem = "speed_vs_error" + ("" if name == "dam_break_2d" else f"_{name}")
    common.write_results(stem, {"machine": machine, "case": case, "threads": threads, "rows": rows},
                         markdown(case, rows, threads), plot(case, rows, threads), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
