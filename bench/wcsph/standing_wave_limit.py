"""The standing wave's frequency against the particle spacing and the kernel's reach, ours beside PySPH.

What it measures
    ``scenes/standing_wave_2d.py`` (L = 1 m, d = 0.5 m, relaxed and settled start) for each (dx, h/dx, amplitude)
    of the plan: the frequency error ω'/ω - 1 against linear theory, the decay rate and the amplitude ratio its
    analysis fits to the centre-of-mass record, with the stepping's wall time. Beside it, where a PySPH venv is
    given (``--pysph PATH``), PySPH's ``WCSPHScheme`` on the same tank from a square lattice
    (``bench/wcsph/peers/pysph_standing_wave.py``), with and without XSPH, fitted by the same function.

    At a fixed h/dx the error does not converge as dx falls: the particle sums' own error depends on h/dx (the
    neighbour count) and on the arrangement, not on dx (Quinlan, Basa & Lastiwka 2006, IJNME 66:2064), while the
    kernel's smoothing error, which lowers the frequency, falls as (k h)². Raising h/dx as dx falls converges.

Usage
    python bench/wcsph/standing_wave_limit.py                 # ~30 min on 2 cores (runs kept in --work)
    python bench/wcsph/standing_wave_limit.py --fine          # adds dx = 0.01 (h = 2.8 dx): ~40 min more
    python bench/wcsph/standing_wave_limit.py --pysph /work/peers-venv/bin/python
Writes bench/results/standing_wave_limit.{json,md,png}. A run whose summary.json is already in ``--work`` (made by
the same command) is read, not repeated.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (peers/)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "half an hour of runs on 2 cores; run it by hand (its results are kept in bench/results)"

#: (dx m, h/dx, amplitude m): the spacing at the default and at its double, h/dx at the default 2.4 and at 1.6,
#: 2.0 and 3.0, and the amplitude at a quarter and four times the default
PLAN = [(0.04, 1.6, 0.01), (0.04, 2.0, 0.01), (0.04, 2.4, 0.01), (0.04, 3.0, 0.01),
        (0.02, 1.6, 0.01), (0.02, 2.0, 0.01), (0.02, 2.4, 0.01),
        (0.02, 1.6, 0.04), (0.02, 2.4, 0.04), (0.02, 2.4, 0.0025)]
FINE = [(0.01, 2.8, 0.01)]
#: PySPH: (dx, h/dx, XSPH)
PEER_PLAN = [(0.04, 1.6, False), (0.04, 1.6, True), (0.02, 1.6, False), (0.02, 1.6, True)]


def wall_layers(h_factor: float) -> int:
    """The fewest wall layers that cover the Wendland support 2h of the fluid row dx/2 from a wall."""
    return math.ceil(2.0 * h_factor - 0.5 - 1e-9)


def ours(dx: float, h_factor: float, amplitude: float, work: Path) -> dict:
    out = work / f"dx{dx:g}_h{h_factor:g}_A{amplitude:g}"
    summary = out / "summary.json"
    if not summary.exists():
        cmd = [common.PYTHON, "-m", "warpfree", "run", "standing_wave_2d", "--out", str(out), "--overwrite",
               "--no-frames", "--set", "vtk=false", "--set", f"dx={dx}", "--set", f"h_factor={h_factor}",
               "--set", f"wall_layers={wall_layers(h_factor)}", "--set", f"amplitude={amplitude}"]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    s = json.loads(summary.read_text())
    a = s["analysis"]["standing_wave"]
    return {"code": "warpfree", "dx": dx, "h_factor": h_factor, "amplitude": amplitude,
            "frequency_error": a["frequency_error"], "decay_rate": a["decay_rate"],
            "amplitude_ratio": a["amplitude_ratio"], "step_s": s["phases_s"]["step"], "steps": s["steps"]}


def peer(dx: float, h_factor: float, xsph: bool, python: str) -> dict:
    from peers import pysph_standing_wave as pysph

    from warpfree.validation import standing_wave_2d as linear

    rec = pysph.run(dx, h_factor, xsph, python)
    fit = linear.fit_damped_oscillation(np.array(rec["time"]), np.array(rec["centre_of_mass_x"]),
                                        rec["omega_linear"])
    expected = linear.centre_of_mass_amplitude(0.01, 1.0, 0.5)
    return {"code": "PySPH" + (" (XSPH)" if xsph else ""), "dx": dx, "h_factor": h_factor, "amplitude": 0.01,
            "frequency_error": fit["omega"] / rec["omega_linear"] - 1.0, "decay_rate": fit["beta"],
            "amplitude_ratio": fit["amplitude"] / expected, "steps": rec["steps"]}


def markdown(result: dict) -> str:
    rows = [[r["code"], r["dx"], r["h_factor"], r["amplitude"], f"{100 * r['frequency_error']:+.2f} %",
             f"{r['decay_rate']:.3f}", f"{r['amplitude_ratio']:.3f}", common.fmt(r.get("step_s"))]
            for r in result["runs"]]
    return "\n".join([
        "# Standing wave: frequency error against dx and h/dx", "",
        f"Machine: {result['machine'].get('cpu')}. L = 1 m, d = 0.5 m, 3 periods; ours from the scene's relaxed and "
        "settled start, PySPH from a square lattice. Frequency error ω'/ω - 1 against linear theory (its "
        "second-order shift is -0.01 % at A = 0.01 m, -0.15 % at 0.04 m). Stepping s: the run's own stepping "
        "time, runs made one after another with other work on the machine: not a speed comparison.", "",
        common.md_table(["code", "dx (m)", "h/dx", "A (m)", "frequency error", "decay (1/s)", "amplitude ratio",
                         "stepping s"], rows), ""]) + "\n"


def plot(result: dict):
    fig, ax = common.new_figure(1, 1, figsize=(6.5, 4.2))
    for code, marker in (("warpfree", "o"), ("PySPH", "s"), ("PySPH (XSPH)", "^")):
        for dx, style in ((0.04, "-"), (0.02, "--"), (0.01, ":")):
            pts = sorted((r["h_factor"], 100 * r["frequency_error"]) for r in result["runs"]
                         if r["code"] == code and r["dx"] == dx and r["amplitude"] == 0.01)
            if pts:
                ax.plot(*zip(*pts), marker + style, label=f"{code}, dx = {dx:g} m")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("h / dx")
    ax.set_ylabel("frequency error (%)")
    ax.set_title("Standing wave (A = 0.01 m): error against the kernel's reach")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--fine", action="store_true", help="add dx = 0.01 m at h = 2.8 dx")
    p.add_argument("--pysph", default=None, help="python of a venv with PySPH 1.0b2 (peer runs)")
    p.add_argument("--work", default=str(common.BENCH / "work" / "standing_wave_limit"))
    args = p.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    runs = []
    for dx, h_factor, amplitude in PLAN + (FINE if args.fine else []):
        runs.append(ours(dx, h_factor, amplitude, work))
        print(f"  warpfree dx {dx:g} h {h_factor:g} A {amplitude:g}: {100 * runs[-1]['frequency_error']:+.2f} %",
              flush=True)
    if args.pysph:
        for dx, h_factor, xsph in PEER_PLAN:
            runs.append(peer(dx, h_factor, xsph, args.pysph))
            print(f"  {runs[-1]['code']} dx {dx:g}: {100 * runs[-1]['frequency_error']:+.2f} %", flush=True)
    result = {"machine": common.machine_info(), "runs": runs}
    common.write_results("standing_wave_limit", result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
