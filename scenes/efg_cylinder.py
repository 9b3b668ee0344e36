"""Thick cylinder under internal pressure by EFG (seed 003 §5.3, Table 5.3): u_r against the plane-strain Lamé solution.

A quarter of the ring a <= r <= b (a = 10, b = 25) with symmetry conditions (u_y = 0 on y = 0, u_x = 0 on x = 0,
Lagrange multipliers), pressure p = 100 on r = a, r = b free; G0 = 8000, ν = 0.3, E = 2 G0 (1 + ν), plane strain.
The exact radial displacement is the plane-strain Lamé solution, u_r(a) = 0.079167 (``warpfree/validation/
efg_cylinder``; the thesis's eq 5.3 is the plane-stress formula, 0.080815, and is not used). EFG as in the thesis:
linear basis, cubic spline, d_max = 2.5, nodes on a polar ("radial") grid, polar background cells of 2 x 2 Gauss
points; variationally consistent integration by default. ``layout="random"``: one random node per polar sub-cell.

Writes ``deformed.png``, VTU of the Gauss points and nodes, and into ``summary.json`` u_r at the inner and outer
radius (mean over the nodes there) against the exact values and the relative energy-norm error.
"""

import math
import os

import numpy as np

from warpfree.errors import ParameterError, require_positive
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, Natural
from warpfree.solvers.efg.layouts import annulus_nodes
from warpfree.solvers.efg.model import EFGModel, MLSSettings
from warpfree.solvers.efg.plots import plot_deformed
from warpfree.solvers.efg.quadrature import annulus_cells, arc_points
from warpfree.solvers.efg.solver import ElasticitySolver
from warpfree.validation import efg_cylinder as ring

LAYOUTS = ("regular", "random")


def cylinder_solver(cells_r: int, cells_t: int, layout: str = "regular", seed: int = 0, d_max: float = 2.5,
                    gauss: int = 2, method: str = "lagrange", integration: str = "consistent") -> ElasticitySolver:
    """The quarter ring's EFG solver (not yet solved) on (cells_r + 1)(cells_t + 1) polar-grid nodes."""
    p = ring.DEFAULTS
    a, b = p["a"], p["b"]
    if layout not in LAYOUTS:
        raise ParameterError("layout", f"must be one of {list(LAYOUTS)}, got {layout!r}")
    nodes = annulus_nodes(a, b, 0.0, math.pi / 2, (cells_r, cells_t), seed=seed if layout == "random" else None,
                          jitter=0.5 if layout == "random" else 0.0)
    x = nodes.position
    model = EFGModel(x, MLSSettings(d_max=d_max))
    cells = annulus_cells(a, b, 0.0, math.pi / 2, (cells_r, cells_t), gauss)
    tol = 1e-9 * b
    bottom = x[np.abs(x[:, 1]) <= tol]
    bottom = bottom[np.argsort(bottom[:, 0])]                    # counter-clockwise: a -> b along y = 0
    left = x[np.abs(x[:, 0]) <= tol]
    left = left[np.argsort(-left[:, 1])]                         # b -> a along x = 0
    zero = lambda q: np.zeros((len(q), 2))  # noqa: E731
    pressure = lambda q, n: ring.traction_on(q, n, plane="strain")  # noqa: E731  (σ·n of the exact field: p e_r on r = a)
    return ElasticitySolver(model, cells, p["E"], p["nu"], "strain",
                            essential=[Essential(bottom, zero, (False, True), name="symmetry_y0"),
                                       Essential(left, zero, (True, False), name="symmetry_x0")],
                            natural=[Natural(arc_points((0, 0), a, 0.0, math.pi / 2, cells_t, 3, outward=False),
                                             pressure, name="pressure")],
                            free=[arc_points((0, 0), b, 0.0, math.pi / 2, cells_t, 3, outward=True)],
                            method=method, integration=integration)


def cylinder_errors(solver: ElasticitySolver) -> dict:
    """u_r at the inner and outer radius (mean over the nodes' positions there) and the energy-norm error."""
    p = ring.DEFAULTS
    out = {"nodes": solver.model.node_count}
    for name, r in (("inner", p["a"]), ("outer", p["b"])):
        t = np.linspace(0.0, math.pi / 2, 9)
        pts = r * np.c_[np.cos(t), np.sin(t)]
        u = solver.field_at(pts)[0]
        ur = float(np.mean(np.einsum("ij,ij->i", u, pts / r)))
        exact = float(ring.radial_displacement(r, plane="strain"))
        out[f"u_r_{name}"], out[f"exact_u_r_{name}"], out[f"u_r_{name}_rel_error"] = ur, exact, ur / exact - 1.0
    err, norm = ring.energy_norm(solver.cells.position, solver.cells.weight, solver.gauss_strain(), plane="strain")
    out["energy_norm_error"] = err / norm
    return out


def build(cells_r: int = 16, cells_t: int = 16, layout: str = "regular", seed: int = 0, d_max: float = 2.5,
          gauss: int = 2, method: str = "lagrange", integration: str = "consistent", magnify: float = 50.0,
          frames: bool = True, vtk: bool = True) -> StaticRun:
    """``cells_r`` x ``cells_t`` polar node spacings (nodes: one more each way)."""
    params = dict(locals())
    for name in ("cells_r", "cells_t", "gauss"):
        v = params[name]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ParameterError(name, f"must be an integer >= 1, got {v!r}")
    require_positive("magnify", magnify)
    solver = cylinder_solver(cells_r, cells_t, layout, seed, d_max, gauss, method, integration)

    def accuracy(run, out_dir):
        u, _, sig = run.solver.strain_stress_at(run.solver.cells.position)
        plot_deformed(os.path.join(out_dir, "deformed.png"), run.solver.cells.position, u, sig, magnify,
                      "EFG thick cylinder", (5.0, 5.0))
        return {"cylinder": cylinder_errors(run.solver)}

    return StaticRun(solver, name="efg_cylinder", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames))
