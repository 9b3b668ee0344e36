"""Two-material resistor by EFG: potential, field and interface conditions against a fine FEM reference.

Marques (2008), §6.2.

An inverted-T conductor (``warpfree/validation/efg_resistor``; the thesis's geometry is lost with its figure): a
lower bar [0, 3] x [0, 1] mm of aluminium (σ1 = 3.57e7 S/m) and an upper bar [1, 2] x [1, 2] mm of copper (σ2 =
5.88e7 S/m) meeting on the interface y = 1 mm, whose ends are re-entrant corners (the thesis's two "critical
regions"); V = 1 V on the top face, 0 on the bottom face, the rest insulated; ∇·(σ∇V) = 0. The reference is our Q9
finite-element solution on 16..256 elements per mm, extrapolated at the corners' singular order.

EFG as in Marques (2008), with nodes graded toward the singular corners: cells of a regular grid (``per_mm`` per mm) split
``corner_levels`` times toward the two re-entrant corners (``warpfree.galerkin.graded``; a cell while its distance to
a corner is below ``corner_reach`` × its side), the nodes on the cells' corners, interface nodes shared by both
materials; the quadratic basis (its quadratic consistency correction, 3 x 3 Gauss points per cell), whose one-sided
gradients at the interface are second order (the linear basis's first order: 3.6 % normal-current mismatch
mid-interface at 13 per mm, graded or not). At fewer than about 5 spacings per mm a quadratic support at a grading
step can hold only two rows of nodes, and the run is refused (raise ``d_max`` or ``per_mm``). Domain truncation
(``truncation=True``): a node of one material serves only Gauss points of its own material, so the shape functions
are discontinuous in gradient across the interface as the field is; cells do not straddle the interface; the
interface term truncation drops put back by symmetric Nitsche terms (``interface_condition="nitsche"``, penalty
β k / h with h the nearest node's spacing; "none": Marques's (2008) truncation alone). The electrode potentials by
Lagrange multipliers (default) or, with the interpolating (singular) weight, by direct substitution (Marques 2008, §3.5).

Writes ``lines.png`` (V and |E| along the crossing line x = 1.5 mm against the reference), VTU, and into
``summary.json``: the largest potential error on the reference lines (fraction of 1 V), the mean and largest
relative |E| error on the crossing lines, the normal-current mismatch σ1 E_y(below) / σ2 E_y(above) - 1 and the
tangential-field mismatch along the interface (x in 1.1..1.9 mm), the conductance against the reference, an
oscillation measure (the total variation of |E| along the crossing line beyond the reference's), and ``checks``: the
potential, field, normal-current and tangential-field errors against Marques's (2008) accuracy, each with its tolerance and
pass/fail (:func:`resistor_checks`).

Errors at the defaults, by basis and interface condition: ``bench/results/scene_studies.md``.
"""

import os
from typing import Annotated

import numpy as np

from warpfree.errors import reported_as
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.boundary import Essential, EssentialMethod, Free, Interface, InterfaceCondition
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, MLSWeight, SupportScale, Weight
from warpfree.galerkin.graded import graded_box, merged_nodes, side_vertices
from warpfree.galerkin.quadrature import BoundaryPoints, QuadraturePoints, cell_order, polyline_points, segment_points
from warpfree.solvers.efg.parameters import CellGauss, DomainIntegration, Method
from warpfree.solvers.efg.solver import Integration, PoissonSolver
from warpfree.validation import efg_resistor as ref, tolerance_check

MM = ref.MM
#: our material indices 0 (lower bar) and 1 (upper bar) are the reference's materials 1 and 2
SIGMA = np.array([ref.CONDUCTIVITY[1], ref.CONDUCTIVITY[2]])


def _merge(parts: list[QuadraturePoints]) -> QuadraturePoints:
    offsets = np.cumsum([0] + [int(p.cell.max()) + 1 for p in parts[:-1]])
    return QuadraturePoints(np.vstack([p.position for p in parts]), np.concatenate([p.weight for p in parts]),
                            np.concatenate([p.cell + o for p, o in zip(parts, offsets)]))


def resistor_solver(per_mm: int = 13, d_max: float = 1.8, weight: MLSWeight = MLSWeight.CUBIC_SPLINE,
                    method: EssentialMethod = EssentialMethod.LAGRANGE, gauss: int = 2, truncation: bool = True,
                    integration: Integration = Integration.CONSISTENT, basis: MLSBasis = MLSBasis.LINEAR,
                    interface_condition: InterfaceCondition = InterfaceCondition.NITSCHE, corner_levels: int = 0,
                    corner_reach: float = 2.0) -> PoissonSolver:
    """The resistor's EFG solver (not yet solved): ``per_mm`` node spacings per mm, the cells (and their corners,
    the nodes) split ``corner_levels`` times toward the re-entrant corners (``warpfree.galerkin.graded``)."""
    n = per_mm
    bars = [graded_box((0.0, 0.0), (3 * MM, MM), (3 * n, n), ref.CORNERS, corner_levels, corner_reach),
            graded_box((MM, MM), (2 * MM, 2 * MM), (n, n), ref.CORNERS, corner_levels, corner_reach)]
    finest = MM / (n * 2 ** corner_levels)
    nodes = merged_nodes([b.nodes() for b in bars], 0.25 * finest)
    tol = 1e-9 * MM
    on_interface = (np.abs(nodes[:, 1] - MM) <= tol) & (nodes[:, 0] >= MM - tol) & (nodes[:, 0] <= 2 * MM + tol)
    material = np.where(nodes[:, 1] > MM + tol, 1, 0)
    material[on_interface] = -1
    model = MLSModel(nodes, MLSSettings(basis=basis, weight=weight, d_max=d_max),
                     node_material=material if truncation else None)
    cells = _merge([b.gauss_points(gauss) for b in bars])
    cell_material = np.r_[np.zeros(bars[0].size.size, dtype=int), np.ones(bars[1].size.size, dtype=int)]

    def side(a, b) -> BoundaryPoints:
        """3 Gauss points on each piece between consecutive nodes along a → b."""
        return polyline_points(side_vertices(nodes, (a[0] * MM, a[1] * MM), (b[0] * MM, b[1] * MM), tol), 3)

    top = side_vertices(nodes, (2 * MM, 2 * MM), (MM, 2 * MM), tol)        # counter-clockwise: x = 2 -> 1 mm
    bottom = side_vertices(nodes, (0.0, 0.0), (3 * MM, 0.0), tol)
    electrodes = [Essential(top, lambda p: np.full((len(p), 1), ref.ELECTRODES["top"]["potential"]), (True,),
                            name="top_electrode", material=1),
                  Essential(bottom, lambda p: np.full((len(p), 1), ref.ELECTRODES["bottom"]["potential"]), (True,),
                            name="bottom_electrode", material=0)]
    insulated = [Free(side((3, 0), (3, 1)), 0), Free(side((3, 1), (2, 1)), 0), Free(side((1, 1), (0, 1)), 0),
                 Free(side((0, 1), (0, 0)), 0), Free(side((2, 1), (2, 2)), 1), Free(side((1, 2), (1, 1)), 1)]
    interface = Interface(side((2, 1), (1, 1)), inside=0, outside=1)    # normal +y: out of the lower bar
    return PoissonSolver(model, cells, conductivity=SIGMA, cell_material=cell_material, essential=electrodes,
                         free=insulated, interfaces=[interface], method=method, integration=integration,
                         interface_condition=interface_condition if truncation else InterfaceCondition.NONE)


def _line_field(solver: PoissonSolver, line: dict) -> tuple[np.ndarray, np.ndarray]:
    pts = np.c_[line["x"], line["y"]]
    mat = np.asarray(line["material"], dtype=int) - 1
    v, g = solver.field_at(pts, mat if solver._node_point_material() is not None else None)
    return v[:, 0], -g[:, 0, :]


def interface_fields(solver: PoissonSolver):
    """Along the interface, x in 1.1..1.9 mm (m): x, the normal-current mismatch σ1 E_y(below) / σ2 E_y(above) - 1,
    and E (V/m) just below and just above."""
    lines = ref.lines()
    below, above = lines["interface_below"], lines["interface_above"]
    keep = (below["x"] > 1.1 * MM) & (below["x"] < 1.9 * MM)
    e_below, e_above = _line_field(solver, below)[1][keep], _line_field(solver, above)[1][keep]
    return below["x"][keep], SIGMA[0] * e_below[:, 1] / (SIGMA[1] * e_above[:, 1]) - 1.0, e_below, e_above


def tangential_mismatch(e_below: np.ndarray, e_above: np.ndarray) -> np.ndarray:
    """|E_x(below) - E_x(above)| / |E(above)| at each interface point: the relative error of the field above
    predicted from below by E1t = E2t (Marques 2008, §6.2.2, Fig. 6.16)."""
    return np.abs(e_below[:, 0] - e_above[:, 0]) / np.hypot(e_above[:, 0], e_above[:, 1])


def resistor_errors(solver: PoissonSolver) -> dict:
    """Errors against the reference (module docstring)."""
    lines = ref.lines()
    out = {"nodes": solver.model.node_count}
    v_err = 0.0
    for name in ("crossing", "crossing_offset", "upper", "lower"):
        v, e = _line_field(solver, lines[name])
        v_err = max(v_err, float(np.abs(v - lines[name]["V"]).max()))
        if name == "crossing":
            out["potential_crossing_max_error"] = float(np.abs(v - lines[name]["V"]).max())
        if name.startswith("crossing"):
            mag, ref_mag = np.hypot(*e.T), lines[name]["E"]
            rel = np.abs(mag - ref_mag) / ref_mag
            out[f"field_{name}_mean_rel_error"] = float(rel.mean())
            out[f"field_{name}_max_rel_error"] = float(rel.max())
        if name == "crossing":
            tv = [float(np.abs(np.diff(m[side])).sum()) for m in (np.hypot(*e.T), lines[name]["E"])
                  for side in (lines[name]["y"] < MM, lines[name]["y"] > MM)]
            out["field_oscillation"] = (tv[0] + tv[1] - tv[2] - tv[3]) / float(lines[name]["E"].max())
    out["potential_lines_max_error"] = v_err
    rng = np.random.default_rng(0)          # uniformly distributed points, as the thesis's Fig. 6.3
    pts = np.vstack([rng.uniform((0.0, 0.0), (3 * MM, MM), (3000, 2)),
                     rng.uniform((MM, MM), (2 * MM, 2 * MM), (1000, 2))])
    mat = (pts[:, 1] > MM).astype(int)
    v = solver.field_at(pts, mat if solver._node_point_material() is not None else None)[0][:, 0]
    err = np.abs(v - ref.potential_at(pts))
    near = np.min(np.linalg.norm(pts[:, None, :] - ref.CORNERS[None, :, :], axis=2), axis=1) < 0.1 * MM
    out["potential_uniform_mean_error"] = float(err.mean())
    out["potential_uniform_max_error"] = float(err.max())
    out["potential_uniform_max_error_beyond_corners"] = float(err[~near].max())
    x, jn, e_below, e_above = interface_fields(solver)
    out["normal_current_max_mismatch"] = float(np.abs(jn).max())
    out["tangential_field_mean_mismatch"] = float(np.mean(tangential_mismatch(e_below, e_above)))
    out["normal_current_mean_mismatch"] = float(np.abs(jn).mean())
    middle = (x > 1.4 * MM) & (x < 1.6 * MM)      # farthest from the singular corners
    out["normal_current_middle_mean_mismatch"] = float(np.abs(jn[middle]).mean())
    out["tangential_field_max_mismatch"] = float(np.abs(e_below[:, 0] - e_above[:, 0]).max()
                                                 / np.abs(e_above[:, 1]).max())
    bottom = segment_points(np.array([[0.0, 0.0]]), np.array([[3 * MM, 0.0]]), 48)
    _, g = solver.field_at(bottom.position, np.zeros(len(bottom.weight), dtype=int)
                           if solver._node_point_material() is not None else None)
    current = float(np.sum(bottom.weight * SIGMA[0] * g[:, 0, 1]))
    out["conductance"] = current / (ref.ELECTRODES["top"]["potential"] - ref.ELECTRODES["bottom"]["potential"])
    out["reference_conductance"] = ref.conductance()
    out["conductance_rel_error"] = out["conductance"] / ref.conductance() - 1.0
    return out


#: Marques (2008), §6.2's accuracy (the thesis against its FEM reference), the tolerances of :func:`resistor_checks`
THESIS = "Marques (2008), §6.2 (warpfree/validation/efg_resistor/README.md)"


#: the tolerances of :func:`resistor_checks` and why they are what they are
TOLERANCES = {
    "potential_lines_max_error": (2e-3, "V", "0.2 % of the 1 V between the electrodes: the thesis's potential error "
                                             "(< 0.2 % for every d_max, 721 nodes, §6.2.1)"),
    "field_crossing_max_rel_error": (0.07, "", "the thesis's largest |E| error on the crossing line (<= 7 % for every "
                                               "d_max, 721 nodes, §6.2.1, Figs 6.6-6.7)"),
    "normal_current_mean_mismatch": (1e-3, "", "the thesis's jump-condition error σ1 E1n = σ2 E2n away from the "
                                               "critical regions ('frequently less than 0.1 %, on average 0.04 %', "
                                               "§6.2.2, Fig. 6.15): 0.1 % on the mean over x 1.1-1.9 mm"),
    "tangential_field_mean_mismatch": (1e-3, "", "the thesis's continuity-condition error E1t = E2t away from the "
                                                 "critical regions (the same 'frequently less than 0.1 %, on average "
                                                 "0.04 %', §6.2.2, Fig. 6.16): 0.1 % on the mean over x 1.1-1.9 mm")}


def resistor_checks(errors: dict) -> dict:
    """The errors of :func:`resistor_errors` against the thesis's accuracy (:data:`TOLERANCES`): potential within
    0.2 % of 1 V on the reference lines, |E| on the crossing line within 7 %, the normal current σ E_y and the
    tangential field E_x continuous across the interface within 0.1 % (means over x 1.1-1.9 mm, away from the
    corners). The reference is our Q9 FEM solution (the thesis's geometry is lost), so the thesis gives the
    accuracy, not the numbers."""
    source = f"Q9 FEM reference, accuracy of {THESIS}"
    return {name: tolerance_check(errors[name], tol, source, unit=unit, basis=basis)
            for name, (tol, unit, basis) in TOLERANCES.items()}


#: the scene's parameters behind the solver's internal names: an error names what the user set
NAMES = {"cells": "per_mm", "order": "gauss", "support": "per_mm, d_max", "levels": "corner_levels",
         "reach": "corner_reach"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"per_mm": 6}

#: ``warpfree validate --quick``: the defaults (7 153 graded nodes, about 4 s): the thesis's accuracy holds for the
#: interface conditions only at this resolution (0.65 % normal-current mismatch at ``per_mm=6``)
QUICK = {"per_mm": 40, "corner_levels": 5}


@checked_parameters
def build(per_mm: Annotated[int, Param("1/mm", "node spacings per mm away from the re-entrant corners",
                                       "[2, inf)")] = 40,
          d_max: SupportScale = 2.5, weight: Weight = MLSWeight.CUBIC_SPLINE,
          method: Method = EssentialMethod.LAGRANGE, gauss: CellGauss = None,
          truncation: Annotated[bool, Param("", "domain truncation at the interface: a node serves only its own "
                                                "material")] = True,
          integration: DomainIntegration = Integration.CONSISTENT,
          interface_condition: Annotated[InterfaceCondition, Param(
              "", "what couples the materials across the interface under truncation")] = InterfaceCondition.NITSCHE,
          basis: Basis = MLSBasis.QUADRATIC,
          corner_levels: Annotated[int, Param("", "times the cells are split toward the re-entrant corners (0: the "
                                                  "regular grid)", "[0, inf)")] = 5,
          corner_reach: Annotated[float, Param("", "a cell is split while its distance to a corner is below this "
                                                   "many of its sides", "(0, inf)")] = 2.0,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """``per_mm``: node spacings per mm away from the corners; ``corner_levels``, ``corner_reach``: the cells (and
    nodes) split ``corner_levels`` times toward the re-entrant corners, a cell while its distance to a corner is below
    ``corner_reach`` × its side (0 levels: the regular grid, 13 per mm its 742 nodes, the thesis's 721-node size);
    ``truncation``: domain truncation at the interface (Marques 2008, §3.3), else every node serves both materials;
    ``gauss``: points per cell side (None: the basis's, ``warpfree.galerkin.quadrature.CELL_ORDER``)."""
    gauss = cell_order(basis, gauss)
    params = dict(locals())
    with reported_as(**NAMES):
        solver = resistor_solver(per_mm, d_max, weight, method, gauss, truncation, integration, basis,
                                 interface_condition, corner_levels, corner_reach)

    def accuracy(run, out_dir):
        result = resistor_errors(run.solver)
        result["checks"] = resistor_checks(result)
        if out_dir is not None:
            line = ref.lines()["crossing"]
            v, e = _line_field(run.solver, line)
            x, jn, e_below, e_above = interface_fields(run.solver)
            _plot_line(os.path.join(out_dir, "lines.png"), line, v, np.hypot(*e.T),
                       (x, jn, tangential_mismatch(e_below, e_above)))
        return {"resistor": result}

    return StaticRun(solver, name="efg_resistor", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames), reported_as=NAMES)


def _plot_line(path, line, v, e, interface):
    """The crossing line against the reference (above) and the errors (below, magnitudes on log axes with the
    tolerances of :data:`TOLERANCES` as dotted lines): V and |E| along the line, and the normal-current and
    tangential-field mismatches along the interface."""
    from warpfree.io.validation_plots import draw_bound, new_figure, save_figure

    fig = new_figure(13.0, 6.0)
    (a, b, c), (ea, eb, ec) = fig.subplots(2, 3, sharex="col", gridspec_kw={"height_ratios": (3, 2)})
    y = line["y"] / MM
    a.plot(y, line["V"], "k-", lw=1, label="Q9 FEM reference")
    a.plot(y, v, "--", label="EFG")
    a.set_ylabel("V (V)")
    b.plot(y, line["E"], "k-", lw=1, label="Q9 FEM reference")
    b.plot(y, e, "--", label="EFG")
    b.set_ylabel("|E| (V/m)")
    tol_v = TOLERANCES["potential_lines_max_error"][0]
    tol_e = TOLERANCES["field_crossing_max_rel_error"][0]
    ea.semilogy(y, np.abs(v - line["V"]), "C0-", lw=1, label="EFG")
    draw_bound(ea, tol_v, f"tolerance {tol_v * 1e3:g} mV (0.2 % of 1 V)")
    ea.set_ylabel("|V − reference| (V)")
    eb.semilogy(y, np.abs(e / line["E"] - 1.0) * 100, "C0-", lw=1, label="EFG")
    draw_bound(eb, tol_e * 100, f"tolerance {tol_e * 100:g} %")
    eb.set_ylabel("| |E| / reference − 1 | (%)")
    for ax in (ea, eb):
        ax.set_xlabel("y (mm), x = 1.5 mm")
    for ax in (a, b, ea, eb):
        ax.axvline(1.0, color="0.7", lw=0.8)
    for ax in (a, b, ea, eb):
        ax.legend(fontsize=7)
    x, jn, jt = interface
    tol_n = TOLERANCES["normal_current_mean_mismatch"][0]
    tol_t = TOLERANCES["tangential_field_mean_mismatch"][0]
    c.axis("off")
    c.text(0.0, 0.5, f"along the interface y = 1 mm, x 1.1-1.9 mm:\n"
                     f"normal current |σ1 E_y(below) / σ2 E_y(above) − 1|:\n"
                     f"  mean {np.abs(jn).mean() * 100:.3f} %, largest {np.abs(jn).max() * 100:.3f} %, "
                     f"tolerance (mean) {tol_n * 100:g} %\n"
                     f"tangential field |E_x(below) − E_x(above)| / |E(above)|:\n"
                     f"  mean {jt.mean() * 100:.3f} %, largest {jt.max() * 100:.3f} %, "
                     f"tolerance (mean) {tol_t * 100:g} %", fontsize=9, va="center", transform=c.transAxes)
    ec.semilogy(x / MM, np.abs(jn) * 100, "C0-", lw=1, label="normal current")
    ec.semilogy(x / MM, jt * 100, "C1-", lw=1, label="tangential field")
    draw_bound(ec, tol_n * 100, f"tolerance of the means {tol_n * 100:g} %")
    ec.set_xlabel("x (mm), y = 1 mm")
    ec.set_ylabel("interface mismatch (%)")
    ec.legend(fontsize=7)
    fig.suptitle("Two-material resistor against the Q9 FEM reference")
    save_figure(fig, path)
