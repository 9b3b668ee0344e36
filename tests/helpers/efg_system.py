"""An EFG scene's assembled system and solution, written by rank 0 of a run of any number of ranks, to compare a
distributed solve with one process's.

    python tests/helpers/efg_system.py SCENE OUT.npz [--solver superlu|petsc] [--set name=value ...]
    mpiexec -n 3 python tests/helpers/efg_system.py SCENE OUT.npz ...

The scene is built at its settings on the CPU, one thread per rank, its solver's linear solver set to ``--solver``,
and solved. OUT.npz holds, on the whole set of unknowns: ``K`` and ``f`` (the stiffness and the load before the
boundary conditions), ``A`` and ``b`` (the system the solve factorises: the conditions imposed), the solution
``nodal`` and ``multipliers``, ``x`` the system's unknowns (the nodal parameters, then the multipliers as the system
scales them) and ``rtol``, the relative residual the Krylov solve reaches (PETSc; 0 for SuperLU). A distributed
solve through PETSc keeps only this rank's rows of K and of A: they are gathered here (each row from the one rank that
holds it, nothing added).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import scipy.sparse as sp


def gathered(world, matrix, part: bool) -> np.ndarray:
    """The whole matrix, dense: ``matrix`` itself, or (``part``) every rank's rows of it put together."""
    if part:
        matrix = world.allreduce_matrix(sp.csr_matrix(matrix))
    return sp.csr_matrix(matrix).toarray()


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("out")
    parser.add_argument("--solver", default="superlu", choices=["superlu", "petsc"])
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args(argv)

    from warpfree import device
    from warpfree.parallel import world
    from warpfree.parameters import parse_overrides, scene_parameters
    from warpfree.run import build_scene
    from warpfree.scene_loader import load_scene

    ranks = world()
    if args.solver == "petsc":
        from mpi4py import MPI  # noqa: F401  (PETSc's library links MPI's, which mpi4py loads)
    device.use("cpu", 1)
    module = load_scene(args.scene)
    run = build_scene(module, parse_overrides(args.overrides, scene_parameters(module)))
    solver = run.solver
    solver.set_linear_solver(args.solver)
    imposed = {}
    impose = solver._impose

    def recording(K, f, essential):
        A, b, prescribed = impose(K, f, essential)
        imposed.update(A=A, b=b)
        return A, b, prescribed

    solver._impose = recording
    solver.solve()
    part = solver.petsc and ranks.distributed
    x = np.concatenate([solver.nodal, solver.multipliers / solver._multiplier_scale])
    out = {"K": gathered(ranks, solver.matrix, part), "f": np.asarray(solver.load),
           "A": gathered(ranks, imposed["A"], part), "b": np.asarray(imposed["b"]),
           "nodal": solver.nodal, "multipliers": solver.multipliers, "x": x,
           "rtol": solver.system.rtol if solver.petsc else 0.0}
    if ranks.is_root:
        np.savez(args.out, **out)
    ranks.barrier()
    return 0


if __name__ == "__main__":
    try:
        code = main(sys.argv[1:])
    except BaseException:
        import traceback

        from warpfree.parallel.world import abort_on_error

        traceback.print_exc()
        sys.stderr.flush()
        abort_on_error(1)  # the other ranks would wait in a collective for ever
        raise
    sys.exit(code)
