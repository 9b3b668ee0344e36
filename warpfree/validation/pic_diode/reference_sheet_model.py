"""The planar diode by the one-dimensional sheet model: the script that wrote ``sheet_model.csv``, the time-averaged
flux a cold injected beam carries through the diode above its space-charge limit.

Normalised units as the scene's (ε0 = 1, electron charge -1, mass 1). Electrons are sheets of areal number density
w between the cathode (y = 0, φ = 0) and the anode (y = d, φ = V), infinite in x and z: no grid, no shape functions.
Gauss's law gives the field exactly (Dawson 1962, Phys. Fluids 5, 445; Birdsall & Langdon, Plasma Physics via
Computer Simulation, ch. 3): φ'' = n, so φ' jumps by w across each sheet,

    φ'(y) = g0 + w N(< y),   g0 = (V - w Σ_k (d - y_k)) / d     (φ(d) - φ(0) = V),

where N(< y) counts the sheets below y. A sheet's acceleration is φ' (charge -1, mass 1) at its own position, the
mean of the two sides, g0 + w (r_k + ½) for the sheet of rank r_k: no self-force. Leapfrog, v^{n+1/2} = v^{n-1/2}
+ φ'(y^n) Δt, y^{n+1} = y^n + v^{n+1/2} Δt; a sheet that reaches y < 0 or y >= d is absorbed and tallied. The
cathode injects ``sheets_per_step`` sheets a step (the fractional part carried over) at speed v0, each a distance
v0 Δt U inside (U uniform in [0, 1)), so the injected flux is Γ = w sheets_per_step / Δt: the scene's injection
(``warpfree.solvers.pic.injection``) in one dimension. The transmitted flux is the anode's tally over the averaging
window divided by its length; its spread, the standard deviation of the same over windows of 2 time units.

Above Γ_max (``beam_through_limit``) a virtual cathode forms close to the cathode and oscillates: the flux it passes
varies over windows of 2 time units by ±1 % about a mean above the steady virtual cathode's
(``virtual_cathode_transmitted_flux``: 1.0115 Γ_CL at V = 2.5, d = 1.5, v0 = 0.1, Γ = 3 Γ_CL, against 1.051 here).
The mean is converged in Δt (below 0.005) and in the sheet weight; ``README.md`` gives the figures.

Rerun (the shipped file, about 5 minutes on one core):

    python -m warpfree.validation.pic_diode.reference_sheet_model --csv warpfree/validation/pic_diode/sheet_model.csv

float64 throughout; NumPy, vectorised over the sheets of a step (one sort a step for the ranks).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

__all__ = ["transmitted_flux", "CASES", "COLUMNS"]

#: (V, d, v0, Γ/Γ_CL) of the shipped file's rows
CASES = [(2.5, 1.5, 0.1, 3.0), (2.5, 1.5, 0.05, 3.0), (2.5, 1.5, 0.02, 3.0), (1.0, 1.0, 0.1, 2.0), (1.0, 1.0, 0.1, 3.0)]
#: the shipped file's columns
COLUMNS = ["voltage", "gap", "injection_speed", "injected_fraction", "dt", "sheets_per_step", "t_end", "average_from",
           "transmitted_over_child_langmuir", "window_std", "returned_over_child_langmuir"]


def transmitted_flux(voltage: float, gap: float, injection_speed: float, injected_fraction: float, dt: float = 0.0025,
                     sheets_per_step: float = 20.0, t_end: float = 100.0, average_from: float | None = None,
                     window: float = 2.0, seed: int = 1) -> dict:
    """The sheet model's run: the anode's and the cathode's fluxes over Γ_CL averaged from ``average_from``
    (default t_end / 2) to ``t_end``, and the standard deviation of the anode's over windows of ``window``."""
    v, d, v0 = float(voltage), float(gap), float(injection_speed)
    child = 4.0 / 9.0 * math.sqrt(2.0) * v ** 1.5 / d ** 2
    flux = injected_fraction * child
    w = flux * dt / sheets_per_step
    rng = np.random.default_rng(seed)
    y = np.zeros(0)
    u = np.zeros(0)
    steps = int(round(t_end / dt))
    anode = np.zeros(steps + 1, dtype=np.int64)
    cathode = np.zeros(steps + 1, dtype=np.int64)
    carry = 0.0
    for n in range(steps):
        if y.size:
            order = np.argsort(y, kind="stable")
            slope = np.empty_like(y)
            slope[order] = (v - w * np.sum(d - y)) / d + w * (np.arange(y.size) + 0.5)
            u = u + slope * dt
            y = y + u * dt
        up, down = y >= d, y < 0.0
        anode[n + 1] = anode[n] + int(np.count_nonzero(up))
        cathode[n + 1] = cathode[n] + int(np.count_nonzero(down))
        keep = ~(up | down)
        carry += sheets_per_step
        new = int(carry)
        carry -= new
        y = np.concatenate([y[keep], v0 * dt * rng.random(new)])
        u = np.concatenate([u[keep], np.full(new, v0)])
    start = int(round((0.5 * t_end if average_from is None else average_from) / dt))
    span = (steps - start) * dt
    edges = np.arange(start, steps + 1, int(round(window / dt)))
    windows = np.diff(anode[edges]) * w / window / child
    return {"transmitted_over_child_langmuir": float((anode[-1] - anode[start]) * w / span / child),
            "window_std": float(np.std(windows)),
            "returned_over_child_langmuir": float((cathode[-1] - cathode[start]) * w / span / child),
            "sheets": int(y.size)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--csv", help="write the table here")
    p.add_argument("--dt", type=float, default=0.0025)
    p.add_argument("--sheets-per-step", type=float, default=20.0)
    p.add_argument("--t-end", type=float, default=100.0)
    args = p.parse_args(argv)
    rows = []
    for case in CASES:
        start = time.perf_counter()
        r = transmitted_flux(*case, dt=args.dt, sheets_per_step=args.sheets_per_step, t_end=args.t_end)
        rows.append([*case, args.dt, args.sheets_per_step, args.t_end, 0.5 * args.t_end,
                     r["transmitted_over_child_langmuir"], r["window_std"], r["returned_over_child_langmuir"]])
        print(", ".join(f"{c} = {x:.6g}" for c, x in zip(COLUMNS, rows[-1])), f"({time.perf_counter() - start:.0f} s)",
              flush=True)
    if args.csv:
        with open(args.csv, "w") as f:
            f.write(", ".join(COLUMNS) + "\n")
            for row in rows:
                f.write(", ".join(f"{x:.10g}" for x in row) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
