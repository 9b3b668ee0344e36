"""Timoshenko cantilever by EFG: tip deflection and energy-norm error against the exact beam.

Rocha (2012), §5.1, Table 5.1.

Beam 0 <= x <= L, -D/2 <= y <= D/2 (E = 3e7, ν = 0.3, D = 12, L = 48, P = 1000, plane stress, unit thickness); the
exact displacements (Rocha 2012, eqs 5.1a/b, ``warpfree/validation/efg_timoshenko``) are imposed on x = 0 with Lagrange
multipliers at the nodes of that edge (Rocha 2012, eqs 3.34-3.36), the parabolic shear traction of the exact solution
on x = L, y = ±D/2 free. EFG as in the thesis: linear basis, cubic-spline weight, d_max = 3.5 (c_I: distance to
the 4th nearest node, the spacing on a regular grid), background cells of 2 x 2 Gauss points, one cell per node
spacing; by default with variationally consistent integration (``integration="gauss"``: the thesis's plain
quadrature). ``layout="random"``: one random node per sub-cell, boundary nodes along their edges (Rocha 2012, §5).

Writes ``deformed.png`` (the Gauss points displaced ×``magnify``, coloured by von Mises stress), ``deflection.png``
(u_y along the neutral axis against the exact one, and their difference with the tip tolerance), VTU of the Gauss
points and nodes, and into ``summary.json`` the tip deflection u_y(L, 0) against the exact 8.900e-3 m and the
relative energy-norm error, and ``checks``: the tip deflection within 0.5 % of the exact one (:func:`beam_checks`);
with ``refinements`` > 0 also the same at that many coarser-to-finer layouts (cells (6·2^k, 1.5·2^k)...) with the
fitted convergence rate and ``convergence.png``.

Errors at the defaults and under refinement: ``bench/results/scene_studies.md``.
"""

import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parallel.petsc_system import Preconditioner
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, EssentialMethod, Natural
from warpfree.galerkin.node_layouts import NodePlacement, box_sides, grid_nodes, random_grid_nodes
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, MLSWeight, SupportScale, Weight
from warpfree.galerkin.shapes import ShapeFunctions
from warpfree.io.validation_plots import plot_against_reference
from warpfree.solvers.efg.parameters import CellGauss, Layout, LayoutSeed, Magnify, Method, Model, ModelIntegration
from warpfree.solvers.efg.plots import plot_deformed
from warpfree.galerkin.quadrature import cell_order, polyline_points, rectangle_cells
from warpfree.solvers.efg.solver import ElasticitySolver, Integration, LinearSolver, Plane
from warpfree.solvers.nem import NEMModel
from warpfree.validation import efg_timoshenko as beam, tolerance_check


def beam_solver(cells_x: int, cells_y: int, layout: NodePlacement = NodePlacement.REGULAR, seed: int = 0,
                d_max: float = 3.5, weight: MLSWeight = MLSWeight.CUBIC_SPLINE, basis: MLSBasis = MLSBasis.LINEAR,
                gauss: int = 2, method: EssentialMethod = EssentialMethod.LAGRANGE,
                integration: Integration | None = None, model: ShapeFunctions = ShapeFunctions.EFG,
                linear_solver: LinearSolver = LinearSolver.AUTO,
                preconditioner: Preconditioner = Preconditioner.AUTO) -> ElasticitySolver:
    """The beam's solver (not yet solved) on (cells_x + 1)(cells_y + 1) nodes; ``model`` "efg" or "nem" (the
    natural element method on the same nodes, direct substitution; by default stabilized conforming nodal integration
    on the nodes' Voronoi cells, ``integration="gauss"`` or ``"consistent"``: Delaunay triangles with 3 Gauss
    points). With "scni" the energy-norm error is that of the smoothed strains at the nodes (cell areas as weights)."""
    p = beam.DEFAULTS
    length, depth = p["L"], p["D"]
    lower, upper = (0.0, -depth / 2), (length, depth / 2)
    if NodePlacement.of("layout", layout) is NodePlacement.REGULAR:
        nodes = grid_nodes(lower, upper, (cells_x, cells_y))
    else:
        nodes = random_grid_nodes(lower, upper, (cells_x, cells_y), seed=seed)
    x = nodes.position
    # NEM integrates by default with stabilized conforming nodal integration (smoothing cells, the only integration
    # of its C0 Laplace functions that converges: bench/results/nem_integration.md); "gauss" and "consistent" on
    # the Delaunay triangles (3 points) keep an error that refinement does not remove
    model = ShapeFunctions.of("model", model)
    integration = Integration.of("integration", integration or (Integration.SCNI if model is ShapeFunctions.NEM
                                                                 else Integration.CONSISTENT))
    if model is ShapeFunctions.NEM:
        shapes, method = NEMModel(x), EssentialMethod.DIRECT
        cells = shapes.smoothing_cells() if integration is Integration.SCNI else shapes.integration_cells()
    else:
        shapes = MLSModel(x, MLSSettings(basis=basis, weight=weight, d_max=d_max))
        cells = rectangle_cells(lower, upper, (cells_x, cells_y), gauss)
    left = box_sides(x, lower, upper)[3]                        # counter-clockwise: top to bottom
    right = np.c_[np.full(cells_y + 1, length), np.linspace(-depth / 2, depth / 2, cells_y + 1)]
    top = np.c_[np.linspace(length, 0.0, cells_x + 1), np.full(cells_x + 1, depth / 2)]
    bottom = np.c_[np.linspace(0.0, length, cells_x + 1), np.full(cells_x + 1, -depth / 2)]
    return ElasticitySolver(shapes, cells, p["E"], p["nu"], Plane.STRESS,
                            essential=[Essential(left, lambda q: beam.displacement(q), name="clamped_edge")],
                            natural=[Natural(polyline_points(right, 3), lambda q, n: beam.traction_end(q),
                                             name="end_load")],
                            free=[polyline_points(top, 3), polyline_points(bottom, 3)], method=method,
                            integration=integration, linear_solver=linear_solver, preconditioner=preconditioner)


def beam_errors(solver: ElasticitySolver) -> dict:
    """Tip deflection against the exact one, and the energy-norm error at the Gauss points."""
    tip = solver.field_at(np.array([beam.TIP_POINT]))[0][0, 1]
    err, norm = beam.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain())
    return {"nodes": solver.model.node_count, "tip_deflection": float(tip), "exact_tip_deflection": beam.TIP_DEFLECTION,
            "tip_rel_error": float(tip / beam.TIP_DEFLECTION - 1.0), "energy_norm_error": err / norm,
            "strain_energy": solver.strain_energy(), "exact_strain_energy": beam.strain_energy()}


#: where the reference comes from
EXACT = "exact: Timoshenko & Goodier §21; Rocha (2012), eq. 5.1b (warpfree/validation/efg_timoshenko/README.md)"
#: the tip deflection's tolerance, a fraction of the exact one
TIP_TOLERANCE = 5e-3


def beam_checks(errors: dict) -> dict:
    """The tip deflection u_y(L, 0) (m) against the exact P L³/(3EI) + (4 + 5ν) P L D²/(24 E I) = 8.900e-3 m."""
    return {"tip_deflection": tolerance_check(
        errors["tip_deflection"], TIP_TOLERANCE * abs(beam.TIP_DEFLECTION), EXACT, reference=beam.TIP_DEFLECTION,
        unit="m", basis="0.5 % of the exact deflection: the accuracy asked of linear-basis EFG with at most 1000 "
                        "regular nodes (Rocha 2012 reports the deflection only as plots, with no stated accuracy)")}


#: the scene's parameters behind the solver's internal names: an error names what the user set
NAMES = {"cells": "cells_x, cells_y", "order": "gauss", "support": "cells_x, cells_y, d_max"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"cells_x": 12, "cells_y": 3}
#: what the benchmarks run of this scene for its family (bench/common.py ``benchmarks``): bench/core/gpu_check.py's
#: throughput at three sizes (``parameter`` set to each of ``values``, ``steps`` timed per block) and
#: bench/core/scaling.py's n and 2n work items on one and two ranks (the settings of each, per sweep size)
BENCHMARK = {"parameter": "cells_x", "values": [24, 48, 96], "steps": 1,
             "scaling": {"large": [{"cells_y": 24, "cells_x": 96}, {"cells_y": 34, "cells_x": 136}],
                         "small": [{"cells_y": 12, "cells_x": 48}, {"cells_y": 17, "cells_x": 68}]}}
#: runs besides ``SMALLEST`` that load kernels it does not (NEM's, the quadratic basis's): the compile-time variants
#: bench/core/register_report.py also compiles
KERNEL_VARIANTS = [{"model": "nem"}, {"basis": "quadratic"}]

#: ``warpfree validate --quick``: the default layout (637 nodes, under 2 s), whose tip is held to the 0.5 %
QUICK = {"cells_x": 48, "cells_y": 12}


@checked_parameters
def build(cells_x: Annotated[int, Param("", "node spacings along the beam's length", "[1, inf)")] = 48,
          cells_y: Annotated[int, Param("", "node spacings across the beam's depth", "[1, inf)")] = 12,
          layout: Layout = NodePlacement.REGULAR, seed: LayoutSeed = 0, d_max: SupportScale = 3.5,
          weight: Weight = MLSWeight.CUBIC_SPLINE, basis: Basis = MLSBasis.LINEAR, gauss: CellGauss = None,
          method: Method = EssentialMethod.LAGRANGE, integration: ModelIntegration = None,
          model: Model = ShapeFunctions.EFG,
          refinements: Annotated[int, Param("", "also solve on this many layouts from 12 x 3 cells, doubling "
                                                "(convergence study; 0: none)", "[0, inf)")] = 0,
          magnify: Magnify = 200.0,
          linear_solver: Annotated[LinearSolver, Param("", "how the assembled system is solved")] = LinearSolver.AUTO,
          preconditioner: Annotated[Preconditioner, Param("", "PETSc's preconditioner")] = Preconditioner.AUTO,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """``cells_x`` x ``cells_y`` node spacings (nodes: one more each way); ``gauss``: points per cell side (None: the
    basis's, ``warpfree.galerkin.quadrature.CELL_ORDER``); ``refinements``: also solve on that many layouts of
    12 x 3, 24 x 6, ... cells (convergence study); ``linear_solver``, ``preconditioner``: how the system is solved
    (``warpfree.solvers.efg.solver.LinearSolver``: SuperLU in one process, PETSc over several ranks)."""
    gauss = cell_order(basis, gauss)
    params = dict(locals())
    options = dict(layout=layout, seed=seed, d_max=d_max, weight=weight, basis=basis, gauss=gauss, method=method,
                   integration=integration, model=model, linear_solver=linear_solver, preconditioner=preconditioner)
    with reported_as(**NAMES):
        solver = beam_solver(cells_x, cells_y, **options)

    def accuracy(run, out_dir):
        result = {"beam": beam_errors(run.solver)}
        result["beam"]["checks"] = beam_checks(result["beam"])
        if refinements:
            study = [beam_errors(_solved(beam_solver(6 * 2 ** (k + 1), 3 * 2 ** k, **options)))
                     for k in range(refinements)]
            h = 1.0 / np.sqrt([s["nodes"] for s in study])
            e = np.array([s["energy_norm_error"] for s in study])
            rate = float(np.polyfit(np.log(h), np.log(e), 1)[0]) if len(study) > 1 else None
            result["convergence"] = {"levels": study, "energy_norm_rate": rate}
            if out_dir is not None:
                _plot_convergence(os.path.join(out_dir, "convergence.png"), study, h, e, rate)
        if out_dir is not None:
            u, _, sig = run.solver.gauss_strain_stress()
            label = "NEM" if model is ShapeFunctions.NEM else "EFG"
            plot_deformed(os.path.join(out_dir, "deformed.png"), run.solver.cells.position, u, sig, magnify,
                          f"{label} Timoshenko beam", (8.0, 3.0))
            _plot_deflection(os.path.join(out_dir, "deflection.png"), run.solver, label)
        return result

    return StaticRun(solver, name="efg_timoshenko", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames), reported_as=NAMES)


def _solved(solver):
    solver.solve()
    return solver


def _plot_deflection(path, solver, label: str):
    """u_y(x, 0) along the neutral axis against the exact (5.1b), and (u_y - exact) / u_y(L, 0) with the tip's
    tolerance."""
    x = np.linspace(0.0, beam.DEFAULTS["L"], 97)
    pts = np.c_[x, np.zeros_like(x)]
    uy = solver.field_at(pts)[0][:, 1]
    exact = beam.displacement(pts)[:, 1]
    plot_against_reference(path, x, {label: uy * 1e3}, exact * 1e3,
                           {label: (uy - exact) / beam.TIP_DEFLECTION * 100}, TIP_TOLERANCE * 100,
                           xlabel="x (m), y = 0", ylabel="u_y (mm)",
                           error_label="(u_y − exact) / u_y(L, 0) (%)",
                           title="Timoshenko beam: deflection of the neutral axis against the exact solution",
                           reference_label="exact (Timoshenko & Goodier, eq 5.1b)",
                           tolerance_label=f"±{TIP_TOLERANCE * 100:g} % (tip tolerance)")


def _plot_convergence(path, study, h, e, rate):
    """Energy-norm error against 1/sqrt(nodes) with the linear basis's rate-1 line (above), the tip deflection's
    relative error per layout with its tolerance (below)."""
    tip = np.array([s["tip_rel_error"] for s in study]) * 100
    plot_against_reference(path, h, {f"EFG (fitted rate {rate:.2f})" if rate is not None else "EFG": e},
                           e[0] * (h / h[0]), {"tip deflection": tip}, TIP_TOLERANCE * 100,
                           xlabel="1/sqrt(nodes)", ylabel="relative energy-norm error",
                           error_label="u_y(L, 0) / exact − 1 (%)", logx=True, logy=True,
                           title="Timoshenko beam: convergence under refinement",
                           reference_label="rate 1 (linear basis, theory)",
                           tolerance_label=f"±{TIP_TOLERANCE * 100:g} %")