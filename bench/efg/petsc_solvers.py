"""The linear solve of a distributed EFG run, by measurement: SciPy's SuperLU on the whole system in every process
against PETSc's Krylov solves of the ranks' rows (``warpfree.parallel.PETScSystem``), at 1 and 2 ranks.

The case: the Timoshenko beam (``scenes/efg_timoshenko.py``, consistent integration) at several node counts, with
its Lagrange multipliers (a saddle-point system) and with the penalty method, and NEM on the same nodes (direct
substitution: an elliptic matrix), each with the "superlu" preconditioner and NEM also with "gamg"
(``warpfree.parallel.petsc_system``). The figure is the solver's "factorisation" + "solve" phases (the assembly and
the shape functions are the same for every choice); the solution's largest difference from SuperLU's on the same
ranks, relative to its largest value, says the choice solves the same system.

Usage
    python bench/efg/petsc_solvers.py [--sizes 48x12,96x24,192x48] [--repeats 3]
Writes bench/results/petsc_solvers.{json,md}. Needs MPI and PETSc (pip install 'warpfree[mpi,petsc]').
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE.parent.parent)]
import common  # noqa: E402

RUN_ALL = [[]]

#: (method, linear solver, preconditioner) in the order they run
#: GAMG on the saddle point and on the penalty system is left out: at 48 x 12 cells it failed to converge in 10 000
#: iterations on both (the saddle point's K alone is singular; the penalty's 10^7 scale is its condition number),
#: and so did a Schur-complement fieldsplit with GAMG or LU on K (the same singular block); PETSc's own LU on a
#: redundant copy (no pivoting: a permutation to a nonzero diagonal and shifted zero pivots) took 2 066 FGMRES
#: iterations, 53 s, on the 96 x 24 beam's saddle point
CHOICES = [("lagrange", "superlu", "auto"), ("lagrange", "petsc", "superlu"),
           ("penalty", "superlu", "auto"), ("penalty", "petsc", "superlu"),
           ("nem", "superlu", "auto"), ("nem", "petsc", "superlu"), ("nem", "petsc", "gamg")]

WORKER = r'''
import json, sys, time
import numpy as np
sys.path.insert(0, {root!r})
from warpfree.device import init_warp
init_warp()
from warpfree.parallel import world
from scenes.efg_timoshenko import beam_solver
cells_x, cells_y, repeats = {cells_x}, {cells_y}, {repeats}
w = world()
reference = {{}}
out = []
for method, linear, pc in {choices!r}:
    seconds, failed = [], None
    options = dict(model="nem", integration="gauss") if method == "nem" else dict(method=method)
    for _ in range(repeats):
        s = beam_solver(cells_x, cells_y, **options)
        s.set_linear_solver(linear, pc)
        try:
            s.solve()
        except Exception as exc:   # a preconditioner that does not converge on this system: recorded as such
            failed = str(exc)
            break
        seconds.append(s.phases.as_dict().get("factorisation", 0.0) + s.phases.as_dict().get("solve", 0.0))
    failed = w.first_message(failed)
    if failed:
        out.append(dict(method=method, linear_solver=linear, preconditioner=pc, seconds=[float("nan")] * repeats,
                        unknowns=None, iterations=None, residual=None, difference=None, failed=failed))
        continue
    u = s.nodal
    if method not in reference:
        reference[method] = u
    diff = float(np.max(np.abs(u - reference[method])) / np.max(np.abs(reference[method])))
    d = s.describe()["linear_solver"]
    out.append(dict(method=method, linear_solver=linear, preconditioner=pc, seconds=seconds,
                    unknowns=int(u.size + s.multipliers.size), iterations=d.get("iterations"),
                    residual=d.get("relative_residual"), difference=diff))
seconds = w.allreduce(np.array([o["seconds"] for o in out]), "max") if out else []
for o, t in zip(out, seconds):
    o["seconds"] = float(np.median(t))
if w.is_root:
    print("RESULT " + json.dumps(out))
'''


def run(ranks: int, cells_x: int, cells_y: int, repeats: int, choices=CHOICES) -> list[dict]:
    import subprocess
    import tempfile

    from warpfree.parallel.launch import mpiexec_environment, run_ranks

    code = WORKER.format(root=str(_HERE.parent.parent), cells_x=cells_x, cells_y=cells_y, repeats=repeats,
                         choices=choices)
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(code)
    if ranks > 1:
        done = run_ranks(ranks, [f.name], timeout=3600)
    else:
        done = subprocess.run([common.PYTHON, f.name], capture_output=True, text=True, timeout=3600,
                              env=mpiexec_environment())
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-3000:])
    line = [x for x in done.stdout.splitlines() if x.startswith("RESULT ")][-1]
    return json.loads(line[7:])


def markdown(result: dict) -> str:
    lines = ["# The linear solve of a distributed EFG run: SuperLU against PETSc", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores; one thread per rank; the Timoshenko "
             f"beam, consistent integration; factorisation + solve seconds, median of {result['repeats']}; "
             "difference: max |u - u(SuperLU)| / max |u|, SuperLU on the same ranks (the whole system in every "
             "process: the one process's to round-off).", ""]
    rows = []
    for size, by_ranks in result["sizes"].items():
        for ranks, entries in by_ranks.items():
            for e in entries:
                rows.append([size, ranks, e["unknowns"], e["method"], e["linear_solver"],
                             e["preconditioner"] if e["linear_solver"] == "petsc" else "",
                             common.fmt(e["seconds"]), e["iterations"] if e["iterations"] is not None else "",
                             f"{e['residual']:.1e}" if e["residual"] is not None else "",
                             f"{e['difference']:.1e}" if e["difference"] is not None else
                             "did not converge: " + e["failed"].split(": ", 1)[-1][:60]])
    lines += [common.md_table(["cells", "ranks", "unknowns", "method", "solver", "preconditioner", "seconds",
                               "iterations", "residual", "difference"], rows), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="48x12,96x24,192x48")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    result = {"machine": common.machine_info(), "repeats": args.repeats, "sizes": {}}
    for size in args.sizes.split(","):
        cx, cy = (int(v) for v in size.split("x"))
        result["sizes"][size] = {}
        for ranks in (1, 2):
            entries = run(ranks, cx, cy, args.repeats)
            result["sizes"][size][str(ranks)] = entries
            print(f"{size} on {ranks}: " + ", ".join(f"{e['method']}/{e['linear_solver']}/{e['preconditioner']} "
                                                      f"{e['seconds']:.3g} s" for e in entries), flush=True)
    common.write_results("petsc_solvers", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
