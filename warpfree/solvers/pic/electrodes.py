"""The PIC field solve on a region of any shape (``warpfree.galerkin.region``): EFG Galerkin Poisson between
electrodes held at a potential or floating, and insulating walls, factorised once.

-∇²u = ρ (ε0 = 1, E = -∇u) in the region, with on its boundary pieces

- an electrode held at V: u = V, by Lagrange multipliers λ_K at its boundary nodes with hats N_K linear in the exact
  curve's parameter (``Region.essential_quadrature``);
- a floating electrode: u = V_f uniform and unknown, its total charge given, Q_f = ∫ σ dΓ;
- any other piece an insulating wall: no surface charge, ∂u/∂n = 0 (the natural condition: nothing to add).

With K_IJ = ∫ ∇φ_I·∇φ_J dΩ (plain Gauss quadrature of the region's cells on the exact curves: a symmetric K, as the
box's field solve keeps for the energy-conserving gather), m_I = ∫ φ_I dΩ, b = Q + ρ_bg m (Q_I = Σ_p q_p φ_I(x_p)),
G_IK = -∫_Γ φ_I N_K dΓ and c_K = ∫_Γ N_K dΓ per electrode:

    [ K   G   0 ] [ u ]   [ b          ]
    [ Gᵀ  0   C ] [ λ ] = [ -V c (held) ]
    [ 0   Cᵀ  0 ] [ V_f ] [ Q_f        ]

(C: the floating electrodes' columns c_e). Integrating the weak form by parts, -G λ = ∮ φ_I ∂u/∂n dΓ, so λ is ∂u/∂n
along the plasma's outward normal: the conductor's surface charge density σ = E·n_conductor = ∂u/∂n. An electrode's
charge is cᵀλ (a floating one's is Q_f); by the partition of unity Σ_I b_I = -Σ_e Q_e, the plasma's charge and the
electrodes' sum to zero exactly. At least one electrode must be held (else u is fixed only up to a constant).
float64. Units: the PIC's normalised units (``warpfree.solvers.pic.species``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError, require_finite
from warpfree.galerkin.assembly import conduction_matrix
from warpfree.galerkin.consistent_integration import consistent_test_gradients
from warpfree.galerkin.layout_quality import layout_report
from warpfree.galerkin.mls import MLSModel
from warpfree.galerkin.region import Region, RegionNodes
from warpfree.parameters import Choice
from warpfree.progress import announced
from warpfree.space import Space
from warpfree.sparse import FactorisedSystem, PrescribedValues

__all__ = ["Electrode", "ElectrodeField", "FieldIntegration", "ENCLOSING_MARGIN", "piece_tags"]

#: how far the particles' box stands outside the region, as a fraction of its larger side
ENCLOSING_MARGIN = 0.1


class FieldIntegration(Choice):
    """How the field solve on a region integrates its stiffness."""

    CONSISTENT = "consistent", ("variationally consistent (test gradients corrected on the region's exact boundary): "
                                "the surface field at the basis's order; K slightly non-symmetric")
    GAUSS = "gauss", ("plain Gauss quadrature of the cells: K symmetric (the energy gather's energy kept), the surface "
                      "field's error stalls near 1 % (a coaxial line, quadratic basis)")


def piece_tags(value, owner: str) -> tuple[str, ...]:
    """``value`` (one tag, or several) as a tuple of tags; ParameterError naming ``tags`` if it holds none or a
    non-string (``owner``: what needs them, for the message)."""
    tags = (value,) if isinstance(value, str) else tuple(value)
    if not tags or not all(isinstance(t, str) and t for t in tags):
        raise ParameterError("tags", f"{owner} needs the tags of its pieces, got {value!r}")
    return tags


@dataclass(frozen=True)
class Electrode:
    """A conductor on the region's pieces tagged ``tags``: held at ``potential`` (normalised units), or floating with
    ``potential=None``, its initial charge ``charge`` (e n_ref λ_D² per unit depth) and the charge of the particles it
    absorbs. ``name``: how outputs call it (default: its tags joined by "+")."""

    tags: tuple
    potential: float | None = 0.0
    charge: float = 0.0
    name: str = ""

    def __post_init__(self):
        tags = piece_tags(self.tags, "an electrode")
        object.__setattr__(self, "tags", tags)
        if self.potential is not None:
            object.__setattr__(self, "potential", require_finite("potential", self.potential))
        object.__setattr__(self, "charge", require_finite("charge", self.charge))
        object.__setattr__(self, "name", self.name or "+".join(tags))

    @property
    def floating(self) -> bool:
        """True when the potential follows from the charge."""
        return self.potential is None


class ElectrodeField:
    """K, m and the electrodes' constraints for ``model`` on ``region`` (``nodes``: the layout ``region.nodes`` made,
    whose positions are the model's), factorised once (module docstring).

    electrodes: the :class:`Electrode` list (pieces of no electrode are insulating walls); integration: a
    :class:`FieldIntegration`; degree: the cells' triangle rule (``Region.cells``); order: Gauss points per boundary
    edge of the boundary integrals.
    """

    #: the field's boundary is the region's: no net charge density to find (a box's periodic solve has one)
    walled = True
    net_charge_density = 0.0

    @announced("field solve made: MLS shape functions on the region, Poisson matrix with electrodes factorised")
    def __init__(self, model: MLSModel, region: Region, nodes: RegionNodes, electrodes: Sequence[Electrode],
                 integration: FieldIntegration = FieldIntegration.CONSISTENT, degree: int = 5, order: int = 3):
        self.integration = FieldIntegration.of("integration", integration)
        if model.space.is_periodic:
            raise ParameterError("space", "the field on a region has walls all round: give the model a free space")
        if model.node_count != nodes.count or not np.array_equal(model.nodes_np, nodes.position):
            raise ParameterError("nodes", "the model's nodes must be the region's layout (region.nodes(...))")
        self.electrodes = list(electrodes)
        if not self.electrodes:
            raise ParameterError("electrodes", "needs at least one electrode held at a potential")
        if all(e.floating for e in self.electrodes):
            raise ParameterError("electrodes", "every electrode floats: hold one at a potential (the potential is "
                                               "otherwise fixed only up to a constant)")
        taken: dict[str, str] = {}
        for e in self.electrodes:
            for t in e.tags:
                if t not in region.tags:
                    raise ParameterError("tags", f"electrode {e.name!r}: no piece is tagged {t!r}; the region's tags: "
                                                 f"{region.tags}")
                if t in taken:
                    raise ParameterError("tags", f"the pieces tagged {t!r} belong to electrodes {taken[t]!r} and "
                                                 f"{e.name!r}")
                taken[t] = e.name
        self.model, self.region, self.nodes = model, region, nodes
        lo, hi = region.bounds()
        margin = ENCLOSING_MARGIN * float(np.max(hi - lo))
        #: the particles' box: the region's bounds and a margin, walled (no particle should reach its walls: the
        #: region's boundary takes them first, ``warpfree.solvers.pic.boundary``)
        self.space = Space(2, (lo[0] - margin, lo[1] - margin, 0.0), (hi[0] + margin, hi[1] + margin, 1.0),
                           periodic=(False, False, False))
        self.gauss = region.cells(nodes, degree)
        shape = model.shape_at(self.gauss.position, name="Gauss point")
        layout_report(model, shape).check(model)
        self.gauss_shape = shape.matrix()
        self.area = float(np.sum(self.gauss.weight))
        test = None
        if self.integration is FieldIntegration.CONSISTENT:
            edge = region.boundary_points(nodes, None, order)
            edge_shape = model.shape_at(edge.position, name="boundary point")
            test, _ = consistent_test_gradients(model, shape, self.gauss.weight,
                                                [(edge_shape, edge.weight, edge.normal, 0)], model.consistency_order)
        stiffness = conduction_matrix(model, shape, self.gauss.weight, test)
        #: K (symmetric with plain Gauss quadrature: its rounding dropped)
        self.stiffness = (stiffness if test is not None else 0.5 * (stiffness + stiffness.T)).tocsr()
        self.node_integral = np.asarray(self.gauss_shape.T @ self.gauss.weight).ravel()   # m_I = ∫ φ_I
        blocks, self.lengths, self.slices = [], [], []
        #: each electrode's boundary Gauss points (on the exact curve) and their multipliers' hats (points ×
        #: multipliers): σ at the points is hats @ surface_charge
        self.surface_points, self.surface_hats = [], []
        start = 0
        for e in self.electrodes:
            coupling, length = self._electrode_terms(e, order)
            blocks.append(coupling)
            self.lengths.append(length)
            self.slices.append(slice(start, start + length.size))
            start += length.size
        m = start
        self.floating = [k for k, e in enumerate(self.electrodes) if e.floating]
        G = sp.hstack(blocks).tocsr()
        C = sp.lil_matrix((m, len(self.floating)))
        for j, k in enumerate(self.floating):
            C[self.slices[k], j] = self.lengths[k][:, None]
        # scaled so that both blocks' pivots are of K's size (as the static EFG solve scales its multipliers): λ = β λ'
        self.scale = float(np.abs(self.stiffness.diagonal()).max()) / max(float(np.abs(G).max()), 1e-300)
        system = sp.bmat([[self.stiffness, self.scale * G, None], [self.scale * G.T, None, self.scale * C],
                          [None, self.scale * C.T.tocsr(), None]], format="csr")
        self.system = FactorisedSystem(system, PrescribedValues(np.zeros(0, np.int64), np.zeros(0), system.shape[0]),
                                       symmetric_pattern=True)
        self._held_rhs = np.concatenate([-(0.0 if e.floating else e.potential) * length
                                         for e, length in zip(self.electrodes, self.lengths)])
        #: the charge each floating electrode holds beyond its initial one (the particles it absorbed; the solver's)
        self.absorbed_charge = np.zeros(len(self.electrodes))
        #: the last solve's potential and charge of every electrode (floating: its V_f, its charge)
        self.potentials = np.array([np.nan if e.floating else e.potential for e in self.electrodes])
        self.charges = np.zeros(len(self.electrodes))
        #: the last solve's surface charge density at each electrode's multipliers (its boundary nodes, in order)
        self.surface_charge = [np.zeros(length.size) for length in self.lengths]
        self.n_multipliers = m

    def _electrode_terms(self, electrode: Electrode, order: int) -> tuple[sp.csr_matrix, np.ndarray]:
        """G_e (N × multipliers) = -∫ φ_I N_K dΓ and c_e = ∫ N_K dΓ over the electrode's pieces (one set of
        multipliers a piece: a corner node gets one per side)."""
        blocks, lengths, points_of, hats_of = [], [], [], []
        for _, q in self.region.essential_quadrature(self.nodes, list(electrode.tags), order):
            points = q.points
            n_points = len(points.weight)
            hats = sp.csr_matrix((q.hat.ravel(), (np.repeat(np.arange(n_points), 2), q.multiplier.ravel())),
                                 shape=(n_points, q.n_multipliers))
            phi = self.model.shape_at(points.position, name=f"{electrode.name} point").matrix()
            blocks.append(-(phi.T @ sp.diags(points.weight) @ hats))
            lengths.append(np.asarray(hats.T @ points.weight).ravel())
            points_of.append(points.position)
            hats_of.append(hats)
        self.surface_points.append(np.vstack(points_of))
        self.surface_hats.append(sp.block_diag(hats_of, format="csr"))
        return sp.hstack(blocks).tocsr(), np.concatenate(lengths)

    def solve(self, charge: np.ndarray, background_density: float = 0.0) -> np.ndarray:
        """The nodal potential u (N,) for the deposited charges Q (N,), a uniform background charge density and the
        floating electrodes' charges (initial + :attr:`absorbed_charge`); keeps every electrode's potential, charge
        and surface charge density."""
        n, m = self.model.node_count, self.n_multipliers
        floating_charge = np.array([self.electrodes[k].charge + self.absorbed_charge[k] for k in self.floating])
        rhs = np.concatenate([charge + background_density * self.node_integral, self.scale * self._held_rhs,
                              floating_charge])
        x = self.system.solve(rhs)
        multipliers = self.scale * x[n:n + m]
        for k, sl in enumerate(self.slices):
            self.surface_charge[k] = multipliers[sl]
            self.charges[k] = float(self.lengths[k] @ multipliers[sl])
        for j, k in enumerate(self.floating):
            self.potentials[k] = float(x[n + m + j])
        return x[:n]

    def electrode_of(self, tags) -> int:
        """The index of the electrode that holds every piece tagged ``tags`` (ParameterError if none)."""
        for k, e in enumerate(self.electrodes):
            if set(tags) <= set(e.tags):
                return k
        raise ParameterError("tags", f"no electrode holds every piece tagged {list(tags)}; the electrodes: "
                                     f"{[list(e.tags) for e in self.electrodes]}")

    def surface_charge_near(self, electrode: int, points: np.ndarray) -> sp.csr_matrix:
        """H (points × the electrode's multipliers): σ at ``points`` on the electrode is H @ surface_charge, the hats
        of the electrode's boundary Gauss point nearest each point."""
        from scipy.spatial import cKDTree

        nearest = cKDTree(self.surface_points[electrode]).query(np.asarray(points, dtype=np.float64))[1]
        return self.surface_hats[electrode][nearest]

    def field_energy(self, potential: np.ndarray) -> float:
        """W = ½ uᵀ K u = ½ ∫ |∇u^h|² dΩ (per unit depth)."""
        return 0.5 * float(potential @ (self.stiffness @ potential))

    def describe(self) -> dict:
        """The field solve for ``summary.json``: the electrodes, the region's area, the Gauss points, the matrix
        entries and the factorisation time."""
        return {"electrodes": [{"name": e.name, "tags": list(e.tags), "potential": e.potential,
                                "floating": e.floating} for e in self.electrodes],
                "area": self.area, "gauss_points": int(self.gauss.weight.size),
                "stiffness_nnz": int(self.stiffness.nnz), "factorise_s": self.system.timings["factorise"]}
