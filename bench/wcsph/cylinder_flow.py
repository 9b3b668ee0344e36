"""Flow past a circular cylinder between an inlet and an outlet at Re = 20 over resolution and domain: drag and wake
length against the published values, and the cost per particle-step beside the 2D dam break's.

What it measures
    The shipped ``cylinder_flow_2d`` scene (its defaults otherwise: the inlet 12 D before the cylinder, the outlet
    14 D behind, a periodic stream 24 D wide, c0 = 15 U, the outlet's background pressure 2 ρU²) at Re = 20 with each
    ``--per-diameter`` (particles across the cylinder) to 30 D/U, averaged over the last 5 D/U: the mean drag and lift
    coefficients, the drag's range over the average, the wake length against Dennis & Chang's (1970) 2.045 and
    0.94 D; the same at ``--domain-per-diameter`` particles across in the domains of ``DOMAINS`` (the inlet's distance,
    the outlet's, the stream's width: what a finite domain adds at Re = 20); and the stepping time per particle-step;
    then the default
    ``dam_break_2d`` on the same threads, whose particle-step time the cylinder's is compared with.

    python bench/wcsph/cylinder_flow.py [--per-diameter 6,8,10] [--domain-per-diameter 6] [--threads 2]

Writes bench/results/cylinder_flow.{json,md,png}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402
from wcsph.channel_flow import dam_break_cost, particle_steps, run_scene  # noqa: E402

from warpfree.validation import cylinder_flow_2d as published  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--per-diameter", "6,8,10", "--domain-per-diameter", "6"]]

#: the domains of the study (upstream, downstream, width, in D), the default's among them
DOMAINS = [(6.0, 14.0, 12.0), (12.0, 14.0, 12.0), (6.0, 14.0, 24.0), (12.0, 14.0, 24.0), (16.0, 16.0, 32.0)]

KEYS = ("drag_mean", "drag_range", "lift_mean", "wake_length", "wake_length_range")


def run_case(per_diameter: int, reynolds: float, threads: int, settings: list[str]) -> dict:
    summary = run_scene("cylinder_flow_2d", threads, [f"per_diameter={per_diameter}", f"reynolds={reynolds}",
                                                      *settings])
    cylinder = summary["analysis"]["cylinder"]
    params = summary["params"]
    return {"per_diameter": per_diameter, "reynolds": reynolds, "particles": summary["model"]["n_particles"],
            "domain": [params["upstream"], params["downstream"], params["width"]],
            "steps": summary["steps"], "step_s": summary["phases_s"]["step"],
            "us_per_particle_step": 1e6 * summary["phases_s"]["step"] / particle_steps(summary),
            "cylinder": {k: cylinder[k] for k in KEYS},
            "checks": {k: v["passed"] for k, v in cylinder.get("checks", {}).items()}}


def _verdict(case: dict) -> str:
    return ", ".join(f"{k} {'pass' if ok else 'FAIL'}" for k, ok in case["checks"].items()) or "–"


def markdown(result: dict) -> str:
    dam = result["dam_break"]
    ref20 = published.REFERENCES[20]
    lines = ["# Flow past a circular cylinder between an inlet and an outlet", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             "`cylinder_flow_2d` scene (the inlet 12 D before the cylinder, the outlet 14 D behind it, a periodic stream "
             "24 D wide, c0 = 15 U, the outlet at 2 ρU², started from the inviscid flow) at D particles across the "
             "cylinder. "
             f"Re = 20 to 30 D/U, averaged over the last 5 D/U, against Dennis & Chang (1970): C_D {ref20['drag'][0]}, "
             f"wake {ref20['wake_length'][0]} D (Fornberg 1980: 2.000, 0.91); the drag's range over the average is "
             "its noise (the particles passing the cylinder's few wall particles). The stepping time per particle-step (fluid and walls) beside the "
             f"default `dam_break_2d`'s in the same run ({dam['us_per_particle_step']:.3f} µs, {dam['particles']} "
             f"particles, {dam['steps']} steps).", ""]
    rows = []
    for c in result["steady"]:
        k = c["cylinder"]
        rows.append([f"{c['per_diameter']}", f"{c['particles']}", f"{c['steps']}", f"{c['step_s']:.0f} s",
                     f"{k['drag_mean']:.3f} ({100 * (k['drag_mean'] / ref20['drag'][0] - 1):+.1f} %)",
                     f"{k['drag_range']:.2f}", f"{k['lift_mean']:+.3f}",
                     f"{k['wake_length']:.3f} ({100 * (k['wake_length'] / ref20['wake_length'][0] - 1):+.1f} %)",
                     f"{c['us_per_particle_step']:.3f} µs ({c['us_per_particle_step'] / dam['us_per_particle_step']:.2f}x)",
                     _verdict(c)])
    lines += [common.md_table(["D / dx", "particles", "steps", "stepping", "C_D (from 2.045)", "C_D range", "C_L",
                               "wake L/D (from 0.94)", "per particle-step (x dam break)", "checks"], rows), ""]
    if result["domains"]:
        rows = []
        for c in result["domains"]:
            k = c["cylinder"]
            up, down, width = c["domain"]
            rows.append([f"{up:g} D", f"{down:g} D", f"{width:g} D ({100 / width:.1f} %)", f"{c['particles']}",
                         f"{c['step_s']:.0f} s",
                         f"{k['drag_mean']:.3f} ({100 * (k['drag_mean'] / ref20['drag'][0] - 1):+.1f} %)",
                         f"{k['wake_length']:.3f} ({100 * (k['wake_length'] / ref20['wake_length'][0] - 1):+.1f} %)"])
        lines += [f"What the finite domain adds at Re = 20, at D = {result['domains'][0]['per_diameter']} dx: the "
                  "inlet's distance before the cylinder (its uniform velocity is imposed where the unbounded flow is "
                  "already slowed), the outlet's behind it and the periodic stream's width (a row of cylinders W "
                  "apart, blockage D/W).", "",
                  common.md_table(["inlet before", "outlet behind", "width (blockage)", "particles", "stepping",
                                   "C_D (from 2.045)", "wake L/D (from 0.94)"], rows), ""]
    return "\n".join(lines)


def plot(result: dict):
    fig, axes = common.new_figure(figsize=(9, 4.0), ncols=2)
    a1, a2 = axes
    steady = result["steady"]
    n = np.array([c["per_diameter"] for c in steady], float)
    ref = published.REFERENCES[20]
    drag = np.array([c["cylinder"]["drag_mean"] for c in steady])
    wake = np.array([c["cylinder"]["wake_length"] for c in steady])
    a1.plot(n, drag, "o-", label="warpfree C_D")
    a1.axhline(ref["drag"][0], color="k", ls="--", lw=0.8, label="Dennis & Chang 1970")
    a1.axhspan(ref["drag"][0] * (1 - published.DRAG_TOLERANCE), ref["drag"][0] * (1 + published.DRAG_TOLERANCE),
               color="0.9", label="check")
    a1.set_xlabel("particles across the cylinder D/dx")
    a1.set_ylabel("drag coefficient, Re = 20")
    a2.plot(n, wake, "o-", label="warpfree")
    a2.axhline(ref["wake_length"][0], color="k", ls="--", lw=0.8, label="Dennis & Chang 1970")
    a2.axhspan(ref["wake_length"][0] * (1 - published.WAKE_TOLERANCE),
               ref["wake_length"][0] * (1 + published.WAKE_TOLERANCE), color="0.9", label="check")
    a2.set_xlabel("particles across the cylinder D/dx")
    a2.set_ylabel("wake length L/D, Re = 20")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Flow past a circular cylinder between an inlet and an outlet", fontsize=10)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--per-diameter", default="6,8,10", help="particles across the cylinder at Re = 20, "
                                                               "comma-separated")
    p.add_argument("--domain-per-diameter", type=int, default=6, help="particles across the cylinder in the domain "
                                                                      "study at Re = 20 (0: no study)")
    p.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    steady = []
    for per_diameter in (int(v) for v in args.per_diameter.split(",")):
        print(f"Re = 20, D = {per_diameter} dx", flush=True)
        steady.append(run_case(per_diameter, 20.0, args.threads, []))
    domains = []
    for up, down, width in DOMAINS if args.domain_per_diameter else []:
        print(f"Re = 20, D = {args.domain_per_diameter} dx, domain {up:g} + {down:g} D by {width:g} D", flush=True)
        domains.append(run_case(args.domain_per_diameter, 20.0, args.threads,
                                [f"upstream={up}", f"downstream={down}", f"width={width}"]))
    result = {"machine": common.machine_info(), "threads": args.threads, "steady": steady, "domains": domains,
              "dam_break": dam_break_cost(args.threads)}
    common.write_results("cylinder_flow", result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
