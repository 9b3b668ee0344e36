"""The static part of SPEM: the E and H sets, their cross-set neighbour lists, derivative coefficients,
materials and the PML loss rates, all computed once (the particles do not move).

Supports. Particle i's support radius is ``support`` × its local spacing Δ_i (widened where that holds fewer
than 2·dim particles of the other set, e.g. next to a curved wall). The default 1.1 Δ reaches
the nearest shell of the other set (4 particles at Δ/√2 in 2D, 2 at Δ/2 in 1D) and no farther (the next
shell is at 1.58 Δ in 2D, 1.5 Δ in 1D): on a uniform layout the FPM derivative is then Yee's central
difference, the least dispersive consistent choice. Jittered layouts need a support that keeps the nearest
shell inside whatever the offsets: 1.1 + 2·jitter (``support_for_jitter``). A particle whose derivative is
ill conditioned (too few or collinear neighbours of the other set) is reported with its position and
neighbour count, never inverted blindly.

Units: SI. ε = ε0 εr, μ = μ0 μr per particle. PML (3.24-3.26): σ(ρ) = σm (ρ/δ)^n on each lossy axis,
σm = -ln(ψ)(n+1) ε0 c/(2δ); per particle the loss rates κ = σ/ε (E) and, matched (3.21), σ*/μ = σ/ε (H).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError, require_bool, require_integer, require_positive
from warpfree.kernels import spem as K
from warpfree.neighbours import NeighbourGrid, NeighbourList, host_rows
from warpfree.parameters import Choice
from warpfree.particles import ParticleSet
from warpfree.progress import announced, group_digits
from warpfree.space import Space

from .conservative import ConservativePair, energy_conserving_pair, pattern_reach
from .layouts import StaggeredLayout, carve_conductors
from .materials import EMObject, check_objects, effective_materials

__all__ = ["EPS0", "MU0", "C0", "PML", "PMLSide", "Scheme", "SPEMModel", "support_for_jitter"]

C0 = 299_792_458.0                       # m/s
MU0 = 4e-7 * math.pi                     # H/m (the classical value; the 2019 SI differs by 1e-10)
EPS0 = 1.0 / (MU0 * C0 * C0)             # F/m

#: largest admitted condition number of a particle's scaled moment matrix (FPM) or denominator ratio (CSPM)
CONDITION_LIMIT = 1.0e4


class Scheme(Choice):
    """The derivative of a field at a particle from the particles of the other set."""

    FPM = "fpm", "finite particle method (Liu & Liu 2006): exact for constant and linear fields on any layout"
    CSPM = "cspm", "the diagonal CSPM ratio (Chen, Beraun & Carney 1999), per axis"
    SPH = "sph", "the uncorrected SPH derivative Σ_j u_j ∇W ω_j"


class PMLSide(Choice):
    """A side of the interior box that a PML lines."""

    X_LOWER = "x-", "beyond the interior's lower x"
    X_UPPER = "x+", "beyond the interior's upper x"
    Y_LOWER = "y-", "beyond the interior's lower y"
    Y_UPPER = "y+", "beyond the interior's upper y"

    @property
    def axis(self) -> int:
        """The axis normal to the side: 0 (x) or 1 (y)."""
        return 0 if self in (PMLSide.X_LOWER, PMLSide.X_UPPER) else 1

    @property
    def lower(self) -> bool:
        """True on the interior's lower side of its axis."""
        return self in (PMLSide.X_LOWER, PMLSide.Y_LOWER)


def support_for_jitter(jitter: float) -> float:
    """Support (in units of the spacing) that keeps the nearest shell of the other set inside for offsets of up
    to ``jitter``·Δ per axis on both sets: 1.1 + 2·jitter."""
    return 1.1 + 2.0 * float(jitter)


@dataclass
class PML:
    """Berenger's split-field PML of ``thickness`` δ (m) on the given ``sides`` of the interior box
    (e.g. ``("x-", "x+", "y-", "y+")``), graded σ = σm (ρ/δ)^order, σm from the normal-incidence
    reflection ``reflection`` ψ (3.26)."""

    thickness: float
    sides: tuple = (PMLSide.X_LOWER, PMLSide.X_UPPER, PMLSide.Y_LOWER, PMLSide.Y_UPPER)
    order: int = 3
    reflection: float = 1e-6

    def __post_init__(self):
        self.sides = tuple(PMLSide.of("pml.sides", s) for s in self.sides)

    def sigma_max(self) -> float:
        """σm = -ln(ψ)(n+1) ε0 c/(2δ) (S/m), eq. 3.26."""
        return -math.log(self.reflection) * (self.order + 1) * EPS0 * C0 / (2.0 * self.thickness)

    def check(self, spacing: float) -> None:
        """Refuse a layer thinner than two particle spacings or a reflection outside (0, 1), naming ``pml.*``."""
        require_positive("pml.thickness", self.thickness)
        if self.thickness < 2.0 * spacing:
            raise ParameterError("pml.thickness", f"{self.thickness:.4g} m is thinner than two particle spacings "
                                                  f"(2 x {spacing:.4g} m): the grading cannot be resolved")
        if not 0.0 < self.reflection < 1.0:
            raise ParameterError("pml.reflection", f"must be in (0, 1) (the target reflection ψ), got {self.reflection}")
        require_integer("pml.order", self.order, minimum=1, maximum=6)  # 3 or 4 usual

    def sigma(self, points: np.ndarray, inner_lower, inner_upper) -> np.ndarray:
        """(N, 2) σx, σy (S/m) at ``points``: graded with the depth ρ beyond the interior box on each lossy side."""
        sm = self.sigma_max()
        out = np.zeros((points.shape[0], 2))
        for side in self.sides:
            a = side.axis
            rho = (inner_lower[a] - points[:, a]) if side.lower else (points[:, a] - inner_upper[a])
            rho = np.clip(rho, 0.0, None)  # depth into the layer: 0 inside the interior (not a clamp of a result)
            out[:, a] = np.maximum(out[:, a], sm * (rho / self.thickness) ** self.order)
        return out


Material = Callable[[np.ndarray], np.ndarray] | float


def _material(name: str, value, points: np.ndarray) -> np.ndarray:
    v = value(points) if callable(value) else value
    v = np.broadcast_to(np.asarray(v, dtype=np.float64), (points.shape[0],)).copy()
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        bad = int(np.argmax(~np.isfinite(v) | (v <= 0)))
        raise ParameterError(name, f"must be finite and > 0 everywhere; particle {bad} at {points[bad, :2]} has {v[bad]}")
    return v


class SPEMModel:
    """E and H particle sets of ``layout`` with their materials, PML and derivative coefficients.

    Parameters
    ----------
    layout: a :class:`~.layouts.StaggeredLayout`.
    scheme: a :class:`Scheme`: FPM (default), CSPM (eq. 3.6) or SPH (uncorrected).
    support: support radius in units of each particle's spacing (default 1.1, module docstring).
    eps_r, mu_r: the background's relative permittivity / permeability: a number or f(points (N, 3)) -> (N,) (read at
        each particle: an interface between values of a function is staircased).
    objects: :class:`~.materials.EMObject` s (shapes with materials) layered over the background in order; each
        particle takes the effective material of its cell (:mod:`.materials`: second order at the interfaces).
    pml: a :class:`PML` or None; ``interior``: (lower, upper) of the interior box the PML surrounds.
    pec: hold the layout's wall E particles at Ez = 0 (explicit perfect-conductor particles; default). False
        leaves them free: the wall is then only the absence of particles beyond it (the thesis's natural
        condition, §3.1.4).
    conservative: replace the pair of derivative operators by the nearest one that conserves the discrete
        energy and stays exact for linear fields (:mod:`.conservative`): stable on any layout (jittered,
        graded, curved walls), with its step limit computed. Default: on for FPM; off for CSPM and SPH, which
        are kept as the thesis printed them for comparison.
    order: the interior difference's order: 2 (FPM, Yee's difference on a lattice) or 4 (Fang's (2,4) difference, closed
        at the walls by images: :mod:`.fourth_order`; a uniform lattice with its walls held, no conductor objects).
    pair_order: 1 (exact for linear fields) or 2 (also the quadratic moments, in least squares: lower error on
        jittered layouts, a set-up that grows fast with the layout; :mod:`.conservative`).
    """

    @announced(lambda self, layout, *a, **k: f"EM model made: operators and volumes ({group_digits(layout.n_e)} E, "
               f"{group_digits(layout.n_h)} H particles)")
    def __init__(self, layout: StaggeredLayout, scheme: Scheme = Scheme.FPM, support: float = 1.1, eps_r: Material = 1.0,
                 mu_r: Material = 1.0, pml: PML | None = None, interior=None, pec: bool = True,
                 conservative: bool | None = None, pair_order: int = 1, order: int = 2,
                 objects: list[EMObject] | None = None,
                 launcher: Launcher | None = None):
        launcher = launcher or current_launcher()
        scheme = Scheme.of("scheme", scheme)
        objects = check_objects(objects, layout)
        conductors = [o.shape for o in objects if o.material.perfect_conductor]
        if conductors:  # cut out, their surfaces held (the model's layout is the carved one)
            if not require_bool("pec", pec):
                raise ParameterError("pec", "perfect-conductor objects hold their surfaces at Ez = 0: leave pec on")
            layout = carve_conductors(layout, conductors)
        self.support = require_positive("support", support)
        if not 0.75 <= self.support <= 4.0:
            raise ParameterError("support", f"must be in [0.75, 4] spacings (the nearest particles of the other set "
                                            f"are 0.5-0.71 spacings away), got {support}")
        self.layout, self.scheme, self.dim = layout, scheme, layout.dim
        self.space = Space.free(layout.dim)
        dev = launcher.device
        self.electric = ParticleSet("electric", layout.e_position, layout.dim, dev)
        self.magnetic = ParticleSet("magnetic", layout.h_position, layout.dim, dev)
        self.eps_r = _material("eps_r", eps_r, layout.e_position)
        self.mu_r = _material("mu_r", mu_r, layout.h_position)
        self.objects = [o for o in objects if not o.material.perfect_conductor]
        self.conductors = [o for o in objects if o.material.perfect_conductor]
        self.conductivity = np.zeros(layout.n_e)
        self.materials = None
        #: the Drude particles: (indices, ε0 ωp² (F/(m s²)), γ (1/s)), or None (:mod:`.materials`)
        self.drude = None
        if self.objects:
            self.materials = effective_materials(self.objects, layout, self.eps_r, self.mu_r)
            self.eps_r, self.mu_r = self.materials.eps_r, self.materials.mu_r
            self.conductivity = self.materials.conductivity
            if self.materials.plasma_frequency_squared is not None:
                at = np.flatnonzero(self.materials.plasma_frequency_squared > 0)
                self.drude = (at, EPS0 * self.materials.plasma_frequency_squared[at], self.materials.collision_rate[at])
        self.pml = pml
        loss_e, loss_h = np.zeros((layout.n_e, 2)), np.zeros((layout.n_h, 2))
        if pml is not None:
            pml.check(layout.spacing)
            if interior is None:
                raise ParameterError("interior", "a PML needs the interior box (lower, upper) it surrounds")
            lo, hi = np.asarray(interior[0], float), np.asarray(interior[1], float)
            eps_h = _material("eps_r", eps_r, layout.h_position)
            loss_e = pml.sigma(layout.e_position, lo, hi) / (EPS0 * self.eps_r[:, None])
            loss_h = pml.sigma(layout.h_position, lo, hi) / (EPS0 * eps_h[:, None])  # σ*/μ = σ/ε (3.21)
        if self.drude is not None and np.any(loss_e[self.drude[0]] != 0.0):
            raise ParameterError("objects", "a dispersive (Drude) object reaches into the PML: keep it in the interior")
        loss_e += (self.conductivity / (EPS0 * self.eps_r))[:, None]  # σ/ε on both parts of the split field
        self.interior = interior
        self.pec = require_bool("pec", pec)
        e, h = self.electric, self.magnetic
        self.held = layout.on_wall.copy() if self.pec else np.zeros(layout.n_e, bool)  # E particles not updated
        self.h_subsets = layout.h_subsets()
        yee = layout.h_carries is not None
        e_support = self._supports(layout.e_position, layout.e_spacing, layout.h_position)
        h_support = self._supports(layout.h_position, layout.h_spacing, layout.e_position)
        if yee:  # enough particles of each component's own set for the one derivative it needs
            e_support = np.max([self._axis_supports(layout.e_position, layout.e_spacing, layout.h_position[sub], a)
                                for a, sub in enumerate(self.h_subsets)], axis=0)
            for a, sub in enumerate(self.h_subsets):
                h_support[sub] = self._axis_supports(layout.h_position[sub], layout.h_spacing[sub],
                                                     layout.e_position, a)
        e.add("support", e_support)
        h.add("support", h_support)
        e.add("inv_permittivity", 1.0 / (EPS0 * self.eps_r))
        h.add("inv_permeability", 1.0 / (MU0 * self.mu_r))
        e.add("permittivity", EPS0 * self.eps_r)
        h.add("permeability", MU0 * self.mu_r)
        e.add("loss", loss_e, dtype=wp.vec2)
        h.add("loss", loss_h, dtype=wp.vec2)
        e.add("cell_volume", layout.e_cell_volume())
        h.add("cell_volume", layout.h_cell_volume())
        self.reach = float(max(e.numpy("support").max(), h.numpy("support").max()))
        self.launcher = launcher
        self.e_rows = NeighbourList(NeighbourGrid(launcher, self.reach, self.space, h.position), e.position)  # E -> H
        self.h_rows = NeighbourList(NeighbourGrid(launcher, self.reach, self.space, e.position), h.position)  # H -> E
        self.conservative = (scheme is Scheme.FPM) if conservative is None else require_bool("conservative", conservative)
        self.pair_order = require_integer("pair_order", pair_order, minimum=1, maximum=2)
        self.order = require_integer("order", order, minimum=2, maximum=4)
        if self.order not in (2, 4):
            raise ParameterError("order", f"must be 2 or 4, got {order}")
        if self.conservative and not self.pec and layout.on_wall.any() and self.order == 2:
            raise ParameterError("conservative", "the energy-conserving pair closes the walls by holding them (pec=True);"
                                                 " walls left free (the thesis's natural condition) take the plain FPM "
                                                 "pair: give conservative=False")
        if self.order == 4:
            if scheme is not Scheme.FPM or self.conductors:
                raise ParameterError("order", "the fourth-order difference is for the FPM scheme on a lattice without "
                                              "conductor objects (their surface row is off the lattice)")
            self._fourth_order()
            return
        self.conservation = None
        if yee:
            if scheme is not Scheme.FPM:
                raise ParameterError("scheme", f"Yee's staggering (h_staggering='edges') is built for 'fpm'; "
                                               f"'{scheme}' is kept on the cell-centred layout it was printed for")
            self._own_set_volume(e)
            h.add("volume", self._subset_volumes(h))
            e_operator, h_operator = self._component_operators()
            if self.conservative:
                self._make_conservative(e_operator, h_operator)
            else:
                self.e_coefficient = self._set_operator(self.e_rows, e_operator)
                self.h_coefficient = self._set_operator(self.h_rows, h_operator)
            return
        # own-set volumes (2.15), then each set's rows over the other set and their coefficients
        for s in (e, h):
            self._own_set_volume(s)
        self.e_coefficient = self._coefficients(e, h, self.e_rows, self.held)
        self.h_coefficient = self._coefficients(h, e, self.h_rows, np.zeros(h.n, bool))
        if self.conservative:  # the nearest energy-conserving pair that is still exact for linear fields
            self._make_conservative(self._operator(self.e_rows, self.e_coefficient, layout.n_h),
                                    self._operator(self.h_rows, self.h_coefficient, layout.n_e))
        else:
            self.e_coefficient = self._compact(self.e_rows, self.e_coefficient)
            self.h_coefficient = self._compact(self.h_rows, self.h_coefficient)

    def _fourth_order(self) -> None:
        """The (2,4) pair (:mod:`.fourth_order`) as the model's rows, conserving the energy with equal volumes (the
        lattice's cell, Δx Δy: Yee's energy norm, in which the images make the pair skew-adjoint)."""
        from .conservative import ConservativePair
        from .fourth_order import fourth_order_pair, lattice_cell

        lay, e, h = self.layout, self.electric, self.magnetic
        cell = lattice_cell(lay)
        ve, vh = self.quadrature = np.full(lay.n_e, cell), np.full(lay.n_h, cell)
        e.add("cell_volume", ve)
        h.add("cell_volume", vh)
        e_operator, h_operator, residual = fourth_order_pair(lay, self.held, ve, vh)
        if residual > 1e-9:
            raise RuntimeError(f"the fourth-order pair is not skew-adjoint (residual {residual:.3g})")
        self.conservative = True
        self.e_coefficient = self._set_operator(self.e_rows, e_operator)
        self.h_coefficient = self._set_operator(self.h_rows, h_operator)
        self.conservation = {"largest_change_per_spacing": 0.0, "residual": residual}
        self._pair = ConservativePair(e_operator, h_operator, 0.0, residual)

    def _own_set_volume(self, s: ParticleSet) -> wp.array:
        """ω_i of eq. 2.15 over ``s``'s own particles (its field ``volume``)."""
        own = NeighbourList(NeighbourGrid(self.launcher, self.reach, self.space, s.position), s.position)
        s.add("volume")
        self.launcher.launch(K.own_set_volume, s.n, [self.space.box, own.rows, s.position, s["support"], s["volume"]])
        return s["volume"]

    def _subset(self, axis: int) -> ParticleSet:
        """The H particles of one component (those the ``axis``-derivatives connect, ``StaggeredLayout.h_subsets``)
        as a set of their own: positions, supports and, once known, volumes."""
        h, sub = self.magnetic, self.h_subsets[axis]
        part = ParticleSet(f"magnetic ({'xy'[axis]} derivative)", self.layout.h_position[sub], self.dim,
                           self.launcher.device)
        part.add("support", h.numpy("support")[sub])
        if "volume" in h:
            part.add("volume", h.numpy("volume")[sub])
        return part

    def _subset_volumes(self, h: ParticleSet) -> np.ndarray:
        """ω (2.15) of each H particle among the particles of its own component (each component is a set)."""
        volume = np.zeros(h.n)
        for axis, sub in enumerate(self.h_subsets):
            volume[sub] = self._own_set_volume(self._subset(axis)).numpy()
        return volume

    def _component_embedding(self, axis: int) -> sp.csr_matrix:
        """(|S_a|, n_h) 0/1 matrix placing axis ``axis``'s H particles (``h_subsets``) among the whole H set."""
        sub = self.h_subsets[axis]
        return sp.csr_matrix((np.ones(sub.size), (np.arange(sub.size), sub)), shape=(sub.size, self.layout.n_h))

    def electric_operator(self) -> list:
        """The E rows as host CSR matrices per axis (n_e, n_h), 1/m: ∂Hy/∂x ≈ D[0] Hy, ∂Hx/∂y ≈ D[1] Hx. Set-up or
        diagnostics only (a host copy)."""
        return self._operator(self.e_rows, self.e_coefficient, self.layout.n_h)

    def _component_operators(self) -> tuple[list, list]:
        """Yee's staggering: per axis a, D_E^a (E rows over the H particles of a's component, ∂/∂x_a of that
        component) and D_H^a (those H particles' rows over E, ∂Ez/∂x_a), each FPM over the component's own
        particles, as CSR matrices over the whole sets (1/m): an H particle takes no a-derivative of another
        component's field."""
        e, lay = self.electric, self.layout
        e_operator, h_operator = [], []
        for axis, sub in enumerate(self.h_subsets):
            part = self._subset(axis)
            to_whole = self._component_embedding(axis)
            rows = NeighbourList(NeighbourGrid(self.launcher, self.reach, self.space, part.position), e.position)
            coefficient = self._coefficients(e, part, rows, self.held, axis)
            e_operator.append((self._operator(rows, coefficient, sub.size)[axis] @ to_whole).tocsr())
            rows = NeighbourList(NeighbourGrid(self.launcher, self.reach, self.space, e.position), part.position)
            coefficient = self._coefficients(part, e, rows, np.zeros(sub.size, bool), axis)
            h_operator.append((to_whole.T @ self._operator(rows, coefficient, lay.n_e)[axis]).tocsr())
        return e_operator, h_operator

    def _compact(self, rows: NeighbourList, coefficient: wp.array) -> wp.array:
        """Drop the row entries whose coefficient is zero (candidates beyond the particle's own support: rows are
        searched to the widest support of the set, 2.2 spacings at a wall corner against 1.1 inside, so that a
        row held 15.5 candidates for 4 non-zero terms on the waveguide). Set-up, once, in NumPy; the gather
        then does only the work that counts, with the same terms in the same order (the result is unchanged)."""
        n, total = rows.n, rows.n_pairs
        if n == 0 or total == 0:
            return coefficient
        start, count = rows.rows.start.numpy()[:n], rows.rows.count.numpy()[:n]
        index, coef = rows.rows.index.numpy()[:total], coefficient.numpy()[:total]
        if not np.array_equal(start, np.concatenate([[0], np.cumsum(count)[:-1]])):
            raise RuntimeError("neighbour rows are not stored in row order")  # NeighbourList's layout (a scan)
        keep = np.any(coef != 0.0, axis=1)
        kept = np.flatnonzero(keep)
        dev = self.launcher.device
        rows.rows = host_rows(np.bincount(np.repeat(np.arange(n), count)[keep], minlength=n), index[kept], dev)
        rows.n_pairs = int(kept.size)
        return wp.array(coef[kept] if kept.size else np.zeros((1, 3), np.float32), dtype=wp.vec3, device=dev)

    def _operator(self, rows: NeighbourList, coefficient: wp.array, n_cols: int) -> list:
        """The rows' coefficients as one CSR matrix per axis (1/m), on the host."""
        ptr, idx = rows.offsets(), rows.indices()
        coef = coefficient.numpy()[:rows.n_pairs].astype(np.float64)
        return [sp.csr_matrix((coef[:, a], idx, ptr), shape=(rows.n, n_cols)) for a in range(self.dim)]

    def _set_operator(self, rows: NeighbourList, operator: list) -> wp.array:
        """Replace ``rows`` by the union pattern of the per-axis CSR ``operator`` and return its coefficients."""
        pattern = abs(operator[0])
        for m in operator[1:]:
            pattern = pattern + abs(m)
        pattern = sp.csr_matrix(pattern)
        pattern.eliminate_zeros()
        pattern.sort_indices()
        r, c = pattern.nonzero()
        coef = np.zeros((pattern.nnz, 3), np.float32)
        for a, m in enumerate(operator):
            coef[:, a] = np.asarray(m[r, c]).ravel()
        dev = self.launcher.device
        rows.rows.start = wp.array(pattern.indptr[:-1].astype(np.int32), dtype=wp.int32, device=dev)
        rows.rows.count = wp.array(np.diff(pattern.indptr).astype(np.int32), dtype=wp.int32, device=dev)
        rows.rows.index = wp.array(pattern.indices.astype(np.int32) if pattern.nnz else np.zeros(1, np.int32),
                                   dtype=wp.int32, device=dev)
        rows.n_pairs = int(pattern.nnz)
        return wp.array(coef if pattern.nnz else np.zeros((1, 3), np.float32), dtype=wp.vec3, device=dev)

    def _make_conservative(self, e_operator: list, h_operator: list) -> None:
        """Replace the FPM pair (per axis CSR) by the nearest pair that conserves energy and is exact for linear
        fields (:mod:`.conservative`), per axis on that axis's H particles."""
        lay, e, h = self.layout, self.electric, self.magnetic
        # the positions the kernels use (float32), so that FPM's rows are exact on them, and the volumes of the
        # same points: with the layout's float64 volumes a uniform line 1500 spacings long carried a 6e-5
        # mismatch between its geometry and its volumes, which the solve "corrected" by 0.23/spacing (the
        # step limit fell to 0.76 Δ/c and the error stalled at 1.7e-3 from 80 particles per λ on)
        xe, xh = e.numpy("position").astype(np.float64), h.numpy("position").astype(np.float64)
        ve, vh = self.quadrature = lay.quadrature_volumes(xe, xh)
        e.add("cell_volume", ve)  # the energy the pair conserves (``SPEMSolver.energy``)
        h.add("cell_volume", vh)
        e_reach = pattern_reach(e.numpy("support"), lay.e_spacing, self.pair_order)
        h_reach = pattern_reach(h.numpy("support"), lay.h_spacing, self.pair_order)
        if lay.h_carries is None:
            pair = energy_conserving_pair(xe, xh, self.dim, self.held, ve, vh, e_operator, h_operator, e_reach,
                                          h_reach, lay.spacing, order=self.pair_order)
        else:
            parts = []
            for axis, sub in enumerate(self.h_subsets):
                to_whole = self._component_embedding(axis)
                ops = [e_operator[axis][:, sub]] * self.dim, [h_operator[axis][sub]] * self.dim
                part = energy_conserving_pair(xe, xh[sub], self.dim, self.held, ve, vh[sub], *ops, e_reach,
                                              h_reach[sub], lay.spacing, axes=(axis,), order=self.pair_order)
                parts.append((part.e_operator[0] @ to_whole, to_whole.T @ part.h_operator[0], part))
            pair = ConservativePair([p[0].tocsr() for p in parts], [p[1].tocsr() for p in parts],
                                    max(p[2].largest_change for p in parts), max(p[2].residual for p in parts))
        self.e_coefficient = self._set_operator(self.e_rows, pair.e_operator)
        self.h_coefficient = self._set_operator(self.h_rows, pair.h_operator)
        self.conservation = {"largest_change_per_spacing": pair.largest_change, "residual": pair.residual}
        self._pair = pair

    def _supports(self, points: np.ndarray, spacing: np.ndarray, other: np.ndarray) -> np.ndarray:
        """Support radius per particle (m): ``support`` × its spacing, widened where that holds fewer than 2·dim
        particles of the other set (next to a curved wall, a graded region) to 1.05 × the distance of the
        2·dim-th nearest one (the k-th-nearest rule of EFG supports). Set-up, once (SciPy's KD-tree)."""
        from scipy.spatial import cKDTree

        k = 2 * self.dim
        radius = self.support * spacing
        if other.shape[0] >= k:
            d, _ = cKDTree(other[:, :self.dim]).query(points[:, :self.dim], k=k)
            radius = np.maximum(radius, 1.05 * d[:, -1])
        return radius

    def _axis_supports(self, points: np.ndarray, spacing: np.ndarray, other: np.ndarray, axis: int) -> np.ndarray:
        """Support radius per particle (m) for the derivative along ``axis`` alone (Yee's staggering): ``support`` ×
        its spacing, widened to 1.05 × the distance of the k-th nearest of ``other``, k the fewest that fix the
        derivative: 2 when those two lie on the line through the particle along ``axis`` and no third is inside
        the support (the 1D fit, Yee's
        difference on a lattice), 3 when three span a triangle of area at least Δ²/8 (a well-posed 2D linear fit),
        else 4. Set-up, once."""
        from scipy.spatial import cKDTree

        radius = self.support * spacing
        k = min(4, other.shape[0])
        if k < 2:
            return radius
        d, idx = cKDTree(other[:, :2]).query(points[:, :2], k=k)
        perpendicular = 1 - axis
        offset = other[idx[:, :2], perpendicular] - points[:, None, perpendicular]
        on_line = np.all(np.abs(offset) < 1e-6 * spacing[:, None], axis=1)
        if k >= 3:  # the 1D fit only where nothing off the line is inside the support as well
            on_line &= d[:, 2] > radius
        needed = np.full(points.shape[0], k)
        if k >= 3:
            p0, p1, p2 = (other[idx[:, n], :2] for n in range(3))
            u, v = p1 - p0, p2 - p0
            spread = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / spacing ** 2
            needed = np.where(spread > 0.25, 3, needed)
        needed = np.where(on_line, 2, needed)
        return np.maximum(radius, 1.05 * d[np.arange(points.shape[0]), needed - 1])

    def _coefficients(self, s: ParticleSet, other: ParticleSet, rows: NeighbourList, exempt: np.ndarray,
                      axis: int = -1) -> wp.array:
        """Derivative coefficients of ``s``'s rows over ``other`` (checked, except for the ``exempt`` particles,
        which are never updated); ``axis`` >= 0: only that derivative is wanted (Yee's staggering)."""
        L = self.launcher
        coef = wp.zeros(max(rows.n_pairs, 1), dtype=wp.vec3, device=L.device)
        condition = wp.zeros(s.n, dtype=float, device=L.device)
        L.launch(K.gradient_coefficients, s.n, [K.SCHEMES[self.scheme.value], self.dim, axis, self.space.box, rows.rows,
                                                 s.position, s["support"], other.position, other["volume"], coef,
                                                 condition])
        cond = condition.numpy()
        bad = np.flatnonzero(~(cond <= CONDITION_LIMIT) & ~exempt)
        if bad.size:
            i = int(bad[np.argmax(cond[bad])])
            counts = rows.counts()
            raise ParameterError("support", f"{bad.size} {s.name} particle(s) have an ill-conditioned derivative "
                                            f"(condition {cond[i]:.3g} > {CONDITION_LIMIT:.0g}), e.g. particle {i} at "
                                            f"{np.round(s.numpy('position')[i, :self.dim], 6).tolist()} with {int(counts[i])} "
                                            f"{other.name} neighbour(s) within {self.support} spacings: widen the support "
                                            f"or fill the gap")
        s.add("condition", cond)
        return coef

    def stable_dt(self) -> float:
        """Largest stable leapfrog step (s), Δt <= 2/sqrt(ρ) with ρ the spectral radius of the E-to-E operator
        ε⁻¹ Σ_a D_E^a μ⁻¹ D_H^a. For the conservative pair ρ is computed (its spectrum is real: the operator is
        similar to Σ_a B_a B_aᵀ, B_a = (V_E/ε)^½ D_E^a (μV_H)^-½); otherwise it is bounded by Gershgorin,
        ρ <= max_i Σ|A_i·| max_k Σ|B_k·| of the E update A and the H update B. On a uniform layout: Δ/c in 1D
        (both), in 2D Δ/c computed (the nearest-shell stencil is Yee's rotated by 45°, √2 above Yee's limit) and
        Δ/(c√2) from the Gershgorin bound; eq. 3.16's √2 c Δt/h_min <= 1 is reported beside it (``describe``)."""
        if self.conservative:
            return 2.0 / math.sqrt(self._spectral_radius() + self._drude_rate())
        L = self.launcher
        row = []
        for s, rows, coef, material, electric in ((self.electric, self.e_rows, self.e_coefficient, "inv_permittivity", 1),
                                                  (self.magnetic, self.h_rows, self.h_coefficient, "inv_permeability", 0)):
            out = wp.zeros(s.n, dtype=float, device=L.device)
            L.launch(K.row_abs_sums, s.n, [rows.rows, coef, s[material], electric, out])
            values = out.numpy()
            if electric:
                values = values[~self.held]  # held particles are not updated (set once: a host read is fine)
            row.append(float(values.max()))
        return 2.0 / math.sqrt(row[0] * row[1] + self._drude_rate())

    def _drude_rate(self) -> float:
        """max ωp²/ε∞ over the Drude particles (1/s²; 0 without): the E-J oscillation's share of the step limit, the
        spectral radii of the curl and of the current adding (:mod:`warpfree.kernels.spem_dispersive`)."""
        if self.drude is None:
            return 0.0
        at, weight, _ = self.drude
        return float(np.max(weight / (EPS0 * self.eps_r[at])))

    def _spectral_radius(self) -> float:
        """Largest eigenvalue of Σ_a B_a B_aᵀ (1/s², ``stable_dt``), by Lanczos (SciPy), 1e-6 relative, from a
        fixed start vector (ARPACK's default is random: runs would differ in the last digits of Δt)."""
        from scipy.sparse.linalg import eigsh

        free = np.flatnonzero(~self.held)
        ve, vh = self.quadrature
        left = sp.diags(np.sqrt(ve[free] / (EPS0 * self.eps_r[free])))
        right = sp.diags(1.0 / np.sqrt(MU0 * self.mu_r * vh))
        b = sp.hstack([left @ m[free] @ right for m in self._pair.e_operator]).tocsr()
        gram = (b @ b.T).tocsr()
        if gram.shape[0] < 3:
            return float(np.linalg.eigvalsh(gram.toarray()).max())
        start = np.random.default_rng(0).standard_normal(gram.shape[0])
        return float(eigsh(gram, k=1, which="LA", tol=1e-6, v0=start, return_eigenvectors=False)[0]) * (1.0 + 1e-5)

    def describe(self) -> dict:
        """The model for ``summary.json``: particle counts, spacing, scheme, support, pairs and neighbour counts,
        materials and PML."""
        lay = self.layout
        d = {"n_electric": lay.n_e, "n_magnetic": lay.n_h, "spacing": lay.spacing, "scheme": self.scheme,
             "support_spacings": self.support, "pairs_e_h": self.e_rows.n_pairs, "pairs_h_e": self.h_rows.n_pairs,
             "neighbours_e_min": int(self.e_rows.counts().min()), "neighbours_h_min": int(self.h_rows.counts().min()),
             # eq. 3.16 with the thesis's h = d_W/α, α = 2 (its Fig. 2.3): Δt <= h_min/(√2 c)
             "eq_3_16_dt": float(0.5 * self.support * min(lay.e_spacing.min(), lay.h_spacing.min())
                                 / (math.sqrt(2.0) * C0))}
        if self.objects or self.conductors:
            d["objects"] = [o.describe() for o in self.conductors + self.objects]
        if self.materials is not None:
            d["particles_on_interfaces"] = {"electric": self.materials.e_on_interface,
                                            "magnetic": self.materials.h_on_interface}
        if self.pml is not None:
            d["pml"] = {"thickness": self.pml.thickness, "sides": list(self.pml.sides), "order": self.pml.order,
                        "reflection": self.pml.reflection, "sigma_max": self.pml.sigma_max()}
        return d
