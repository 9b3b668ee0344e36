"""A static linear system over the ranks, solved by PETSc (petsc4py): each rank's part of the matrix, one
distributed matrix, a Krylov solve, the solution on every rank.

The ranks of a distributed Galerkin solve each integrate their own Gauss points, so each holds a part K_r of the
stiffness, K = Σ_r K_r, over every unknown (a part's rows are the nodes its points reach). With the prescribed
unknowns p eliminated (:class:`~warpfree.sparse.PrescribedValues`),

    K_ff u_f = b_f - K_fp u_p,      K_ff = Σ_r (K_r)_ff,   K_fp u_p = Σ_r (K_r)_fp u_p,

and both sums are PETSc's: each rank gives its part's triplets (``MatSetValuesCOO``, entries of rows another rank
owns sent to it) and its part of the right-hand side (rank 0 adds ``b_f``, which every rank knows); PETSc's rows
are split in contiguous blocks over the ranks. The solve is a Krylov method with a preconditioner
(:data:`PRECONDITIONERS`); ``bench/efg/petsc_solvers.py`` measured them on the elasticity systems of the EFG scenes:

- "fieldsplit" (the saddle points of Lagrange multipliers, the EFG default): GMRES on [K G; Gᵀ 0] with a
  Schur-complement split, the displacement block by algebraic multigrid (GAMG), the multipliers' Schur complement
  by its diagonal approximation Gᵀ diag(K)⁻¹ G (solved exactly: it has as many rows as multipliers);
- "gamg": GMRES (CG for a symmetric matrix) with algebraic multigrid on the whole matrix (a penalty or direct
  substitution leaves K alone: an elliptic matrix);
- "lu": every rank factorises the whole matrix (PETSc's LU on a redundant copy), the one-process direct solve.

PETSc's own options (``PETSC_OPTIONS="-ksp_type ... -pc_type ..."``) come last and override the choice.
Precision: float64 (PETSc's scalar); the relative residual of the solve ``rtol`` (default 1e-12), checked after it.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError, RunError
from warpfree.sparse import PrescribedValues

from .world import World

__all__ = ["PETScSystem", "PRECONDITIONERS", "PETSC_EXTRA", "require_petsc"]

#: what to install for a distributed Galerkin solve
PETSC_EXTRA = "pip install 'warpfree[petsc]' (PETSc builds from source: install petsc first, then petsc4py)"

#: the preconditioners :class:`PETScSystem` offers (module docstring); "auto": fieldsplit for a saddle-point
#: system, gamg otherwise
PRECONDITIONERS = ("auto", "fieldsplit", "gamg", "lu")


def require_petsc(parameter: str = "linear_solver"):
    """petsc4py's PETSc module, initialised; ParameterError naming ``parameter`` and the extra when missing."""
    try:
        import petsc4py

        petsc4py.init()
        from petsc4py import PETSc
    except ImportError:
        raise ParameterError(parameter, f"a distributed Galerkin solve needs PETSc for Python: {PETSC_EXTRA}") \
            from None
    return PETSc


class PETScSystem:
    """``K u = b`` with prescribed values over ``world``'s ranks, its matrix assembled once and solved many times.

    Parameters
    ----------
    world: the ranks (one process works too: the same solve on one rank).
    part: this rank's part K_r of the square matrix (SciPy sparse, n x n; the parts add up to K).
    prescribed: the prescribed unknowns (every rank the same).
    preconditioner: one of :data:`PRECONDITIONERS`.
    saddle: the number of leading unknowns that are not Lagrange multipliers (the rest are: a saddle-point
        system), None when there are none.
    symmetric: K is symmetric (CG instead of GMRES for "gamg").
    rtol: the relative residual the Krylov solve reaches.

    ``solve(b, values)`` mirrors :class:`~warpfree.sparse.FactorisedSystem`: ``b`` the whole right-hand side (every
    rank the same), ``values`` new prescribed values; the whole u on every rank. ``timings`` (seconds: assemble,
    setup, solve, last_solve), ``counts``, ``iterations`` and ``residual`` (the last solve's) describe it.
    """

    def __init__(self, world: World, part, prescribed: PrescribedValues, preconditioner: str = "auto",
                 saddle: int | None = None, symmetric: bool = False, rtol: float = 1e-12):
        if preconditioner not in PRECONDITIONERS:
            raise ParameterError("preconditioner", f"must be one of {list(PRECONDITIONERS)}, got {preconditioner!r}")
        PETSc = require_petsc()
        self._PETSc = PETSc
        self.world = world
        self.prescribed = prescribed
        self.rtol = float(rtol)
        self.preconditioner = preconditioner if preconditioner != "auto" else ("fieldsplit" if saddle else "gamg")
        if self.preconditioner == "fieldsplit" and not saddle:
            raise ParameterError("preconditioner", "'fieldsplit' splits Lagrange multipliers off: this system has "
                                                   "none (use 'gamg' or 'lu')")
        self.timings = {"assemble": 0.0, "setup": 0.0, "solve": 0.0, "last_solve": 0.0}
        self.counts = {"factorise": 0, "solve": 0}
        self.iterations = 0
        self.residual = float("nan")
        start = time.perf_counter()
        K_ff, self.K_fp = prescribed.split(sp.csr_matrix(part, dtype=np.float64))
        self.n_free = K_ff.shape[0]
        comm = PETSc.COMM_SELF if world.comm is None else PETSc.Comm(world.comm)
        self._matrix = self._assemble(comm, K_ff.tocoo())
        self._rows = self._matrix.getOwnershipRange()
        self.rows_per_rank = np.concatenate(world.allgather(
            np.array([self._rows[1] - self._rows[0]], dtype=np.int64))).tolist()
        self.timings["assemble"] = time.perf_counter() - start
        start = time.perf_counter()
        self._ksp = self._krylov(comm, saddle, symmetric)
        self._gather, self._whole = PETSc.Scatter.toAll(self._matrix.createVecRight())
        self.timings["setup"] = time.perf_counter() - start
        self.counts["factorise"] = 1

    # -- making it ------------------------------------------------------------------------------------------
    def _assemble(self, comm, coo: sp.coo_matrix):
        PETSc = self._PETSc
        A = PETSc.Mat().create(comm=comm)
        A.setSizes(((PETSc.DECIDE, self.n_free), (PETSc.DECIDE, self.n_free)))
        A.setType(PETSc.Mat.Type.AIJ)
        A.setPreallocationCOO(coo.row.astype(PETSc.IntType), coo.col.astype(PETSc.IntType))
        A.setValuesCOO(coo.data.astype(PETSc.ScalarType), addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()
        return A

    def _krylov(self, comm, saddle: int | None, symmetric: bool):
        PETSc = self._PETSc
        ksp = PETSc.KSP().create(comm=comm)
        ksp.setOperators(self._matrix)
        ksp.setTolerances(rtol=self.rtol, atol=0.0, max_it=10_000)
        pc = ksp.getPC()
        if self.preconditioner == "lu":
            ksp.setType(PETSc.KSP.Type.PREONLY)
            pc.setType(PETSc.PC.Type.REDUNDANT)
            PETSc.Options().setValue("redundant_pc_type", "lu")
        elif self.preconditioner == "gamg":
            ksp.setType(PETSc.KSP.Type.CG if symmetric else PETSc.KSP.Type.GMRES)
            pc.setType(PETSc.PC.Type.GAMG)
        else:
            ksp.setType(PETSc.KSP.Type.FGMRES)
            ksp.setGMRESRestart(200)
            pc.setType(PETSc.PC.Type.FIELDSPLIT)
            lo, hi = self._rows
            rows = np.arange(lo, hi, dtype=PETSc.IntType)
            n_u = int(saddle) - self._prescribed_before(saddle)
            u = PETSc.IS().createGeneral(rows[rows < n_u], comm=comm)
            m = PETSc.IS().createGeneral(rows[rows >= n_u], comm=comm)
            pc.setFieldSplitIS(("u", u), ("m", m))
            pc.setFieldSplitType(PETSc.PC.CompositeType.SCHUR)
            pc.setFieldSplitSchurFactType(PETSc.PC.FieldSplitSchurFactType.FULL)
            pc.setFieldSplitSchurPreType(PETSc.PC.FieldSplitSchurPreType.SELFP)
            options = PETSc.Options()
            for key, value in (("fieldsplit_u_ksp_type", "preonly"), ("fieldsplit_u_pc_type", "gamg"),
                               ("fieldsplit_m_ksp_type", "preonly"), ("fieldsplit_m_pc_type", "redundant"),
                               ("fieldsplit_m_redundant_pc_type", "lu")):
                options.setValue(key, value)
        ksp.setFromOptions()
        ksp.setUp()
        return ksp

    def _prescribed_before(self, n: int) -> int:
        """Prescribed unknowns among the first n (they leave the free numbering)."""
        return int(np.count_nonzero(self.prescribed.indices < n))

    # -- solving --------------------------------------------------------------------------------------------
    def solve(self, b, values=None) -> np.ndarray:
        """The whole u (every rank) solving K_ff u_f = b_f - K_fp u_p; ``b`` the whole right-hand side."""
        start = time.perf_counter()
        PETSc = self._PETSc
        prescribed = self.prescribed if values is None else self.prescribed.with_values(values)
        rhs = -(self.K_fp @ prescribed.values)                   # this rank's part of -K_fp u_p
        if self.world.is_root:
            rhs = rhs + np.asarray(b, dtype=np.float64)[prescribed.free]
        vector = self._matrix.createVecLeft()
        present = np.flatnonzero(rhs)
        vector.setValues(present.astype(PETSc.IntType), rhs[present], addv=PETSc.InsertMode.ADD_VALUES)
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
        return {"library": "PETSc", "preconditioner": self.preconditioner, "unknowns": self.n_free,
                "iterations": self.iterations, "relative_residual": self.residual, "rtol": self.rtol,
                "rows_per_rank": self.rows_per_rank}
