"""A channel between an inlet and an outlet against plane Poiseuille flow over resolution, and its cost per
particle-step beside the 2D dam break's.

What it measures
    The shipped ``channel_flow_2d`` scene at each ``--n`` (particles across; its defaults otherwise: 5 widths long,
    Re = 1, shifting, to 4 H²/ν, the profile from 2 widths after the inlet to 1 before the outlet, averaged over the
    last 0.5 H²/ν): the largest and rms bin error of its shape (against the Poiseuille profile fitted at each output)
    in units of u_max, its flux (the fitted mean velocity over the inlet's), the particles that entered and left over
    the average, the pressure drop against 12 μ U L/H²,
    and the stepping time per particle-step; then the default ``dam_break_2d`` (dx = a/40, to its default t_end) on the
    same threads, whose particle-step time the channel's is compared with (the openings' buffers, their values each
    step and the particles made and taken out at the rebuilds are the difference).

    python bench/wcsph/channel_flow.py [--n 10,20,30,40] [--threads 2]

Writes bench/results/channel_flow.{json,md,png}.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402

from warpfree.validation import channel_flow_2d as poiseuille  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--n", "10,20,30,40"]]


def run_scene(scene: str, threads: int, settings: list[str]) -> dict:
    """One run of ``scene`` with ``settings`` (name=value): its summary."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", scene, "--set", "vtk=false", "--no-frames", "--no-progress",
                "--threads", str(threads), "--out", str(out)]
        args += [a for setting in settings for a in ("--set", setting)]
        done = subprocess.run(args, capture_output=True, text=True)
        if not (out / "summary.json").is_file():
            raise RuntimeError(f"{scene} {settings}: {done.stderr.strip().splitlines()[-1:]}")
        return json.loads((out / "summary.json").read_text())


def particle_steps(summary: dict) -> float:
    """The run's particle-steps (fluid and wall particles times steps; a channel's count changes by a column or so)."""
    return float(summary["model"]["n_particles"]) * summary["steps"]


def dam_break_cost(threads: int) -> dict:
    """The default ``dam_break_2d``'s stepping on ``threads``: particles, steps, seconds and µs per particle-step, the
    baseline the fluid studies give their cost against."""
    print("dam_break_2d", flush=True)
    dam = run_scene("dam_break_2d", threads, [])
    return {"particles": dam["model"]["n_particles"], "steps": dam["steps"], "step_s": dam["phases_s"]["step"],
            "us_per_particle_step": 1e6 * dam["phases_s"]["step"] / particle_steps(dam)}


def run_case(n: int, threads: int) -> dict:
    summary = run_scene("channel_flow_2d", threads, [f"n={n}"])
    channel = summary["analysis"]["channel"]
    return {"n": n, "particles": summary["model"]["n_particles"], "fluid": summary["model"]["n_fluid"],
            "steps": summary["steps"], "step_s": summary["phases_s"]["step"],
            "us_per_particle_step": 1e6 * summary["phases_s"]["step"] / particle_steps(summary),
            "channel": {k: channel[k] for k in ("error_max", "error_rms", "mean_velocity_ratio", "entered", "left",
                                                 "pressure_drop_ratio",
                                                 "outputs_averaged", "u_bins_averaged", "y_bins", "u_max")},
            "passed": (summary.get("validation") or {}).get("passed")}


def markdown(result: dict) -> str:
    cases, dam = result["cases"], result["dam_break"]
    lines = ["# A channel between an inlet and an outlet against plane Poiseuille flow", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             "`channel_flow_2d` scene (5 widths long, Re = 1, shifting A = 2, to 4 H²/ν) at n particles across: the "
             "profile from 2 widths after the inlet to 1 before the outlet against the Poiseuille profile 6U' y(H − y)/H² "
             "fitted at each output, its bin errors averaged over the outputs of the last 0.5 H²/ν, in % of u_max; the "
             "flux U'/U (averaged); the order "
             "between successive resolutions from the largest error; the particles that entered and left over the "
             "average; the pressure drop over the same stretch against 12 μ U L/H² (the channel's slowest sound mode "
             "rings through it: not checked); the stepping time per particle-step (fluid and walls) beside the "
             f"default `dam_break_2d`'s in the same run ({dam['us_per_particle_step']:.3f} µs, "
             f"{dam['particles']} particles, {dam['steps']} steps).", ""]
    rows, previous = [], None
    for c in cases:
        k = c["channel"]
        order = ("" if previous is None else
                 f"{math.log(previous['channel']['error_max'] / k['error_max']) / math.log(c['n'] / previous['n']):.2f}")
        rows.append([f"{c['n']}", f"{c['fluid']}", f"{c['steps']}", f"{c['step_s']:.1f} s",
                     f"{100 * k['error_max']:.2f} %", f"{100 * k['error_rms']:.2f} %", order,
                     f"{k['mean_velocity_ratio']:.4f}",
                     f"{k['entered']}, {k['left']}", f"{k['pressure_drop_ratio']:.3f}",
                     f"{c['us_per_particle_step']:.3f} µs ({c['us_per_particle_step'] / dam['us_per_particle_step']:.2f}x)",
                     {True: "pass", False: "FAIL", None: "–"}[c["passed"]]])
        previous = c
    lines += [common.md_table(["n", "water particles (start)", "steps", "stepping", "shape: largest error", "rms",
                               "order", "flux U'/U", "entered, left", "pressure drop / theory", "per particle-step (x dam break)",
                               "checks (shape within 1 %)"], rows), ""]
    return "\n".join(lines)


def plot(result: dict):
    fig, axes = common.new_figure(figsize=(9, 4.0), ncols=2)
    a1, a2 = axes
    cases = result["cases"]
    yy = np.linspace(0.0, 1.0, 201)
    a1.plot(poiseuille.profile(yy, 2.0 / 3.0, 1.0), yy, "k-", lw=1.0, label="6U y(H−y)/H² (u/u_max)")
    for c in cases:
        k = c["channel"]
        a1.plot(np.asarray(k["u_bins_averaged"]) / k["u_max"], np.asarray(k["y_bins"]) / 1.0e-3, "o", mfc="none",
                ms=4, label=f"n = {c['n']}")
    a1.set_xlabel("u / u_max (2H after the inlet to 1H before the outlet, averaged)")
    a1.set_ylabel("y / H")
    n = np.array([c["n"] for c in cases], float)
    err = np.array([c["channel"]["error_max"] for c in cases])
    rms = np.array([c["channel"]["error_rms"] for c in cases])
    a2.loglog(n, 100 * err, "o-", label="largest bin error")
    a2.loglog(n, 100 * rms, "s-", label="rms")
    a2.loglog(n, 100 * err[0] * (n[0] / n), "k:", lw=0.8, label="order 1")
    a2.axhline(100 * poiseuille.PROFILE_TOLERANCE, color="r", ls="--", lw=0.8, label="check")
    a2.set_xlabel("particles across n")
    a2.set_ylabel("% of u_max")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Channel between an inlet and an outlet, Re = 1", fontsize=10)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", default="10,20,30,40", help="particles across, comma-separated")
    p.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    cases = []
    for n in (int(v) for v in args.n.split(",")):
        print(f"n = {n}", flush=True)
        cases.append(run_case(n, args.threads))
    result = {"machine": common.machine_info(), "threads": args.threads, "cases": cases,
              "dam_break": dam_break_cost(args.threads)}
    common.write_results("channel_flow", result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
