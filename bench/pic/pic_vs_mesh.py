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
    * ``cylindrical_diode`` (on request, ~10 min): the space-charge-limited current of the cylindrical diode
      (``scenes/pic_cylindrical_diode.py``: exact circles, Gauss's-law emission, 50 particles a step, Δt = 0.02, to
      t = 10) against Langmuir and Blodgett's, EFG on uniform layouts (0.1, 0.05) and graded toward the cathode
      (0.05 there growing to 0.1; 0.025 to 0.05, the scene's defaults; 0.0125 to 0.05 with 200 particles a step), and
      the mesh PIC with staircased electrodes (``bench/pic/mesh_diode.py``: the same emission and steps) at 32 .. 512
      cells across the anode; and, with no charge, the field at the cathode: EFG's |∇u| on the exact circle, the
      mesh's on its staircase (each face's (φ_f - φ_c)/Δx, which its emission draws on, and |E| at the free nodes
      next to it), against V / (r ln 2);
    * ``drift`` (on request, minutes): the thermal plasma (``scenes/pic_thermal_plasma.py``) on a 16 x 32 λ_D box to
      20 plasma periods: total-energy drift against particles per node support (4, 8, 16 particles per node cell),
      both gathers.
    Wall time: the stepping only (EFG: the solver's timed phases, set-up excluded; mesh: its time loop). Equal-error
    ratios EFG/mesh are interpolated log-log between the mesh runs (``common.equal_error_ratio``).

Usage
    python bench/pic/pic_vs_mesh.py [--quick] [--threads N] [--cases oscillation two_stream drift] [--name STEM]
    python bench/pic/pic_vs_mesh.py --cases drift --name pic_drift     # ~5 min
    python bench/pic/pic_vs_mesh.py --cases cylindrical_diode --name pic_diode_vs_mesh     # ~10 min
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
import mesh_diode  # noqa: E402
import mesh_pic  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[], ["--cases", "drift", "--name", "pic_drift"],
           ["--cases", "cylindrical_diode", "--name", "pic_diode_vs_mesh"]]

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


def cylindrical_diode(quick: bool) -> dict:
    """The cylindrical diode's anode current, EFG (exact circles) against the staircased mesh PIC, and the vacuum
    field at the cathode."""
    import numpy as np

    from warpfree.galerkin.mls import MLSModel, MLSSettings
    from warpfree.galerkin.region import Region
    from warpfree.solvers.pic.electrodes import Electrode, ElectrodeField
    from warpfree.validation.pic_cylindrical_diode import current_per_length

    expected = current_per_length(1.0, 1.0, 2.0)
    t_end = 10.0
    layouts = [("efg_uniform", 0.1, 0.1, 50.0), ("efg_graded", 0.1, 0.05, 50.0)]
    if not quick:
        layouts = [("efg_uniform", 0.1, 0.1, 50.0), ("efg_uniform", 0.05, 0.05, 50.0),
                   ("efg_graded", 0.1, 0.05, 50.0), ("efg_graded", 0.05, 0.025, 50.0),
                   ("efg_graded", 0.05, 0.0125, 200.0)]
    rows = {"efg_uniform": [], "efg_graded": [], "mesh": []}
    fields = {"efg_uniform": [], "efg_graded": [], "mesh": []}
    for method, spacing, cathode, per_step in layouts:
        r, wall = _efg("pic_cylindrical_diode", "diode", node_spacing=spacing, cathode_spacing=cathode,
                        particles_per_step=per_step, t_end=t_end)
        rows[method].append({"spacing": cathode, "node_spacing": spacing, "particles_per_step": per_step,
                             "nodes": r["nodes"], "particles": r["particles"],
                             "signed_error": r["anode_over_langmuir_blodgett"] - 1.0,
                             "error": abs(r["anode_over_langmuir_blodgett"] - 1.0), "wall_s": wall})
        region = Region.disc((0.0, 0.0), 2.0, "anode") - Region.disc((0.0, 0.0), 1.0, "cathode")
        size = None if cathode == spacing else (
            lambda p, s=spacing, c=cathode: np.clip(c + 0.1 * (np.hypot(p[:, 0], p[:, 1]) - 1.0), c, s))
        nodes = region.nodes(spacing, size=size)
        model = MLSModel(nodes.position, MLSSettings(basis="quadratic", d_max=3.0))
        field = ElectrodeField(model, region, nodes, [Electrode("cathode", 0.0), Electrode("anode", 1.0)])
        u = field.solve(np.zeros(model.node_count))
        t = np.linspace(0.0, 2.0 * math.pi, 721)[:-1]
        gradient = model.evaluate(u, model.shape_at(np.column_stack([np.cos(t), np.sin(t)])))[1].reshape(len(t), 2)
        error = np.linalg.norm(gradient, axis=1) * math.log(2.0) - 1.0
        fields[method].append({"spacing": cathode, "node_spacing": spacing,
                               "surface_field_max_error": float(np.max(np.abs(error))),
                               "surface_field_rms_error": float(np.sqrt(np.mean(error ** 2)))})
    for cells in ([32, 64] if quick else [32, 64, 128, 256, 512]):
        m = mesh_diode.cylindrical_diode(cells, expected_current=expected, t_end=t_end)
        rows["mesh"].append({"spacing": m["spacing"], "cells_across": cells, "particles_per_step": 50.0,
                             "nodes": m["nodes"], "particles": m["particles"],
                             "signed_error": m["over_reference"] - 1.0, "error": abs(m["over_reference"] - 1.0),
                             "wall_s": m["wall_s"]})
        fields["mesh"].append(mesh_diode.vacuum_surface_field(cells))
    graded_and_uniform = sorted(rows["efg_graded"] + rows["efg_uniform"], key=lambda r: r["wall_s"])
    return {"runs": rows, "surface_field": fields, "t_end": t_end, "langmuir_blodgett_current": expected,
            "ratio": common.equal_error_ratio(graded_and_uniform, rows["mesh"])}


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
    if "cylindrical_diode" in result:
        d = result["cylindrical_diode"]
        rows = []
        for method, runs in d["runs"].items():
            for r in runs:
                layout = (f"{common.fmt(r['spacing'])} to {common.fmt(r['node_spacing'])}" if method == "efg_graded"
                          else common.fmt(r["spacing"]))
                rows.append([method, layout, r["nodes"], common.fmt(r["particles_per_step"]), r["particles"],
                             f"{r['signed_error']:+.2%}", common.fmt(r["wall_s"])])
        out.append(f"### cylindrical diode (r_c = 1, r_a = 2, V = 1, Δt 0.02, to t = {common.fmt(d['t_end'])}): the "
                   "anode current over the second half against Langmuir-Blodgett's "
                   f"{d['langmuir_blodgett_current']:.4f}\n\n"
                   + common.md_table(["method", "spacing (at the cathode to beyond)", "nodes", "particles a step",
                                      "particles", "current error", "wall s"], rows))
        ratio = [[f"{r['error']:.2%}", common.fmt(r["a_s"]), common.fmt(r["b_s"]), common.fmt(r["ratio"])]
                 for r in d["ratio"]]
        table = common.md_table(["error", "EFG s", "mesh s", "ratio"], ratio) if ratio else "(no overlap)\n"
        out.append("EFG/mesh time at equal current error:\n\n" + table)
        rows = []
        for method, runs in d["surface_field"].items():
            for r in runs:
                if method == "mesh":
                    rows.append([method, common.fmt(r["spacing"]), f"{r['face_field_max_error']:.1e}",
                                 f"{r['face_field_rms_error']:.1e}", f"{r['node_field_max_error']:.1e}",
                                 f"{r['node_field_rms_error']:.1e}"])
                else:
                    layout = (f"{common.fmt(r['spacing'])} to {common.fmt(r['node_spacing'])}"
                              if method == "efg_graded" else common.fmt(r["spacing"]))
                    rows.append([method, layout, f"{r['surface_field_max_error']:.1e}",
                                 f"{r['surface_field_rms_error']:.1e}", "", ""])
        out.append("The field at the cathode with no charge, against V / (r ln 2) (EFG: |∇u| at 720 points of the "
                   "exact circle; mesh: (φ_f - φ_c)/Δx on each staircase face, and |E| at the free nodes next to "
                   "the cathode):\n\n" + common.md_table(["method", "spacing", "surface max", "surface rms",
                                                           "next nodes max", "next nodes rms"], rows))
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


def plot_diode(d: dict):
    fig, (left, right) = common.new_figure(1, 2, figsize=(11, 4.2))
    for method, runs in d["runs"].items():
        if runs:
            left.loglog([r["wall_s"] for r in runs], [r["error"] for r in runs], "o-", label=method)
    left.set_xlabel("wall s (stepping)")
    left.set_ylabel("|anode current / Langmuir-Blodgett - 1|")
    left.set_title("cylindrical diode: current")
    left.legend()
    for method, runs in d["surface_field"].items():
        if not runs:
            continue
        key = "face_field_max_error" if method == "mesh" else "surface_field_max_error"
        label = "mesh (staircase faces)" if method == "mesh" else method
        right.loglog([r["spacing"] for r in runs], [r[key] for r in runs], "o-", label=label)
        if method == "mesh":
            right.loglog([r["spacing"] for r in runs], [r["node_field_max_error"] for r in runs], "s--",
                         label="mesh (nodes next to it)")
    right.set_xlabel("spacing at the cathode")
    right.set_ylabel("largest relative error")
    right.set_title("vacuum field at the cathode")
    right.legend()
    return fig


def plot(result: dict):
    if "cylindrical_diode" in result:
        return plot_diode(result["cylindrical_diode"])
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
        result[case] = {"oscillation": oscillation, "two_stream": two_stream, "drift": drift,
                        "cylindrical_diode": cylindrical_diode}[case](args.quick)
    fig = plot(result) if {"oscillation", "two_stream", "cylindrical_diode"} & set(result) else None
    common.write_results(args.name, result, markdown(result), fig, quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
