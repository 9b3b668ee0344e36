"""Wave makers against linear theory over resolution: the wave height against Biesel's, the wavelength against the
dispersion relation, and their cost.

What it measures
    The shipped ``wave_flume_2d`` scene at each ``--n`` (particles over the depth) for each ``--paddle``, at its
    defaults otherwise (d = 0.5 m, T = 1.6 s, kd = 1.02, H = 0.05 m, a flume of 15 m; ``--set`` more settings): the
    first-harmonic height at the nine gauges over one wavelength from two depths off the paddle, each against
    Biesel's (the largest difference, the mean ratio, the first and last gauges'), the wavelength from the phases'
    slope against the dispersion relation's, the second harmonic's height, and the stepping time.

    python bench/wcsph/wave_flume.py [--n 12,16,20,30] [--paddle piston] [--threads 2] [--set name=value]...
    python bench/wcsph/wave_flume.py --n 12,16,20 --paddle flap --results wave_flume_flap

Writes bench/results/wave_flume.{json,md,png} (``--results NAME``: another name).
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

from warpfree.validation import wave_flume_2d as theory  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--n", "12,16,20,30", "--paddle", "piston"], ["--n", "12,16,20", "--paddle", "flap", "--results",
                                                                 "wave_flume_flap"]]


def run_case(n: int, paddle: str, threads: int, settings: list[str]) -> dict:
    """One run of the scene: its wave analysis, steps and stepping time."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", "wave_flume_2d", "--set", f"n={n}", "--set",
                f"paddle={paddle}", "--set", "vtk=false", "--no-frames", "--no-progress", "--threads", str(threads),
                "--out", str(out)]
        args += [a for setting in settings for a in ("--set", setting)]
        done = subprocess.run(args, capture_output=True, text=True)
        summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else None
        if summary is None:
            raise RuntimeError(f"n = {n}, {paddle}: {done.stderr.strip().splitlines()[-1:]}")
    waves = summary["analysis"]["waves"]
    keep = ("kd", "gauges", "window", "periods_fitted", "height", "height_ratio", "height_error", "height_theory",
            "wavelength", "wavelength_theory", "wavelength_error", "second_harmonic", "transfer_function")
    return {"n": n, "paddle": paddle, "settings": settings, "particles": summary["model"]["n_particles"],
            "fluid": summary["model"]["n_fluid"], "steps": summary["steps"], "step_s": summary["phases_s"]["step"],
            "waves": {k: waves[k] for k in keep if k in waves},
            "passed": (summary.get("validation") or {}).get("passed")}


def decay(case: dict) -> tuple[float, float]:
    """The case's generated height over Biesel's and its loss of height a wavelength (the gauges' H0 e^(-κx) fit)."""
    w = case["waves"]
    h0, kappa = theory.height_decay(w["gauges"], w["height"])
    return h0 / w["height_theory"], 1.0 - float(np.exp(-kappa * w["wavelength_theory"]))


def markdown(result: dict) -> str:
    lines = ["# Wave makers against linear theory", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             f"`wave_flume_2d` scene (settings: {' '.join(result['settings']) or 'defaults'}: d = 0.5 m, T = 1.6 s, "
             "H = 0.05 m, a 15 m flume), each gauge's first harmonic fitted over the whole periods between the steady "
             "waves' arrival at the last gauge and the far wall's reflection's return; nine gauges over one "
             "wavelength from two depths off the paddle. The height the paddle makes: the gauges' heights fitted by "
             "H0 e^(-κx) at the paddle, against Biesel's transfer function (the scene checks 5 %); the height the "
             "waves lose over a wavelength, 1 - e^(-κL); each gauge's height against Biesel's (the largest "
             "difference, the first and the last gauge's ratio); the wavelength from the phases' slope against the "
             "dispersion relation's (the scene checks 2 %); the second harmonic's height at the first gauge over the "
             "first harmonic's.", ""]
    rows = []
    for c in result["cases"]:
        w = c["waves"]
        ratio = np.asarray(w["height_ratio"])
        made, lost = decay(c)
        passed = abs(made - 1.0) <= theory.HEIGHT_TOLERANCE and w["wavelength_error"] <= theory.WAVELENGTH_TOLERANCE
        rows.append([c["paddle"], f"{c['n']}", f"{c['fluid']}", f"{c['steps']}", f"{c['step_s']:.0f} s",
                     f"{w['periods_fitted']}", f"{made:.4f}", f"{100 * lost:.1f} %",
                     f"{100 * w['height_error']:.2f} %", f"{ratio[0]:.4f}", f"{ratio[-1]:.4f}",
                     f"{w['wavelength']:.4f} m ({w['wavelength_theory']:.4f})", f"{100 * w['wavelength_error']:.2f} %",
                     f"{w['second_harmonic'][0] / w['height'][0]:.3f}", "pass" if passed else "FAIL"])
    lines += [common.md_table(["paddle", "n", "water particles", "steps", "stepping", "periods", "H0/H_Biesel",
                               "lost a wavelength", "largest gauge difference", "first gauge", "last gauge",
                               "wavelength (theory)", "wavelength difference", "H2/H1", "checks"], rows), ""]
    return "\n".join(lines)


def plot(result: dict):
    fig, axes = common.new_figure(figsize=(11, 4.2), ncols=2)
    a1, a2 = axes
    for c in result["cases"]:
        w = c["waves"]
        a1.plot(w["gauges"], w["height_ratio"], "o-", ms=3, lw=1.0, label=f"{c['paddle']}, n = {c['n']}")
    for f in (1 - theory.HEIGHT_TOLERANCE, 1.0, 1 + theory.HEIGHT_TOLERANCE):
        a1.axhline(f, color="k", lw=0.6 if f != 1.0 else 1.0, ls=":" if f != 1.0 else "-")
    a1.set_xlabel("gauge x (m)")
    a1.set_ylabel("H / H_Biesel")
    for paddle in sorted({c["paddle"] for c in result["cases"]}):
        cases = [c for c in result["cases"] if c["paddle"] == paddle]
        n = [c["n"] for c in cases]
        a2.plot(n, [100 * abs(decay(c)[0] - 1.0) for c in cases], "o-", label=f"{paddle}: height made, diff.")
        a2.plot(n, [100 * decay(c)[1] for c in cases], "^:", label=f"{paddle}: height lost a wavelength")
        a2.plot(n, [100 * c["waves"]["wavelength_error"] for c in cases], "s--", label=f"{paddle}: wavelength diff.")
    a2.set_xlabel("particles over the depth n")
    a2.set_ylabel("%")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Wave makers against linear theory (Biesel; the dispersion relation)", fontsize=10)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", default="12,16,20,30", help="particles over the depth, comma-separated")
    p.add_argument("--paddle", default="piston", help="paddles, comma-separated")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--set", action="append", default=[], dest="settings", help="a scene setting name=value")
    p.add_argument("--results", default="wave_flume")
    p.add_argument("--render", action="store_true", help="write the tables and figure again from the results' JSON")
    args = p.parse_args(argv)
    if args.render:
        result = json.loads((common.RESULTS / f"{args.results}.json").read_text())
        common.write_results(args.results, result, markdown(result), plot(result))
        return 0
    cases = []
    for paddle in args.paddle.split(","):
        for n in (int(v) for v in args.n.split(",")):
            print(f"{paddle}, n = {n}", flush=True)
            cases.append(run_case(n, paddle, args.threads, args.settings))
    result = {"machine": common.machine_info(), "threads": args.threads, "settings": args.settings, "cases": cases}
    common.write_results(args.results, result, markdown(result), plot(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
