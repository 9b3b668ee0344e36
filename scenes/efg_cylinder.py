"""Thick cylinder under internal pressure by EFG: u_r against the plane-strain Lamé solution.

Rocha (2012), §5.3, Table 5.3.

A quarter of the ring a <= r <= b (a = 10, b = 25) with symmetry conditions (u_y = 0 on y = 0, u_x = 0 on x = 0,
Lagrange multipliers), pressure p = 100 on r = a, r = b free; G0 = 8000, ν = 0.3, E = 2 G0 (1 + ν), plane strain.
The exact radial displacement is the plane-strain Lamé solution, u_r(a) = 0.079167 (``warpfree/validation/
efg_cylinder``; the thesis's eq 5.3 is the plane-stress formula, 0.080815, and is not used). EFG as in the thesis:
linear basis, cubic spline, d_max = 2.5, nodes on a polar ("radial") grid, polar background cells of 2 x 2 Gauss
points; variationally consistent integration by default. ``layout="random"``: one random node per polar sub-cell.

Writes ``deformed.png``, ``radial.png`` (u_r at every node against Lamé's, and the relative errors with the arcs'
means and their tolerance), VTU of the Gauss points and nodes, and into ``summary.json`` u_r at the inner and outer radius (mean
over the nodes on each arc) against the exact values and the relative energy-norm error, and ``checks`` for the
three (:func:`cylinder_checks`). Lengths and stresses are in the consistent units of Table 5.3 (a, b; p, G0).
"""

import math
import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, EssentialMethod, Natural
from warpfree.galerkin.node_layouts import NodePlacement, annulus_nodes
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, SupportScale
from warpfree.galerkin.shapes import ShapeFunctions
from warpfree.solvers.efg.parameters import CellGauss, Layout, LayoutSeed, Magnify, Method, Model, ModelIntegration
from warpfree.solvers.efg.plots import plot_deformed
from warpfree.galerkin.quadrature import annulus_cells, arc_points, cell_order, polyline_points
from warpfree.solvers.efg.solver import ELASTICITY_UNITS, ElasticitySolver, Integration, Plane
from warpfree.solvers.nem import NEMModel
from warpfree.validation import efg_cylinder as ring, tolerance_check


def cylinder_solver(cells_r: int, cells_t: int, layout: NodePlacement = NodePlacement.REGULAR, seed: int = 0,
                    d_max: float = 2.5, gauss: int = 2, method: EssentialMethod = EssentialMethod.LAGRANGE,
                    integration: Integration | None = None, model: ShapeFunctions = ShapeFunctions.EFG,
                    basis: MLSBasis = MLSBasis.LINEAR) -> ElasticitySolver:
    """The quarter ring's solver (not yet solved) on (cells_r + 1)(cells_t + 1) polar-grid nodes; ``model`` "efg"
    or "nem" (natural elements on the same nodes: the domain is the polygon through the boundary nodes, Delaunay
    triangles, by default stabilized conforming nodal integration on the nodes' Voronoi cells clipped to them
    (``integration="gauss"`` or ``"consistent"``: 3 Gauss points per triangle), direct substitution, the pressure on
    the inner chords)."""
    p = ring.DEFAULTS
    a, b = p["a"], p["b"]
    jittered = NodePlacement.of("layout", layout) is NodePlacement.RANDOM
    model = ShapeFunctions.of("model", model)
    nodes = annulus_nodes(a, b, 0.0, math.pi / 2, (cells_r, cells_t), seed=seed if jittered else None,
                          jitter=0.5 if jittered else 0.0)
    x = nodes.position
    # NEM integrates by default with stabilized conforming nodal integration (smoothing cells, the only integration
    # of its C0 Laplace functions that converges: bench/results/nem_integration.md); "gauss" and "consistent" on
    # the Delaunay triangles (3 points) keep an error that refinement does not remove
    integration = Integration.of("integration", integration or (Integration.SCNI if model is ShapeFunctions.NEM
                                                                 else Integration.CONSISTENT))
    tol = 1e-9 * b
    bottom = x[np.abs(x[:, 1]) <= tol]
    bottom = bottom[np.argsort(bottom[:, 0])]                    # counter-clockwise: a -> b along y = 0
    left = x[np.abs(x[:, 0]) <= tol]
    left = left[np.argsort(-left[:, 1])]                         # b -> a along x = 0
    zero = lambda q: np.zeros((len(q), 2))  # noqa: E731
    symmetry = [Essential(bottom, zero, (False, True), name="symmetry_y0"),
                Essential(left, zero, (True, False), name="symmetry_x0")]
    if model is ShapeFunctions.EFG:
        shapes = MLSModel(x, MLSSettings(basis=basis, d_max=d_max))
        cells = annulus_cells(a, b, 0.0, math.pi / 2, (cells_r, cells_t), gauss)
        pressure = Natural(arc_points((0, 0), a, 0.0, math.pi / 2, cells_t, 3, outward=False),
                           lambda q, n: ring.traction_on(q, n, plane=Plane.STRAIN), name="pressure")
        free = [arc_points((0, 0), b, 0.0, math.pi / 2, cells_t, 3, outward=True)]
    else:
        r = np.hypot(x[:, 0], x[:, 1])
        t = np.arctan2(x[:, 1], x[:, 0])
        inner = x[np.abs(r - a) <= tol][np.argsort(-t[np.abs(r - a) <= tol])]     # θ = π/2 -> 0
        outer = x[np.abs(r - b) <= tol][np.argsort(t[np.abs(r - b) <= tol])]      # θ = 0 -> π/2
        shapes = NEMModel(x, domain=np.vstack([bottom[:-1], outer[:-1], left[:-1], inner[:-1]]))
        cells = shapes.smoothing_cells() if integration is Integration.SCNI else shapes.integration_cells()
        pressure = Natural(polyline_points(inner, 3), lambda q, n: -ring.DEFAULTS["p"] * n, name="pressure")
        free, method = [polyline_points(outer, 3)], EssentialMethod.DIRECT
    return ElasticitySolver(shapes, cells, p["E"], p["nu"], Plane.STRAIN, essential=symmetry, natural=[pressure],
                            free=free, method=method, integration=integration)

def cylinder_errors(solver: ElasticitySolver) -> dict:
    """u_r at the inner and outer radius (mean over the nodes on each arc) and the energy-norm error."""
    p = ring.DEFAULTS
    out = {"nodes": solver.model.node_count}
    x = solver.model.nodes_np
    r = np.hypot(x[:, 0], x[:, 1])
    for name, radius in (("inner", p["a"]), ("outer", p["b"])):
        pts = x[np.abs(r - radius) <= 1e-9 * p["b"]]
        u = solver.field_at(pts)[0]
        ur = float(np.mean(np.einsum("ij,ij->i", u, pts / radius)))
        exact = float(ring.radial_displacement(radius, plane=Plane.STRAIN))
        out[f"u_r_{name}"], out[f"exact_u_r_{name}"], out[f"u_r_{name}_rel_error"] = ur, exact, ur / exact - 1.0
    err, norm = ring.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain(),
                                 plane=Plane.STRAIN)
    out["energy_norm_error"] = err / norm
    return out


#: where the reference comes from
EXACT = "exact: plane-strain Lamé, Timoshenko & Goodier §31 (warpfree/validation/efg_cylinder/README.md)"
#: u_r's tolerance at r = a and r = b, a fraction of the exact value
RADIAL_TOLERANCE = 5e-3
#: the relative energy-norm error's tolerance by node layout
ENERGY_TOLERANCE = {NodePlacement.REGULAR: 1e-2, NodePlacement.RANDOM: 5e-2}


def cylinder_checks(errors: dict, layout: NodePlacement) -> dict:
    """u_r at r = a and r = b (mean over each arc's nodes) within 0.5 % of Lamé's, and the relative energy-norm
    error within 1 % (regular polar nodes; 5 % with one random node per sub-cell)."""
    checks = {}
    for name in ("inner", "outer"):
        exact = errors[f"exact_u_r_{name}"]
        checks[f"u_r_{name}"] = tolerance_check(
            errors[f"u_r_{name}"], RADIAL_TOLERANCE * abs(exact), EXACT, reference=exact,
            basis="0.5 % of Lamé's u_r: the accuracy asked of EFG on 17 x 17 polar nodes (Rocha 2012 reports u_r only "
                  "as plots, with 'relatively small differences' from theory)")
    checks["energy_norm_error"] = tolerance_check(
        errors["energy_norm_error"], ENERGY_TOLERANCE[NodePlacement.of("layout", layout)], EXACT,
        basis="the relative energy-norm error asked of linear-basis EFG on 17 x 17 polar nodes: 1 % on the regular "
              "layout, 5 % with one random node per sub-cell (Rocha 2012 reports no error norm)")
    return checks


#: the scene's parameters behind the solver's internal names: an error names what the user set
NAMES = {"cells": "cells_r, cells_t", "order": "gauss", "support": "cells_r, cells_t, d_max"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"cells_r": 4, "cells_t": 4}

#: ``warpfree validate --quick``: the default layout (289 nodes, under 2 s), the resolution the tolerances are for
QUICK = {"cells_r": 16, "cells_t": 16}


@checked_parameters
def build(cells_r: Annotated[int, Param("", "node spacings along the radius", "[1, inf)")] = 16,
          cells_t: Annotated[int, Param("", "node spacings along the quarter circle", "[1, inf)")] = 16,
          layout: Layout = NodePlacement.REGULAR, seed: LayoutSeed = 0, d_max: SupportScale = 2.5,
          gauss: CellGauss = None, method: Method = EssentialMethod.LAGRANGE, integration: ModelIntegration = None,
          model: Model = ShapeFunctions.EFG, basis: Basis = MLSBasis.LINEAR, magnify: Magnify = 50.0,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """``cells_r`` x ``cells_t`` polar node spacings (nodes: one more each way); ``basis``: EFG's MLS basis, "linear"
    or "quadratic"; ``gauss``: points per cell side (None: the basis's, ``warpfree.galerkin.quadrature.CELL_ORDER``)."""
    gauss = cell_order(basis, gauss)
    params = dict(locals())
    with reported_as(**NAMES):
        solver = cylinder_solver(cells_r, cells_t, layout, seed, d_max, gauss, method, integration, model, basis)

    def accuracy(run, out_dir):
        result = cylinder_errors(run.solver)
        result["checks"] = cylinder_checks(result, layout)
        if out_dir is not None:
            u, _, sig = run.solver.gauss_strain_stress()
            label = "NEM" if model is ShapeFunctions.NEM else "EFG"
            plot_deformed(os.path.join(out_dir, "deformed.png"), run.solver.cells.position, u, sig, magnify,
                          f"{label} thick cylinder", (5.0, 5.0),
                          stress_unit="consistent units", length_unit="consistent units")
            _plot_radial(os.path.join(out_dir, "radial.png"), run.solver, label)
        return {"cylinder": result}

    return StaticRun(solver, name="efg_cylinder", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames,  # lengths and stresses in Table 5.3's units
                                          units=dict.fromkeys(ELASTICITY_UNITS, "consistent units")),
                     reported_as=NAMES)


def _plot_radial(path, solver, label: str):
    """u_r at every node against r, over the plane-strain Lamé solution (above), and u_r / exact - 1 at the nodes
    with the arcs' means that the checks take (below), the ±0.5 % tolerance drawn."""
    from warpfree.io.validation_plots import COMPUTED, REFERENCE, comparison_axes, draw_tolerance, save_figure

    p = ring.DEFAULTS
    x = solver.model.nodes_np
    r = np.hypot(x[:, 0], x[:, 1])
    u_r = np.einsum("ij,ij->i", solver.field_at(x)[0], x / r[:, None])
    rr = np.linspace(p["a"], p["b"], 101)
    fig, top, bottom = comparison_axes(title=f"Thick cylinder: radial displacement at the {x.shape[0]} nodes "
                                             "against Lamé (plane strain)")
    top.plot(rr, ring.radial_displacement(rr, plane=Plane.STRAIN), "-", color=REFERENCE, lw=1.2,
             label="Lamé, plane strain")
    top.plot(r, u_r, "o", ms=3, mfc="none", color=COMPUTED, label=f"{label}, each node")
    top.set_ylabel("u_r (consistent units)")
    top.legend(fontsize=8)
    draw_tolerance(bottom, RADIAL_TOLERANCE * 100, label=f"tolerance ±{RADIAL_TOLERANCE * 100:g} % (arc means)")
    bottom.plot(r, (u_r / ring.radial_displacement(r, plane=Plane.STRAIN) - 1.0) * 100, "o", ms=3, mfc="none",
                color=COMPUTED, label=f"{label}, each node")
    errors = cylinder_errors(solver)
    bottom.plot([p["a"], p["b"]], [errors["u_r_inner_rel_error"] * 100, errors["u_r_outer_rel_error"] * 100], "D",
                ms=7, color="C1", label="mean over each arc's nodes (checked)")
    bottom.axhline(0.0, color="0.5", lw=0.8)
    bottom.set_xlabel("r (consistent units)")
    bottom.set_ylabel("u_r / exact − 1 (%)")
    bottom.legend(fontsize=7)
    save_figure(fig, path)
