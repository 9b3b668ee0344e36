"""How NEM's integration decides whether the Timoshenko beam converges: tip, energy and the stiffness's own error.

What it measures
    The beam of ``scenes/efg_timoshenko.py`` by NEM (Laplace shape functions, direct substitution) on the regular
    and a random layout (seed 1), 175 ... 9457 nodes, with each integration of the stiffness:
    * ``gauss``: 3 Gauss points per Delaunay triangle (the thesis's rule);
    * ``consistent``: the same points, test gradients corrected by the linear variationally consistent correction
      (``warpfree.galerkin.consistent_integration``);
    * ``consistent_fine``: the same correction on 12 points per triangle (each triangle split in 4, 3 points each);
    * ``scni``: stabilized conforming nodal integration on the Voronoi cells (``warpfree.galerkin.nodal_integration``,
      one Gauss point per cell side).
    Per run: the tip deflection's relative error u_y(L, 0); the strain energy ½ uᵀ K u of the solution against the
    exact 4.47467 (the method's own, ``strain_energy``); the energy-norm error of ∇u^h on a common fine quadrature
    (every Delaunay triangle split in 16, 3 points each: 48 points per triangle) and, for ``scni``, also that of the
    smoothed strains at the nodes (cell areas as weights); and the stiffness's integration error on the exact
    solution's nodal interpolant I u: ½ (I u)ᵀ K (I u) against the same energy on the common fine quadrature
    (regular layout). ``|ξ| h``: the median size of the consistent correction ξ_I at interior nodes times the node
    spacing (a relative change of the test gradients).

Usage
    python bench/efg/nem_integration.py            # ~2 min on 2 cores
    python bench/efg/nem_integration.py --quick    # 175 ... 2425 nodes
Writes bench/results/nem_integration[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

ROOT = common.ROOT
sys.path.insert(0, str(ROOT / "scenes"))

INTEGRATIONS = ("gauss", "consistent", "consistent_fine", "scni")


def split_triangles(points: np.ndarray, triangles: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle split into 4^levels by its side midpoints (vertices repeated per triangle: set-up only)."""
    p, t = points, triangles
    for _ in range(levels):
        a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
        m = len(t)
        p = np.concatenate([a, b, c, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)])
        i = np.arange(m)
        A, B, C, AB, BC, CA = (i + k * m for k in range(6))
        t = np.concatenate([np.c_[A, AB, CA], np.c_[AB, B, BC], np.c_[CA, BC, C], np.c_[AB, BC, CA]])
    return p, t


def fine_cells(model, levels: int):
    from warpfree.galerkin.quadrature import triangle_cells

    return triangle_cells(*split_triangles(model.nodes_np, model.triangles, levels), 2)


def beam(n: int, layout: str, integration: str):
    """The scene's NEM beam (4n x n spacings), with ``consistent_fine`` swapping in 12 points per triangle."""
    import efg_timoshenko

    if integration != "consistent_fine":
        return efg_timoshenko.beam_solver(4 * n, n, layout=layout, seed=1, model="nem", integration=integration)
    s = efg_timoshenko.beam_solver(4 * n, n, layout=layout, seed=1, model="nem", integration="consistent")
    s.cells = fine_cells(s.model, 1)
    return s


def energy_norm_error(solver, cells, gradient) -> float:
    from warpfree.validation import efg_timoshenko as exact

    err, norm = exact.energy_norm(cells.position, cells.weight, solver.strain_from(gradient))
    return err / norm


#: ½ ∫ ε(I u)·D ε(I u) on 192 points per triangle, per level of the regular layout (computed once)
_INTERPOLANT_ENERGY: dict = {}


def measure(n: int, layout: str, integration: str) -> dict:
    from warpfree.validation import efg_timoshenko as exact

    s = beam(n, layout, integration)
    s.solve()
    fine = fine_cells(s.model, 2)
    row = {"n": n, "nodes": s.model.node_count, "layout": layout, "integration": integration,
           "tip_rel_error": float(s.field_at(np.array([exact.TIP_POINT]))[0][0, 1] / exact.TIP_DEFLECTION - 1.0),
           "strain_energy_rel_error": s.strain_energy() / exact.strain_energy() - 1.0,
           "energy_norm_error_fine": energy_norm_error(s, fine, s.field_at(fine.position)[1])}
    if integration == "scni":
        row["energy_norm_error_nodes"] = energy_norm_error(s, s.cells, s.gauss_field()[1])
    if layout == "regular":
        interpolant = exact.displacement(s.model.nodes_np).ravel()
        if n not in _INTERPOLANT_ENERGY:
            finer = fine_cells(s.model, 3)
            eps = s.strain_from(s.model.evaluate(interpolant, s.model.shape_at(finer.position), 2)[1])
            _INTERPOLANT_ENERGY[n] = 0.5 * float(np.sum(finer.weight * np.einsum("ni,ij,nj->n", eps, s.D, eps)))
        reference = _INTERPOLANT_ENERGY[n]
        row["interpolant_energy_integration_error"] = 0.5 * float(interpolant @ (s.matrix @ interpolant)) / reference - 1
        if integration == "consistent":
            x = s.model.nodes_np
            p = exact.DEFAULTS
            inner = (x[:, 0] > 1e-9) & (x[:, 0] < p["L"] - 1e-9) & (np.abs(x[:, 1]) < p["D"] / 2 - 1e-9)
            xi = np.linalg.norm(s.correction[:, 0, :], axis=1) * s.model.spacing
            row["correction_times_spacing_median"] = float(np.median(xi[inner]))
    print("  " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)
    return row


def markdown(result: dict) -> str:
    lines = ["# NEM integration: the Timoshenko beam under refinement", "",
             f"Machine: {result['machine'].get('cpu')}. Errors relative; energy-norm errors of ∇u^h on 48 points per "
             "Delaunay triangle (for scni also of the smoothed strains at the nodes); ½(Iu)ᵀK(Iu): the stiffness's "
             "integration error on the exact solution's nodal interpolant.", ""]
    for layout in ("regular", "random"):
        rows = []
        for r in (r for r in result["rows"] if r["layout"] == layout):
            rows.append([r["integration"], r["nodes"], f"{100 * r['tip_rel_error']:+.3f} %",
                         f"{100 * r['strain_energy_rel_error']:+.3f} %", f"{r['energy_norm_error_fine']:.3e}",
                         f"{r['energy_norm_error_nodes']:.3e}" if "energy_norm_error_nodes" in r else "",
                         f"{100 * r['interpolant_energy_integration_error']:+.3f} %"
                         if "interpolant_energy_integration_error" in r else "",
                         f"{r['correction_times_spacing_median']:.4f}" if "correction_times_spacing_median" in r
                         else ""])
        lines += [f"## {layout} nodes" + (" (seed 1)" if layout == "random" else ""), "",
                  common.md_table(["integration", "nodes", "tip error", "strain energy", "energy norm (48/tri)",
                                   "energy norm (nodes)", "½(Iu)ᵀK(Iu) error", "|ξ| h"], rows), ""]
    return "\n".join(lines) + "\n"


def plot(result: dict):
    fig, axes = common.new_figure(1, 2, figsize=(10, 4))
    for ax, layout in zip(axes, ("regular", "random")):
        for integration in INTEGRATIONS:
            rows = [r for r in result["rows"] if r["layout"] == layout and r["integration"] == integration]
            ax.loglog([r["nodes"] for r in rows], [abs(r["tip_rel_error"]) for r in rows], "o-", label=integration)
        ax.set_xlabel("nodes")
        ax.set_ylabel("|tip deflection error|")
        ax.set_title(f"NEM beam, {layout} nodes")
        ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    from warpfree import device

    device.use("cpu", None)
    levels = [3, 6, 12] if args.quick else [3, 6, 12, 24]
    result = {"machine": common.machine_info(),
              "rows": [measure(2 * n, layout, integration) for layout in ("regular", "random")
                       for integration in INTEGRATIONS for n in levels]}
    common.write_results("nem_integration", result, markdown(result), plot(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
