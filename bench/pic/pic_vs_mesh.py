"""PIC with an EFG field solve against a conventional mesh PIC: accuracy against wall time, side by side in one run.

What it measures
    * ``oscillation``: the cold plasma oscillation (k = 0.5, ``scenes/pic_plasma_oscillation.py``, 4 particles per
      node cell, Δt = 0.1, 4 periods): the frequency error against the leapfrog value (2/Δt) asin(Δt/2), for EFG at
      node spacings 1/2, 1/4, 1/8 (momentum gather; and the energy gather at 1/2) and for the mesh PIC
      (``bench/pic/mesh_pic.py``: cloud-in-cell deposit and gather, FFT Poisson, 4 particles per cell) on the same box at
      nx = 25 .. 200 (Δx = 0.5 .. 1/16);
    * ``two_stream``: the cold two-stream instability (``scenes/pic_two_stream.py``, 4 particles per node cell and
      beam, Δt = 0.1, to t = 40): the growth-rate error against ω_p/(2√2), EFG at node spacings 1, 1/2, 1/4, mesh at
      Δx = 1 .. 1/8;
    * ``drift`` (on request, minutes): the thermal plasma (``scenes/pic_thermal_plasma.py``) on a 16 x 32 λ_D box to
      20 plasma periods: total-energy drift against particles per node support (4, 8, 16 particles per node cell),
      both gathers.
    Wall time: the stepping only (EFG: the solver's timed phases, set-up excluded; mesh: its time loop). Equal-error
    ratios EFG/mesh are interpolated log-log between the mesh runs (``common.equal_error_ratio``).

Usage
    python bench/pic/pic_vs_mesh.py [--quick] [--threads N] [--cases oscillation two_stream drift] [--name STEM]
    python bench/pic/pic_vs_mesh.py --cases drift --name pic_drift     # ~5 min
Writes bench/results/<name>[_quick].{json,md,png} (name: pic_vs_mesh by default).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402
import mesh_pic  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[], ["--cases", "drift", "--name", "pic_drift"]]

_THREADS: int | None = None


def _efg(scene: str, key: str, **params) -> tuple[dict, float]:
    run = common.build_scene(scene, _THREADS, **params)
    with tempfile.TemporaryDirectory() as tmp:
        result = run.run(tmp, progress=False)["analysis"][key]
    phases = run.solver.phases.as_dict()
    return result, sum(phases.values())


def oscillation(quick: bool) -> dict:
    rows = {"efg": [], "efg_energy": [], "mesh": []}
    for h in ([0.5, 0.25] if quick else [0.5, 0.25, 0.125]):
        r, wall = _efg("pic_plasma_oscillation", "oscillation", node_spacing=h, particles_per_node=2)
        rows["efg"].append({"spacing": h, "particles": r["particles"], "error": abs(r["frequency_rel_error"]),
                             "signed_error": r["frequency_rel_error"], "wall_s": wall})
    r, wall = _efg("pic_plasma_oscillation", "oscillation", node_spacing=0.5, particles_per_node=2, gather="energy")
    rows["efg_energy"].append({"spacing": 0.5, "particles": r["particles"], "error": abs(r["frequency_rel_error"]),
                                "signed_error": r["frequency_rel_error"], "wall_s": wall})
    lx = 4.0 * math.pi
    for nx in ([25, 50] if quick else [25, 50, 100, 200]):
        m = mesh_pic.plasma_oscillation(nx=nx, particles_per_cell=4, dt=0.1, periods=4.0, ny=max(8, nx // 3),
                                        lx=lx)
        rows["mesh"].append({"spacing": lx / nx, "particles": m["particles"], "error": abs(m["frequency_error"]),
                             "signed_error": m["frequency_error"], "wall_s": m["wall_s"]})
    rows["ratio"] = common.equal_error_ratio(rows["efg"], rows["mesh"])
    return rows


def two_stream(quick: bool) -> dict:
    rows = {"efg": [], "mesh": []}
    for h in ([1.0, 0.5] if quick else [1.0, 0.5, 0.25]):
        r, wall = _efg("pic_two_stream", "two_stream", node_spacing=h, particles_per_node=2,
                        length_y=max(4.0, 8.0 * h))
        rows["efg"].append({"spacing": h, "particles": r["particles"], "error": abs(r["growth_rate_rel_error"]),
                             "signed_error": r["growth_rate_rel_error"], "wall_s": wall})
    lx = 2.0 * math.pi / 0.612
    for nx in ([10, 20] if quick else [10, 20, 40, 80]):
        m = mesh_pic.two_stream(nx=nx, particles_per_cell=4, dt=0.1, t_end=40.0, ny=max(4, int(round(nx * 4 / lx))))
        rows["mesh"].append({"spacing": lx / nx, "particles": m["particles"], "error": abs(m["growth_rate_error"]),
                             "signed_error": m["growth_rate_error"], "wall_s": m["wall_s"]})
    rows["ratio"] = common.equal_error_ratio(rows["efg"], rows["mesh"])
    return rows


def drift(quick: bool) -> dict:
    """Thermal plasma, 16 x 32 λ_D, 20 periods: energy drift and heating rate against particles per support and
    node spacing (λ_D units), both gathers."""
    configs = [(1.0, 4, "momentum"), (1.0, 16, "momentum")] if quick else [
        (1.0, 4, "momentum"), (1.0, 8, "momentum"), (1.0, 16, "momentum"), (0.5, 4, "momentum"),
        (2.0, 16, "momentum"), (1.0, 4, "energy"), (1.0, 16, "energy"), (2.0, 16, "energy")]
    rows = []
    for spacing, ppn, gather in configs:
        r, wall = _efg("pic_thermal_plasma", "thermal", box=(16.0, 32.0), periods=5.0 if quick else 20.0,
                        node_spacing=spacing, particles_per_node=ppn, gather=gather)
        rows.append({"gather": gather, "spacing": spacing, "particles_per_node": ppn,
                     "particles_per_support": r["particles_per_support"], "drift": r["total_energy_drift"],
                     "heating_rate_per_period": r["heating_rate_per_period"],
                     "momentum_change": r["momentum_change"], "thermal_momentum": r["thermal_momentum"],
                     "particles": r["particles"], "wall_s": wall, "pushes_per_s": r["particles"] * r["steps"] / wall})
    return {"runs": rows}


def markdown(result: dict) -> str:
    out = [f"PIC with an EFG field solve against a mesh PIC, {result['threads']} thread(s)\n"]
    for case, label in (("oscillation", "frequency error"), ("two_stream", "growth-rate error")):
        if case not in result:
            continue
        rows = []
        for method, runs in result[case].items():
            if method == "ratio":
                continue
            rows += [[method, common.fmt(r["spacing"]), r["particles"], f"{r['signed_error']:+.2e}",
                      common.fmt(r["wall_s"])] for r in runs]
        out.append(f"### {case}\n\n" + common.md_table(["method", "spacing", "particles", label, "wall s"], rows))
        ratio = [[f"{r['error']:.2e}", common.fmt(r["a_s"]), common.fmt(r["b_s"]), common.fmt(r["ratio"])]
                 for r in result[case]["ratio"]]
        table = common.md_table(["error", "EFG s", "mesh s", "ratio"], ratio) if ratio else "(no overlap)\n"
        out.append("EFG/mesh time at equal error:\n\n" + table)
    if "drift" in result:
        rows = [[r["gather"], common.fmt(r["spacing"]), r["particles_per_node"], common.fmt(r["particles_per_support"]),
                 f"{r['drift']:.2e}", f"{r['heating_rate_per_period']:+.1e}",
                 f"{r['momentum_change'] / r['thermal_momentum']:.1e}", common.fmt(r["wall_s"]),
                 common.fmt_rate(r["pushes_per_s"])] for r in result["drift"]["runs"]]
        out.append("### thermal plasma, 16 x 32 λ_D, 20 periods (spacing in λ_D; heating: slope of the total energy "
                   "per period / initial kinetic energy; momentum change / electrons' thermal momentum)\n\n"
                   + common.md_table(["gather", "spacing", "per node cell", "per support", "energy drift",
                                      "heating / period", "momentum change", "wall s", "pushes/s"], rows))
    return "\n\n".join(out)


def plot(result: dict):
    fig, axes = common.new_figure(1, 2, figsize=(11, 4.2))
    for ax, case in zip(axes, ("oscillation", "two_stream")):
        if case not in result:
            continue
        for method, runs in result[case].items():
            if method == "ratio" or not runs:
                continue
            ax.loglog([r["wall_s"] for r in runs], [r["error"] for r in runs], "o-", label=method)
        ax.set_xlabel("wall s (stepping)")
        ax.set_ylabel("|relative error|")
        ax.set_title(case.replace("_", " "))
        ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--cases", nargs="+", default=["oscillation", "two_stream"])
    p.add_argument("--name", default="pic_vs_mesh", help="results file stem")
    args = p.parse_args(argv)
    from warpfree import device

    global _THREADS
    _THREADS = args.threads
    device.use("cpu", args.threads)
    result = {"machine": common.machine_info(), "threads": device.current_launcher().threads}
    for case in args.cases:
        result[case] = {"oscillation": oscillation, "two_stream": two_stream, "drift": drift}[case](args.quick)
    fig = plot(result) if {"oscillation", "two_stream"} & set(result) else None
    common.write_results(args.name, result, markdown(result), fig, quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
