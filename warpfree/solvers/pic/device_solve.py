"""The PIC field solve on the device: the nodal potential and fields from the deposited charge, with no host copy.

:class:`~.field.PlasmaPoisson` solves on the host with its SuperLU factorisation (the CPU's fastest: 9 ms a step at
8 192 nodes against 4 s for Warp's CG there). On a GPU that is a copy of the charge to the host and of the potential
and fields back, every step. :class:`DeviceFieldSolve` keeps it on the device, two ways:

- ``"cg"`` (a periodic box): Warp's conjugate gradients (``warp.optim.linear.cg``, Jacobi-preconditioned, relative
  tolerance 1e-13, the residual checked on the device on a GPU: no host read) with the consistent load b - λ m, λ =
  Σb/A, on K with node 0 pinned (u_0 = 0), then the gauge ∫u = 0. K itself is singular (its null space is the
  constants: the partition of unity), and the load's round-off, ~1e-16 |Q|, leaves a component along that null space
  that no iteration removes: on a near-neutral plasma (|b| ≪ |Q|) the residual stalls above the tolerance (192
  nodes, a deposit neutral to 1e-6: no convergence in 868 iterations, against 70 pinned; 90 against 70 at 1e-2).
  Pinned, K is positive definite and the round-off goes to node 0's row, which the gauge then spreads as a constant.
  Measured on the CPU against SuperLU: the potential within 1e-13 of SuperLU's. On the CPU it is slow (Warp's tiled
  dot products: 9 ms an iteration at 800 nodes): the CPU keeps SuperLU.
- ``"dense"`` (walls; any box of up to :data:`DENSE_MAX` nodes): the solve is linear in the charge, u = P Q + u0,
  so its map P (and the nodal fields' -M⁻¹ G P) is made once by SuperLU with the identity as right-hand sides and
  applied as a dense product each step (N² memory, N back-substitutions to set up).

Both give the momentum gather's nodal fields (``PlasmaPoisson.nodal_field``: E = -M⁻¹ G u, or its antisymmetric part
on node layouts that need it, two more solves) and the net charge density. float64.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import warp as wp
import warp.sparse as wsp
from warp.optim.linear import cg, preconditioner

from warpfree.device import Launcher
from warpfree.errors import ParameterError
from warpfree.kernels import pic_field as K
from warpfree.parameters import Choice
from warpfree.reduce import Reduction

from .field import PlasmaPoisson

__all__ = ["FieldSolve", "DeviceFieldSolve", "DENSE_MAX", "CG_TOLERANCE", "bsr_matrix"]

#: most nodes the dense map is made for (3 N² float64: 400 MB at 4 096)
DENSE_MAX = 4096
#: the conjugate gradients' relative tolerance on the residual
CG_TOLERANCE = 1e-13
#: iterations between the CPU's host checks of the residual (a GPU checks on the device)
CHECK_EVERY = 10


class FieldSolve(Choice):
    """Where the PIC field is solved each step (and how, on the device)."""

    HOST = "host", "the host's SuperLU factorisation: the charge to the host and the potential back"
    DEVICE = "device", "on the device, no host copy: conjugate gradients in a periodic box, the dense map between walls"
    CG = "cg", "on the device by conjugate gradients (a periodic box)"
    DENSE = "dense", f"on the device by the dense map of the solve (walls, or any box of up to {DENSE_MAX} nodes)"


def bsr_matrix(matrix: sp.spmatrix, device: str) -> wsp.BsrMatrix:
    """A SciPy sparse matrix as a Warp BSR matrix (1x1 blocks, float64) on ``device``."""
    m = matrix.tocoo()
    rows = wp.array(m.row.astype(np.int32), dtype=wp.int32, device=device)
    columns = wp.array(m.col.astype(np.int32), dtype=wp.int32, device=device)
    return wsp.bsr_from_triplets(m.shape[0], m.shape[1], rows, columns,
                                 wp.array(m.data.astype(np.float64), dtype=wp.float64, device=device))


class DeviceFieldSolve:
    """u, the nodal fields E_I and the net charge density from the nodal charge Q, on ``launcher``'s device.

    ``field``: the :class:`~.field.PlasmaPoisson` (its matrices and, for ``"dense"``, its factorisation);
    ``background_density``: ρ_bg; ``momentum``: compute the nodal fields (the momentum gather); ``method``: a
    :class:`FieldSolve` on the device, ``CG``, ``DENSE`` or ``DEVICE`` (cg in a periodic box, dense between walls).
    Outputs (device arrays, overwritten by :meth:`solve`): ``potential`` (N), ``nodal_field`` (N vec2d), ``net`` (1);
    ``iterations``: the last CG solve's count (an int on the CPU, a device array on a GPU).
    """

    def __init__(self, field: PlasmaPoisson, background_density: float, momentum: bool, launcher: Launcher,
                 method: FieldSolve = FieldSolve.DEVICE):
        method = FieldSolve.of("field_solve", method)
        if method is FieldSolve.DEVICE:
            method = FieldSolve.DENSE if field.walled else FieldSolve.CG
        if method is FieldSolve.HOST:
            raise ParameterError("field_solve", "the device solve is 'device', 'cg' or 'dense', got 'host'")
        if method is FieldSolve.CG and field.walled:
            raise ParameterError("field_solve", "the conjugate gradients solve a periodic box; walls need 'dense'")
        n = field.model.node_count
        if method is FieldSolve.DENSE and n > DENSE_MAX:
            raise ParameterError("field_solve", f"the dense map holds 3 N² numbers: {n} nodes are more than "
                                                f"{DENSE_MAX}; a periodic box takes 'cg'")
        self.field, self.method, self.momentum = field, method, momentum
        self.launcher, self.n = launcher, n
        dev = launcher.device
        self.background = float(background_density)
        self.area = float(field.area)
        self.node_integral = wp.array(field.node_integral, dtype=wp.float64, device=dev)
        self.inv_mass = wp.array(1.0 / field.node_integral, dtype=wp.float64, device=dev)
        self.potential = wp.zeros(n, dtype=wp.float64, device=dev)
        self.nodal_field = wp.zeros(n, dtype=wp.vec2d, device=dev)
        self.net = wp.zeros(1, dtype=wp.float64, device=dev)
        self._sum = Reduction(launcher, wp.float64, "sum")
        if method is FieldSolve.DENSE:
            self._set_up_dense()
        else:
            self._set_up_cg()

    # -- dense: u = P Q + u0, E = P_E Q + E0 ----------------------------------------------------------------------
    def _set_up_dense(self) -> None:
        f, n, dev = self.field, self.n, self.launcher.device
        size = f.system.K_ff.shape[0]
        rhs = np.zeros((size, n))
        rhs[np.arange(n), np.arange(n)] = 1.0
        p = f.system._lu.solve(rhs)[:n]                                   # u = P Q (the charge's part)
        # the background's and the walls' part (the system itself: PlasmaPoisson.solve would record a net charge)
        u0 = f.system.solve(np.r_[self.background * f.node_integral, f.constraint_values])[:n]
        maps, offsets = [p], [u0]
        if self.momentum:
            mass = f.node_integral[:, None]
            fields = [-(g @ p) / mass for g in f.gradient]
            e0 = [-(g @ u0) / mass[:, 0] for g in f.gradient]
            if f.antisymmetrise:  # E = ½ (-M⁻¹ G S Q - S G M⁻¹ Q) (PlasmaPoisson.nodal_field): S G M⁻¹ = P G M⁻¹
                scale = sp.diags(1.0 / f.node_integral)
                fields = [0.5 * (a - (sp.csr_matrix(g @ scale).T @ p.T).T) for a, g in zip(fields, f.gradient)]
            maps += fields
            offsets += e0
        self.map = wp.array(np.vstack(maps), dtype=wp.float64, device=dev)
        self.offset = wp.array(np.concatenate(offsets), dtype=wp.float64, device=dev)
        self.stacked = wp.zeros(self.offset.shape[0], dtype=wp.float64, device=dev)

    def _solve_dense(self, charge: wp.array) -> None:
        L, n = self.launcher, self.n
        L.launch(K.dense_apply, self.stacked.shape[0], [self.map, charge, self.offset, self.stacked])
        L.launch(K.take, n, [self.stacked, self.potential])
        if self.momentum:
            L.launch(K.pack_field, n, [self.stacked, n, self.nodal_field])
        if not self.field.walled:
            self._net(charge)

    def _net(self, charge: wp.array) -> None:
        self._sum.launch(charge, self.n)
        self.launcher.launch(K.net_density, 1, [self._sum.result, wp.float64(1.0 / self.area),
                                                wp.float64(self.background), self.net])

    # -- cg: the periodic box's singular K with the consistent load, then the gauge ---------------------------------
    def _set_up_cg(self) -> None:
        f, dev, n = self.field, self.launcher.device, self.n
        pinned = f.stiffness.tolil()
        pinned[0, :] = 0.0
        pinned[:, 0] = 0.0
        pinned[0, 0] = 1.0
        self.stiffness = bsr_matrix(pinned.tocsr(), dev)
        self.gradient = [bsr_matrix(g, dev) for g in f.gradient]
        self._precondition = preconditioner(self.stiffness, "diag")
        self._load = wp.zeros(n, dtype=wp.float64, device=dev)
        self._scratch = wp.zeros(n, dtype=wp.float64, device=dev)
        self._density = wp.zeros(n, dtype=wp.float64, device=dev)
        self._gx = wp.zeros(n, dtype=wp.float64, device=dev)
        self._gy = wp.zeros(n, dtype=wp.float64, device=dev)
        self._transposed = ([wp.zeros(n, dtype=wp.float64, device=dev) for _ in range(2)] if f.antisymmetrise
                            else None)
        self._solves = {}
        # a GPU loops on the device until converged (a conditional graph: no host read); a CPU has no such loop
        # (Warp would run every one of maxiter iterations), so there the residual is read every CHECK_EVERY
        self._check_every = CHECK_EVERY if self.launcher.is_cpu else 0

    def _gauged_solve(self, load: wp.array, out: wp.array) -> None:
        """``out`` = S load (K u + m λ = load, ∫u = 0) by CG from zero on the pinned K, then the gauge."""
        L, n = self.launcher, self.n
        self._sum.launch(load, n)
        L.launch(K.periodic_load, n, [load, self.node_integral, self._sum.result, wp.float64(1.0 / self.area),
                                      self._load])
        out.zero_()
        key = out.ptr
        if key not in self._solves:  # pre-allocated CG state per output array (no allocation per step)
            self._solves[key] = cg(self.stiffness, self._load, out, tol=CG_TOLERANCE, atol=0.0, maxiter=4 * n + 100,
                                   M=self._precondition, check_every=self._check_every, run=False)
        self.iterations = self._solves[key]()[0]
        L.launch(K.product, n, [out, self.node_integral, self._scratch])
        self._sum.launch(self._scratch, n)
        L.launch(K.remove_mean, n, [out, self._sum.result, wp.float64(1.0 / self.area)])

    def _solve_cg(self, charge: wp.array) -> None:
        L, n = self.launcher, self.n
        self._net(charge)
        self._gauged_solve(charge, self.potential)
        if not self.momentum:
            return
        wsp.bsr_mv(self.gradient[0], self.potential, self._gx)
        wsp.bsr_mv(self.gradient[1], self.potential, self._gy)
        L.launch(K.nodal_field, n, [self._gx, self._gy, self.inv_mass, self.nodal_field])
        if self._transposed is None:
            return
        # the antisymmetric part's second term S G M⁻¹ Q: one gauged solve per axis (PlasmaPoisson.nodal_field)
        L.launch(K.product, n, [charge, self.inv_mass, self._density])
        for g, out in zip(self.gradient, self._transposed):
            wsp.bsr_mv(g, self._density, self._gx)
            self._gauged_solve(self._gx, out)
        L.launch(K.add_transposed, n, [*self._transposed, self.nodal_field])

    def solve(self, charge: wp.array) -> None:
        """The potential, nodal fields and net charge density for the nodal charge ``charge`` (device, N)."""
        if self.method is FieldSolve.DENSE:
            self._solve_dense(charge)
        else:
            self._solve_cg(charge)
