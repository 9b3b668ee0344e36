"""EFG on a region bounded by exact curves: the coaxial line's potential, surface field and capacitance.

The case of ``warpfree/validation/efg_coax``: -Δφ = 0 between the conductor r = a (φ = 0) and the shield r = b
(φ = 1), both circles held exactly (``warpfree.galerkin.region``): nodes ``spacing`` apart along them and a relaxed
lattice between, integration cells laid on the true circles, φ held by Lagrange multipliers on the circles
themselves. The MLS basis is quadratic by default (the surface field at second order). Writes into ``summary.json``
the largest relative error of the field |∇φ| over Gauss points on the conductor, the capacitance ∫|∇φ|² dA against
2π/ln(b/a) and, with ``refinements`` = 1, the field's error at twice the spacing and the rate between them
(``checks``: :func:`coax_checks`). Unit-free (lengths in a's units, unit permittivity).
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np

from warpfree.errors import ParameterError, reported_as
from warpfree.galerkin.mls import Basis, MLSBasis, MLSModel, MLSSettings, SupportScale
from warpfree.galerkin.region import Region
from warpfree.parameters import Frames, Param, Vtk, checked_parameters
from warpfree.run import OutputOptions, StaticRun
from warpfree.solvers.efg.region_conditions import essential
from warpfree.solvers.efg.solver import POISSON_UNITS, PoissonSolver
from warpfree.validation import tolerance_check
from warpfree.validation.efg_coax import capacitance, field_magnitude

NAMES = {"support": "spacing, d_max", "cells": "spacing", "nodes": "spacing"}

#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"spacing": 0.25, "refinements": 0}

#: ``warpfree validate --quick``: the default (spacings 0.2 and 0.1, a few seconds)
QUICK = {"spacing": 0.1, "refinements": 1}

#: the checks' tolerances (``warpfree/validation/efg_coax/README.md``)
FIELD_TOLERANCE, RATE, RATE_TOLERANCE, CAPACITANCE_TOLERANCE = 5e-3, 2.0, 0.6, 1e-4
EXACT = "φ = ln(r/a)/ln(b/a), |∇φ| = 1/(r ln(b/a)), C = 2π/ln(b/a) (warpfree/validation/efg_coax/README.md)"


def coax_solver(inner: float, outer: float, spacing: float, basis: MLSBasis, d_max: float,
                relax: int) -> tuple[PoissonSolver, Region, object]:
    """The solver (not yet solved), its region and its nodes."""
    region = Region.disc((0.0, 0.0), outer, "shield") - Region.disc((0.0, 0.0), inner, "conductor")
    nodes = region.nodes(spacing, relax=relax)
    held = (essential(region, nodes, "conductor", lambda p: np.zeros((len(p), 1)))
            + essential(region, nodes, "shield", lambda p: np.ones((len(p), 1))))
    model = MLSModel(nodes.position, MLSSettings(basis=basis, d_max=d_max))
    return PoissonSolver(model, region.cells(nodes), essential=held), region, nodes


def coax_errors(solver: PoissonSolver, region: Region, nodes, inner: float, outer: float) -> dict:
    """The field's largest relative error on the conductor (4 Gauss points a side) and the capacitance's."""
    surface = region.boundary_points(nodes, "conductor", order=4).position
    gradient = solver.field_at(surface)[1].reshape(len(surface), -1)
    field = np.linalg.norm(gradient, axis=1)
    cells = solver.cells
    energy = float(np.sum(cells.weight * np.sum(solver.field_at(cells.position)[1].reshape(len(cells.weight), -1) ** 2,
                                                axis=1)))
    exact_c = capacitance(inner, outer)
    return {"field_error": float(np.max(np.abs(field / field_magnitude(inner, inner, outer) - 1.0))),
            "capacitance": energy, "capacitance_exact": exact_c, "capacitance_error": energy / exact_c - 1.0,
            "nodes": int(nodes.count), "gauss_points": int(len(cells.weight))}


def coax_checks(result: dict) -> dict:
    """The surface field within 0.5 % (largest over the conductor), its rate 2 ± 0.6 when a coarser level was
    solved, the capacitance within 1e-4."""
    checks = {"field_error": tolerance_check(result["field_error"], FIELD_TOLERANCE, EXACT, reference=0.0,
                                             basis="quadratic MLS at spacing 0.1: measured 2.4e-3"),
              "capacitance_error": tolerance_check(result["capacitance_error"], CAPACITANCE_TOLERANCE, EXACT,
                                                   reference=0.0, basis="the field energy converges at twice the "
                                                                        "gradient's order")}
    if "field_rate" in result:
        checks["field_rate"] = tolerance_check(result["field_rate"], RATE_TOLERANCE, EXACT, reference=RATE,
                                               basis="the gradient of quadratic MLS converges at order 2")
    return checks


@checked_parameters
def build(spacing: Annotated[float, Param("a", "node spacing along the circles and between them", "(0, inf)")] = 0.1,
          outer_radius: Annotated[float, Param("a", "radius b of the shield (the conductor's is 1)", "(1, inf)")] = 2.0,
          basis: Basis = MLSBasis.QUADRATIC, d_max: SupportScale = 3.0,
          relax: Annotated[int, Param("", "relaxation steps of the inside nodes (0: a plain lattice)", "[0, inf)")]
          = 25,
          refinements: Annotated[int, Param("", "also solve at twice the spacing, for the field's rate (0 or 1)",
                                            "[0, 1]")] = 1,
          frames: Frames = True, vtk: Vtk = True) -> StaticRun:
    """``spacing`` and ``outer_radius`` in units of the conductor's radius; ``refinements``: 1 also solves at twice
    the spacing for the rate."""
    params = dict(locals())
    inner = 1.0
    if spacing >= outer_radius - inner:
        raise ParameterError("spacing", f"must be below the gap b - a = {outer_radius - inner:g}, got {spacing}")
    with reported_as(**NAMES):
        solver, region, nodes = coax_solver(inner, outer_radius, spacing, basis, d_max, relax)

    def accuracy(run, out_dir):
        result = coax_errors(run.solver, region, nodes, inner, outer_radius)
        result["spacing"] = spacing
        if refinements:
            coarse, coarse_region, coarse_nodes = coax_solver(inner, outer_radius, 2 * spacing, basis, d_max, relax)
            coarse.solve()
            result["coarse"] = coax_errors(coarse, coarse_region, coarse_nodes, inner, outer_radius)
            result["field_rate"] = math.log2(result["coarse"]["field_error"] / result["field_error"])
        result["checks"] = coax_checks(result)
        return {"coax": result}

    return StaticRun(solver, name="efg_coax", params=params, analyses=[accuracy],
                     output=OutputOptions(vtk=vtk, frames=frames, units=dict.fromkeys(POISSON_UNITS, "1")),
                     reported_as=NAMES)
