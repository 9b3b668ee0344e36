"""A plate with an elliptical hole under tension by EFG: the stress concentration against Inglis and the exact field.

The case of ``warpfree/validation/efg_plate_hole``: an infinite plate with the hole x²/a² + y²/b² = 1 under a
remote tension p along x has exact stresses (Muskhelishvili's potentials), σ_xx = p (1 + 2b/a) at the hole's tip
(0, b) (Inglis 1913). A quarter of a square plate of half-width ``half_width`` is solved with those stresses as
tractions on its outer sides, so that they are its exact solution: symmetry on the axes (u_x = 0 on x = 0, u_y = 0 on
y = 0, Lagrange multipliers), the hole traction-free, all on the exact curves (``warpfree.galerkin.region``: the
region is a rectangle less an ellipse). Nodes ``hole_spacing`` apart along the hole, growing away from it at
``grading`` (the local spacing = hole_spacing + grading × the distance to the hole) up to ``spacing``; relaxed as
DistMesh does. The MLS basis is quadratic by default. Writes into ``summary.json`` the tip stress against Inglis, the
stresses' relative energy-norm error over the plate, and with ``refinements`` = 1 the same at twice every spacing and
the energy error's rate (``checks``: :func:`plate_checks`); the layout's quality (``solver.layout``). Plane stress,
E = ``young``; the stresses do not depend on E or ν. Units: SI (m, Pa), any consistent set alike.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, SupportScale
from warpfree.galerkin.region import Region, RegionNodes
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.region_conditions import essential, free, natural
from warpfree.solvers.efg.solver import ELASTICITY_UNITS, ElasticitySolver
from warpfree.validation import tolerance_check
from warpfree.validation.efg_plate_hole import stresses, tip_stress

NAMES = {"support": "hole_spacing, spacing, grading, d_max", "cells": "hole_spacing, spacing",
         "nodes": "hole_spacing, spacing, grading, d_max"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"hole_spacing": 0.08, "spacing": 0.4, "refinements": 0}

#: ``warpfree validate --quick``: the default
QUICK = {}

#: the checks' tolerances (``warpfree/validation/efg_plate_hole/README.md``)
TIP_TOLERANCE, ENERGY_TOLERANCE, RATE, RATE_TOLERANCE = 1e-2, 1e-3, 2.0, 0.6
EXACT = ("Muskhelishvili's stresses of an infinite plate with an elliptical hole; the tip σ_xx = p (1 + 2b/a), "
         "Inglis 1913 (warpfree/validation/efg_plate_hole/README.md)")
POISSON = 0.3


def plate_region(half_width: float, a: float, b: float) -> Region:
    """The quarter plate [0, half_width]² less the ellipse's quarter: sides tagged bottom, right, top, left; the
    hole "hole"."""
    return (Region.rectangle([0.0, 0.0], [half_width, half_width], ["bottom", "right", "top", "left"])
            - Region.ellipse((0.0, 0.0), (a, b), tag="hole"))


def graded_size(a: float, b: float, hole_spacing: float, spacing: float, grading: float):
    """The local spacing: hole_spacing + grading × (distance to the hole), at most ``spacing``."""
    hole = Region.ellipse((0.0, 0.0), (a, b))

    def size(points: np.ndarray) -> np.ndarray:
        return np.minimum(spacing, hole_spacing + grading * np.maximum(hole.signed_distance(points), 0.0))
    return size


def plate_traction(a: float, b: float, tension: float):
    """t = σ·n of the exact stresses, for the natural condition on the outer sides."""
    def traction(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        s = stresses(points, a, b, tension)
        return np.stack([s[:, 0] * normals[:, 0] + s[:, 2] * normals[:, 1],
                         s[:, 2] * normals[:, 0] + s[:, 1] * normals[:, 1]], axis=1)
    return traction


def plate_solver(region: Region, nodes: RegionNodes, a: float, b: float, tension: float, young: float,
                 basis: MLSBasis, d_max: float) -> ElasticitySolver:
    """The solver (not yet solved) on ``nodes`` filling ``region`` (:func:`plate_region`)."""
    zero = lambda p: np.zeros((len(p), 2))  # noqa: E731
    held = (essential(region, nodes, "left", zero, constrained=(True, False))
            + essential(region, nodes, "bottom", zero, constrained=(False, True)))
    model = MLSModel(nodes.position, MLSSettings(basis=basis, d_max=d_max))
    return ElasticitySolver(model, region.cells(nodes), young, POISSON, essential=held,
                            natural=[natural(region, nodes, ["right", "top"], plate_traction(a, b, tension))],
                            free=[free(region, nodes, "hole")])


def stress_at(solver: ElasticitySolver, points: np.ndarray) -> np.ndarray:
    """(n, 3) σ_xx, σ_yy, σ_xy of the solution at ``points``."""
    gradient = solver.field_at(points)[1].reshape(len(points), 2, 2)
    return ElasticitySolver.strain_from(gradient) @ solver.D.T


def plate_errors(solver: ElasticitySolver, a: float, b: float, tension: float) -> dict:
    """The tip stress against Inglis and the stresses' relative energy-norm error
    √(∫ e·D⁻¹e dA / ∫ σ·D⁻¹σ dA), e = σ^h - σ, over the Gauss points."""
    cells = solver.cells
    sigma = stress_at(solver, cells.position)
    exact = stresses(cells.position, a, b, tension)
    compliance = np.linalg.inv(solver.D)
    e = sigma - exact

    def energy(s):
        return float(np.sum(cells.weight * np.einsum("ni,ij,nj->n", s, compliance, s)))
    tip = float(stress_at(solver, np.array([[0.0, b]]))[0, 0])
    return {"tip_stress": tip, "tip_stress_exact": tip_stress(a, b, tension),
            "tip_error": tip / tip_stress(a, b, tension) - 1.0, "energy_error": math.sqrt(energy(e) / energy(exact)),
            "nodes": int(solver.model.node_count), "gauss_points": int(len(cells.weight)),
            "lebesgue_max": solver.layout.lebesgue_max}


def plate_checks(result: dict) -> dict:
    """The tip stress within 1 % of Inglis, the energy-norm error within 1e-3, and its rate 2 ± 0.6 when a coarser
    level was solved."""
    checks = {"tip_error": tolerance_check(result["tip_error"], TIP_TOLERANCE, EXACT, reference=0.0,
                                           basis="quadratic MLS, the default layout: measured +0.08 % "
                                                 "(+1.5 % at twice its spacings)"),
              "energy_error": tolerance_check(result["energy_error"], ENERGY_TOLERANCE, EXACT, reference=0.0,
                                              basis="quadratic MLS, the default layout: measured 2.6e-4 "
                                                    "(1.1e-3 at twice its spacings)")}
    if "energy_rate" in result:
        checks["energy_rate"] = tolerance_check(result["energy_rate"], RATE_TOLERANCE, EXACT, reference=RATE,
                                                basis="the stresses of quadratic MLS converge at order 2")
    return checks


@checked_parameters
def build(hole_spacing: Annotated[float, Param("m", "node spacing along the hole", "(0, inf)")] = 0.01,
          spacing: Annotated[float, Param("m", "the largest node spacing, away from the hole", "(0, inf)")] = 0.1,
          grading: Annotated[float, Param("", "growth of the spacing per unit distance from the hole", "[0, inf)")]
          = 0.1,
          semi_axes: Annotated[tuple[float, float], Param("m", "the hole's semi-axes a (along the load, x) and b",
                                                                   "(0, inf)")]
          = (0.25, 0.5),
          half_width: Annotated[float, Param("m", "half the plate's side (the quarter solved is this square)",
                                             "(0, inf)")] = 2.0,
          tension: Annotated[float, Param("Pa", "the remote tension p along x", "(0, inf)")] = 1.0,
          young: Annotated[float, Param("Pa", "Young's modulus E (the stresses do not depend on it)", "(0, inf)")]
          = 1.0,
          basis: Basis = MLSBasis.QUADRATIC, d_max: SupportScale = 3.0,
          refinements: Annotated[int, Param("", "also solve at twice every spacing, for the energy error's rate "
                                                "(0 or 1)", "[0, 1]")] = 1,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """Lengths in m, stresses in Pa; ``refinements``: 1 also solves at twice every spacing for the rate."""
    params = dict(locals())
    a, b = (float(v) for v in semi_axes)
    if not (a > 0 and b > 0 and math.isfinite(a) and math.isfinite(b)):
        raise ParameterError("semi_axes", f"must be two finite lengths > 0, got {semi_axes!r}")
    if max(a, b) >= 0.5 * half_width:
        raise ParameterError("semi_axes", f"the hole must fit well inside the quarter plate: its semi-axes "
                                          f"{a:g}, {b:g} must be below half of half_width = {half_width:g}")
    if hole_spacing > spacing:
        raise ParameterError("hole_spacing", f"must not exceed spacing ({spacing:g}), got {hole_spacing:g}")
    if hole_spacing >= min(a, b):
        raise ParameterError("hole_spacing", f"must be below the hole's smaller semi-axis {min(a, b):g}, got "
                                             f"{hole_spacing:g}")
    region = plate_region(half_width, a, b)

    size = graded_size(a, b, hole_spacing, spacing, grading)

    def solver_at(scale: float) -> ElasticitySolver:
        """The solver on the layout with every spacing ``scale`` times the asked (the same layout, scaled)."""
        nodes = region.nodes(scale * spacing, size=lambda points: scale * size(points))
        return plate_solver(region, nodes, a, b, tension, young, basis, d_max)

    with reported_as(**NAMES):
        solver = solver_at(1.0)

    def accuracy(run, out_dir):
        result = plate_errors(run.solver, a, b, tension)
        if refinements:
            with reported_as(**NAMES):
                coarse = solver_at(2.0)
                coarse.solve()
            result["coarse"] = plate_errors(coarse, a, b, tension)
            result["energy_rate"] = math.log2(result["coarse"]["energy_error"] / result["energy_error"])
        result["checks"] = plate_checks(result)
        return {"plate": result}

    return StaticRun(solver, name="efg_plate_hole", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames, units=ELASTICITY_UNITS), reported_as=NAMES)
