"""The plane wave's leakage and box error against the phase lag Yee's dispersion predicts, over box sizes and densities.

What it measures
    ``scenes/em_plane_wave_2d.py`` (3.6 GHz, uniform layout, PML 12 spacings, to 2 ns or until the wave has crossed a
    larger box) for square boxes of 0.2 to 0.7 m and 20 to 80 particles per wavelength, at 0°, 30° and 45° and on both
    H staggerings: the largest |Ez - Ez_inc| / A in the total-field box at the end, the largest |Ez| / A in the
    scattered region over the outputs (and where: beyond the exit, beside the box, before the entry), against the
    scene's prediction 2 sin(δφ/2), δφ the lag the uniform layout's dispersion gives over the longest path the wave
    travels in the box (``warpfree/solvers/spem/dispersion.py``).

    Beside it, a paraxial model of the same error (``edge_factor``): with the discrete wave slower than the analytic
    one by δk, the difference e between them obeys ∂e/∂y = (i/2k) ∂²e/∂x² + i δk A χ(x) inside the box (χ = 1 across
    its width, 0 outside) and the free equation beyond it; its largest |e| over A δk L, in the box and beyond its
    exit, is the factor by which the diffraction of the box's side edges raises the error above the plane lag.

Usage
    python bench/spem/plane_wave_leakage.py            # about 3 minutes on 2 quiet cores
    python bench/spem/plane_wave_leakage.py --quick    # the 0.2 m boxes only
Writes bench/results/plane_wave_leakage[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent)]  # bench/ (common.py)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

#: scene settings of each run; t_end 2 ns unless a larger box needs longer for the wave to cross it
CASES = [dict(size=0.2, margin=0.03), dict(size=0.2, margin=0.03, particles_per_wavelength=20.0),
         dict(size=0.2, margin=0.03, particles_per_wavelength=80.0), dict(size=0.2, margin=0.03, angle=30.0),
         dict(size=0.3, margin=0.04), dict(size=0.5, margin=0.05), dict(size=0.7, margin=0.05, t_end=2.8e-9),
         dict(size=0.5, margin=0.05, particles_per_wavelength=30.0),
         dict(size=0.5, margin=0.05, particles_per_wavelength=56.0),
         dict(size=0.5, margin=0.05, particles_per_wavelength=80.0),
         dict(size=0.5, margin=0.05, angle=30.0), dict(size=0.5, margin=0.05, angle=45.0),
         dict(size=0.5, margin=0.05, h_staggering="centres"),
         dict(size=0.5, margin=0.05, h_staggering="centres", angle=30.0),
         dict(size=0.5, margin=0.05, t_end=1.2e-9)]


def edge_factor(width: float, length: float, beyond: float, nx: int = 8192, dy: float = 0.005) -> tuple:
    """(box, beyond): the paraxial model's largest |e| / (A δk L) in a box ``width`` x ``length`` wavelengths and in
    the ``beyond`` wavelengths past its exit (split-step Fourier in x over width + 40 wavelengths, Strang-split
    source; e to first order in δk, so the factor is geometric)."""
    span = width + 40.0
    x = (np.arange(nx) - nx / 2) * span / nx
    kx = 2 * np.pi * np.fft.fftfreq(nx, span / nx)
    chi = (np.abs(x) <= width / 2).astype(float)
    near = np.abs(x) <= width / 2 + 0.6
    diffract = np.exp(-1j * kx ** 2 / (4 * np.pi) * dy)  # (i/2k) ∂²/∂x² with lengths in wavelengths: 1/2k = 1/4π
    e = np.zeros(nx, complex)
    y, box, past = 0.0, 0.0, 0.0
    while y < length + beyond - 1e-12:
        inside = y < length
        if inside:
            e += 0.5j * dy * chi
        e = np.fft.ifft(np.fft.fft(e) * diffract)
        if inside:
            e += 0.5j * dy * chi
        y += dy
        if y <= length:
            box = max(box, float(np.abs(e)[chi > 0].max()))
        else:
            past = max(past, float(np.abs(e)[near].max()))
    return box / length, past / length


def one(case: dict) -> dict:
    from warpfree import device
    from warpfree.scene_loader import load_scene
    from warpfree.solvers.spem import C0

    device.use("cpu", 1)
    run = load_scene("em_plane_wave_2d").build(frames=False, vtk=False, **case)
    size, margin = case["size"], case["margin"]
    e = run.solver.model.layout.e_position
    x, y, tol = e[:, 0], e[:, 1], 1e-9 * size
    lo, hi = margin - tol, size - margin + tol
    interior = np.all((e[:, :2] >= 0.0) & (e[:, :2] <= size), axis=1)
    beside = (x < lo) | (x > hi)
    regions = {"exit": interior & (y > hi) & ~beside, "sides": interior & beside,
               "entry": interior & (y < lo) & ~beside}
    for name, sel in regions.items():
        run.probes["leak_" + name] = (lambda s_: lambda solver, t: float(np.max(np.abs(
            solver.electric.numpy("ez")[s_]))))(sel)
        run.series["leak_" + name] = []
    summary = run.run(None, progress=False)
    pw = summary["analysis"]["plane_wave"]
    predicted = pw["predicted_lag_error"]
    out = {"case": case, "particles_per_wavelength": pw["particles_per_wavelength"],
           "courant_number": pw["courant_number"], "travel_wavelengths": pw["travel_wavelengths"],
           "predicted": predicted, "max_error": pw["max_error"], "max_leakage": pw["max_leakage"],
           "leakage_by_region": {k: max(summary["probes"]["leak_" + k]) for k in regions},
           "passed": {k: c["passed"] for k, c in pw["checks"].items()}}
    out["error_ratio"] = out["max_error"] / predicted
    out["leakage_ratio"] = out["max_leakage"] / predicted
    if case.get("angle", 0.0) == 0.0 and case.get("t_end", 2e-9) >= 2e-9:  # a square box crossed along an axis
        width = (size - 2 * margin) * 3.6e9 / C0
        out["edge_factor"] = edge_factor(width, width, margin * 3.6e9 / C0)
    return out


def markdown(result: dict) -> str:
    rows = []
    for r in result["runs"]:
        c = r["case"]
        label = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in c.items()
                          if k not in ("size", "margin"))
        ef = r.get("edge_factor")
        rows.append([f"{c['size']:g}", label or "default density, 0°", f"{r['travel_wavelengths']:.2f}",
                     f"{r['particles_per_wavelength']:.0f}", f"{r['courant_number']:.3f}",
                     f"{100 * r['predicted']:.3f} %", f"{100 * r['max_error']:.3f} %",
                     f"{100 * r['max_leakage']:.3f} %", f"{r['error_ratio']:.2f}", f"{r['leakage_ratio']:.2f}",
                     f"{ef[0]:.2f} / {ef[1]:.2f}" if ef else "",
                     " / ".join(f"{100 * r['leakage_by_region'][k]:.3f}" for k in ("exit", "sides", "entry")),
                     "pass" if all(r["passed"].values()) else "FAIL"])
    return "\n".join([
        "# Plane wave (TF/SF): leakage and box error against the predicted phase lag", "",
        f"Machine: {result['machine'].get('cpu')}. `scenes/em_plane_wave_2d.py`, 3.6 GHz, uniform layout; predicted: "
        "2 sin(δφ/2), δφ the uniform layout's dispersion lag over the longest path in the box "
        "(`warpfree/solvers/spem/dispersion.py`); the scene's tolerance is 1.5 times it. Paraxial: the edges' "
        "diffraction factor of the model in the script's docstring, in the box / beyond its exit. Leakage by region "
        "(% of A): beyond the exit / beside the box / before the entry.", "",
        common.md_table(["box (m)", "settings", "λ crossed", "λ/Δ", "c Δt/Δ", "predicted", "box error",
                         "leakage", "box / predicted", "leakage / predicted", "paraxial", "exit / sides / entry",
                         "checks"], rows), ""]) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="the 0.2 m boxes only")
    args = p.parse_args(argv)
    runs = []
    for case in CASES:
        if args.quick and case["size"] != 0.2:
            continue
        runs.append(one(case))
        print(f"  {case}: predicted {100 * runs[-1]['predicted']:.3f} %, box {100 * runs[-1]['max_error']:.3f} %, "
              f"leakage {100 * runs[-1]['max_leakage']:.3f} %", flush=True)
    result = {"machine": common.machine_info(), "runs": runs}
    common.write_results("plane_wave_leakage", result, markdown(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
