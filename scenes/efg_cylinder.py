"""Thick cylinder under internal pressure by EFG (seed 003 §5.3, Table 5.3): u_r against the plane-strain Lamé solution.

A quarter of the ring a <= r <= b (a = 10, b = 25) with symmetry conditions (u_y = 0 on y = 0, u_x = 0 on x = 0,
Lagrange multipliers), pressure p = 100 on r = a, r = b free; G0 = 8000, ν = 0.3, E = 2 G0 (1 + ν), plane strain.
The exact radial displacement is the plane-strain Lamé solution, u_r(a) = 0.079167 (``warpfree/validation/
efg_cylinder``; the thesis's eq 5.3 is the plane-stress formula, 0.080815, and is not used). EFG as in the thesis:
linear basis, cubic spline, d_max = 2.5, nodes on a polar ("radial") grid, polar background cells of 2 x 2 Gauss
points; variationally consistent integration by default. ``layout="random"``: one random node per polar sub-cell.

Writes ``deformed.png``, VTU of the Gauss points and nodes, and into ``summary.json`` u_r at the inner and outer
radius (mean over the nodes on each arc) against the exact values and the relative energy-norm error.
"""

import math
import os

import numpy as np

from warpfree.errors import ParameterError, reported_as, require_integer, require_positive
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, Natural
from warpfree.galerkin.node_layouts import annulus_nodes
from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.solvers.efg.plots import plot_deformed
from warpfree.galerkin.quadrature import annulus_cells, arc_points, cell_order, polyline_points
from warpfree.solvers.efg.solver import ElasticitySolver
from warpfree.solvers.nem import NEMModel
from warpfree.validation import efg_cylinder as ring

LAYOUTS = ("regular", "random")


def cylinder_solver(cells_r: int, cells_t: int, layout: str = "regular", seed: int = 0, d_max: float = 2.5,
                    gauss: int = 2, method: str = "lagrange", integration: str | None = None,
                    model: str = "efg", basis: str = "linear") -> ElasticitySolver:
    """The quarter ring's solver (not yet solved) on (cells_r + 1)(cells_t + 1) polar-grid nodes; ``model`` "efg"
    or "nem" (natural elements on the same nodes: the domain is the polygon through the boundary nodes, Delaunay
    triangles, by default stabilized conforming nodal integration on the nodes' Voronoi cells clipped to them
    (``integration="gauss"`` or ``"consistent"``: 3 Gauss points per triangle), direct substitution, the pressure on
    the inner chords)."""
    p = ring.DEFAULTS
    a, b = p["a"], p["b"]
    if layout not in LAYOUTS:
        raise ParameterError("layout", f"must be one of {list(LAYOUTS)}, got {layout!r}")
    nodes = annulus_nodes(a, b, 0.0, math.pi / 2, (cells_r, cells_t), seed=seed if layout == "random" else None,
                          jitter=0.5 if layout == "random" else 0.0)
    x = nodes.position
    # NEM integrates by default with stabilized conforming nodal integration (smoothing cells, the only integration
    # of its C0 Laplace functions that converges: bench/results/nem_integration.md); "gauss" and "consistent" on
    # the Delaunay triangles (3 points) keep an error that refinement does not remove
    integration = integration or ("scni" if model == "nem" else "consistent")
    tol = 1e-9 * b
    bottom = x[np.abs(x[:, 1]) <= tol]
    bottom = bottom[np.argsort(bottom[:, 0])]                    # counter-clockwise: a -> b along y = 0
    left = x[np.abs(x[:, 0]) <= tol]
    left = left[np.argsort(-left[:, 1])]                         # b -> a along x = 0
    zero = lambda q: np.zeros((len(q), 2))  # noqa: E731
    symmetry = [Essential(bottom, zero, (False, True), name="symmetry_y0"),
                Essential(left, zero, (True, False), name="symmetry_x0")]
    if model == "efg":
        shapes = MLSModel(x, MLSSettings(basis=basis, d_max=d_max))
        cells = annulus_cells(a, b, 0.0, math.pi / 2, (cells_r, cells_t), gauss)
        pressure = Natural(arc_points((0, 0), a, 0.0, math.pi / 2, cells_t, 3, outward=False),
                           lambda q, n: ring.traction_on(q, n, plane="strain"), name="pressure")
        free = [arc_points((0, 0), b, 0.0, math.pi / 2, cells_t, 3, outward=True)]
    elif model == "nem":
        r = np.hypot(x[:, 0], x[:, 1])
        t = np.arctan2(x[:, 1], x[:, 0])
        inner = x[np.abs(r - a) <= tol][np.argsort(-t[np.abs(r - a) <= tol])]     # θ = π/2 -> 0
        outer = x[np.abs(r - b) <= tol][np.argsort(t[np.abs(r - b) <= tol])]      # θ = 0 -> π/2
        shapes = NEMModel(x, domain=np.vstack([bottom[:-1], outer[:-1], left[:-1], inner[:-1]]))
        cells = shapes.smoothing_cells() if integration == "scni" else shapes.integration_cells()
        pressure = Natural(polyline_points(inner, 3), lambda q, n: -ring.DEFAULTS["p"] * n, name="pressure")
        free, method = [polyline_points(outer, 3)], "direct"
    else:
        raise ParameterError("model", f"must be 'efg' or 'nem', got {model!r}")
    return ElasticitySolver(shapes, cells, p["E"], p["nu"], "strain", essential=symmetry, natural=[pressure],
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
        exact = float(ring.radial_displacement(radius, plane="strain"))
        out[f"u_r_{name}"], out[f"exact_u_r_{name}"], out[f"u_r_{name}_rel_error"] = ur, exact, ur / exact - 1.0
    err, norm = ring.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain(), plane="strain")
    out["energy_norm_error"] = err / norm
    return out


#: the scene's parameters behind the solver's internal names: an error names what the user set
NAMES = {"cells": "cells_r, cells_t", "order": "gauss", "support": "cells_r, cells_t, d_max"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"cells_r": 4, "cells_t": 4}


def build(cells_r: int = 16, cells_t: int = 16, layout: str = "regular", seed: int = 0, d_max: float = 2.5,
          gauss: int | None = None, method: str = "lagrange", integration: str | None = None, model: str = "efg",
          basis: str = "linear", magnify: float = 50.0,
          frames: bool = True, vtk: bool = True) -> StaticRun:
    """``cells_r`` x ``cells_t`` polar node spacings (nodes: one more each way); ``basis``: EFG's MLS basis, "linear"
    or "quadratic"; ``gauss``: points per cell side (None: the basis's, ``warpfree.galerkin.quadrature.CELL_ORDER``)."""
    gauss = cell_order(basis, gauss)
    params = dict(locals())
    for name in ("cells_r", "cells_t", "gauss"):
        require_integer(name, params[name], minimum=1)
    require_positive("magnify", magnify)
    with reported_as(**NAMES):
        solver = cylinder_solver(cells_r, cells_t, layout, seed, d_max, gauss, method, integration, model, basis)

    def accuracy(run, out_dir):
        u, _, sig = run.solver.gauss_strain_stress()
        plot_deformed(os.path.join(out_dir, "deformed.png"), run.solver.cells.position, u, sig, magnify,
                      "EFG thick cylinder", (5.0, 5.0))
        return {"cylinder": cylinder_errors(run.solver)}

    return StaticRun(solver, name="efg_cylinder", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames), reported_as=NAMES)
