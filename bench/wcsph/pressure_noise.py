"""The pressure's noise at every output: p minus its local linear fit over 2h, rms over the fluid, in % of ρ g H.

What it measures
    ``scene_tools.pressure_noise`` (the rms over the fluid of p_i - p̂_i, p̂_i the kernel-weighted linear fit of the
    fluid's pressures over twice the smoothing length, exact for a hydrostatic field) at every output of a shipped scene, in per cent of ρ0 g H with H the scene's water depth:
    the tank at rest (``tank_at_rest_2d``, H = its depth), the 2D dam break (``dam_break_2d``, H = its column) and the
    3D dam break (``dam_break_3d``, H = 0.55 m), each at its defaults and with the ``--variant`` settings; and the
    same over the water's body (``pressure_noise(body_only=True)``: the particles whose support the water and the
    walls fill), without the free surface's layer, thin sheets and spray.

    python bench/wcsph/pressure_noise.py [--threads 2] [--variant "name=value ..."]...

Writes bench/results/pressure_noise.{json,md,png}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402

from warpfree import device  # noqa: E402
from warpfree.scene_loader import load_scene  # noqa: E402
from warpfree.solvers.wcsph.scene_tools import BODY_FILLED, filled_support, pressure_noise  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [["--variant", "default", "--variant", "delta_gradient=true", "--variant", "riemann=3 alpha=0",
            "--variant", "riemann=3 alpha=0 tension=false"]]

G, RHO0 = 9.81, 1000.0

#: scene, the settings of its run, its water depth H (m), and whether the fluid variants apply
CASES = [("tank_at_rest_2d", {"output_interval": 0.1}, None, False),
         ("dam_break_2d", {"output_interval": 0.05}, 2.0, True),
         ("dam_break_3d", {"output_interval": 0.05}, 0.55, True)]


def value(text: str):
    """A ``--variant`` value: true/false, an integer, or a float."""
    return {"true": True, "false": False}.get(text, None) if text in ("true", "false") else (
        int(text) if text.lstrip("-").isdigit() else float(text))


def run_case(scene: str, settings: dict, depth: float | None) -> dict:
    """The scene at ``settings`` with the noise as a probe; its times, noise (in ρ0 g H) and particle count."""
    module = load_scene(scene)
    run = module.build(frames=False, vtk=False, **settings)
    if depth is None:  # the tank: its depth is a parameter
        depth = float(run.params["depth"])
    run.probes["pressure_noise"] = lambda solver, t: pressure_noise(solver)
    run.probes["body_noise"] = lambda solver, t: pressure_noise(solver, body_only=True)
    run.probes["body_share"] = lambda solver, t: float(np.mean(filled_support(solver) >= BODY_FILLED))
    for name in ("pressure_noise", "body_noise", "body_share"):
        run.series[name] = []
    summary = run.run(None, progress=False)
    scale = RHO0 * G * depth
    return {"scene": scene, "settings": {k: v for k, v in settings.items() if k != "output_interval"},
            "time": list(map(float, run.series["time"])),
            "noise": (np.asarray(run.series["pressure_noise"]) / scale).tolist(),
            "body_noise": (np.asarray(run.series["body_noise"]) / scale).tolist(),
            "body_share": list(map(float, run.series["body_share"])), "depth": depth,
            "particles": summary["model"]["n_particles"], "steps": summary["steps"]}


def markdown(result: dict) -> str:
    lines = ["# Pressure noise at every output", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores, {result['threads']} threads. The rms "
             "over the fluid of p_i minus its kernel-weighted linear fit over 2h (`scene_tools.pressure_noise`), in % "
             "of ρ0 g H, "
             "at every output of each scene's default run (the settings as listed); and the same over the water's "
             f"body only: the particles whose support the water and the walls fill (Σ V W >= {BODY_FILLED}, "
             "`scene_tools.filled_support`), without the free surface's layer, thin sheets and spray.", ""]
    rows = []
    for c in result["cases"]:
        noise, body = 100.0 * np.asarray(c["noise"]), 100.0 * np.asarray(c["body_noise"])
        t = np.asarray(c["time"])
        k, kb = int(np.argmax(noise)), int(np.argmax(body))
        rows.append([c["scene"], " ".join(f"{k_}={v}" for k_, v in c["settings"].items()) or "defaults",
                     f"{c['depth']:.3g} m", f"{c['particles']}", f"{np.median(noise):.2f} %",
                     f"{noise[k]:.2f} % at t = {t[k]:.2f} s", f"{noise[-1]:.2f} %",
                     f"{100.0 * np.median(c['body_share']):.0f} %", f"{np.median(body):.2f} %",
                     f"{body[kb]:.2f} % at t = {t[kb]:.2f} s"])
    lines += [common.md_table(["scene", "settings", "H", "particles", "median over the outputs", "largest", "last",
                               "body: share of the fluid (median)", "body: median", "body: largest"], rows), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--variant", action="append", default=None,
                   help="fluid settings for the dam breaks, space-separated name=value (default: none); repeatable")
    args = p.parse_args(argv)
    device.use("cpu", args.threads)
    variants = [{} if v.strip() in ("", "default") else {k: value(x) for k, x in (s.split("=") for s in v.split())}
                for v in (args.variant or ["default"])]
    cases = []
    for scene, settings, depth, varied in CASES:
        for extra in (variants if varied else [{}]):
            print(scene, extra, flush=True)
            cases.append(run_case(scene, {**settings, **extra}, depth))
    result = {"machine": common.machine_info(), "threads": args.threads, "cases": cases}
    fig, ax = common.new_figure(figsize=(8, 4.5))
    for c in cases:
        label = c["scene"] + (" " + " ".join(f"{k}={v}" for k, v in c["settings"].items()) if c["settings"] else "")
        line, = ax.plot(c["time"], 100.0 * np.asarray(c["noise"]), lw=0.9, label=label)
        ax.plot(c["time"], 100.0 * np.asarray(c["body_noise"]), lw=0.9, ls=":", color=line.get_color())
    ax.axhline(5.0, color="k", lw=0.5, ls="--")
    ax.set_yscale("log")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("pressure noise (% of ρ0 g H); dotted: the body's")
    ax.legend(fontsize=7)
    common.write_results("pressure_noise", result, markdown(result), fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
