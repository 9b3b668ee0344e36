"""The PIC field solve: EFG Galerkin Poisson (Marques 2008, eqs 3.8-3.9, 4.4-4.5) in a box periodic along x and either
periodic along y or closed by two walls of given potential (grounded walls, electrodes), factorised once.

-∇²u = ρ (ε0 = 1, E = -∇u). With the EFG shape functions φ_I of an
:class:`~warpfree.galerkin.mls.MLSModel` over a periodic :class:`~warpfree.space.Space`:

    K u + m λ = b,   mᵀ u = 0,   K_IJ = ∫ ∇φ_I·∇φ_J dΩ,   m_I = ∫ φ_I dΩ,   b_I = Q_I + ρ_bg m_I

where Q_I = Σ_p q_p φ_I(x_p) is the deposited charge (eq 4.4) and ρ_bg a uniform background. K is singular (the
constant mode: Σ_J K_IJ = 0 exactly by the partition of unity); the constraint fixes the gauge ∫u = 0 and the
multiplier λ = Σ_I b_I / Σ_I m_I is the net charge per area (0 for a neutral plasma, to round-off).

Walls (y not periodic, ``walls=(V_lower, V_upper)``): the MLS shape functions do not interpolate, so the wall
potentials are imposed by Lagrange multipliers at collocation points, u^h(x_c) = V at one point under each wall
node (K u + Cᵀλ = b, C u = V with C_cI = φ_I(x_c)); λ_c approximates the wall's surface charge at x_c.

K is integrated with plain Gauss quadrature on rectangular cells, not the consistent integration of the static
scenes: a symmetric K with the deposit's own φ_I makes the scheme energy-conserving in the time-continuous limit
(the field energy W = ½ uᵀ K u changes by exactly the work -Σ_p q_p E(x_p)·v_p, Lewis 1970), which a
Petrov-Galerkin K would break. float64 (see ``kernels/mls.py``).

Two gathers (:class:`~.solver.PICSolver` ``gather=``):

- "energy": E(x_p) = -Σ_I u_I ∇φ_I(x_p) (Marques 2008, eq. 4.5). Energy-conserving, but the force on a particle includes
  its own: F = -∇S(x_p) with the self-energy S(x) = ½ q² φ(x)ᵀ K⁻¹ φ(x), which varies across a node cell.
  The self-force grows as 1/spacing (``bench/results/pic_design.md``).
- "momentum": nodal fields E_I = -(1/m_I) Σ_J G_IJ u_J with G_IJ = ∫ φ_I ∇φ_J dΩ (antisymmetric on a periodic
  domain: ∫ ∇(φ_I φ_J) = 0) and the lumped mass m_I = ∫ φ_I, interpolated back with the deposit's shape
  functions, E(x_p) = Σ_I φ_I(x_p) E_I. On a node lattice M⁻¹ G K⁻¹ is a product of commuting circulants and
  antisymmetric, so the self-force and the total force Σ_p F_p vanish to round-off (momentum conservation); on other
  node layouts :meth:`PlasmaPoisson.nodal_field` takes its antisymmetric part (two more back-substitutions a step),
  with the same result. Energy is then conserved only approximately (finite-grid heating, small while the node
  spacing is below λ_D). The lumped mass is kept: a consistent
  one amplifies the short-range field of a point charge (``bench/results/pic_design.md``). Between walls the
  projection tests with ψ_I instead of φ_I (:func:`wall_corrected_test`: the first moment about x_I corrected where a
  wall cuts the support, G_IJ = ∫ ψ_I ∇φ_J), so that E_I is the field at the node, not half a spacing inside.
  The price: near a wall the ψ_I are no partition of unity (Σ_I ψ_I = 0.72 one spacing from the wall, 1.02 three
  spacings in, on a lattice with d_max 2), and cannot be one: with the interior φ_I unchanged, Σ ψ_I = 1 and
  ∫ψ_I = m_I, the wall nodes' first moments would sum to the plain ones' (0.32 h² per unit wall length), not 0. So
  Σ_I m_I E_I = -∫ (Σ_I ψ_I) ∇u^h differs from the potential difference across the wall layer where ∇u^h changes
  within a spacing: a particle's energy there no longer follows u^h (at a virtual cathode inside the first spacing,
  0.009 short over two spacings, twice the injection energy; ``bench/results/pic_design.md``). The energy gather
  has no such error (a particle's field is -∇u^h itself), which is why the diode scene uses it.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError, require_finite
from warpfree.galerkin.assembly import conduction_matrix
from warpfree.galerkin.mls import MLSModel
from warpfree.galerkin.quadrature import rectangle_cells
from warpfree.progress import announced
from warpfree.sparse import FactorisedSystem, PrescribedValues

__all__ = ["PlasmaPoisson", "ANTISYMMETRY_TOLERANCE", "wall_corrected_test"]

#: |rᵀ M⁻¹ G S r| relative to |r| |M⁻¹ G S r| above which the momentum gather adds the transposed term
ANTISYMMETRY_TOLERANCE = 1e-10


class PlasmaPoisson:
    """K, m and their factorisation for ``model`` (nodes in a box periodic along x; along y periodic, or walls).

    cells: (nx, ny) background cells (default: one per node spacing along each axis); order: Gauss points per
    axis and cell (default 4: the MLS integrands are rational, not polynomials); walls: (V at y = lower, V at y =
    upper) when y is not periodic (the model's nodes must then include both wall rows).
    """

    @announced("field solve made: MLS shape functions, Poisson matrix factorised")
    def __init__(self, model: MLSModel, cells: tuple[int, int] | None = None, order: int = 4,
                 walls: tuple[float, float] | None = None):
        space = model.space
        if not space.periodic[0]:
            raise ParameterError("space", f"the PIC field solve needs x periodic, got periodic = {space.periodic[:2]}")
        self.walled = not space.periodic[1]
        if self.walled != (walls is not None):
            raise ParameterError("walls", "give the two wall potentials exactly when y is not periodic (got "
                                          f"walls = {walls!r}, periodic = {space.periodic[:2]})")
        self.model = model
        self.lower = space.lower[:2].copy()
        self.length = space.length[:2].copy()
        self.area = float(np.prod(self.length))
        if cells is None:
            h = math.sqrt(self.area / model.node_count)
            cells = tuple(max(1, int(round(L / h))) for L in self.length)
        self.cells = cells
        self.gauss = rectangle_cells(self.lower, self.lower + self.length, cells, order)
        shape = model.shape_at(self.gauss.position, name="Gauss point")
        self.gauss_shape = shape.matrix()                          # Φ at the Gauss points (n_g × N)
        self.stiffness = conduction_matrix(model, shape, self.gauss.weight)
        self.stiffness = 0.5 * (self.stiffness + self.stiffness.T)  # symmetric by construction; drop the rounding
        self.node_integral = np.asarray(self.gauss_shape.T @ self.gauss.weight).ravel()   # m_I = ∫ φ_I
        if self.walled:
            self.wall_potentials = np.array([require_finite("walls", v) for v in walls])
            constraint, self.constraint_values = self._wall_rows(model)
        else:
            constraint = sp.csr_matrix(self.node_integral.reshape(1, -1))
            self.constraint_values = np.zeros(1)
        system = sp.bmat([[self.stiffness, constraint.T], [constraint, None]], format="csr")
        self.system = FactorisedSystem(system, PrescribedValues(np.zeros(0, np.int64), np.zeros(0),
                                                                system.shape[0]), symmetric_pattern=True)
        self.net_charge_density = 0.0
        gx, gy = shape.gradient_matrices()
        # the momentum gather's test functions: φ_I, with their first moment about x_I corrected at the walls
        test = (wall_corrected_test(self.gauss_shape, self.gauss.position, self.gauss.weight, model.nodes_np,
                                    self.length) if self.walled else self.gauss_shape)
        weighted = sp.diags(self.gauss.weight) @ test
        gradient = [(weighted.T @ gx).tocsr(), (weighted.T @ gy).tocsr()]
        # G = ∫ ψ_I ∇φ_J (ψ_I = φ_I in a periodic box): antisymmetric exactly in a periodic box (the quadrature's
        # asymmetry, which does not integrate ∇(φ_I φ_J) to 0 exactly, is removed); walls add their boundary term,
        # kept as assembled
        self.gradient = gradient if self.walled else [0.5 * (g - g.T) for g in gradient]
        #: whether the momentum gather needs the second, transposed term (:meth:`nodal_field`): not on a node lattice
        self.antisymmetrise = not self.walled and self._projection_asymmetry() > ANTISYMMETRY_TOLERANCE

    def _projection_asymmetry(self) -> float:
        """|rᵀ M⁻¹ G S r| / (|r| |M⁻¹ G S r|) for a random r, the larger over x and y: ~1e-16 when M⁻¹ G S is
        antisymmetric (node lattices: commuting circulants); 3e-4 and 7e-3 on lattice nodes jittered by 1 % and 20 %."""
        r = np.random.default_rng(12345).standard_normal(self.model.node_count)
        u = self.solve_gauged(r)
        worst = 0.0
        for g in self.gradient:
            v = (g @ u) / self.node_integral
            worst = max(worst, abs(float(r @ v)) / max(np.linalg.norm(r) * np.linalg.norm(v), 1e-300))
        return worst

    def _wall_rows(self, model: MLSModel) -> tuple[sp.csr_matrix, np.ndarray]:
        """C (collocation points × N) and the wall potentials at them: one point on each wall under every node of
        the lower wall's row."""
        lo, hi = self.lower[1], self.lower[1] + self.length[1]
        x = model.nodes_np
        tol = 1e-9 * self.length[1]
        xs = np.unique(x[np.abs(x[:, 1] - lo) <= tol, 0])
        if xs.size < 2 or np.count_nonzero(np.abs(x[:, 1] - hi) <= tol) < 2:
            raise ParameterError("nodes", f"walls need a row of nodes on each wall (y = {lo:.6g} and y = {hi:.6g})")
        points = np.r_[np.c_[xs, np.full(xs.size, lo)], np.c_[xs, np.full(xs.size, hi - tol)]]
        c = model.shape_at(points, name="wall point").matrix()
        values = np.r_[np.full(xs.size, self.wall_potentials[0]), np.full(xs.size, self.wall_potentials[1])]
        return c, values

    def solve(self, charge: np.ndarray, background_density: float = 0.0) -> np.ndarray:
        """The nodal potential u (N,) for the deposited charges Q (N,) and a uniform background charge density."""
        n = self.model.node_count
        b = np.r_[charge + background_density * self.node_integral, self.constraint_values]
        sol = self.system.solve(b)
        if not self.walled:
            self.net_charge_density = float(sol[-1])
        return sol[:n]

    def nodal_field(self, potential: np.ndarray, charge: np.ndarray | None = None) -> np.ndarray:
        """Nodal fields E_I (N, 2) for the momentum-conserving gather.

        Walls, a node layout where M⁻¹ G S is antisymmetric already (lattices; :attr:`antisymmetrise` False), or no
        ``charge``: E = -M⁻¹ G u, the lumped L2 projection of -∇u^h onto the shape functions.
        In a periodic box with the deposited ``charge`` Q: E = -½ (M⁻¹ G S + S G M⁻¹) Q, the antisymmetric part of
        the map Q -> -M⁻¹ G S Q (S: the gauged solve, u = S Q), so that the self-force q φᵀ E and the total force
        Qᵀ E vanish on any node layout. The second term S G M⁻¹ Q (≈ ∇S ρ = ∇u: two more back-substitutions)
        equals the first on a node lattice, where M⁻¹, G and S are commuting circulants (so it is skipped there:
        two back-substitutions a step, serial, would cost 1.5x the solve phase at 4 096 nodes). A uniform background
        adds nothing (S m = 0 in the first term; in the second it would enter as S G 1, which the quadrature
        leaves at ~1e-5 instead of 0, so it is left out).
        The measured self-force, net force and energy drift of each variant: ``bench/results/pic_design.md``."""
        m = self.node_integral[:, None]
        projected = -np.stack([g @ potential for g in self.gradient], axis=1) / m
        if not self.antisymmetrise or charge is None:
            return projected
        density = charge / self.node_integral
        transposed = -np.stack([self.solve_gauged(g @ density) for g in self.gradient], axis=1)
        return 0.5 * (projected + transposed)

    def solve_gauged(self, load: np.ndarray) -> np.ndarray:
        """S b: the potential for a nodal load b with the gauge ∫u = 0 (periodic box), without touching the net
        charge density that :meth:`solve` records."""
        return self.system.solve(np.r_[load, np.zeros(1)])[:self.model.node_count]

    def field_energy(self, potential: np.ndarray) -> float:
        """W = ½ uᵀ K u = ½ ∫ |∇u^h|² dΩ (per unit depth)."""
        return 0.5 * float(potential @ (self.stiffness @ potential))

    def mode_coefficients(self, modes) -> np.ndarray:
        """C (n_modes × N) with C_kI = (1/A) ∫ φ_I e^{-i k·x} dΩ, so the Fourier coefficient of u^h is C u
        (k = 2π (mx/Lx, my/Ly) for each (mx, my) in ``modes``)."""
        k = self.wavevectors(modes)
        phase = np.exp(-1j * (self.gauss.position - self.lower) @ k.T)        # (n_g, n_modes)
        return np.asarray((self.gauss_shape.T @ (self.gauss.weight[:, None] * phase)).T) / self.area

    def wavevectors(self, modes) -> np.ndarray:
        """The wavevectors k = 2π m / L (1/λ_D) of Fourier modes ``m`` (n, 2) of the box."""
        m = np.asarray(modes, dtype=np.float64).reshape(-1, 2)
        return 2.0 * math.pi * m / self.length

    def describe(self) -> dict:
        """The field solve for ``summary.json``: wall potentials, background cells, Gauss points, matrix entries,
        factorisation time."""
        return {"walls": self.wall_potentials.tolist() if self.walled else None, "cells": list(self.cells),
                "gauss_points": int(self.gauss.weight.size),
                "stiffness_nnz": int(self.stiffness.nnz), "factorise_s": self.system.timings["factorise"]}


def wall_corrected_test(shape: sp.spmatrix, points: np.ndarray, weights: np.ndarray, nodes: np.ndarray,
                        length: np.ndarray) -> sp.csr_matrix:
    """ψ_I(x_g) (n_g × N): the test functions of the lumped projection E_I = (1/m_I) ∫ ψ_I E dΩ, corrected so that
    E_I is the field at the node, to second order in the spacing, also where a wall cuts φ_I's support.

    The plain lumped projection (ψ_I = φ_I) gives E_I = E(c_I) + O(h²) at the centroid c_I = ∫ φ_I x / ∫ φ_I,
    which is x_I at an interior lattice node but lies about half a spacing inside the box for a node on or near a
    wall: there Σ_I φ_I(x) E_I misses E(x) by O(h ∂E), and at a space-charge-limited cathode, where E climbs from 0
    steeply through the dense slow beam, that error is the largest one in the particles' field
    (``bench/results/pic_design.md``). The reproducing-kernel correction (Liu, Jun & Zhang 1995, Int. J. Numer.
    Meth. Fluids 20, 1081: a kernel multiplied by a linear polynomial so that it reproduces constants and linears)
    gives

        ψ_I(x) = φ_I(x) (a_I + b_I · (x - x_I)),   ∫ ψ_I = m_I,   ∫ ψ_I (x - x_I) = 0,

    i.e. with the moments m_I = ∫ φ_I, μ_I = ∫ φ_I (x - x_I), S_I = ∫ φ_I (x - x_I)(x - x_I)ᵀ:
    b_I = -a_I S_I⁻¹ μ_I, a_I = m_I / (m_I - μ_Iᵀ S_I⁻¹ μ_I) (> 0 where the 3 × 3 moment matrix of 1, x - x_I is
    positive definite). Then E_I = E(x_I) + O(h²) for a smooth E, and, the MLS shape functions reproducing linears,
    the projection adds no O(h) error of its own at a wall: what is left there is the error of ∇u^h itself (first
    order for the linear basis; ``tests/pic/test_pic.py``). Interior lattice nodes have μ_I = 0 (a_I = 1, b_I = 0,
    ψ_I = φ_I). The moments are integrated with
    the Gauss points of K (``points``, ``weights``); offsets along x are minimum images (x periodic, side
    ``length[0]``). float64.
    """
    g = shape.tocoo()
    offset = points[g.row, :2] - nodes[g.col, :2]
    offset[:, 0] -= length[0] * np.round(offset[:, 0] / length[0])
    wphi = weights[g.row] * g.data
    n = shape.shape[1]
    mass = np.bincount(g.col, wphi, minlength=n)
    first = np.stack([np.bincount(g.col, wphi * offset[:, a], minlength=n) for a in range(2)], axis=1)
    second = np.empty((n, 2, 2))
    for a in range(2):
        for b in range(2):
            second[:, a, b] = np.bincount(g.col, wphi * offset[:, a] * offset[:, b], minlength=n)
    solved = np.linalg.solve(second, first[:, :, None])[:, :, 0]              # S_I⁻¹ μ_I
    scale = mass / (mass - np.einsum("na,na->n", first, solved))               # a_I
    slope = -scale[:, None] * solved                                            # b_I
    factor = scale[g.col] + np.einsum("ka,ka->k", slope[g.col], offset)
    return sp.csr_matrix((g.data * factor, (g.row, g.col)), shape=shape.shape)
