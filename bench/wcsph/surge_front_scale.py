"""The dam-break surge front against Martin & Moyce at the experiment's size and at 1 m: what the water's viscosity does.

What it measures
    The shipped ``dam_break_2d`` scene for Martin & Moyce's two columns, n² = 2 (a = 1⅛ in) and the square n² = 1
    (a = 2¼ in), each at the experiment's width a and at a = 1 m, with the water's viscosity (μ = 1e-3 Pa·s, the
    scene's default) and without it (μ = 0), at the same relative resolution dx = a/40 (and a/80 for the square column
    at its experiment's size): the front Z = x/a against the experiment's points, T = t sqrt(n² g/a) (the scene's own
    figures, ``front_errors``), and the same with the run delayed by 0.175 in T = t sqrt(2g/a) (0.124 in the square
    column's T), the gate-release shift the literature applies to Martin & Moyce (Lethe's dam-break example).

    python bench/wcsph/surge_front_scale.py [--threads 2]

Writes bench/results/surge_front_scale.{json,md}.
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

from warpfree.validation.dam_break_2d import MARTIN_MOYCE, MARTIN_MOYCE_SQUARE  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

G = 9.81
INCH = 0.0254
#: the gate-release shift, in T = t sqrt(2g/a) (Lethe's dam-break example adds it to the simulation's T)
GATE_SHIFT = 0.175

#: (label, n², a (m), dx/a, μ (Pa·s))
CASES = [("n² = 2, a = 1 m", 2.0, 1.0, 40, 1.0e-3),
         ("n² = 2, a = 1⅛ in (the experiment's)", 2.0, 1.125 * INCH, 40, 1.0e-3),
         ("n² = 2, a = 1⅛ in, μ = 0", 2.0, 1.125 * INCH, 40, 0.0),
         ("n² = 1, a = 1 m", 1.0, 1.0, 40, 1.0e-3),
         ("n² = 1, a = 2¼ in (the experiment's)", 1.0, 2.25 * INCH, 40, 1.0e-3),
         ("n² = 1, a = 2¼ in, dx = a/80", 1.0, 2.25 * INCH, 80, 1.0e-3),
         ("n² = 1, a = 2¼ in, μ = 0", 1.0, 2.25 * INCH, 40, 0.0)]


def run_case(n2: float, a: float, per_a: int, mu: float, threads: int) -> dict:
    """One run of the scene; the front series (t in s, x in m) and the run's own figures."""
    t_max = 2.5 if n2 == 2.0 else 9.6           # the compared points' last T, in T = t sqrt(n² g/a)
    t_end = t_max / np.sqrt(n2 * G / a)
    settings = {"a": a, "dx": a / per_a, "mu": mu, "t_end": round(float(t_end), 6),
                "output_interval": round(float(t_end) / 100, 8)}
    if n2 == 1.0:
        settings.update(column_height=1.0, tank_length=15.0, tank_height=2.0)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", "dam_break_2d", "--set", "vtk=false", "--no-frames",
                "--no-progress", "--threads", str(threads), "--out", str(out)]
        args += [a_ for k, v in settings.items() for a_ in ("--set", f"{k}={v!r}")]
        done = subprocess.run(args, capture_output=True, text=True)
        if done.returncode not in (0, 1):       # 1: a check failed, the figures are still wanted
            raise RuntimeError(done.stderr.strip().splitlines()[-1:])
        summary = json.loads((out / "summary.json").read_text())
    return {"settings": settings, "t": summary["probes"]["time"], "front": summary["probes"]["front"],
            "steps": summary["steps"]}


def errors(case: dict, n2: float, a: float, shift: float) -> np.ndarray:
    """Z_run - Z_exp at the experiment's points (the square column: relative, and its last point, where the run's
    front has reached the tank's end, left out), the run delayed by ``shift`` in its T."""
    data = MARTIN_MOYCE if n2 == 2.0 else MARTIN_MOYCE_SQUARE[:-1]
    T = np.asarray(case["t"]) * np.sqrt(n2 * G / a)
    Z = np.asarray(case["front"]) / a
    dz = np.interp(data[:, 0] - shift, T, Z) - data[:, 1]
    if n2 == 2.0:
        return dz[data[:, 0] <= 2.5]
    return dz / data[:, 1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    rows, cases = [], []
    for label, n2, a, per_a, mu in CASES:
        print(label, flush=True)
        case = run_case(n2, a, per_a, mu, args.threads)
        shift = GATE_SHIFT * np.sqrt(n2 / 2.0)   # 0.175 in sqrt(2g/a) units, in this column's T
        plain, shifted = errors(case, n2, a, 0.0), errors(case, n2, a, shift)
        case.update(label=label, errors=plain.tolist(), errors_shifted=shifted.tolist(), shift_T=shift)
        cases.append(case)
        unit = "" if n2 == 2.0 else " %"
        scale = 1.0 if n2 == 2.0 else 100.0
        fmt = (lambda v: f"{scale * v:+.3f}") if n2 == 2.0 else (lambda v: f"{scale * v:+.1f}{unit}")
        rows.append([label, f"{a:.5g} m, dx = a/{per_a}, μ = {mu:g}", str(case["steps"]),
                     fmt(plain.mean()), fmt(plain[np.argmax(np.abs(plain))]),
                     fmt(shifted.mean()), fmt(shifted[np.argmax(np.abs(shifted))])])
    result = {"machine": common.machine_info(), "threads": args.threads, "gate_shift": GATE_SHIFT, "cases": cases}
    md = ["# The surge front at the experiment's size and at 1 m", "",
          f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {args.threads} threads. The `dam_break_2d` "
          "scene against Martin & Moyce's points: n² = 2, ΔZ over T <= 2.5 (T = t sqrt(2g/a)); n² = 1, ΔZ/Z over its "
          "points up to Z = 12 (T = t sqrt(g/a); at Z = 13 the run's front has reached the tank's end). \"Delayed\": "
          f"the run shifted by the gate's release, {GATE_SHIFT} in T = t sqrt(2g/a).", "",
          common.md_table(["case", "run", "steps", "mean", "largest", "mean, delayed", "largest, delayed"], rows), ""]
    common.write_results("surge_front_scale", result, "\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
