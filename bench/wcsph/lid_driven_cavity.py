"""The lid-driven cavity against Ghia, Ghia & Shin (1982) over resolution: the centreline error and its cost.

What it measures
    The shipped ``lid_driven_cavity_2d`` scene at each ``--n`` (particles across) and ``--reynolds``, to its default
    t_end = 20 L/U with the profiles averaged over 10-20 L/U (``--set`` more scene settings): the rms difference from
    Ghia et al. over the 30 interior centreline points (both lines, each, the largest), the smallest u on the
    vertical centreline against Ghia's, the observed order between successive resolutions, and the stepping time.

    python bench/wcsph/lid_driven_cavity.py [--n 20,30,40,60,80] [--reynolds 100] [--threads 2] [--set name=value]...
    python bench/wcsph/lid_driven_cavity.py --n 40,60,80 --reynolds 1000 --set t_end=60 --set average_from=40 \
        --results lid_driven_cavity_re1000     # Re = 1000, steady later: about 10 minutes

Writes bench/results/lid_driven_cavity.{json,md,png} (``--results NAME``: another name, e.g. for another Reynolds
number).
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

from warpfree.validation import lid_driven_cavity_2d as ghia  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--n", "20,30,40,60,80", "--reynolds", "100"],
           ["--n", "40,60,80", "--reynolds", "1000", "--set", "t_end=60", "--set", "average_from=40", "--results",
            "lid_driven_cavity_re1000"]]


def run_case(n: int, reynolds: float, threads: int, settings: list[str]) -> dict:
    """One run of the scene at ``n`` and ``reynolds``: its cavity analysis, steps and stepping time."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", "lid_driven_cavity_2d", "--set", f"n={n}", "--set",
                f"reynolds={reynolds:g}", "--set", "vtk=false", "--no-frames", "--no-progress", "--threads",
                str(threads), "--out", str(out)]
        args += [a for setting in settings for a in ("--set", setting)]
        done = subprocess.run(args, capture_output=True, text=True)
        summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else None
        if summary is None:
            raise RuntimeError(f"n = {n}: {done.stderr.strip().splitlines()[-1:]}")
    cavity = summary["analysis"]["cavity"]
    return {"n": n, "reynolds": reynolds, "settings": settings, "particles": summary["model"]["n_particles"],
            "fluid": summary["model"]["n_fluid"], "steps": summary["steps"], "step_s": summary["phases_s"]["step"],
            "cavity": {k: cavity[k] for k in ("rms", "u_rms", "v_rms", "max", "u_min", "u_min_ghia", "line",
                                               "u_line", "v_line", "averaged_outputs")},
            "passed": (summary.get("validation") or {}).get("passed")}


def window(settings: list[str]) -> tuple[float, float]:
    """The run's end and the start of its average (L/U with the scene's L = U = 1): the scene's defaults, 20 and 10,
    or the ``t_end`` and ``average_from`` of ``settings``."""
    values = dict(setting.split("=", 1) for setting in settings)
    return float(values.get("t_end", 20.0)), float(values.get("average_from", 10.0))


def markdown(result: dict) -> str:
    cases = result["cases"]
    re_ = cases[0]["reynolds"]
    t_end, average_from = window(result["settings"])
    lines = ["# Lid-driven cavity against Ghia, Ghia & Shin (1982)", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             f"`lid_driven_cavity_2d` scene at Re = {re_:g} (settings: {' '.join(result['settings']) or 'defaults'}), "
             f"to t = {t_end:g} L/U, the centreline velocities averaged over the outputs from {average_from:g} L/U; "
             "the difference from Ghia et al. over the 15 interior points of each centreline, in % of the lid speed "
             "U; the order between successive resolutions from the rms (log of its ratio over log of the ratio of n); "
             "the scene checks Re = 100 only.", ""]
    rows, previous = [], None
    for c in cases:
        k = c["cavity"]
        order = "" if previous is None else f"{math.log(previous['cavity']['rms'] / k['rms']) / math.log(c['n'] / previous['n']):.2f}"
        rows.append([f"{c['n']}", f"{c['fluid']}", f"{c['steps']}", f"{c['step_s']:.1f} s",
                     f"{100 * k['rms']:.2f} %", f"{100 * k['u_rms']:.2f} %", f"{100 * k['v_rms']:.2f} %",
                     f"{100 * k['max']:.2f} %", f"{k['u_min']:.4f} ({k['u_min_ghia']:.4f})", order,
                     {True: "pass", False: "FAIL", None: "–"}[c["passed"]]])
        previous = c
    lines += [common.md_table(["n", "water particles", "steps", "stepping", "rms (both lines)", "rms u", "rms v",
                               "largest", "min u (Ghia)", "order", "check (rms ≤ 2 %)"], rows), ""]
    return "\n".join(lines)


def plot(result: dict):
    fig, axes = common.new_figure(figsize=(12, 4.2), ncols=3)
    a1, a2, a3 = axes
    cases = result["cases"]
    re_ = cases[0]["reynolds"]
    ref = ghia.reference(re_)
    for c in cases:
        k = c["cavity"]
        line = np.concatenate([[0.0], k["line"], [1.0]])
        a1.plot(np.concatenate([[0.0], k["u_line"], [1.0]]), line, lw=1.0, label=f"n = {c['n']}")
        a2.plot(line, np.concatenate([[0.0], k["v_line"], [0.0]]), lw=1.0, label=f"n = {c['n']}")
    a1.plot(ref["u"], ref["y"], "ko", mfc="none", ms=4, label="Ghia et al. 1982")
    a2.plot(ref["x"], ref["v"], "ko", mfc="none", ms=4, label="Ghia et al. 1982")
    a1.set_xlabel("u/U on x = L/2")
    a1.set_ylabel("y/L")
    a2.set_xlabel("x/L")
    a2.set_ylabel("v/U on y = L/2")
    n = np.array([c["n"] for c in cases], float)
    rms = np.array([c["cavity"]["rms"] for c in cases])
    a3.loglog(n, 100 * rms, "o-", label="rms, both centrelines")
    a3.loglog(n, 100 * rms[0] * (n[0] / n) ** 2, "k:", lw=0.8, label="order 2")
    a3.axhline(100 * ghia.PROFILE_TOLERANCE, color="r", ls="--", lw=0.8, label="check (Re = 100)")
    a3.set_xlabel("particles across n")
    a3.set_ylabel("% of U")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Lid-driven cavity, Re = {re_:g}", fontsize=10)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", default="20,30,40,60,80", help="particles across, comma-separated")
    p.add_argument("--reynolds", type=float, default=100.0, choices=[float(r) for r in ghia.REYNOLDS])
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--set", action="append", default=[], dest="settings", help="a scene setting name=value")
    p.add_argument("--results", default="lid_driven_cavity")
    args = p.parse_args(argv)
    cases = []
    for n in (int(v) for v in args.n.split(",")):
        print(f"n = {n}", flush=True)
        cases.append(run_case(n, args.reynolds, args.threads, args.settings))
    result = {"machine": common.machine_info(), "threads": args.threads, "settings": args.settings, "cases": cases}
    common.write_results(args.results, result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
