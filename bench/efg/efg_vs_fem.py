"""EFG against the finite element method: energy-norm error against wall time, Timoshenko beam and thick cylinder.

What it measures
    For each case and resolution, the wall time of a whole solve and its relative energy-norm error against the
    exact solution, for
    * EFG (``scenes/efg_timoshenko.py`` / ``scenes/efg_cylinder.py`` solvers: nodes, supports, shape functions,
      assembly, Lagrange multipliers, SuperLU), timed from the node layout to the solution, with the linear basis
      (the scenes' default) and the quadratic one (:data:`QUADRATIC`);
    * FEM with linear (P1) and quadratic (P2) triangles from scikit-fem (``pip install scikit-fem``, the bench
      extra), timed from the mesh to the solution: mesh, basis, assembly, the traction load, the Dirichlet values
      interpolated at the boundary DOFs, condensation and a sparse direct solve.
    Errors: sqrt(½ ∫ (ε_h - ε)ᵀ D (ε_h - ε)) / sqrt(½ ∫ εᵀ D ε) by each method's own quadrature (EFG: its 2 x 2
    Gauss points per cell, 3 x 3 for the quadratic basis; FEM: the basis quadrature of order 4). Times: the median of ``--repeats`` solves after a
    warm-up (kernel loads). One thread count for all (``--threads``, default all cores). The ratio EFG / FEM at
    equal error is read off the FEM curve (log-log interpolation), as for SPEM against FDTD.

Usage
    python bench/efg/efg_vs_fem.py            # ~2 min on 2 cores
    python bench/efg/efg_vs_fem.py --quick
Writes bench/results/efg_vs_fem[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]  # needs scikit-fem (in the extra warpfree[bench]); without it: ModuleNotFoundError

ROOT = common.ROOT
sys.path.insert(0, str(ROOT / "scenes"))


def _timed(fn, repeats: int):
    fn()
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


# -- EFG -----------------------------------------------------------------------------------------------------
#: EFG's quadratic basis: d_max 2.5 (the beam converges at 2.2-2.4 in energy with it, 3.5 jumps between levels),
#: 3 x 3 Gauss points per cell and its quadratic consistency correction (the solver's default for the basis)
QUADRATIC = {"basis": "quadratic", "d_max": 2.5, "gauss": 3}


def efg_beam(n: int, basis: str = "linear"):
    import efg_timoshenko

    s = efg_timoshenko.beam_solver(4 * n, n, **(QUADRATIC if basis == "quadratic" else {}))
    s.solve()
    return s


def efg_cylinder(n: int, basis: str = "linear"):
    import efg_cylinder

    s = efg_cylinder.cylinder_solver(n, n, **(QUADRATIC if basis == "quadratic" else {}))
    s.solve()
    return s


def efg_error(case: str, solver) -> float:
    from warpfree.validation import efg_cylinder as ring
    from warpfree.validation import efg_timoshenko as beam

    if case == "beam":
        err, norm = beam.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain())
    else:
        err, norm = ring.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain(), plane="strain")
    return err / norm


# -- FEM (scikit-fem) ----------------------------------------------------------------------------------------
def _fem_mesh(case: str, n: int):
    from skfem import MeshTri

    if case == "beam":
        return MeshTri.init_tensor(np.linspace(0.0, 48.0, 4 * n + 1), np.linspace(-6.0, 6.0, n + 1))
    m = MeshTri.init_tensor(np.linspace(10.0, 25.0, n + 1), np.linspace(0.0, math.pi / 2, n + 1))
    r, t = m.p
    return MeshTri(np.array([r * np.cos(t), r * np.sin(t)]), m.t)


def fem_solve(case: str, n: int, degree: int):
    """(basis, solution, D) of the case on an n-element-per-unit structured triangle mesh, P1 or P2."""
    from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, FacetBasis, LinearForm, asm, condense, solve
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from warpfree.validation import efg_cylinder as ring
    from warpfree.validation import efg_timoshenko as beam

    mesh = _fem_mesh(case, n)
    element = ElementVector(ElementTriP2() if degree == 2 else ElementTriP1())
    basis = Basis(mesh, element, intorder=4)
    if case == "beam":
        p = beam.DEFAULTS
        lam, mu = lame_parameters(p["E"], p["nu"])
        lam = 2.0 * lam * mu / (lam + 2.0 * mu)                      # plane stress
        loaded = mesh.facets_satisfying(lambda x: np.isclose(x[0], 48.0))
        fixed = basis.get_dofs(lambda x: np.isclose(x[0], 0.0))

        def traction(x, normal):
            return beam.traction_end(x.reshape(2, -1).T).T.reshape(x.shape)

        exact = beam.displacement
    else:
        p = ring.DEFAULTS
        lam, mu = lame_parameters(p["E"], p["nu"])
        # the inner arc's boundary facets (straight chords: their midpoints lie inside r = 10 by the sagitta)
        loaded = mesh.facets_satisfying(lambda x: np.hypot(x[0], x[1]) < 10.0 + 0.25 * 15.0 / n, boundaries_only=True)
        fixed = None

        def traction(x, normal):
            pts = x.reshape(2, -1).T
            return ring.traction_on(pts, -pts / np.linalg.norm(pts, axis=1, keepdims=True)).T.reshape(x.shape)

        exact = None
    K = asm(linear_elasticity(lam, mu), basis)
    fbasis = FacetBasis(mesh, element, facets=loaded, intorder=4)

    @LinearForm
    def load(v, w):
        t = traction(w.x, None)
        return t[0] * v[0] + t[1] * v[1]

    f = asm(load, fbasis)
    u = np.zeros(basis.N)
    if case == "beam":
        ix, iy = basis.split_indices()
        locs = basis.doflocs
        u[ix] = exact(locs[:, ix].T)[:, 0]
        u[iy] = exact(locs[:, iy].T)[:, 1]
        dofs = fixed
    else:
        dofs = np.concatenate([basis.get_dofs(lambda x: np.isclose(x[1], 0.0)).keep("u^2").flatten(),   # u_y = 0
                               basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).keep("u^1").flatten()])  # u_x = 0
    system = condense(K, f, x=u, D=dofs)
    u = solve(*system)
    fem_solve.last_matrix = system[0]       # the condensed stiffness, for factor_stats
    return basis, u


def factor_stats(matrix) -> dict:
    """Size, entries per row, LU fill and factorisation time of ``matrix`` under one SuperLU setting for both
    methods (the EFG solver's: minimum degree on Aᵀ + A, diagonal pivots, ``warpfree.sparse.FactorisedSystem``)."""
    import scipy.sparse.linalg as spla

    from warpfree.sparse import FactorisedSystem

    a = matrix.tocsc()
    start = time.perf_counter()
    lu = spla.splu(a, permc_spec="MMD_AT_PLUS_A", options=dict(SymmetricMode=True),
                   diag_pivot_thresh=FactorisedSystem.SYMMETRIC_PIVOT_THRESHOLD)
    seconds = time.perf_counter() - start
    return {"rows": int(a.shape[0]), "entries_per_row": a.nnz / a.shape[0], "fill": int(lu.L.nnz + lu.U.nnz),
            "factor_s": seconds}


def fem_error(case: str, basis, u) -> float:
    from skfem import Functional

    from warpfree.validation import efg_cylinder as ring
    from warpfree.validation import efg_timoshenko as beam

    plane = "stress" if case == "beam" else "strain"
    dm = beam.elasticity_matrix(*(beam.DEFAULTS["E"], beam.DEFAULTS["nu"]) if case == "beam"
                                else (ring.DEFAULTS["E"], ring.DEFAULTS["nu"]), plane)
    exact_strain = beam.strain if case == "beam" else (lambda pts: ring.strain(pts, plane="strain"))

    def densities(w):
        g = w["u"].grad
        eps = np.array([g[0, 0], g[1, 1], g[0, 1] + g[1, 0]])
        shape = eps.shape[1:]
        ex = exact_strain(w.x.reshape(2, -1).T).T.reshape((3,) + shape)
        return eps - ex, ex

    @Functional
    def error_energy(w):
        e, _ = densities(w)
        return 0.5 * np.einsum("i...,ij,j...->...", e, dm, e)

    @Functional
    def exact_energy(w):
        _, ex = densities(w)
        return 0.5 * np.einsum("i...,ij,j...->...", ex, dm, ex)

    uh = basis.interpolate(u)
    return math.sqrt(error_energy.assemble(basis, u=uh) / exact_energy.assemble(basis, u=uh))


def run_case(case: str, args) -> dict:
    levels = [2, 4, 8, 16, 32] if not args.quick else [2, 4, 8]
    cyl_levels = [4, 8, 16, 32, 64] if not args.quick else [4, 8]
    out = {"efg": [], "efg_quadratic": [], "fem_p1": [], "fem_p2": [], "factor": []}
    for n in (levels if case == "beam" else cyl_levels):
        for basis, key in (("linear", "efg"), ("quadratic", "efg_quadratic")):
            solve_efg = (lambda n=n, b=basis: efg_beam(n, b)) if case == "beam" else \
                (lambda n=n, b=basis: efg_cylinder(n, b))
            t, s = _timed(solve_efg, args.repeats)
            out[key].append({"n": n, "unknowns": 2 * s.model.node_count, "wall_s": t, "error": efg_error(case, s)})
        for degree in (1, 2):
            fn = (lambda n=n, d=degree: fem_solve(case, 2 * n if d == 1 else n, d))
            t, (basis, u) = _timed(fn, args.repeats)
            out[f"fem_p{degree}"].append({"n": n, "unknowns": int(basis.N), "wall_s": t,
                                          "error": fem_error(case, basis, u)})
        # the factorisations side by side: EFG's quadratic basis and P2 reach about the same error at the same level
        efg_q = efg_beam(n, "quadratic") if case == "beam" else efg_cylinder(n, "quadratic")
        fem_solve(case, n, 2)
        out["factor"].append({"n": n, "efg_quadratic": factor_stats(efg_q.system.K_ff),
                              "fem_p2": factor_stats(fem_solve.last_matrix)})
        print(f"  {case} n={n}: " + ", ".join(f"{k} {v[-1]['unknowns']} dof {v[-1]['wall_s']:.3f} s "
                                             f"err {v[-1]['error']:.2e}" for k, v in out.items()
                                             if k != "factor"), flush=True)
    out["ratio_p1"] = common.equal_error_ratio(out["efg"], out["fem_p1"])
    out["ratio_p2"] = common.equal_error_ratio(out["efg"], out["fem_p2"])
    out["ratio_quadratic_p2"] = common.equal_error_ratio(out["efg_quadratic"], out["fem_p2"])
    for key in ("efg", "efg_quadratic", "fem_p2"):       # energy-norm convergence order per level (h halves)
        e = np.array([x["error"] for x in out[key]])
        out[f"rates_{key}"] = [float(r) for r in np.log2(e[:-1] / e[1:])]
    return out


def markdown(result: dict) -> str:
    lines = ["# EFG against FEM (scikit-fem), energy-norm error against wall time", "",
             f"Machine: {result['machine'].get('cpu')}, threads {result['threads']}.", ""]
    for case in ("beam", "cylinder"):
        r = result[case]
        lines += [f"## {case}", ""]
        rows = []
        for k in ("efg", "efg_quadratic", "fem_p1", "fem_p2"):
            for x in r[k]:
                rows.append([k, x["n"], x["unknowns"], common.fmt(x["wall_s"]), f"{x['error']:.3e}"])
        lines.append(common.md_table(["method", "level", "unknowns", "wall s", "energy-norm error"], rows))
        for k, name in (("ratio_p1", "EFG (linear) / FEM P1"), ("ratio_p2", "EFG (linear) / FEM P2"),
                        ("ratio_quadratic_p2", "EFG (quadratic) / FEM P2")):
            lines.append("")
            lines.append(f"{name} time at equal error: " +
                         (", ".join(f"{x['ratio']:.2f} (error {x['error']:.2e})" for x in r[k]) or
                          "no overlap of the error ranges"))
        lines.append("")
        lines.append("Energy-norm order per level: " + "; ".join(
            f"{k.replace('_', ' ')} " + ", ".join(f"{v:.2f}" for v in r[f"rates_{k}"])
            for k in ("efg", "efg_quadratic", "fem_p2")))
        lines += ["", "The factorisations at each level (EFG quadratic and P2 reach about the same error there), "
                      "one SuperLU setting for both (minimum degree on Aᵀ + A, diagonal pivots):", ""]
        rows = []
        for x in r["factor"]:
            e, f = x["efg_quadratic"], x["fem_p2"]
            rows.append([x["n"], e["rows"], f"{e['entries_per_row']:.0f}", f"{e['fill'] / 1e6:.2f}",
                         common.fmt(e["factor_s"]), f["rows"], f"{f['entries_per_row']:.0f}", f"{f['fill'] / 1e6:.2f}", common.fmt(f["factor_s"]),
                         f"{e['factor_s'] / f['factor_s']:.1f}"])
        lines.append(common.md_table(["level", "EFG q rows", "entries/row", "LU fill (M)", "factor s", "P2 rows",
                                      "entries/row", "LU fill (M)", "factor s", "EFG q / P2 factor time"], rows))
        lines.append("")
    return "\n".join(lines) + "\n"


def plot(result: dict):
    fig, axes = common.new_figure(1, 2, figsize=(10, 4))
    for ax, case in zip(axes, ("beam", "cylinder")):
        for k, style in (("efg", "o-"), ("efg_quadratic", "D-"), ("fem_p1", "s--"), ("fem_p2", "^--")):
            rows = result[case][k]
            ax.loglog([x["wall_s"] for x in rows], [x["error"] for x in rows], style, label=k.upper().replace("_", " "))
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative energy-norm error")
        ax.set_title(f"{case}: error against time")
        ax.legend()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=None)
    args = p.parse_args(argv)
    from warpfree import device

    launcher = device.use("cpu", args.threads)
    if args.quick:
        args.repeats = 1
    result = {"machine": common.machine_info(), "threads": launcher.threads}
    for case in ("beam", "cylinder"):
        result[case] = run_case(case, args)
    common.write_results("efg_vs_fem", result, markdown(result), plot(result), quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
