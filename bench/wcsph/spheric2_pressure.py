"""Loads on an obstacle: SPHERIC benchmark test 2 (Kleefsman et al. 2005) through the sensors, against the experiment.

What it measures
    The shipped ``dam_break_3d`` scene (the experiment's tank, obstacle and 0.55 m column) run to t = 2 s at each
    ``--dx`` with the command line's sensors at the experiment's positions (``warpfree.validation.dam_break_3d``): the
    pressures P1 and P3 on the obstacle's front face and the water heights H2 (between the obstacle and the dam) and H4
    (in the reservoir), every 1 ms, against the record:

    * P1, P3: the first impact (the first 5 ms mean above 0.05 ρ g H), the peak of the 5 ms mean, the mean over
      1.2-2.0 s (``pressure_figures``);
    * H2, H4: the rms difference from the record over 0-2 s, in units of the record's range (``height_rms``).

    python bench/wcsph/spheric2_pressure.py [--dx 0.05,0.04,0.03] [--threads 2] [--variant "name=value ..."]...
    python bench/wcsph/spheric2_pressure.py --dx 0.02 --results spheric2_pressure_fine   # one finer run, once

Each ``--variant`` (scene settings, space-separated; ``default`` for none) is run at every ``--dx``, side by side.
Writes bench/results/spheric2_pressure.{json,md,png}.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402

from warpfree.validation.dam_break_3d import (EXPERIMENT, KLEEFSMAN, RHO_G_H, compare,  # noqa: E402
                                              running_mean)

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--dx", "0.05,0.04,0.03", "--variant", "default", "--variant", "riemann=3 alpha=0", "--variant",
            "delta_gradient=true"],
           ["--dx", "0.02", "--results", "spheric2_pressure_fine"]]

T_END = 2.0
PRESSURES, HEIGHTS = ("P1", "P3"), ("H2", "H4")


def run_case(dx: float, threads: int, settings: tuple = ()) -> dict:
    """One run of the scene (and ``settings``, more ``name=value`` of the scene), which records the experiment's
    sensors itself: each sensor's rows (t, value), the run's step time and its sensors' time."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", "dam_break_3d", "--set", f"dx={dx}", "--set", f"t_end={T_END}",
                "--set", "output_interval=0.1", "--set", "vtk=false", "--no-frames", "--no-progress",
                "--threads", str(threads), "--out", str(out)]
        args += [a for setting in settings for a in ("--set", setting)]
        done = subprocess.run(args, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"dx = {dx} {settings}: {done.stderr.strip().splitlines()[-1:]}")
        series = {name: np.loadtxt(out / "sensors" / f"{name}.csv", delimiter=",", skiprows=1).tolist()
                  for name in PRESSURES + HEIGHTS}
        summary = json.loads((out / "summary.json").read_text())
    return {"dx": dx, "settings": list(settings), "series": series, "steps": summary["steps"],
            "step_s": summary["phases_s"]["step"], "sensors_s": summary["phases_s"].get("sensors", 0.0),
            "particles": summary["model"]["n_particles"]}


def figures(case: dict) -> dict:
    """The comparison's numbers of one run (``warpfree.validation.dam_break_3d.compare``)."""
    return compare(case["series"])


def compact(case: dict) -> dict:
    """The case as stored: each series as its 5 ms running mean every 5 ms in place of its samples."""
    series = {}
    for name, rows in case["series"].items():
        rows = np.asarray(rows)
        step = max(1, int(round(0.005 / float(np.median(np.diff(rows[:, 0]))))))
        keep = slice(step // 2, None, step)
        series[name] = np.column_stack([np.round(rows[keep, 0], 4),
                                        np.round(running_mean(rows[:, 0], rows[:, 1])[keep], 4)]).tolist()
    return {**case, "series": series, "stored": "5 ms running mean every 5 ms"}


def pct(value) -> str:
    return "—" if value is None else f"{100.0 * value:+.1f} %"


def markdown(result: dict) -> str:
    lines = ["# Loads on an obstacle: SPHERIC test 2 (Kleefsman et al. 2005) at the experiment's sensors", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             f"`dam_break_3d` scene with the sensors P1, P3 (pressure, obstacle's front face), H2, H4 (water height) "
             f"at the experiment's positions, every 1 ms, to t = {T_END} s. First impact: the first 5 ms mean above "
             f"0.05 ρ g H ({0.05 * RHO_G_H:.0f} Pa); peak: the largest 5 ms mean; mean over 1.2-2.0 s; gauges: rms "
             "difference from the record over 0-2 s, in units of its range.", ""]
    exp = result["experiment"]
    rows = [["experiment", ""] + [f"{exp[n]['arrival']:.3f} s" for n in PRESSURES]
            + [f"{exp[n]['peak'] / 1e3:.2f} kPa at {exp[n]['peak_time']:.3f}" for n in PRESSURES]
            + [f"{exp[n]['mean'] / 1e3:.2f} kPa" for n in PRESSURES] + ["", ""]]
    for c in result["cases"]:
        f = c["figures"]
        rows.append([f"dx = {c['dx']} m ({c['particles']} particles, {c['steps']} steps, {c['step_s']:.0f} s)",
                     " ".join(c["settings"]) or "defaults"]
                    + [f"{f[n]['arrival']:.3f} ({pct(f[n]['arrival_error'])})" if f[n]["arrival"] else "—"
                       for n in PRESSURES]
                    + [f"{f[n]['peak'] / 1e3:.1f} at {f[n]['peak_time']:.3f} (×{f[n]['peak_ratio']:.2f})"
                       for n in PRESSURES]
                    + [f"{f[n]['mean'] / 1e3:.2f} ({pct(f[n]['mean_error'])})" if f[n]["mean"] else "—"
                       for n in PRESSURES]
                    + [f"{100.0 * f[n]['rms_of_range']:.1f} %" for n in HEIGHTS])
    lines += [common.md_table(["", "settings", "P1 first impact (s)", "P3 first impact (s)", "P1 peak (kPa, 5 ms)",
                               "P3 peak (kPa, 5 ms)", "P1 mean 1.2-2 s (kPa)", "P3 mean 1.2-2 s (kPa)",
                               "H2 rms / range", "H4 rms / range"], rows), ""]
    return "\n".join(lines)


def plot(result: dict, variants: list[tuple]):
    """One row per variant: P1 and P3 (5 ms means) and the gauges against the record, each spacing a line."""
    cases = result["cases"]
    fig, axes = common.new_figure(nrows=len(variants), ncols=3, figsize=(15, 3.4 * len(variants)),
                                  squeeze=False, layout="constrained")
    t_exp = KLEEFSMAN["t"]
    for row, settings in zip(axes, variants):
        label = " ".join(settings) or "scene defaults"
        for ax, name in zip(row[:2], PRESSURES):
            ax.plot(t_exp, running_mean(t_exp, KLEEFSMAN[name]) / 1e3, "k", lw=0.8, label=f"experiment {name}")
            for c in (c for c in cases if tuple(c["settings"]) == settings):
                s = np.asarray(c["series"][name])
                ax.plot(s[:, 0], s[:, 1] / 1e3, lw=0.7, label=f"dx = {c['dx']} m")
            ax.set_xlim(0.3, T_END)
            ax.set_xlabel("t (s)")
            ax.set_ylabel(f"{name} (kPa, 5 ms mean)")
            ax.set_title(f"{name}: {label}", fontsize=9)
            ax.legend(fontsize=7)
        ax = row[2]
        for name, style in zip(HEIGHTS, ("-", "--")):
            ax.plot(t_exp, KLEEFSMAN[name], "k" + style, lw=0.8, label=f"experiment {name}")
            for c in (c for c in cases if tuple(c["settings"]) == settings):
                s = np.asarray(c["series"][name])
                ax.plot(s[:, 0], s[:, 1], style, lw=0.7, label=f"{name} dx = {c['dx']} m")
        ax.set_xlim(0.0, T_END)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("water height (m)")
        ax.set_title(f"H2, H4: {label}", fontsize=9)
        ax.legend(fontsize=6)
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    common.add_variant_sweep(p, "0.05,0.04,0.03")
    p.add_argument("--results", default="spheric2_pressure",
                   help="the results' name in bench/results (another keeps a single finer run beside the sweep)")
    args = p.parse_args(argv)
    variants, cases = common.variant_sweep(args, run_case, lambda case: compact({**case, "figures": figures(case)}))
    result = {"machine": common.machine_info(), "threads": args.threads, "experiment": EXPERIMENT, "cases": cases}
    common.write_results(args.results, result, markdown(result), plot(result, variants))
    return 0


if __name__ == "__main__":
    sys.exit(main())
