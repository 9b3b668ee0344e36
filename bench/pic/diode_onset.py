"""The planar diode's onset of reflection against the steady beam-through limit, per node spacing.

What it measures
    For each case (voltage V, gap d, injection speed v0) and node spacing, the injected fraction Γ/Γ_CL at which
    electrons first return to the cathode (``scenes/pic_diode.py`` at its defaults otherwise: width 0.25, 20
    particles a step, Δt = 0.02, d_max 2), bisected between a fraction that returns nothing and one that returns
    some, to ``tol`` in the fraction. A run goes on to ``t_end`` or stops at the first step whose lower-wall tally
    is below 0 (checked every 50 steps). The reference is Γ_max (``warpfree.validation.pic_diode.
    beam_through_limit``): the largest flux a steady state carries through. Near Γ_max the time to the first return
    grows (the steady state is marginal there), so a longer ``t_end`` moves the measured onset down a little: the
    same bisection on the one-dimensional sheet model (``warpfree.validation.pic_diode.reference_sheet_model``:
    exact field, no grid, the scene's Δt and 20 sheets a step) gives the onset this criterion itself yields,
    free of the field solve's resolution (+0.4..+0.75 % at v0 = 0.05, V = d = 1). Accuracy only: the wall time
    printed is not a timing.

Usage
    python bench/pic/diode_onset.py [--quick] [--t-end 40] [--tol 0.005]
Writes bench/results/pic_diode_onset[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

#: (V, d, v0, node spacings); v0 = 0.02: the beam's dense layer at the cathode, ~v0^{3/2} sqrt(3/Γ) thick, is 1/5 of
#: a spacing at 1/32
CASES = [(1.0, 1.0, 0.05, (1 / 32, 1 / 64, 1 / 128)), (4.0, 2.0, 0.05, (1 / 32,)), (1.0, 1.0, 0.1, (1 / 32,)),
         (1.0, 1.0, 0.02, (1 / 32, 1 / 64))]
QUICK = [(1.0, 1.0, 0.05, (1 / 32,))]


def first_return(build, fraction: float, t_end: float) -> float | None:
    """The time of the first electron returned to the cathode at ``fraction`` Γ_CL, or None up to ``t_end``."""
    run = build(injected_fraction=fraction, t_end=t_end)
    s = run.solver
    steps = int(round(t_end / s.dt))
    for k in range(steps):
        s.step(s.dt)
        if k % 50 == 49 and s.history["wall_charge_lower"][-1] < 0.0:
            return s.t
    return None


def bisect(returns, limit: float, tol: float) -> tuple[float, float, list] | None:
    """(low, high, log) bracketing the fraction where ``returns(fraction)`` (a first-return time or None) turns
    from None to a time, from ±6 % of ``limit`` down to ``tol`` of it; None when ±6 % does not bracket it."""
    lo, hi = 0.94 * limit, 1.06 * limit
    log = [(f, returns(f)) for f in (lo, hi)]
    if log[0][1] is not None or log[1][1] is None:
        return None
    while hi - lo > tol * limit:
        mid = 0.5 * (lo + hi)
        t = returns(mid)
        log.append((mid, t))
        lo, hi = (mid, hi) if t is None else (lo, mid)
    return lo, hi, log


def sheet_onset(voltage: float, gap: float, v0: float, t_end: float, tol: float, dt: float = 0.02) -> dict:
    """The same bisection on the sheet model (no grid), at the scene's Δt and 20 sheets a step: whether any
    electron returns within ``t_end``."""
    from warpfree.validation.pic_diode import beam_through_limit, child_langmuir_flux
    from warpfree.validation.pic_diode.reference_sheet_model import transmitted_flux

    def returns(fraction):
        r = transmitted_flux(voltage, gap, v0, fraction, dt=dt, t_end=t_end, average_from=0.0)
        return t_end if r["returned_over_child_langmuir"] > 0.0 else None

    limit = beam_through_limit(v0, voltage, gap) / child_langmuir_flux(voltage, gap)
    found = bisect(returns, limit, tol)
    if found is None:
        return {"sheet_error": "the onset lies outside ±6 % of the limit"}
    return {"sheet_low": found[0], "sheet_high": found[1], "sheet_deviation_low": found[0] / limit - 1.0,
            "sheet_deviation_high": found[1] / limit - 1.0}


def onset(voltage: float, gap: float, v0: float, spacing: float, t_end: float, tol: float) -> dict:
    from warpfree.scene_loader import load_scene
    from warpfree.validation.pic_diode import beam_through_limit, child_langmuir_flux

    scene = load_scene("pic_diode")

    def build(**kw):
        return scene.build(voltage=voltage, gap=gap, injection_speed=v0, node_spacing=spacing, frames=False,
                           vtk=False, **kw)

    limit = beam_through_limit(v0, voltage, gap) / child_langmuir_flux(voltage, gap)
    start = time.perf_counter()
    found = bisect(lambda f: first_return(build, f, t_end), limit, tol)
    if found is None:
        return {"voltage": voltage, "gap": gap, "v0": v0, "spacing": spacing, "limit": limit,
                "error": "the onset lies outside ±6 % of the limit"}
    lo, hi, log = found
    return {"voltage": voltage, "gap": gap, "v0": v0, "spacing": spacing, "limit": limit, "onset_low": lo,
            "onset_high": hi, "deviation_low": lo / limit - 1.0, "deviation_high": hi / limit - 1.0, "log": log,
            "wall_s": time.perf_counter() - start, **sheet_onset(voltage, gap, v0, t_end, tol)}


def markdown(result: dict) -> str:
    rows = []
    for r in result["runs"]:
        if "error" in r:
            rows.append([common.fmt(r["voltage"]), common.fmt(r["gap"]), common.fmt(r["v0"]), f"1/{1 / r['spacing']:.0f}",
                         f"{r['limit']:.4f}", r["error"], ""])
            continue
        sheet = (f"{100 * r['sheet_deviation_low']:+.2f} .. {100 * r['sheet_deviation_high']:+.2f} %"
                 if "sheet_low" in r else r.get("sheet_error", ""))
        rows.append([common.fmt(r["voltage"]), common.fmt(r["gap"]), common.fmt(r["v0"]), f"1/{1 / r['spacing']:.0f}",
                     f"{r['limit']:.4f}", f"{r['onset_low']:.4f}-{r['onset_high']:.4f}",
                     f"{100 * r['deviation_low']:+.2f} .. {100 * r['deviation_high']:+.2f} %", sheet])
    head = (f"Diode: onset of reflection (first return within t = {result['t_end']:g}, bisected to "
            f"{100 * result['tol']:g} % of the limit) against Γ_max, in Γ_CL; the scene's gather: "
            f"{result.get('gather', 'momentum')}; the last column: the same bisection on the sheet model (no grid)\n\n")
    return head + common.md_table(["V", "d", "v0", "spacing", "Γ_max", "onset", "onset / Γ_max - 1",
                                   "sheet model"], rows)


def plot(result: dict):
    fig, ax = common.new_figure(1, 1, figsize=(6.5, 4.2))
    cases = {}
    for r in result["runs"]:
        if "error" not in r:
            cases.setdefault((r["voltage"], r["gap"], r["v0"]), []).append(r)
    for (v, d, v0), runs in cases.items():
        h = [r["spacing"] for r in runs]
        mid = [50 * (r["deviation_low"] + r["deviation_high"]) for r in runs]
        err = [50 * (r["deviation_high"] - r["deviation_low"]) for r in runs]
        bars = ax.errorbar(h, mid, yerr=err, fmt="o-", capsize=3, label=f"V = {v:g}, d = {d:g}, v0 = {v0:g}")
        if "sheet_low" in runs[0]:  # the criterion's own onset (no grid): dashed, the case's colour
            ax.axhline(50 * (runs[0]["sheet_deviation_low"] + runs[0]["sheet_deviation_high"]), ls="--", lw=1.0,
                       color=bars.lines[0].get_color())
    ax.axhspan(-2.0, 2.0, color="0.9", label="±2 %")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("node spacing")
    ax.set_ylabel("onset / Γ_max - 1 (%)")
    ax.set_title("diode: onset of reflection against Γ_max (dashed: the sheet model)")
    ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--t-end", type=float, default=40.0)
    p.add_argument("--tol", type=float, default=0.005, help="bisection width, as a fraction of Γ_max")
    p.add_argument("--threads", type=int, default=1)
    args = p.parse_args(argv)
    from warpfree import device

    device.use("cpu", args.threads)
    runs = []
    for voltage, gap, v0, spacings in QUICK if args.quick else CASES:
        for spacing in spacings:
            runs.append(onset(voltage, gap, v0, spacing, args.t_end, 2 * args.tol if args.quick else args.tol))
            print(runs[-1], flush=True)
    from warpfree.scene_loader import load_scene
    import inspect
    gather = inspect.signature(load_scene("pic_diode").build).parameters["gather"].default
    result = {"machine": common.machine_info(), "t_end": args.t_end, "tol": args.tol, "gather": gather, "runs": runs}
    common.write_results("pic_diode_onset", result, markdown(result), plot(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
