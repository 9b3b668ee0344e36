"""EFG static solvers: scalar Poisson/conduction and 2D linear elasticity, through the core's run shell.

Both take a shape-function model (:class:`~warpfree.galerkin.shapes.ShapeModel`: MLS for EFG, or NEM's), integration
points (:class:`~warpfree.galerkin.quadrature.QuadraturePoints`: background cells or triangles), boundary conditions
(:mod:`~warpfree.solvers.efg.boundary`) and materials, and ``solve()`` in timed phases: "shape functions" (at the
Gauss points), "assembly", "boundary", "factorisation", "solve". The system is factorised once
(:class:`~warpfree.sparse.FactorisedSystem`, SciPy's SuperLU) and kept: :meth:`EFGSolver.resolve` solves again for
new loads (the PIC field solve). The solution is nodal parameters ``nodal`` (not nodal values unless the shape
functions interpolate); :meth:`EFGSolver.field_at` evaluates u^h and ∇u^h anywhere.

How the ranks share the work: by rows. Space is cut between the ranks (``warpfree.parallel``, balancing the Gauss
points); a rank owns the rows of the nodes its box holds and holds the Gauss points its box owns and, as ghosts,
those within the shape functions' reach (``model.reach``) of its box: every point in the support of each of its
nodes, in global order. It evaluates the shape functions at the points it holds and assembles each of its rows from
every point in that node's support, in the one process's order (the node-row kernels of
``warpfree.galerkin.assembly``, the load's per-point slots, the per-node sums of consistent integration): each entry
of its rows is the one process's, bit for bit. The boundary and interface points (essential, natural, free,
interfaces: lines, few) every rank holds in full, so their terms (multipliers, penalty, Nitsche, the boundary
integrals of consistent integration) are the one process's on every rank. The solve then takes either the whole
system, every rank's rows put together (``linear_solver="superlu"``: each rank factorises the same matrix as one
process and finds the same solution, bitwise), or each rank's rows as its part of one PETSc matrix
(:class:`~warpfree.parallel.PETScSystem`, ``linear_solver="petsc"``, the default over several ranks: no entry added
across ranks, so the matrix is the one process's, but the Krylov solve's parallel sums make its solution agree to
its tolerance, not bitwise). One process is a one-rank partition: every row, every point, nothing to put together.

Problems:

- :class:`PoissonSolver`: -∇·(k ∇u) = s (Marques 2008, eq. 3.3 with the sign made consistent; K_IJ = ∫ k ∇φ_I·∇φ_J,
  f_I = ∫ φ_I s + ∫_Γ φ_I q̄, q̄ = k ∂u/∂n the inflow flux... given as the natural value), k per material; Gauss
  points and nodes carry material indices so that nodes serve only their own material (Marques 2008, §3.3).
- :class:`ElasticitySolver`: ∇·σ + b = 0, σ = D ε (Rocha 2012, eqs 3.34-3.38), plane stress or plane strain.

float64 throughout (``kernels/mls.py``, ``kernels/galerkin.py``, ``kernels/efg.py``). Units: the caller's, consistently (SI or any consistent set).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from warpfree.errors import ParameterError, require_finite, require_integer, require_positive
from warpfree.parallel import CutMethod, Decomposition, Partition, world as ranks_of_run
from warpfree.parallel.petsc_system import PETScSystem, Preconditioner, require_petsc
from warpfree.parameters import Choice
from warpfree.solver import OutputSet, StaticSolver
from warpfree.sparse import FactorisedSystem, PrescribedValues

from warpfree.galerkin import assembly
from warpfree.galerkin.consistent_integration import ORDERS, consistent_test_gradients
from warpfree.galerkin.layout_quality import LayoutReport, layout_report
from warpfree.galerkin.nodal_integration import SmoothingCells, smoothed_shape
from warpfree.galerkin.quadrature import BoundaryPoints, QuadraturePoints
from warpfree.galerkin.shapes import ShapeData, ShapeModel

from . import boundary_terms
from .boundary import (Essential, EssentialMethod, Free, Interface, InterfaceCondition, Natural, essential_points,
                       nodes_on_polyline)
from .plots import von_mises

__all__ = ["EFGSolver", "PoissonSolver", "ElasticitySolver", "elasticity_matrix", "Integration", "LinearSolver",
           "Plane"]


#: the longest piece of an essential boundary (between consecutive vertices), in node spacings (the distance to the
#: 4th nearest node: √2 h at a regular grid's side): harmonic u on the unit square held on its sides by multipliers
#: (16 x 16 nodes, linear basis, d_max 2, consistent integration), L2 error 1.1e-3, 5.1e-4, 8.5e-4, 5.8e-3 with pieces
#: of 1, 2, 3, 4 grid spacings h (0.7 to 2.8 of these), 2.4e-2 at 6 and 8 (4.2, 5.7: refused), 0.19 (0.38 with Gauss
#: integration) with one piece a side
ESSENTIAL_PIECE_SPACINGS = 3.0
#: the most multipliers an essential boundary may hold for each node along it (within half a spacing): on the same
#: square, 1.06 and 1.12 of them a node gave 0.7-2.6x the error of one (1.1e-3 at 16 x 16 nodes, 1.1e-4 at 32 x 32),
#: 1.24 gave 26-38x (4.1e-2, 2.9e-3), 1.5 gave 0.27 and 2 a singular system
MULTIPLIER_EXCESS = 1.15


class Integration(Choice):
    """How the weak form is integrated over the domain."""

    CONSISTENT = "consistent", ("variationally consistent: test gradients corrected so that the discrete divergence "
                                "theorem holds for fields of the consistency order, by default one above the basis's "
                                "degree")
    GAUSS = "gauss", "plain Gauss quadrature of the integration cells"
    SCNI = "scni", "stabilized conforming nodal integration on the nodes' smoothing cells"


class LinearSolver(Choice):
    """How the assembled system is solved."""

    AUTO = "auto", "SuperLU in one process, PETSc over several ranks"
    SUPERLU = "superlu", "every process factorises the whole system with SciPy's SuperLU"
    PETSC = "petsc", "the ranks' rows as one PETSc matrix, a Krylov solve"


class Plane(Choice):
    """The plane condition of 2D elasticity."""

    STRESS = "stress", "plane stress: σ_zz = 0"
    STRAIN = "strain", "plane strain: ε_zz = 0"


#: relative tolerance of the check that the boundary pieces enclose the cells (∮ x·n dΓ = 2 · area)
CLOSURE_RTOL = 1e-6

#: the units of a Poisson solve's outputs, SI as for conduction (-∇·(σ∇V) = 0, σ in S/m): the potential (and the nodal
#: parameters) in V, the field -∇V in V/m, the current density -σ∇V in A/m²; a scene in other units says so in its
#: ``OutputOptions.units``
POISSON_UNITS = {"position": "m", "potential": "V", "field_x": "V/m", "field_y": "V/m", "flux_x": "A/m²",
                 "flux_y": "A/m²", "parameter": "V"}
#: the units of an elasticity solve's outputs (SI: lengths in m, E in Pa): the displacement (and the nodal parameters)
#: in m, the stresses in Pa
ELASTICITY_UNITS = {"position": "m", "displacement": "m", "stress_xx": "Pa", "stress_yy": "Pa", "stress_xy": "Pa",
                    "von_mises": "Pa", "parameter": "m"}
#: winding number below which a node counts as outside the domain (a boundary node at an interior angle θ has
#: θ/2π: 0.25 at a right corner, 0.12 at Cook's sharpest corner)
OUTSIDE_WINDING = 0.02


def elasticity_matrix(young: float, poisson: float, plane: Plane) -> np.ndarray:
    """D (3, 3), Voigt with engineering shear: plane stress (Rocha 2012, eq. 3.37) E/(1-ν²) [[1, ν, 0], [ν, 1, 0],
    [0, 0, (1-ν)/2]]; plane strain (3.38) E/((1+ν)(1-2ν)) [[1-ν, ν, 0], [ν, 1-ν, 0], [0, 0, (1-2ν)/2]]."""
    e = require_positive("young", young)
    nu = require_finite("poisson", poisson)
    if not -1.0 < nu < 0.5:
        raise ParameterError("poisson", f"must lie in (-1, 0.5), got {nu}")
    if Plane.of("plane", plane) is Plane.STRESS:
        return e / (1.0 - nu * nu) * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    return e / ((1.0 + nu) * (1.0 - 2.0 * nu)) * np.array([[1.0 - nu, nu, 0.0], [nu, 1.0 - nu, 0.0],
                                                           [0.0, 0.0, 0.5 - nu]])


class EFGSolver(StaticSolver):
    """What both problems share: shape functions at the Gauss points, boundary conditions, factorise, solve.

    model: the :class:`~warpfree.galerkin.shapes.ShapeModel`; cells: Gauss points of the domain (``cell`` indices select materials);
    essential / natural: boundary conditions; free: the rest of the boundary (:class:`Free` pieces or
    BoundaryPoints: traction-free or insulated, no load, but part of the boundary integral of consistent
    integration); interfaces: material interfaces (:class:`Interface`, with consistent integration and several
    materials, which then needs every piece's ``material``); method: "lagrange",
    "penalty" or "direct" (module ``boundary``); penalty: α as a multiple of the largest diagonal entry of K per
    unit boundary weight; integration: "consistent" (test gradients corrected so that the discrete divergence
    theorem holds, ``consistent_test_gradients``: the Galerkin equations of every polynomial field of degree
    ``consistency`` exact, by default the model's ``consistency_order``, for MLS one above its basis's degree; needs
    essential + natural + free to cover the whole boundary), "gauss" (plain Gauss quadrature, the thesis's) or
    "scni" (stabilized conforming nodal integration, ``warpfree.galerkin.nodal_integration``: ``cells`` are then
    :class:`~warpfree.galerkin.nodal_integration.SmoothingCells`, one per node, and the strains at the nodes are
    cell averages; linear fields exact; one material, no interfaces); interface_condition: "nitsche"
    (the interface term of the weak form that domain truncation drops, its symmetric partner and a penalty
    ``nitsche_penalty`` · k_max / h: a conforming interface, ``boundary_terms.interface_matrix``) or "none" (truncation
    alone, Marques's (2008)); linear_solver, preconditioner: :meth:`set_linear_solver` (SuperLU in one process, PETSc
    over several ranks); consistency: the order of consistent integration (None: the model's).
    """

    distributes = True

    name: ClassVar[str] = "efg"
    work_unit: ClassVar[str] = "Gauss points"
    components: ClassVar[int] = 1

    def __init__(self, model: ShapeModel, cells: QuadraturePoints, essential: list[Essential] | None = None,
                 natural: list[Natural] | None = None, method: EssentialMethod = EssentialMethod.LAGRANGE,
                 penalty: float = 1e7, cell_material=None, free: list | None = None,
                 interfaces: list[Interface] | None = None, integration: Integration = Integration.CONSISTENT,
                 interface_condition: InterfaceCondition = InterfaceCondition.NITSCHE, nitsche_penalty: float = 20.0,
                 linear_solver: LinearSolver = LinearSolver.AUTO, preconditioner: Preconditioner = Preconditioner.AUTO,
                 consistency: int | None = None):
        super().__init__(model, model.launcher)
        method = EssentialMethod.of("method", method)
        if method is EssentialMethod.DIRECT and not model.settings.interpolating:
            raise ParameterError("method", "'direct' substitution needs interpolating shape functions "
                                           "(weight='singular'); use 'lagrange' or 'penalty'")
        integration = Integration.of("integration", integration)
        if (integration is Integration.SCNI) != isinstance(cells, SmoothingCells):
            raise ParameterError("cells", "integration='scni' integrates on smoothing cells (SmoothingCells, e.g. "
                                          "NEMModel.smoothing_cells()) and they need integration='scni', got "
                                          f"integration={integration!r} with {type(cells).__name__}")
        if integration is Integration.SCNI and (interfaces or cell_material is not None):
            raise ParameterError("integration", "'scni' is implemented for one material without interfaces")
        self.integration = integration
        self.free = [f if isinstance(f, Free) else Free(f) for f in (free or [])]
        self.interfaces = list(interfaces or [])
        interface_condition = InterfaceCondition.of("interface_condition", interface_condition)
        if interface_condition is InterfaceCondition.NITSCHE and self.interfaces and self.components != 1:
            raise ParameterError("interface_condition", "Nitsche interface terms are implemented for the scalar "
                                                        "problem only; use 'none' for elasticity")
        self.interface_condition = interface_condition
        self.nitsche_penalty = require_positive("nitsche_penalty", nitsche_penalty)
        self.method = method
        self.penalty = require_positive("penalty", penalty)
        self.cells = cells
        self.essential = list(essential or [])
        self.natural = list(natural or [])
        if not self.essential:
            raise ParameterError("essential", "needs at least one boundary with prescribed values (else the "
                                              "solution is defined only up to a rigid motion or a constant)")
        if method is not EssentialMethod.DIRECT:
            self._check_essential_pieces()
        self.point_material = None if cell_material is None else np.asarray(cell_material)[np.asarray(cells.cell)]
        self.nodal = np.zeros(self.components * model.node_count)
        self.shape: ShapeData | None = None
        self.system: FactorisedSystem | None = None
        #: K and f as the solve took them: f whole; K whole, or with PETSc this rank's rows (the others empty)
        self.matrix: sp.csr_matrix | None = None
        self.load: np.ndarray | None = None
        self.multipliers = np.zeros(0)
        #: the constant part of consistent integration's correction, (N, regions, 2), every node's on every rank
        self.correction: np.ndarray | None = None
        #: the degree of the fields whose Galerkin equations consistent integration makes exact
        self.consistency_order = model.consistency_order if consistency is None else require_integer(
            "consistency", consistency, minimum=ORDERS[0], maximum=ORDERS[-1])
        self.world = ranks_of_run()
        self.set_linear_solver(linear_solver, preconditioner)
        if self.world.distributed and integration is Integration.SCNI:
            raise ParameterError("integration", "a distributed run cannot integrate on smoothing cells ('scni') yet: "
                                                "use 'consistent' or 'gauss', or run in one process")
        #: the work over the ranks (module docstring; one process: a one-rank partition, every row and point): the
        #: Gauss points this rank holds (its own and, as ghosts, those in its nodes' supports) and the nodes whose rows
        #: it assembles
        self.point_part, self.node_part = self._partition()
        held = self.point_part.ids
        self._points = cells if self.point_part.whole else cells.subset(held)  # smoothing cells: one part
        self._material = None if self.point_material is None else self.point_material[held]
        self._multiplier_scale = 1.0
        self._interface_cache: dict = {}
        #: the layout's quality at the Gauss points (``warpfree.galerkin.layout_quality``), made by :meth:`solve`
        self.layout: LayoutReport | None = None

    def set_linear_solver(self, linear_solver: LinearSolver = LinearSolver.AUTO,
                          preconditioner: Preconditioner = Preconditioner.AUTO) -> None:
        """How :meth:`solve` solves the system (:class:`LinearSolver`; ``preconditioner``: PETSc's,
        :class:`~warpfree.parallel.petsc_system.Preconditioner`). PETSc missing: ParameterError naming the extra."""
        linear_solver = LinearSolver.of("linear_solver", linear_solver)
        preconditioner = Preconditioner.of("preconditioner", preconditioner)
        #: the ranks' rows of the system solved as one PETSc matrix (each rank keeps its rows of K)
        self.petsc = linear_solver is LinearSolver.PETSC or (linear_solver is LinearSolver.AUTO
                                                             and self.world.distributed)
        if self.petsc:
            require_petsc("linear_solver")
        self.preconditioner = preconditioner

    # -- what a problem defines --------------------------------------------------------------------------------
    def stiffness(self, shape: ShapeData, test_dphi) -> sp.csr_matrix:
        """K over the Gauss points this process holds, with test gradients ``test_dphi`` (None: ∇φ): the rows of the
        nodes whose supports it holds whole (a rank's own nodes') are K's."""
        raise NotImplementedError

    def body_load(self, shape: ShapeData) -> np.ndarray:
        """The body-force part of the load vector from the shape functions at the Gauss points ``shape`` (zeros: no body
        force; the subclasses add theirs)."""
        return np.zeros(self.components * self.model.node_count)

    def interface_stiffness(self) -> sp.csr_matrix:
        """The Nitsche terms of every interface (scalar problems, :class:`PoissonSolver`)."""
        raise NotImplementedError

    # -- the solve ---------------------------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """2: the EFG solvers work in the plane."""
        return 2

    @property
    def work_items(self) -> int:
        """Gauss points (the unit of the throughput)."""
        return int(self.cells.position.shape[0])

    def solve(self) -> None:
        """Shape functions, assembly, boundary conditions, factorisation and solve. In a distributed run each rank
        assembles its nodes' rows from the Gauss points it holds (module docstring): the rows of K, f and the
        consistent correction are the one process's, bit for bit; the solve takes them put together (SuperLU: the one
        process's system and solution on every rank) or as its part of a PETSc matrix."""
        model, c = self.model, self.components
        with self.phases("shape functions"):
            if self.integration is Integration.SCNI:
                self.shape = smoothed_shape(model, self.cells)
            else:
                self.shape = model.shape_at(self._points.position, self._material, name="Gauss point")
                self._check_supports_held(self.shape)
                self.layout = layout_report(model, self.shape, self.point_part.owned, self.point_part.ids, self.world)
                self.layout.check(model)
            direct = self.method is EssentialMethod.DIRECT
            essential = [] if direct else [self._essential_set(b) for b in self.essential]
            natural = [(nat, self._shape(nat.points.position, nat.material, f"{nat.name} point"))
                       for nat in self.natural]
            test = None
            if self.integration is Integration.CONSISTENT:
                pieces = self._boundary_pieces(essential, natural)
                self._check_closed(pieces)
                self._check_nodes_inside([p for _, p, _ in pieces])
                regions = 1 if self.point_material is None else int(self.point_material.max()) + 1
                test, correction = consistent_test_gradients(
                    model, self.shape, self._points.weight, [(sh, p.weight, p.normal, r) for sh, p, r in pieces],
                    self.consistency_order, self._material, regions=regions)
                self.correction = self.node_part.gather(correction[self.node_part.ids])
        with self.phases("assembly"):
            K = self._assembled(self.stiffness(self.shape, test))
            if self.interfaces and self.interface_condition is InterfaceCondition.NITSCHE:
                K = K + self._part_of(self.interface_stiffness())
            f = self._assembled_load(self.body_load(self.shape))
            for nat, sh in natural:
                f = f + self._natural_load(nat, sh)
        with self.phases("boundary"):
            system_matrix, rhs, prescribed = self._impose(K, f, essential)
        self._condition_rhs = rhs.copy()
        self._condition_rhs[: c * model.node_count] -= f      # what the boundary conditions add
        with self.phases("factorisation"):
            if self.petsc:
                self.system = PETScSystem(self.world, system_matrix, prescribed, self.preconditioner)
            else:
                self.system = FactorisedSystem(system_matrix, prescribed, symmetric_pattern=True)
        with self.phases("solve"):
            x = self.system.solve(rhs)
        n = c * model.node_count
        self.nodal, self.multipliers = x[:n], x[n:] * self._multiplier_scale
        self.matrix, self.load = K, f

    # -- over the ranks ----------------------------------------------------------------------------------------
    def _partition(self) -> tuple[Partition, Partition]:
        """(the Gauss points, the nodes) over the ranks (module docstring): space cut over the shape functions'
        reach, balancing the Gauss points (``warpfree.parallel``); a rank holds the points its box owns and, as
        ghosts, those within the reach of its box, and owns (holds) the nodes its box holds, whose rows it
        assembles."""
        p = _points3(self.cells.position)
        reach = float(self.model.reach)
        dec = Decomposition.build(self.world.size, p, None, reach, 2, CutMethod.RCB)
        points = Partition.of_all(self.world, dec, reach, p)
        nodes = _points3(self.model.nodes_np)
        own = np.flatnonzero(dec.owner(nodes) == self.world.rank)
        return points, Partition.of_items(self.world, dec, 0.0, own, nodes[own], self.model.node_count)

    def _check_supports_held(self, shape: ShapeData) -> None:
        """Every point in the support of each of this rank's nodes is held (a node's row needs them all): the count
        of its support's points here equals the count over every rank's own points (RuntimeError otherwise)."""
        index = shape.rows.index.numpy()[: shape.n_entries]
        own = np.repeat(self.point_part.owned, shape.counts)
        n = self.model.node_count
        everywhere = self.world.allreduce(np.bincount(index[own], minlength=n), "sum")
        here = np.bincount(index, minlength=n)
        mine = self.node_part.ids
        if not np.array_equal(here[mine], everywhere[mine]):
            node = int(mine[np.flatnonzero(here[mine] != everywhere[mine])[0]])
            raise RuntimeError(f"node {node}'s support reaches a Gauss point this rank does not hold: the ghost "
                               f"layer (the shape model's reach, {self.model.reach:.6g}) is too thin")

    def _unknowns(self, rows: np.ndarray) -> np.ndarray:
        """The unknowns (components·I + k) of the nodes ``rows``."""
        c = self.components
        return (c * np.asarray(rows, dtype=np.int64)[:, None] + np.arange(c)).reshape(-1)

    def _own_rows(self, M: sp.spmatrix) -> sp.csr_matrix:
        """The rows of ``M`` this rank owns, the others emptied: its nodes' unknowns and (rank 0) the rows past the
        nodes' unknowns (the multipliers'): every row in one process."""
        M = M.tocsr()
        keep = np.zeros(M.shape[0], dtype=bool)
        keep[self._unknowns(self.node_part.ids)] = True
        keep[self.components * self.model.node_count:] = self.world.is_root
        counts = np.diff(M.indptr)
        entries = np.repeat(keep, counts)
        return sp.csr_matrix((M.data[entries], M.indices[entries], np.r_[0, np.cumsum(counts * keep)]),
                             shape=M.shape)

    def _part_of(self, M: sp.spmatrix) -> sp.csr_matrix:
        """What the solve takes of a matrix every rank has in full (boundary and interface terms): with PETSc this
        rank's rows (:meth:`_own_rows`), else ``M``."""
        return self._own_rows(M) if self.petsc else M.tocsr()

    def _assembled(self, M: sp.spmatrix) -> sp.csr_matrix:
        """What the solve takes of a matrix whose rows of this rank's nodes this rank assembled: with PETSc those rows
        (the others emptied), else the whole matrix, every rank's rows put together (nothing added: each row comes
        from its one owner); ``M`` itself in one process."""
        own = self._own_rows(M)
        return own if self.petsc else self.world.allreduce_matrix(own)

    def _assembled_load(self, f: np.ndarray) -> np.ndarray:
        """The whole load vector, every rank's rows of its nodes put together (a copy of ``f`` in one process)."""
        c = self.components
        mine = self.node_part.ids
        return self.node_part.gather(np.asarray(f).reshape(-1, c)[mine]).reshape(-1)

    def _pieces(self, sets: list[OutputSet]) -> list[OutputSet]:
        """This process's parts of the output sets: its own Gauss points, and (rank 0) the nodes, which every rank
        holds (``OutputSet.ids``: their indices); the whole sets in one process."""
        own_points = self.point_part.ids[self.point_part.owned_index]
        out = []
        for s in sets:
            rows = own_points if s.name == "gauss_points" else (np.arange(len(s.points)) if self.world.is_root
                                                                else np.zeros(0, np.int64))
            out.append(dataclasses.replace(s, points=s.points[rows], fields={k: v[rows] for k, v in s.fields.items()},
                                           ids=rows))
        return out

    def _shape(self, points: np.ndarray, material: int, name: str) -> ShapeData:
        """Shape functions at boundary points that belong to ``material`` (-1: every node serves them)."""
        m = None if material < 0 else np.full(points.shape[0], int(material))
        return self.model.shape_at(points, m, name=name)

    def _interface_shapes(self, face: Interface) -> tuple[ShapeData, ShapeData]:
        """Shape functions at an interface's points seen from each side (computed once: consistent integration and
        the Nitsche terms both use them)."""
        key = id(face)
        if key not in self._interface_cache:
            p = face.points.position
            self._interface_cache[key] = (self._shape(p, face.inside, "interface point"),
                                          self._shape(p, face.outside, "interface point"))
        return self._interface_cache[key]

    def _essential_set(self, b: Essential):
        ep = essential_points(b, self.components)
        return ep, self._shape(ep.points.position, b.material, f"{b.name} point")

    def _boundary_pieces(self, essential, natural) -> list:
        """(shape, points, region) for every piece closing a material region: essential, natural, free, and both
        sides of every interface."""
        several = self.point_material is not None and int(self.point_material.max()) > 0
        named = [(b.material, b.name) for b in self.essential] + [(n.material, n.name) for n in self.natural] \
            + [(f.material, f"free piece {i}") for i, f in enumerate(self.free)]
        for material, name in named:
            if several and material < 0:
                raise ParameterError("material", f"{name}: with several materials and consistent integration every "
                                                 f"boundary piece needs the material it bounds")
        pieces = [(sh, ep.points, b.material) for (ep, sh), b in zip(essential, self.essential)]
        pieces += [(sh, nat.points, nat.material) for nat, sh in natural]
        pieces += [(self._shape(f.points.position, f.material, "free boundary point"), f.points, f.material)
                   for f in self.free]
        if self.method is EssentialMethod.DIRECT:
            for b in self.essential:
                ep = essential_points(b, self.components)
                pieces.append((self._shape(ep.points.position, b.material, f"{b.name} point"), ep.points, b.material))
        for face in self.interfaces:
            p = face.points
            flipped = BoundaryPoints(p.position, p.weight, -p.normal, p.segment)
            inside, outside = self._interface_shapes(face)
            pieces.append((inside, p, face.inside))
            pieces.append((outside, flipped, face.outside))
        return pieces

    def _check_essential_pieces(self) -> None:
        """Each essential boundary's pieces (between consecutive vertices: its multipliers, or the penalty's Gauss
        pieces) span at most :data:`ESSENTIAL_PIECE_SPACINGS` node spacings (the distance from the node nearest
        either end to its 4th nearest node: the spacing on a regular grid, steadier than the nearest on random
        nodes); a longer piece holds the value in too few moments (refused, naming the piece)."""
        nodes = self.model.nodes_np
        tree = cKDTree(nodes)
        rank = min(4, len(nodes) - 1)  # the distance to the 4th nearest node: the spacing MLS supports scale with
        spacing = tree.query(nodes, k=rank + 1)[0][:, rank] if rank > 0 else np.ones(len(nodes))
        for b in self.essential:
            v = np.asarray(b.vertices, dtype=np.float64)
            if v.ndim != 2 or v.shape[0] < 2:
                continue  # refused with its shape where its points are made
            v = v[:, :2]
            nearest = tree.query(v)[1]
            length = np.linalg.norm(np.diff(v, axis=0), axis=1)
            local = np.maximum(spacing[nearest[:-1]], spacing[nearest[1:]])
            long = np.flatnonzero(length > ESSENTIAL_PIECE_SPACINGS * local)
            if long.size:
                k = int(long[0])
                raise ParameterError(f"{b.name}.vertices", f"its piece from ({v[k, 0]:.6g}, {v[k, 1]:.6g}) to "
                                                           f"({v[k + 1, 0]:.6g}, {v[k + 1, 1]:.6g}) spans "
                                                           f"{length[k] / local[k]:.1f} node spacings: the value is "
                                                           f"held there in too few moments (at most "
                                                           f"{ESSENTIAL_PIECE_SPACINGS:g} spacings a piece); put a "
                                                           "vertex at every boundary node (node_layouts.box_sides, "
                                                           "or a region's essential)")
            if self.method is EssentialMethod.LAGRANGE:
                self._check_multiplier_count(b, v, tree, float(np.median(local)))

    def _check_multiplier_count(self, b: Essential, v: np.ndarray, tree, spacing: float) -> None:
        """More multipliers than the nodes along the boundary (within half a spacing of it) by over
        :data:`MULTIPLIER_EXCESS` make the multipliers' system unstable (refused, naming the boundary)."""
        length = np.linalg.norm(np.diff(v, axis=0), axis=1)
        steps = np.maximum(1, np.ceil(length / (0.25 * spacing)).astype(np.int64))
        piece = np.repeat(np.arange(len(length)), steps)           # samples a quarter spacing apart on each piece
        fraction = (np.arange(piece.size) - np.repeat(np.cumsum(steps) - steps, steps)) / steps[piece]
        samples = np.vstack([v[piece] + fraction[:, None] * (v[piece + 1] - v[piece]), v[-1:]])
        distance = cKDTree(samples).query(tree.data, distance_upper_bound=0.5 * spacing)[0]
        near = np.flatnonzero(np.isfinite(distance))
        distinct = len(np.unique(np.round(v / (1e-9 * spacing)).astype(np.int64), axis=0))  # a closed loop's end
        if len(near) >= 2 and distinct > MULTIPLIER_EXCESS * len(near) + 1:
            raise ParameterError(f"{b.name}.vertices", f"its {distinct} vertices (the multipliers) outnumber the "
                                                       f"{len(near)} nodes along it by more than "
                                                       f"{MULTIPLIER_EXCESS - 1:.0%}: the multipliers' system is "
                                                       "unstable (put the vertices at the boundary nodes)")

    def _check_closed(self, pieces: list) -> None:
        """The pieces of each material region must enclose its cells (divergence theorem): ∮ n dΓ = 0 and
        ∮ x ⊗ n dΓ = area · I, the second about the cells' centroid (a missing side through the origin would leave
        ∮ x·n alone unchanged). A gap is named by the outward normals it lacks, -∮ n dΓ."""
        region = np.zeros(self.work_items, dtype=int) if self.point_material is None else self.point_material
        for r in range(int(region.max()) + 1):
            inside = region == r
            weight = self.cells.weight[inside]
            area = float(np.sum(weight))
            centre = (weight @ self.cells.position[inside]) / area
            side = [p for _, p, m in pieces if max(m, 0) == r]
            normal_sum = sum((p.weight @ p.normal for p in side), np.zeros(2))
            moment = sum((np.einsum("g,gi,gj->ij", p.weight, p.position - centre, p.normal) for p in side),
                         np.zeros((2, 2)))
            scale = math.sqrt(area)
            if (np.linalg.norm(normal_sum) > CLOSURE_RTOL * scale
                    or np.abs(moment - area * np.eye(2)).max() > CLOSURE_RTOL * area):
                gap = np.where(np.abs(normal_sum) > CLOSURE_RTOL * scale, -normal_sum, 0.0) + 0.0  # no -0
                lacking = (f"they lack a part whose outward normals sum to ({gap[0]:.6g}, {gap[1]:.6g}) m (a side "
                           f"{np.linalg.norm(gap):.6g} m long facing ({gap[0] / np.linalg.norm(gap):.3g}, "
                           f"{gap[1] / np.linalg.norm(gap):.3g}), if straight)" if np.linalg.norm(gap) >
                           CLOSURE_RTOL * scale else
                           f"∮ x ⊗ n dΓ = {np.round(moment, 6).tolist()}, area · I = {area:.6g} · I")
                raise ParameterError("free", f"the boundary pieces (essential, natural, free, interfaces) do not "
                                             f"enclose the integration cells of material {r}: {lacking}; add the "
                                             f"load-free sides to free= (and material interfaces to interfaces=), or "
                                             f"use integration='gauss'")

    def _check_nodes_inside(self, pieces: list[BoundaryPoints]) -> None:
        """Every node inside or on the boundary: its winding number (1/2π) ∮ (x_b - x)·n / |x_b - x|² dΓ is 1
        inside, 0 outside, the interior angle / 2π on the boundary (1/4 at a right corner); below
        ``OUTSIDE_WINDING`` a node is outside (a wrong layout or geometry)."""
        xb = np.vstack([p.position for p in pieces])
        wn = np.concatenate([p.weight[:, None] * p.normal for p in pieces])
        nodes = self.model.nodes_np
        winding = np.empty(nodes.shape[0])
        for lo in range(0, nodes.shape[0], 2048):
            d = xb[None, :, :] - nodes[lo:lo + 2048, None, :]
            r2 = np.einsum("nmk,nmk->nm", d, d)
            flux = np.einsum("nmk,mk->nm", d, wn)
            winding[lo:lo + 2048] = np.sum(np.divide(flux, r2, out=np.zeros_like(flux), where=r2 > 0), axis=1)
        winding /= 2.0 * np.pi
        outside = np.flatnonzero(winding < OUTSIDE_WINDING)
        if outside.size:
            i = int(outside[0])
            raise ParameterError("nodes", f"node {i} at ({nodes[i, 0]:.6g}, {nodes[i, 1]:.6g}) lies outside the domain "
                                          f"the boundary pieces enclose (winding number {winding[i]:.3f}; "
                                          f"{outside.size} such nodes)")

    def _natural_load(self, nat: Natural, shape: ShapeData) -> np.ndarray:
        pts = nat.points
        value = np.asarray(nat.value(pts.position, pts.normal), dtype=np.float64).reshape(len(pts.weight), -1)
        if value.shape[1] != self.components or not np.all(np.isfinite(value)):
            raise ParameterError(f"{nat.name}.value", f"must return finite (n, {self.components}) values")
        return assembly.load_vector(self.model, shape, value * pts.weight[:, None])

    def _impose(self, K, f, essential) -> tuple[sp.csr_matrix, np.ndarray, PrescribedValues]:
        model, c = self.model, self.components
        n = c * model.node_count
        if self.method is EssentialMethod.DIRECT:
            idx, val = [], []
            tol = 1e-9 * float(model.spacing.min())
            for b in self.essential:
                nodes = nodes_on_polyline(model.nodes_np, np.asarray(b.vertices, dtype=np.float64)[:, :2], tol)
                if nodes.size == 0:
                    raise ParameterError(f"{b.name}.vertices", "no node lies on this boundary: direct substitution "
                                                               "needs nodes on it")
                ubar = np.asarray(b.value(model.nodes_np[nodes]), dtype=np.float64).reshape(nodes.size, -1)
                for k in range(c):
                    if b.constrained[k]:
                        idx.append(c * nodes + k)
                        val.append(ubar[:, k])
            idx, val = np.concatenate(idx), np.concatenate(val)
            idx, first = np.unique(idx, return_index=True)
            return K, f, PrescribedValues(idx, val[first], n)
        blocks, rhs_parts, mass = [], [], None
        for (ep, shape), b in zip(essential, self.essential):
            if shape.counts.min() == 0:
                raise ParameterError(f"{b.name}.vertices", "part of this boundary lies outside every node's support")
            if self.method is EssentialMethod.LAGRANGE:
                G = boundary_terms.multiplier_matrix(model, shape, ep.points.weight, ep.multiplier, ep.hat, c, b.constrained,
                                               ep.n_multipliers)
                q = np.zeros((ep.n_multipliers, c))
                for e in range(2):
                    np.add.at(q, ep.multiplier[:, e], -(ep.points.weight * ep.hat[:, e])[:, None] * ep.prescribed)
                keep = np.flatnonzero(np.tile(np.asarray(b.constrained, bool), ep.n_multipliers))
                blocks.append(G[:, keep])
                rhs_parts.append(q.reshape(-1)[keep])
            else:
                M = boundary_terms.boundary_mass_matrix(model, shape, ep.points.weight, c, b.constrained)
                mask = np.asarray(b.constrained, dtype=float)[None, :]
                fb = assembly.load_vector(model, shape, ep.prescribed * mask * ep.points.weight[:, None])
                mass = M if mass is None else mass + M
                rhs_parts.append(fb)
        if self.method is EssentialMethod.PENALTY:
            alpha = self.penalty * self._largest_diagonal(K) / float(np.abs(mass.diagonal()).max())
            return ((K + self._part_of(alpha * mass)).tocsr(), f + alpha * np.sum(rhs_parts, axis=0),
                    PrescribedValues([], [], n))
        # scale the constraint rows so that both blocks' pivots are of K's size (K ~ E, G ~ length: unscaled, the
        # multipliers' Schur complement -GᵀK⁻¹G is 1e-14 of K's pivots and reads as singular); λ = β λ'
        G = sp.hstack(blocks).tocsr()
        m = G.shape[1]
        beta = self._largest_diagonal(K) / max(float(np.abs(G).max()), 1e-300)
        self._multiplier_scale = beta
        G = beta * G
        kkt = sp.bmat([[K, G], [G.T, None]]).tocsr()
        return self._part_of(kkt), np.concatenate([f] + [beta * q for q in rhs_parts]), PrescribedValues([], [], n + m)

    def _largest_diagonal(self, K) -> float:
        """max |K_II| of the whole stiffness (with PETSc K holds this rank's rows: the largest over the ranks)."""
        return float(self.world.allreduce(np.abs(K.diagonal()).max(initial=0.0), "max"))

    def resolve(self, load) -> np.ndarray:
        """Solve again with the kept factorisation for a new load vector on the nodes, under the same boundary
        conditions (their contributions to the right-hand side are kept from :meth:`solve`)."""
        if self.system is None:
            raise ParameterError("resolve", "call solve() first")
        f = np.asarray(load, dtype=np.float64)
        n = self.components * self.model.node_count
        if f.shape != (n,):
            raise ParameterError("load", f"must have shape ({n},), got {f.shape}")
        rhs = self._condition_rhs.copy()
        rhs[:n] += f
        x = self.system.solve(rhs)
        self.nodal, self.multipliers = x[:n], x[n:] * self._multiplier_scale
        return self.nodal

    # -- results -----------------------------------------------------------------------------------------------
    def field_at(self, points, material=None) -> tuple[np.ndarray, np.ndarray]:
        """(u^h (n, components), ∇u^h (n, components, 2)) at any points inside the model."""
        shape = self.model.shape_at(points, material, name="point")
        return self.model.evaluate(self.nodal, shape, self.components)

    def gauss_field(self) -> tuple[np.ndarray, np.ndarray]:
        """u^h and ∇u^h at the Gauss points (reusing their shape functions; in a distributed run every rank's own
        points, gathered in the points' order)."""
        u, g = self.model.evaluate(self.nodal, self.shape, self.components)
        return self.point_part.gather(u), self.point_part.gather(g)

    def nodal_values(self) -> np.ndarray:
        """u^h at the nodes (n_nodes, components): the nodal parameters are not nodal values unless the shape
        functions interpolate."""
        return self.field_at(self.model.nodes_np, self._node_point_material())[0]

    def _node_point_material(self):
        m = self.model.node_material.numpy()
        return None if np.all(m < 0) else m

    def describe(self) -> dict:
        """The solve for ``summary.json``: the shape model, Gauss points, method, integration, unknowns, multipliers and
        the linear solver."""
        return {**self.model.describe(), "gauss_points": self.work_items, "method": self.method,
                "integration": self.integration,
                "unknowns": int(self.components * self.model.node_count),
                "multipliers": int(self.multipliers.size),
                **({"layout": self.layout.describe()} if self.layout is not None else {}),
                "linear_solver": (self.system.describe() if isinstance(self.system, PETScSystem)
                                  else {"library": "SciPy SuperLU"})}


class PoissonSolver(EFGSolver):
    """-∇·(k ∇u) = s with k per material (``conductivity``: one value per material index), s = ``source(points)``.
    Node materials (the model's ``node_material``) and cell materials (``cell_material``, per integration cell)
    truncate supports at interfaces (Marques 2008, §3.3)."""

    name: ClassVar[str] = "efg_poisson"
    components: ClassVar[int] = 1

    def __init__(self, model: ShapeModel, cells: QuadraturePoints, conductivity=1.0,
                 source: Callable[[np.ndarray], np.ndarray] | None = None, **kwargs):
        super().__init__(model, cells, **kwargs)
        k = np.atleast_1d(np.asarray(conductivity, dtype=np.float64))
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise ParameterError("conductivity", f"must be finite and > 0 per material, got {k.tolist()}")
        self.conductivity = k
        m = self.point_material
        if m is None and k.size != 1:
            raise ParameterError("cell_material", f"{k.size} conductivities need a material index per cell")
        if m is not None and (m.min() < 0 or m.max() >= k.size):
            bad = int(np.flatnonzero((m < 0) | (m >= k.size))[0])
            raise ParameterError("cell_material", f"Gauss point {bad} at {cells.position[bad].tolist()} has material "
                                                  f"{m[bad]}, not one of 0..{k.size - 1}")
        self.source = source

    def interface_stiffness(self) -> sp.csr_matrix:
        """Σ over ``interfaces`` of the symmetric Nitsche terms (``boundary_terms.interface_matrix``), α = β k_max / h at
        each point, h the spacing of the node nearest to it (graded layouts keep the penalty in step with the local
        spacing)."""
        nearest = cKDTree(self.model.nodes_np)
        K = sp.csr_matrix((self.model.node_count, self.model.node_count))
        for face in self.interfaces:
            p = face.points
            a, b = self._interface_shapes(face)
            ka, kb = self.conductivity[face.inside], self.conductivity[face.outside]
            h = np.asarray(self.model.spacing, dtype=np.float64)[nearest.query(p.position)[1]]
            K = K + boundary_terms.interface_matrix(self.model, a, b, p.normal, p.weight, ka, kb,
                                                    self.nitsche_penalty * max(ka, kb) / h)
        return K

    def point_conductivity(self, material=None, count: int | None = None) -> np.ndarray:
        """k at the Gauss points (``material``, ``count``: of a subset; default every point)."""
        material = self.point_material if count is None else material
        count = self.work_items if count is None else count
        return self.conductivity[0] * np.ones(count) if material is None else self.conductivity[material]

    def stiffness(self, shape: ShapeData, test_dphi) -> sp.csr_matrix:
        """K over the Gauss points this process holds (:meth:`EFGSolver.stiffness`)."""
        k = self.point_conductivity(self._material, self._points.weight.shape[0])
        return assembly.conduction_matrix(self.model, shape, self._points.weight * k, test_dphi)

    def body_load(self, shape: ShapeData) -> np.ndarray:
        """The source's load ∫ φ_I s dΩ at the Gauss points (zeros without a source)."""
        if self.source is None:
            return np.zeros(self.model.node_count)
        s = np.asarray(self.source(self._points.position), dtype=np.float64).reshape(-1)
        return assembly.load_vector(self.model, shape, (s * self._points.weight)[:, None])

    def output_sets(self) -> list[OutputSet]:
        """Gauss points (potential, field -∇u, flux -k∇u; zeros before the solve) and nodes (parameters), in the units
        of :data:`POISSON_UNITS`."""
        n = self.work_items
        u, g = self.gauss_field() if self.shape is not None else (np.zeros((n, 1)), np.zeros((n, 1, 2)))
        flux = -self.point_conductivity()[:, None] * g[:, 0, :]
        return self._pieces([OutputSet("gauss_points", _points3(self.cells.position),
                                       {"potential": u[:, 0], "field_x": -g[:, 0, 0], "field_y": -g[:, 0, 1],
                                        "flux_x": flux[:, 0], "flux_y": flux[:, 1]}, frame_field="potential",
                                       units=POISSON_UNITS),
                             OutputSet("nodes", _points3(self.model.nodes_np), {"parameter": self.nodal.copy()},
                                       units=POISSON_UNITS, backdrop=False)])


def _points3(p: np.ndarray) -> np.ndarray:
    out = np.zeros((p.shape[0], 3))
    out[:, :2] = p
    return out


class ElasticitySolver(EFGSolver):
    """Plane linear elasticity, one material: ``young`` E, ``poisson`` ν, ``plane`` "stress" or "strain", body force
    ``body(points)`` -> (n, 2) (optional). Unknowns (u_x, u_y) per node."""

    name: ClassVar[str] = "efg_elasticity"
    components: ClassVar[int] = 2

    def __init__(self, model: ShapeModel, cells: QuadraturePoints, young: float, poisson: float,
                 plane: Plane = Plane.STRESS, body: Callable[[np.ndarray], np.ndarray] | None = None, **kwargs):
        plane = Plane.of("plane", plane)
        self.D = elasticity_matrix(young, poisson, plane)
        self.young, self.poisson, self.plane = float(young), float(poisson), plane
        super().__init__(model, cells, **kwargs)
        self.body = body

    def stiffness(self, shape: ShapeData, test_dphi) -> sp.csr_matrix:
        """K over the Gauss points this process holds (:meth:`EFGSolver.stiffness`)."""
        d = np.broadcast_to(self.D, (shape.n, 3, 3))
        return assembly.elastic_matrix(self.model, shape, self._points.weight, d, test_dphi)

    def body_load(self, shape: ShapeData) -> np.ndarray:
        """The body force's load ∫ φ_I b dΩ at the Gauss points (zeros without one), two entries per node."""
        if self.body is None:
            return np.zeros(2 * self.model.node_count)
        b = np.asarray(self.body(self._points.position), dtype=np.float64).reshape(-1, 2)
        return assembly.load_vector(self.model, shape, b * self._points.weight[:, None])

    @staticmethod
    def strain_from(gradient: np.ndarray) -> np.ndarray:
        """Engineering strains [ε_xx, ε_yy, γ_xy] (n, 3) from ∇u (n, 2, 2) (row: component, column: ∂/∂x_b)."""
        return np.stack([gradient[:, 0, 0], gradient[:, 1, 1], gradient[:, 0, 1] + gradient[:, 1, 0]], axis=1)

    def _strain_stress(self, u: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        eps = self.strain_from(gradient)
        return u, eps, eps @ self.D.T

    def gauss_strain(self) -> np.ndarray:
        """ε at the integration points (with integration="scni": the smoothed strains at the nodes)."""
        return self.strain_from(self.gauss_field()[1])

    def gauss_strain_stress(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u (n, 2), ε (n, 3), σ (n, 3)) at the integration points, as the stiffness saw them."""
        return self._strain_stress(*self.gauss_field())

    def strain_energy(self) -> float:
        """½ ∫ σ:ε dΩ of the solution (Gauss points)."""
        eps = self.gauss_strain()
        return 0.5 * float(np.sum(self.cells.weight * np.einsum("ni,ij,nj->n", eps, self.D, eps)))

    def output_sets(self) -> list[OutputSet]:
        """Gauss points (displacement, stresses, von Mises; zeros before the solve) and nodes (parameters), in the units
        of :data:`ELASTICITY_UNITS`."""
        n = self.work_items
        u, g = self.gauss_field() if self.shape is not None else (np.zeros((n, 2)), np.zeros((n, 2, 2)))
        sig = self.strain_from(g) @ self.D.T
        vm = von_mises(sig)
        return self._pieces([OutputSet("gauss_points", _points3(self.cells.position),
                                       {"displacement": _points3(u), "stress_xx": sig[:, 0], "stress_yy": sig[:, 1],
                                        "stress_xy": sig[:, 2], "von_mises": vm}, frame_field="von_mises",
                                       units=ELASTICITY_UNITS),
                             OutputSet("nodes", _points3(self.model.nodes_np),
                                       {"parameter": _points3(self.nodal.reshape(-1, 2))}, units=ELASTICITY_UNITS,
                                       backdrop=False)])

    def describe(self) -> dict:
        """The solve for ``summary.json`` with the material: Young's modulus, Poisson's ratio, the plane condition."""
        return {**super().describe(), "young": self.young, "poisson": self.poisson, "plane": self.plane}
