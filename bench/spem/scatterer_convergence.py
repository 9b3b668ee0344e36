"""The dielectric cylinder's near field against the Bessel series by resolution: the averaged interface against the
staircase.

What it measures
    ``scenes/em_scatterer_2d.py`` (εr = 4, k0 a = 2.5, 30 periods, DFT over the last 4) at 10 to 80 particles per
    wavelength in the dielectric, each with ``interface=average`` (each particle's cell mean) and ``interface=centre``
    (the permittivity at the particle: a staircase): the relative L2 error of the complex amplitude on the ring r = 1.5 a
    and on the two lines through the centre, the order between successive resolutions, and the wall time of each run
    (set-up and stepping, one thread).

Usage
    python bench/spem/scatterer_convergence.py            # about 10 minutes on one core
    python bench/spem/scatterer_convergence.py --quick    # 10 to 40 only
Writes bench/results/scatterer_convergence[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent)]  # bench/ (common.py)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

RESOLUTIONS = (10, 20, 25, 40, 80)


def one(resolution: float, interface: str) -> dict:
    from warpfree import device
    from warpfree.scene_loader import load_scene

    device.use("cpu", 1)
    start = time.perf_counter()
    run = load_scene("em_scatterer_2d").build(particles_per_wavelength=resolution, interface=interface, frames=False,
                                              vtk=False)
    summary = run.run(None, progress=False)
    result = summary["analysis"]["scatterer"]
    return {"particles_per_wavelength": resolution, "interface": interface, "ring_error": result["ring_error"],
            "line_error": result["line_error"], "ring_phase_error": result["ring_phase_error"],
            "particles": run.solver.work_items, "wall_s": time.perf_counter() - start}


def markdown(result: dict) -> str:
    rows = []
    for interface in ("average", "centre"):
        runs = [r for r in result["runs"] if r["interface"] == interface]
        for k, r in enumerate(runs):
            order = ""
            if k:
                p = runs[k - 1]
                order = f"{math.log(p['ring_error'] / r['ring_error']) / math.log(r['particles_per_wavelength'] / p['particles_per_wavelength']):.2f}"
            rows.append([interface, f"{r['particles_per_wavelength']:g}", f"{r['particles']:,}",
                         f"{100 * r['ring_error']:.3f} %", f"{100 * r['line_error']:.3f} %", order,
                         f"{r['ring_phase_error']:.4f}", f"{r['wall_s']:.1f}"])
    return "\n".join([
        "# Dielectric cylinder (εr = 4, k0 a = 2.5): near field against the Bessel series by resolution", "",
        f"Machine: {result['machine'].get('cpu')}, one thread. `scenes/em_scatterer_2d.py` at its defaults but the "
        "resolution (λ/Δ in the dielectric) and the interface; errors: relative L2 of the complex amplitude (amplitude "
        "and phase) on the ring r = 1.5 a and on the lines through the centre; order: of the ring error between this "
        "resolution and the previous; phase: the ring's largest phase error (rad) where |Ez| is at least half its mean.",
        "", common.md_table(["interface", "λ/Δ", "E and H particles", "ring", "lines", "order", "phase (rad)",
                             "wall (s)"], rows), ""]) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="10 to 40 particles per wavelength only")
    args = p.parse_args(argv)
    resolutions = [r for r in RESOLUTIONS if not args.quick or r <= 40]
    runs = [one(r, interface) for interface in ("average", "centre") for r in resolutions]
    result = {"runs": runs, "machine": common.machine_info()}
    common.write_results("scatterer_convergence", result, markdown(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
