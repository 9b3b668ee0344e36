"""Impact pressure on a wall: the 2D dam break of Buchner (2002) through a pressure sensor, against the experiment.

What it measures
    The shipped ``dam_break_2d`` scene in Buchner's geometry (a column H = 0.6 m high and 2H wide, a tank 5.366 H =
    3.22 m long, 1.5 m high) run to t = 2 s (T = t sqrt(g/H) = 8.1) at each ``--dx``, with the command line's panel
    sensor P1: the mean wall pressure over ten points of the wall's face from y = 0.07 to 0.16 m, a transducer face
    0.09 m tall with its top at the experiment's middle, as the reference codes read it (Greco's shift, Adami et al.
    2012; TrixiParticles.jl's set-up), every 1 ms, against Buchner's P1 (``warpfree/validation/dam_break_2d``,
    TrixiParticles.jl's digitisation), everything in T and p/(ρ g H):

    * arrival: the first 5 ms mean above 0.05 ρ g H (the experiment's rule: its first point above 0.05, T = 2.47);
    * the mean over T = 2.6-3.0 (the experiment's is about 0.63) and the lowest 5 ms mean there;
    * the mean over T = 3.0-4.0, the run-up's quasi-steady pressure between the peaks (the experiment's 0.56);
    * the first and second peaks of the 5 ms running mean (a transducer averages over its face), T <= 4 and 5-6.5;
    * the rms difference of the 5 ms mean from the experiment's points (T <= 7.3);
    * the noise: the rms of p minus its 50 ms running mean over T = 3.5-5 (the quasi-steady stretch);
    * the front before the impact against a reference simulation (TrixiParticles.jl's WCSPH at H/40,
      ``BUCHNER_FRONT_TRIXIPARTICLES``): the difference of the fronts' advance x(t) - x(0) at t = 0.4 and 0.58 s.

    python bench/wcsph/buchner_pressure.py [--dx 0.03,0.02,0.01] [--threads 2] [--variant "name=value ..."]...

Each ``--variant`` (scene settings, space-separated; ``default`` for none) is run at every ``--dx``, side by side.
Writes bench/results/buchner_pressure.{json,md,png}.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402

from warpfree.validation import running_mean  # noqa: E402
from warpfree.validation.dam_break_2d import (BUCHNER_FRONT_TRIXIPARTICLES, BUCHNER_P1, BUCHNER_P1_FACE,  # noqa: E402
                                              BUCHNER_P1_FIGURES, BUCHNER_TANK_LENGTH, wall_pressure_figures)

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--dx", "0.03,0.02,0.01", "--variant", "default", "--variant", "riemann=3 alpha=0", "--variant",
            "tension=false", "--variant", "riemann=3 alpha=0 tension=false", "--variant",
            "riemann=3 alpha=0 delta_gradient=true"]]

H, WIDTH, LENGTH, G, RHO0 = 0.6, 1.2, 3.22, 9.81, 1000.0
#: the transducer's face on the wall: ten points over BUCHNER_P1_FACE (its top at the experiment's middle), as the
#: scene dam_break_wall_2d reads it
FACE = [(BUCHNER_TANK_LENGTH, round(float(y), 4)) for y in np.linspace(BUCHNER_P1_FACE[1], BUCHNER_P1_FACE[0], 10)]
SENSOR = "P1=panel:" + ";".join(f"{x},{y}" for x, y in FACE) + "@0.001"
T_END = 2.0


def run_case(dx: float, threads: int, settings: tuple = ()) -> dict:
    """One run of the scene with the sensor (and ``settings``, more ``name=value`` of the scene); its rows (t, p) and
    the run's step time."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        args = [sys.executable, "-m", "warpfree", "run", "dam_break_2d", "--set", f"a={WIDTH}",
                "--set", f"column_height={H / WIDTH}", "--set", f"tank_length={LENGTH / WIDTH!r}",
                "--set", "tank_height=1.25", "--set", f"dx={dx}", "--set", f"t_end={T_END}",
                "--set", "output_interval=0.02", "--set", "vtk=false", "--no-frames", "--no-progress",
                "--threads", str(threads), "--sensor", SENSOR, "--out", str(out)]
        args += [a for setting in settings for a in ("--set", setting)]
        done = subprocess.run(args, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"dx = {dx}: {done.stderr.strip().splitlines()[-1:]}")
        rows = np.loadtxt(out / "sensors" / "P1.csv", delimiter=",", skiprows=1)
        import json

        summary = json.loads((out / "summary.json").read_text())
    return {"dx": dx, "settings": list(settings), "t": rows[:, 0].tolist(), "p": rows[:, 1].tolist(),
            "front_t": summary["probes"]["time"], "front": summary["probes"]["front"], "steps": summary["steps"],
            "step_s": summary["phases_s"]["step"], "particles": summary["model"]["n_particles"]}


def figures(case: dict) -> dict:
    """The comparison's numbers (T and p/(ρ g H)) of one run: the validation's (``wall_pressure_figures``: arrival,
    means, peaks, named as in the table) and the benchmark's own (the lowest 5 ms mean over the impact, the rms
    difference from the experiment's points, the noise, the front against the reference run)."""
    T = np.asarray(case["t"]) * np.sqrt(G / H)
    p = np.asarray(case["p"]) / (RHO0 * G * H)
    per_ms = 1.0e-3 * np.sqrt(G / H)  # one sample in T
    mean5, mean50 = running_mean(T, p, 5 * per_ms), running_mean(T, p, 50 * per_ms)
    early, quiet = (T >= 2.6) & (T <= 3.0), (T >= 3.5) & (T <= 5.0)
    exp_T, exp_p = BUCHNER_P1[:, 0], BUCHNER_P1[:, 1]
    inside = exp_T <= T[-1]
    rms = float(np.sqrt(np.mean((np.interp(exp_T[inside], T, mean5) - exp_p[inside]) ** 2)))
    ref_t, ref_x = BUCHNER_FRONT_TRIXIPARTICLES[:, 0], BUCHNER_FRONT_TRIXIPARTICLES[:, 1]
    front_t, front = np.asarray(case["front_t"]), np.asarray(case["front"])
    lag = {when: float(np.interp(when, front_t, front) - front[0] - (np.interp(when, ref_t, ref_x) - ref_x[0]))
           for when in (0.4, 0.58)}
    return {**named(wall_pressure_figures(T, p, smoothing=5 * per_ms)),
            "lowest_5ms_2.6_3.0": float(mean5[early].min()),
            "rms_vs_experiment": rms, "noise_rms": float(np.sqrt(np.mean((p - mean50)[quiet] ** 2))),
            "front_vs_reference_0.4": lag[0.4], "front_vs_reference_0.58": lag[0.58],
            "sample_T": per_ms}


def named(figures: dict) -> dict:
    """``wall_pressure_figures``' figures under the names of this benchmark's table (its windows in T)."""
    names = {"arrival": "arrival_T", "mean_impact": "mean_2.6_3.0", "mean_run_up": "mean_3.0_4.0"}
    return {names.get(k, k): v for k, v in figures.items()}


def compact(case: dict) -> dict:
    """The case as stored: its 5 ms running mean every 5 ms (t, p) in place of the 1 kHz samples, and the front."""
    t, p = np.asarray(case["t"]), np.asarray(case["p"])
    keep = slice(2, None, 5)
    return {**case, "t": np.round(t[keep], 4).tolist(), "p": np.round(running_mean(t, p, 0.005)[keep], 1).tolist(),
            "series": "5 ms running mean every 5 ms"}


def markdown(result: dict) -> str:
    exp = result["experiment"]
    lines = ["# Impact pressure at Buchner's P1 (2D dam break, H = 0.6 m)", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The shipped "
             f"`dam_break_2d` scene in Buchner's geometry with the panel sensor P1 (the mean wall pressure over ten "
             f"points from y = 0.07 to 0.16 m on the wall x = 3.22 m: a face 0.09 m tall with its top at the "
             f"experiment's middle, as the reference codes place it), to t = {T_END} s; T = t sqrt(g/H), "
             "pressures in ρ g H; 5 ms running means for the peaks.", ""]
    rows = [["experiment (Buchner 2002)", "", f"{exp['arrival_T']:.2f}", f"{exp['mean_2.6_3.0']:.2f}", "",
             f"{exp['mean_3.0_4.0']:.2f}", f"{exp['peak1']:.3f} at {exp['peak1_T']:.2f}",
             f"{exp['peak2']:.3f} at {exp['peak2_T']:.2f}", "", "", ""]]
    for c in result["cases"]:
        f = c["figures"]
        rows.append([f"dx = {c['dx']} m ({c['particles']} particles, {c['steps']} steps, {c['step_s']:.0f} s)",
                     " ".join(c["settings"]) or "defaults",
                     common.fmt(f["arrival_T"]), common.fmt(f["mean_2.6_3.0"]), common.fmt(f["lowest_5ms_2.6_3.0"]),
                     common.fmt(f["mean_3.0_4.0"]),
                     f"{f['peak1']:.3f} at {f['peak1_T']:.2f}", f"{f['peak2']:.3f} at {f['peak2_T']:.2f}",
                     common.fmt(f["rms_vs_experiment"]), common.fmt(f["noise_rms"]),
                     f"{100 * f['front_vs_reference_0.4']:+.1f} / {100 * f['front_vs_reference_0.58']:+.1f}"])
    lines += [common.md_table(["", "settings", "arrival T", "mean T 2.6-3.0", "lowest 5 ms mean there",
                               "mean T 3.0-4.0", "peak 1 (5 ms)",
                               "peak 2 (5 ms)", "rms vs experiment", "noise rms (T 3.5-5)",
                               "front vs reference at t = 0.4 / 0.58 s (cm)"], rows), "",
              "The arrival is the first time the pressure passes 0.05 ρ g H: the experiment's first point above it "
              "(its rise starts between T = 2.45 and 2.49), a run's first 5 ms mean above it. The noise is p minus its "
              "50 ms running mean, rms, over the quasi-steady T = 3.5-5. The front column: the run's front advance "
              "x(t) - x(0) minus that of TrixiParticles.jl's WCSPH run at H/40 (a reference simulation, "
              "warpfree/validation/dam_break_2d/README.md), before either reaches the wall.", ""]
    return "\n".join(lines)


def plot(result: dict, variants: list[tuple]):
    """One panel per variant: each spacing's 5 ms mean against the experiment's points."""
    exp_T, exp_p = BUCHNER_P1[:, 0], BUCHNER_P1[:, 1]
    cases = result["cases"]
    fig, axes = common.new_figure(nrows=len(variants), figsize=(8, 3.2 * len(variants)), squeeze=False,
                                  layout="constrained")
    for ax, settings in zip(axes[:, 0], variants):
        for c in (c for c in cases if tuple(c["settings"]) == settings):
            T = np.asarray(c["t"]) * np.sqrt(G / H)
            ax.plot(T, np.asarray(c["p"]) / (RHO0 * G * H), lw=0.8, label=f"dx = {c['dx']} m (5 ms mean)")
        ax.plot(exp_T, exp_p, "k.", ms=4, label="Buchner 2002 (P1)")
        ax.set_xlim(2.0, 8.1)
        ax.set_xlabel("T = t sqrt(g/H)")
        ax.set_ylabel("p / (ρ g H)")
        ax.set_title("Wall pressure at P1, 2D dam break (H = 0.6 m): " + (" ".join(settings) or "scene defaults"),
                     fontsize=9)
        ax.legend(fontsize=7)
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    common.add_variant_sweep(p, "0.03,0.02,0.01")
    args = p.parse_args(argv)
    variants, cases = common.variant_sweep(args, run_case, lambda case: compact({**case, "figures": figures(case)}))
    experiment = named(BUCHNER_P1_FIGURES)
    result = {"machine": common.machine_info(), "threads": args.threads, "sensor": SENSOR, "experiment": experiment,
              "cases": cases}
    common.write_results("buchner_pressure", result, markdown(result), plot(result, variants))
    return 0


if __name__ == "__main__":
    sys.exit(main())
