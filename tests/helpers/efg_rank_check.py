"""How far a distributed EFG solve's system and solution are from one process's: ``efg_system.py`` at 1, 2 and 3
ranks, each array's largest difference from the one-process run printed ("EQ": bitwise the same).

    python tests/helpers/efg_rank_check.py SCENE [--solver superlu|petsc] [--set name=value ...]

e.g. ``efg_timoshenko --set cells_x=24 --set cells_y=6`` or ``efg_l_shape --set n=8 --set refinements=0``. The
one-process run uses the same linear solver (PETSc on one rank with ``--solver petsc``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from warpfree.parallel.launch import run_ranks

HELPER = str(Path(__file__).resolve().parent / "efg_system.py")
ARRAYS = ("K", "f", "A", "b", "nodal", "multipliers")


def difference(a: np.ndarray, b: np.ndarray) -> str:
    """"EQ" when bitwise the same, else the largest difference and its ratio to the largest |a|."""
    if np.array_equal(a, b):
        return "EQ"
    d = float(np.abs(a - b).max())
    return f"{d:.2e} (rel {d / max(float(np.abs(a).max()), 1e-300):.1e})"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--solver", default="superlu", choices=["superlu", "petsc"])
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args(argv)
    sets = [a for s in args.overrides for a in ("--set", s)]
    with tempfile.TemporaryDirectory() as tmp:
        results = {}
        for ranks in (1, 2, 3):
            out = str(Path(tmp) / f"{ranks}.npz")
            command = [HELPER, args.scene, out, "--solver", args.solver, *sets]
            done = (subprocess.run([sys.executable, *command], capture_output=True, text=True) if ranks == 1
                    else run_ranks(ranks, command, timeout=900))
            if done.returncode:
                print(f"{ranks} ranks failed:\n{done.stderr[-2000:]}")
                return 1
            with np.load(out) as data:
                results[ranks] = dict(data)
        for ranks in (2, 3):
            print(f"{args.scene} {args.solver} {ranks} ranks: "
                  + ", ".join(f"{k} {difference(results[1][k], results[ranks][k])}" for k in ARRAYS))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
