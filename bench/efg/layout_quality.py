"""Node layouts against their errors: the Lebesgue constant Λ = Σ|φ_I| that the EFG solvers check, measured where the
stresses are known exactly, and the plate with an elliptical hole's convergence.

What it measures
    The case ``warpfree.validation.efg_plate_hole`` as ``scenes/efg_plate_hole.py`` builds it (a quarter of a square
    plate of half-width 2 less the ellipse a = 0.25, b = 0.5, exact tractions outside, symmetry on the axes; Inglis'
    tip stress 5p), on layouts a user might make, each solved with the layout check off so that its error shows:

    - uniform: the region's lattice at one spacing (relaxed);
    - graded: the scene's default grading (0.02 along the hole, +0.1 per unit distance, at most 0.2);
    - stretched: a layout made in coordinates scaled by 1/s along y and scaled back (spacing s times larger along y);
    - jump: spacing 0.04 within r = 0.8 and k times that beyond.

    For each: the nodes, Λ's largest value and where the spacings serving it spread, the smallest scaled pivot of the
    moment matrices, the stresses' relative energy-norm error, the tip stress's error, and whether the solver now
    refuses the layout (Λ above ``warpfree.galerkin.layout_quality.LEBESGUE_LIMIT``). Then the default layout scaled
    by 4, 2, 1, 1/2 (tip error, the largest error along the tip's arc, energy error and its rate), and Λ at the Gauss
    points of every shipped EFG scene's default (and the random layouts of Cook's membrane and the cylinder).

Usage
    python bench/efg/layout_quality.py          # ~4 min on 2 cores
    python bench/efg/layout_quality.py --quick  # the layouts only
Writes bench/results/layout_quality[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

A, B, HALF_WIDTH = 0.25, 0.5, 2.0

#: (label, basis, d_max, layout kind, parameter, spacing)
LAYOUTS = [
    ("uniform", "linear", 2.0, "uniform", None, 0.05),
    ("uniform", "linear", 2.0, "uniform", None, 0.025),
    ("graded", "linear", 2.0, "graded", None, None),
    ("stretched 2:1", "linear", 2.0, "stretched", 2.0, 0.025),
    ("stretched 4:1", "linear", 2.0, "stretched", 4.0, 0.025),
    ("jump 2x", "linear", 2.0, "jump", 2.0, None),
    ("jump 4x", "linear", 2.0, "jump", 4.0, None),
    ("jump 8x", "linear", 2.0, "jump", 8.0, None),
    ("jump 2x", "linear", 1.6, "jump", 2.0, None),
    ("jump 4x", "linear", 1.6, "jump", 4.0, None),
    ("jump 8x", "linear", 1.6, "jump", 8.0, None),
    ("jump 8x", "linear", 3.0, "jump", 8.0, None),
    ("uniform", "quadratic", 2.0, "uniform", None, 0.05),
    ("uniform", "quadratic", 2.0, "uniform", None, 0.025),
    ("graded", "quadratic", 2.0, "graded", None, None),
    ("stretched 2:1", "quadratic", 2.0, "stretched", 2.0, 0.05),
    ("jump 4x", "quadratic", 2.0, "jump", 4.0, None),
    ("uniform", "quadratic", 3.0, "uniform", None, 0.05),
    ("graded", "quadratic", 3.0, "graded", None, None),
    ("stretched 2:1", "quadratic", 3.0, "stretched", 2.0, 0.05),
    ("stretched 3:1", "quadratic", 3.0, "stretched", 3.0, 0.05),
    ("jump 4x", "quadratic", 3.0, "jump", 4.0, None),
    ("jump 8x", "quadratic", 3.0, "jump", 8.0, None),
]

#: the shipped scenes whose Gauss points are reported (scene, parameters)
SCENES = [("efg_timoshenko", {}), ("efg_cylinder", {}), ("efg_cylinder", {"layout": "random", "seed": 1}),
          ("efg_cook", {}), ("efg_cook", {"layout": "random", "seed": 1}), ("efg_resistor", {}),
          ("efg_l_shape", {}), ("efg_coax", {"refinements": 0}), ("efg_plate_hole", {"refinements": 0})]


def layout_nodes(scene, kind: str, parameter, spacing):
    """The region and the nodes of one layout (module docstring)."""
    from warpfree.galerkin.region import RegionNodes

    region = scene.plate_region(HALF_WIDTH, A, B)
    if kind == "uniform":
        return region, region.nodes(spacing)
    if kind == "graded":
        return region, region.nodes(0.2, size=scene.graded_size(A, B, 0.02, 0.2, 0.1))
    if kind == "jump":
        return region, region.nodes(0.04 * parameter, size=lambda p: np.where(np.hypot(p[:, 0], p[:, 1]) < 0.8,
                                                                             0.04, 0.04 * parameter))
    from warpfree.galerkin.region import Region

    squeezed = (Region.rectangle([0.0, 0.0], [HALF_WIDTH, HALF_WIDTH / parameter], ["bottom", "right", "top", "left"])
                - Region.ellipse((0.0, 0.0), (A, B / parameter), tag="hole"))
    n = squeezed.nodes(spacing)  # an ellipse and its image share their parameter: the pieces' stations carry over
    return region, RegionNodes(n.position * [1.0, parameter], n.edge_nodes, n.edge_piece, n.edge_s, n.boundary,
                               n.spacing * parameter)


def arc_error(scene, solver) -> float:
    """The largest relative error of σ_xx along the hole from the tip to 0.3 rad from it (61 points)."""
    t = np.linspace(0.5 * math.pi, 0.5 * math.pi - 0.3, 61)
    points = np.column_stack([A * np.cos(t), B * np.sin(t)])
    return float(np.max(np.abs(scene.stress_at(solver, points)[:, 0] / scene.stresses(points, A, B)[:, 0] - 1.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="the layouts only")
    args = ap.parse_args()
    import warpfree.device
    from warpfree.errors import ParameterError
    from warpfree.galerkin import layout_quality
    from warpfree.run import build_scene
    from warpfree.scene_loader import load_scene

    warpfree.device.use("cpu", 2)
    scene = load_scene("efg_plate_hole")
    limit = layout_quality.LEBESGUE_LIMIT
    layout_quality.LEBESGUE_LIMIT = math.inf  # measured with the check off: the refused layouts' errors show
    rows = []
    for label, basis, d_max, kind, parameter, spacing in LAYOUTS:
        region, nodes = layout_nodes(scene, kind, parameter, spacing)
        row = dict(layout=label, spacing=spacing, basis=basis, d_max=d_max, nodes=nodes.count)
        try:
            solver = scene.plate_solver(region, nodes, A, B, 1.0, 1.0, basis, d_max)
            solver.solve()
        except ParameterError as e:
            row.update(failed=str(e))
        else:
            errors = scene.plate_errors(solver, A, B, 1.0)
            report = solver.layout
            row.update(lebesgue_max=report.lebesgue_max, spread=report.worst_spread, count=report.worst_count,
                       rcond_min=report.rcond_min, energy_error=errors["energy_error"],
                       tip_error=errors["tip_error"], refused=report.lebesgue_max > limit)
        rows.append(row)
        print("  ", {k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()}, flush=True)
    layout_quality.LEBESGUE_LIMIT = limit
    levels, shipped = [], []
    if not args.quick:
        region = scene.plate_region(HALF_WIDTH, A, B)
        size = scene.graded_size(A, B, 0.01, 0.1, 0.1)
        for scale in (4.0, 2.0, 1.0, 0.5):
            nodes = region.nodes(0.1 * scale, size=lambda p, s=scale: s * size(p))
            solver = scene.plate_solver(region, nodes, A, B, 1.0, 1.0, "quadratic", 3.0)
            solver.solve()
            errors = scene.plate_errors(solver, A, B, 1.0)
            levels.append(dict(hole_spacing=0.01 * scale, nodes=nodes.count, tip_error=errors["tip_error"],
                               arc_error=arc_error(scene, solver), energy_error=errors["energy_error"],
                               lebesgue_max=solver.layout.lebesgue_max))
            print("  ", levels[-1], flush=True)
        for name, params in SCENES:
            with tempfile.TemporaryDirectory() as out:
                summary = build_scene(load_scene(name), {**params, "frames": False, "vtk": False}).run(
                    out, progress=False)
            report = summary["model"]["layout"]
            shipped.append(dict(scene=name, params=params, gauss_points=report["points"],
                                lebesgue_max=report["lebesgue_max"], lebesgue_mean=report["lebesgue_mean"],
                                spread=report["worst_spread"]))
            print("  ", shipped[-1], flush=True)
    md = ["## Node layouts against their errors: the plate with an elliptical hole", "",
          f"Quarter plate of half-width {HALF_WIDTH:g}, hole a = {A:g}, b = {B:g} (Inglis: 5p), exact tractions; "
          "each layout solved with the layout check off. Λ: the largest Σ|φ_I| over the Gauss points; spread: the "
          "largest over the smallest spacing of the nodes around that point (as near as the farthest serving it); "
          "refused: Λ above the solver's limit "
          f"{limit:g}.", "",
          "| layout | spacing | basis | d_max | nodes | Λ max | spread | rcond min | energy error | tip error | "
          "refused |", "| --- | --: | --- | --: | --: | --: | --: | --: | --: | --: | --- |"]
    for r in rows:
        head = (f"| {r['layout']} | {common.fmt(r['spacing']) if r['spacing'] else '-'} | {r['basis']} | "
                f"{r['d_max']:g} | {r['nodes']} |")
        if "failed" in r:
            md.append(head + f" - | - | - | - | - | refused before: {r['failed'].split(':')[0]} |")
        else:
            md.append(head + f" {common.fmt(r['lebesgue_max'])} | {r['spread']:.2f} | {r['rcond_min']:.2e} | "
                             f"{r['energy_error']:.2e} | {r['tip_error']:+.2%} | {'yes' if r['refused'] else 'no'} |")
    if levels:
        md += ["", "## The default layout scaled (quadratic MLS, d_max 3)", "",
               "| hole spacing | nodes | tip error | largest error on the tip's arc | energy error | rate | Λ max |",
               "| --: | --: | --: | --: | --: | --: | --: |"]
        for k, r in enumerate(levels):
            rate = math.log2(levels[k - 1]["energy_error"] / r["energy_error"]) if k else None
            md.append(f"| {r['hole_spacing']:g} | {r['nodes']} | {r['tip_error']:+.2%} | {r['arc_error']:.2%} | "
                      f"{r['energy_error']:.2e} | {common.fmt_rate(rate)} | {common.fmt(r['lebesgue_max'])} |")
        md += ["", "## The shipped scenes' Gauss points", "", "| scene | parameters | Gauss points | Λ max | Λ mean |",
               "| --- | --- | --: | --: | --: |"]
        for r in shipped:
            md.append(f"| {r['scene']} | {r['params'] or 'default'} | {r['gauss_points']} | "
                      f"{common.fmt(r['lebesgue_max'])} | {common.fmt(r['lebesgue_mean'])} |")
    common.write_results("layout_quality", {"limit": limit, "layouts": rows, "levels": levels, "scenes": shipped},
                         "\n".join(md), quick=args.quick)


if __name__ == "__main__":
    main()
