"""A half-immersed cylinder's free heave over resolution against Ursell's linear transient, and its cost per
particle-step beside the 2D dam break's.

What it measures
    The shipped ``heave_decay_2d`` scene at each ``--per-radius`` (particles over the radius a; its defaults otherwise:
    released 0.2 a above its floating level in water 5 a deep, the tank 24 a long, 25 sqrt(a/g) after 10 of settling
    with the cylinder held): its own floating level, and about it, over the first two periods, the period between the
    first and third zero crossings, the first trough and the rms difference from the linear transient
    (``warpfree.validation.heave_decay_2d``); the stepping time per particle-step (fluid and walls, over the free
    run: the settling is not counted) beside the default ``dam_break_2d``'s in the same run (the floating body's step
    is the host's, with a gather of its load each step: a cost per step, not per particle).

    python bench/wcsph/heave_decay.py [--per-radius 6,10] [--threads 2]

Writes bench/results/heave_decay.{json,md,png}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402
from wcsph.channel_flow import dam_break_cost, particle_steps, run_scene  # noqa: E402

from warpfree.validation import heave_decay_2d as ursell  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--per-radius", "6,10"]]

KEYS = ("floating_level", "period", "period_theory", "period_error", "first_trough", "first_trough_theory",
        "rms_difference", "rms_difference_whole_run")


def run_case(per_radius: int, threads: int) -> dict:
    summary = run_scene("heave_decay_2d", threads, [f"per_radius={per_radius}"])
    heave = summary["analysis"]["heave"]
    return {"per_radius": per_radius, "particles": summary["model"]["n_particles"], "steps": summary["steps"],
            "step_s": summary["phases_s"]["step"],
            "us_per_particle_step": 1e6 * summary["phases_s"]["step"] / particle_steps(summary),
            "heave": {k: heave[k] for k in KEYS}, "checks": {k: v["passed"] for k, v in heave["checks"].items()}}


def markdown(result: dict) -> str:
    dam = result["dam_break"]
    natural = ursell.natural_frequency()
    lines = ["# Heave decay of a half-immersed cylinder", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             "`heave_decay_2d` scene (released 0.2 a above its floating level, 5 a deep, the tank 24 a long, 25 "
             "sqrt(a/g) free after 10 settling with the cylinder held) at a/dx particles over the radius, against the "
             "linear transient of Ursell's (1949) coefficients (Maskell & Ursell 1970): its damped period "
             f"{natural['period']:.2f} sqrt(a/g) at ω_n = {natural['omega']:.3f} sqrt(g/a), added mass "
             f"{natural['added_mass']:.3f} of the displaced, damping ratio {natural['damping_ratio']:.3f}. About the "
             "body's own floating level c (fitted), over t sqrt(g/a) <= 14: the period between the first and third "
             "zero crossings, the first trough, the rms difference (also over the whole run). The stepping time per "
             "particle-step (fluid and walls, over the free run: the settling is not counted) beside the default `dam_break_2d`'s in the same "
             f"run ({dam['us_per_particle_step']:.3f} µs, {dam['particles']} particles, {dam['steps']} steps).", ""]
    rows = []
    for c in result["cases"]:
        h = c["heave"]
        rows.append([f"{c['per_radius']}", f"{c['particles']}", f"{c['steps']}", f"{c['step_s']:.0f} s",
                     f"{h['floating_level']:.3f} y0", f"{h['period']:.3f} ({100 * h['period_error']:+.2f} %)",
                     f"{h['first_trough']:.3f} ({h['first_trough_theory']:.3f})", f"{h['rms_difference']:.3f}",
                     f"{h['rms_difference_whole_run']:.3f}",
                     f"{c['us_per_particle_step']:.3f} µs ({c['us_per_particle_step'] / dam['us_per_particle_step']:.2f}x)",
                     ", ".join(f"{k} {'pass' if ok else 'FAIL'}" for k, ok in c["checks"].items())])
    lines += [common.md_table(["a / dx", "particles", "steps", "stepping", "floating level c", "period (theory "
                               f"{result['cases'][0]['heave']['period_theory']:.3f})", "first trough (theory)",
                               "rms, t <= 14", "rms, whole run", "per particle-step (x dam break)", "checks"], rows), ""]
    return "\n".join(lines)


def plot(result: dict):
    fig, axes = common.new_figure(figsize=(9, 4.0), ncols=2)
    a1, a2 = axes
    n = np.array([c["per_radius"] for c in result["cases"]], float)
    a1.plot(n, [100 * c["heave"]["period_error"] for c in result["cases"]], "o-", label="period error (%)")
    a1.axhspan(-100 * ursell.TOLERANCES["period"], 100 * ursell.TOLERANCES["period"], color="0.9", label="check")
    a1.set_xlabel("particles over the radius a/dx")
    a1.set_ylabel("period error (%)")
    a2.plot(n, [c["heave"]["first_trough"] - c["heave"]["first_trough_theory"] for c in result["cases"]], "o-",
            label="first trough − theory (y0)")
    a2.plot(n, [c["heave"]["rms_difference"] for c in result["cases"]], "s-", label="rms difference (y0)")
    a2.set_xlabel("particles over the radius a/dx")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Heave decay of a half-immersed cylinder against Ursell's linear theory", fontsize=10)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--per-radius", default="6,10", help="particles over the radius, comma-separated")
    p.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    cases = []
    for per_radius in (int(v) for v in args.per_radius.split(",")):
        print(f"a = {per_radius} dx", flush=True)
        cases.append(run_case(per_radius, args.threads))
    result = {"machine": common.machine_info(), "threads": args.threads, "cases": cases,
              "dam_break": dam_break_cost(args.threads)}
    common.write_results("heave_decay", result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
