"""A distributed EFG solve assembles the one process's system, bit for bit, at 2 and 3 ranks: each rank assembles
the rows of its own nodes from every Gauss point of their supports, in the one process's order
(``warpfree.solvers.efg.solver``), and the boundary and interface terms on every rank in full.

Each case runs ``tests/helpers/efg_system.py`` in this process (one rank, SciPy's SuperLU) and under ``mpiexec``,
and compares the stiffness K and the load f (before the boundary conditions), the system A, b the solve takes (the
conditions imposed: Lagrange multipliers, a penalty, direct substitution; Nitsche interface terms) and the solution:

- SuperLU on every rank (``linear_solver=superlu``): the same whole system, so the same factorisation and the same
  solution, bitwise;
- PETSc (the ranks' rows as one distributed matrix, each entry from one rank): the same A and b, bitwise; the
  solution to the Krylov solve's tolerance, as its parallel sums round differently.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from warpfree.parallel import MPI_EXTRA
from warpfree.parallel.launch import find_mpiexec, run_ranks
from warpfree.parallel.petsc_system import PETSC_EXTRA

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "helpers"))
import efg_system  # noqa: E402

HELPER = str(Path(efg_system.__file__))

needs_mpi = pytest.mark.skipif(find_mpiexec() is None, reason=f"no MPI here: {MPI_EXTRA}")

#: the arrays that are the assembled system: K, f before the boundary conditions, A, b with them
SYSTEM = ("K", "f", "A", "b")

#: (scene, settings, ranks): Poisson with a source and a natural flux (the L-shape: f from both), two materials with
#: Nitsche interface terms and truncated supports (the resistor); elasticity with Lagrange multipliers (the beam), its
#: penalty form, and NEM on its Delaunay triangles with direct substitution; 24 x 6 cells: three ranks need the beam
#: longer than the smallest's 12 cells, which span two supports
BEAM = ["cells_x=24", "cells_y=6"]
CASES = [("efg_l_shape", ["n=8", "refinements=0"], 2), ("efg_l_shape", ["n=8", "refinements=0"], 3),
         ("efg_resistor", ["per_mm=6"], 3),
         ("efg_timoshenko", BEAM, 2), ("efg_timoshenko", BEAM, 3),
         ("efg_timoshenko", BEAM + ["method=penalty"], 3),
         ("efg_timoshenko", BEAM + ["model=nem", "integration=gauss"], 2)]


def system_of(scene: str, settings: list[str], ranks: int, solver: str, directory: Path) -> dict:
    """The arrays ``efg_system.py`` writes for ``scene`` at ``settings`` on ``ranks`` ranks (1: in this process)."""
    out = directory / f"{scene}_{solver}_{ranks}.npz"
    args = [scene, str(out), "--solver", solver] + [a for s in settings for a in ("--set", s)]
    if ranks == 1:
        assert efg_system.main(args) == 0
    else:
        done = run_ranks(ranks, [HELPER, *args], timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
    with np.load(out) as data:
        return dict(data)


@needs_mpi
@pytest.mark.parametrize("scene,settings,ranks", CASES)
def test_a_distributed_efg_solve_assembles_and_solves_the_one_process_system_bitwise(scene, settings, ranks,
                                                                                     tmp_path):
    one = system_of(scene, settings, 1, "superlu", tmp_path)
    many = system_of(scene, settings, ranks, "superlu", tmp_path)
    assert np.count_nonzero(one["K"]) and np.count_nonzero(one["b"])   # (f: zero for the resistor, no source)
    for key in SYSTEM + ("nodal", "multipliers"):
        assert np.array_equal(one[key], many[key]), key


def _has_petsc() -> bool:
    try:
        import petsc4py  # noqa: F401
    except ImportError:
        return False
    return True


@needs_mpi
@pytest.mark.skipif(not _has_petsc(), reason=f"no PETSc here: {PETSC_EXTRA}")
@pytest.mark.parametrize("scene,settings,ranks", [("efg_l_shape", ["n=8", "refinements=0"], 3),
                                                  ("efg_timoshenko", BEAM, 2)])
def test_a_distributed_efg_solve_through_petsc_takes_the_one_process_system_and_solves_it_to_its_tolerance(
        scene, settings, ranks, tmp_path):
    """Each rank's rows as its part of one PETSc matrix: A and b (every rank's rows put together) bitwise the one
    process's; the solution x within the bound a relative residual r = |b - A x| / |b| <= rtol gives,
    |x - x*| / |x*| <= κ₂(A) r (κ₂ of the one process's A, computed here; SuperLU's own error, κ₂ times a few
    units of round-off, is far below it)."""
    one = system_of(scene, settings, 1, "superlu", tmp_path)
    many = system_of(scene, settings, ranks, "petsc", tmp_path)
    for key in SYSTEM:
        assert np.array_equal(one[key], many[key]), key
    rtol = float(many["rtol"])
    assert 0.0 < rtol <= 1e-10
    bound = np.linalg.cond(one["A"]) * rtol
    error = np.linalg.norm(many["x"] - one["x"]) / np.linalg.norm(one["x"])
    assert error <= bound, (error, bound)
