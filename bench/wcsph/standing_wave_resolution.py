"""The standing wave's frequency error against dx at a fixed kernel reach h/dx, and what it does not depend on.

What it measures
    ``scenes/standing_wave_2d.py`` (L = 1 m, d = 0.5 m, A = 0.01 m, relaxed and settled start) at h = 2.4 dx and
    2.8 dx for dx = 0.04, 0.033, 0.025, 0.02 m (``--fine``: 0.01 m at 2.4 dx as well): the frequency error ω'/ω - 1
    against linear theory from the scene's fit (c + B e^(-βt) sin(ω't + ϕ)) over the first three periods, with the
    decay rate, the amplitude ratio and the fit's rms residual. Then what could make the figure move without the
    discretisation changing:

    * the estimator: 8-period records at dx = 0.04 and 0.02 (2.4 dx) fitted over [0, n] periods (n = 2 to 8) and over
      every 3-period window starting each half period;
    * the settling: the same runs settled 2 and 4 periods instead of 3 (a different start from the same relaxation);
    * the sign of the wave: the start velocity reversed (the mirrored slosh; a linear system's frequency cannot
      depend on it);
    * the arrangement: dx nudged by 1e-8 of itself either way, which leaves the resolution as it is but lets the
      relaxation land on another arrangement (its particle motion amplifies the difference).

    At 2.4 dx the error moves by tenths of a per cent from one dx to the next with no trend towards zero, while the
    estimator, the settling and the sign move it by hundredths: the particle sums' error at that reach depends on
    the arrangement each resolution relaxes to. At 2.8 dx it changes monotonically with dx and converges (+0.13 % at
    dx = 0.01, ``bench/results/standing_wave_limit.md``).

Usage
    python bench/wcsph/standing_wave_resolution.py            # about an hour on 2 quiet cores, one run at a time
    python bench/wcsph/standing_wave_resolution.py --fine     # adds dx = 0.01 at 2.4 dx: about 40 min more
Writes bench/results/standing_wave_resolution.{json,md}. A run whose summary.json is already in ``--work`` (made by
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
sys.path[:0] = [str(_HERE.parent)]  # bench/ (common.py)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "an hour of runs on 2 cores; run it by hand (its results are kept in bench/results)"

DX = [0.04, 1.0 / 30.0, 0.025, 0.02]
#: (dx m, h/dx, settle periods, periods, reversed start, nudge: the run's dx is dx (1 + nudge))
PLAN = ([(dx, 2.4, 3.0, 8.0 if dx in (0.04, 0.02) else 3.0, False, 0.0) for dx in DX]
        + [(dx, 2.8, 3.0, 3.0, False, 0.0) for dx in DX]
        + [(dx, 2.4, settle, 3.0, False, 0.0) for dx in DX[:2] for settle in (2.0, 4.0)]
        + [(0.02, 2.4, 2.0, 3.0, False, 0.0), (0.02, 2.8, 2.0, 3.0, False, 0.0), (0.02, 2.4, 3.0, 3.0, True, 0.0)]
        + [(dx, 2.8, 3.0, 3.0, False, nudge) for dx in DX[1:] for nudge in (-1e-8, 1e-8)]
        + [(0.02, 2.4, 3.0, 3.0, False, 1e-8)])
FINE = [(0.01, 2.4, 3.0, 3.0, False, 0.0)]


def wall_layers(h_factor: float) -> int:
    """The fewest wall layers that cover the Wendland support 2h of the fluid row dx/2 from a wall."""
    return math.ceil(2.0 * h_factor - 0.5 - 1e-9)


def run_name(dx, h_factor, settle, periods, reverse, nudge) -> str:
    return (f"dx{dx:.4g}_h{h_factor:g}_s{settle:g}_p{periods:g}" + ("_reversed" if reverse else "")
            + (f"_nudge{nudge:+g}" if nudge else ""))


def one(out: str, dx: float, h_factor: float, settle: float, periods: float, reverse: bool) -> None:
    """One run of the scene into ``out`` (a worker process: ``reverse`` swaps the sign of linear theory's start)."""
    from warpfree import device
    from warpfree.scene_loader import load_scene
    from warpfree.validation import standing_wave_2d as linear

    if reverse:
        forward = linear.initial_velocity
        linear.initial_velocity = lambda *a, **k: -forward(*a, **k)
    device.use("cpu", 1)
    run = load_scene("standing_wave_2d").build(dx=dx, h_factor=h_factor, wall_layers=wall_layers(h_factor),
                                               settle_periods=settle, periods=periods, frames=False, vtk=False)
    run.run(out, progress=False)


def fits(summary: dict) -> dict:
    """The scene's fit over the first 3 periods, over [0, n] periods and over each 3-period window."""
    from warpfree.validation import standing_wave_2d as linear

    t = np.asarray(summary["probes"]["time"])
    x = np.asarray(summary["probes"]["centre_of_mass_x"])
    omega = summary["analysis"]["standing_wave"]["omega_linear"]
    period = 2.0 * math.pi / omega
    recorded = t[-1] / period

    p = summary["params"]
    expected = linear.centre_of_mass_amplitude(p["amplitude"], p["length"], p["depth"])

    def fit(a, b):
        sel = (t >= a * period - 1e-9) & (t <= b * period + 1e-9)
        f = linear.fit_damped_oscillation(t[sel] - a * period, x[sel], omega)
        return {"frequency_error": f["omega"] / omega - 1.0, "decay_rate": f["beta"],
                "amplitude_ratio": f["amplitude"] / expected, "fit_residual": f["relative_residual"]}

    out = {"first_3": fit(0.0, 3.0), "recorded_periods": recorded}
    if recorded > 3.5:
        out["spans"] = {n: fit(0.0, n)["frequency_error"] for n in range(2, int(recorded + 1e-6) + 1)}
        out["windows"] = [(a, fit(a, a + 3.0)["frequency_error"]) for a in np.arange(0.0, recorded - 2.999, 0.5)]
    return out


def markdown(result: dict) -> str:
    runs = result["runs"]
    main = [r for r in runs if r["settle"] == 3.0 and not r["reversed"] and not r["nudge"]]
    dxs = sorted({r["dx"] for r in main}, reverse=True)
    cell = {(r["dx"], r["h_factor"]): r for r in main}
    rows = []
    for h in (2.4, 2.8):
        rows.append([f"{h:g} dx"] + [f"{100 * cell[(dx, h)]['first_3']['frequency_error']:+.2f} %"
                                     if (dx, h) in cell else "" for dx in dxs])
    lines = ["# Standing wave: frequency error against dx at a fixed h/dx", "",
             f"Machine: {result['machine'].get('cpu')}. L = 1 m, d = 0.5 m, A = 0.01 m, relaxed and settled 3 periods, "
             "fitted over the first 3 periods (`bench/wcsph/standing_wave_resolution.py`). At 2.8 dx, dx = 0.01 m: "
             "+0.13 % (`standing_wave_limit.md`). The summary rows are the runs settled 3 periods, not reversed, not "
             "nudged.", "",
             common.md_table(["h"] + [f"dx = {dx:.3g} m" for dx in dxs], rows), "",
             "Every run, first 3 periods:", "",
             common.md_table(["dx (m)", "h/dx", "settled (periods)", "start", "dx nudged by", "frequency error",
                              "decay (1/s)", "amplitude ratio", "fit rms"],
                             [[f"{r['dx']:.3g}", r["h_factor"], r["settle"],
                               "reversed" if r["reversed"] else "linear theory's",
                               f"{r['nudge']:+g}" if r["nudge"] else "",
                               f"{100 * r['first_3']['frequency_error']:+.3f} %", f"{r['first_3']['decay_rate']:.3f}",
                               f"{r['first_3']['amplitude_ratio']:.3f}", f"{100 * r['first_3']['fit_residual']:.2f} %"]
                              for r in runs]), ""]
    for r in runs:
        if "spans" in r:
            lines += [f"Estimator, dx = {r['dx']:.3g} m, {r['h_factor']:g} dx, {r['recorded_periods']:.0f} periods "
                      "recorded: fitted over [0, n] periods "
                      + ", ".join(f"n = {n}: {100 * v:+.3f} %" for n, v in r["spans"].items())
                      + "; over 3 periods from t = a periods: "
                      + ", ".join(f"{a:g}: {100 * v:+.2f} %" for a, v in r["windows"]), ""]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--fine", action="store_true", help="add dx = 0.01 m at h = 2.4 dx")
    p.add_argument("--work", default=str(common.BENCH / "work" / "standing_wave_resolution"))
    p.add_argument("--one", nargs=6, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one:
        out, dx, h, settle, periods, reverse = args.one
        one(out, float(dx), float(h), float(settle), float(periods), reverse == "1")
        return 0
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    runs = []
    for dx, h_factor, settle, periods, reverse, nudge in PLAN + (FINE if args.fine else []):
        out = work / run_name(dx, h_factor, settle, periods, reverse, nudge)
        if not (out / "summary.json").exists():
            subprocess.run([common.PYTHON, __file__, "--one", str(out), repr(dx * (1.0 + nudge)), repr(h_factor),
                            repr(settle), repr(periods), "1" if reverse else "0"], check=True,
                           stdout=subprocess.DEVNULL)
        summary = json.loads((out / "summary.json").read_text())
        runs.append({"dx": dx, "h_factor": h_factor, "settle": settle, "periods": periods, "reversed": reverse,
                     "nudge": nudge, **fits(summary)})
        print(f"  dx {dx:.3g} h {h_factor:g} settle {settle:g}{' reversed' if reverse else ''}"
              f"{f' nudged {nudge:+g}' if nudge else ''}: {100 * runs[-1]['first_3']['frequency_error']:+.3f} %",
              flush=True)
    result = {"machine": common.machine_info(), "runs": runs}
    common.write_results("standing_wave_resolution", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
