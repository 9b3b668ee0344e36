"""The cylinder's near field and scattering width against the Bessel series by resolution: a dielectric with the
averaged interface and with the staircase, a perfect conductor cut out and as a staircase, and free space (the
incident wave's own error).

What it measures
    ``scenes/em_scatterer_2d.py`` (k0 a = 2.5, 30 periods, DFT over the last 4) by resolution (particles per
    wavelength in the densest medium): a dielectric (εr = 4) with ``interface=average`` (each particle's cell mean),
    with Fang's fourth-order difference (``order=4``) and Yee's (``order=2``), and ``interface=centre`` (the
    permittivity at the particle: a staircase); a perfect conductor cut out with a held row
    on its surface (``average``) and as the lattice's particles inside held (``centre``); and εr = 1 (no scatterer:
    the error of the incident wave alone). Per run: the relative L2 error of the complex amplitude on the ring
    r = 1.5 a and on the two lines through the centre, the order of the ring error from the previous resolution, the
    scattering width's error and the wall time (set-up and stepping, one thread).

Usage
    python bench/spem/scatterer_convergence.py            # about 9 minutes on one core
    python bench/spem/scatterer_convergence.py --quick    # up to 40 particles per wavelength
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

#: (label, scene settings, resolutions)
CASES = [("dielectric, averaged, order 4", {"order": 4}, (10, 14, 20, 28, 40, 56)),
         ("dielectric, averaged, order 2", {"order": 2}, (10, 20, 25, 40, 80)),
         ("dielectric, staircase, order 2", {"interface": "centre", "order": 2}, (10, 20, 25, 40, 80)),
         ("conductor, surface row", {"cylinder": "conductor"}, (20, 24, 28, 32, 40, 48, 56, 64, 80)),
         ("conductor, staircase", {"cylinder": "conductor", "interface": "centre"}, (20, 40)),
         ("free space (εr = 1), order 4", {"eps_r": 1.0, "order": 4}, (20, 28, 40)),
         ("free space (εr = 1), order 2", {"eps_r": 1.0, "order": 2}, (20, 28, 40, 56))]


def one(resolution: float, settings: dict) -> dict:
    from warpfree import device
    from warpfree.scene_loader import load_scene

    device.use("cpu", 1)
    start = time.perf_counter()
    run = load_scene("em_scatterer_2d").build(particles_per_wavelength=resolution, frames=False, vtk=False, **settings)
    summary = run.run(None, progress=False)
    result = summary["analysis"]["scatterer"]
    return {"particles_per_wavelength": resolution, "settings": settings, "ring_error": result["ring_error"],
            "line_error": result["line_error"], "ring_phase_error": result["ring_phase_error"],
            "scattering_width_error": result["scattering_width_error"], "particles": run.solver.work_items,
            "wall_s": time.perf_counter() - start}


def markdown(result: dict) -> str:
    rows = []
    for label, runs in result["cases"].items():
        for k, r in enumerate(runs):
            order = ""
            if k:
                p = runs[k - 1]
                order = (f"{math.log(p['ring_error'] / r['ring_error']) / math.log(r['particles_per_wavelength'] / p['particles_per_wavelength']):.2f}")
            free = label.startswith("free")
            rows.append([label, f"{r['particles_per_wavelength']:g}", f"{r['particles']:,}",
                         f"{100 * r['ring_error']:.3f} %", f"{100 * r['line_error']:.3f} %", order,
                         "" if free else f"{100 * r['scattering_width_error']:+.2f} %", f"{r['ring_phase_error']:.4f}",
                         f"{r['wall_s']:.1f}"])
    return "\n".join([
        "# Cylinder (k0 a = 2.5) in a plane wave: near field and scattering width against the Bessel series", "",
        f"Machine: {result['machine'].get('cpu')}, one thread. `scenes/em_scatterer_2d.py` at its defaults but the "
        "cylinder, the interface and the resolution (λ/Δ in the densest medium); errors: relative L2 of the complex "
        "amplitude (amplitude and phase) on the ring r = 1.5 a and on the lines through the centre; order: of the ring "
        "error from the previous resolution; width: the scattering width's relative error; phase: the ring's largest "
        "phase error (rad) where |Ez| is at least half its mean.", "",
        common.md_table(["case", "λ/Δ", "E and H particles", "ring", "lines", "order", "width", "phase (rad)",
                         "wall (s)"], rows), ""]) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="up to 40 particles per wavelength")
    args = p.parse_args(argv)
    cases = {label: [one(r, settings) for r in resolutions if not args.quick or r <= 40]
             for label, settings, resolutions in CASES}
    result = {"cases": cases, "machine": common.machine_info()}
    common.write_results("scatterer_convergence", result, markdown(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
