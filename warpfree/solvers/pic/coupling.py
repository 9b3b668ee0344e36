"""The particle-node coupling of PIC (Marques 2008, ch. 4): the field at the particles' positions x^n.

    neighbours:  rebuild the particles' grid (``warpfree.neighbours.GatherGrid``: no images, the nodes query it at
                 their static periodic copies)
    fits:        the MLS fit of every particle over the nodes (γ, ∂γ: φ_I and ∇φ_I, stored once per step)
    deposit:     Q_I = Σ_p q_p φ_I(x_p), a node gather (eq 4.4)
    solve:       K u = Q + ρ_bg m on the kept factorisation (:class:`~.field.PlasmaPoisson`)
    gather:      E_p = -Σ_I u_I ∇φ_I(x_p) (eq 4.5), or Σ_I φ_I(x_p) E_I from nodal fields (the momentum gather)

Kernels: ``kernels/pic.py`` (one set per basis size), on the MLS model's nodes (``kernels/mls.py: NodeSet``). float64.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpfree.galerkin.mls import RCOND_LIMIT, MLSModel
from warpfree.kernels import mls as mk
from warpfree.kernels import pic as pk
from warpfree.neighbours import GatherGrid
from warpfree.parameters import Choice
from warpfree.reduce import Reduction
from warpfree.solver import PhaseTimes

from .device_solve import DeviceFieldSolve, FieldSolve
from .field import PlasmaPoisson
from .particles import Particles

__all__ = ["NodeCoupling", "Gather", "FieldSolve"]


class Gather(Choice):
    """How the particles take the field from the nodes (``warpfree.solvers.pic.field``)."""

    MOMENTUM = "momentum", ("nodal fields E_I interpolated with φ_I: no self-force, momentum conserved; energy "
                            "approximately")
    ENERGY = "energy", "E(x_p) = -Σ_I u_I ∇φ_I(x_p) (eq 4.5): energy conserved, with a self-force"


class NodeCoupling:
    """Deposit, field solve and gather between the particles and the nodes of ``field``'s MLS model.

    ``charge`` (nodes, device), ``potential`` (nodes, read to the host when asked for) and ``nodal_field`` hold the
    last solve's; the particles' field goes to ``particles.e_field``. ``background_density``: the uniform immobile
    charge density. ``gather``: a :class:`Gather`. ``field_solve``: a :class:`FieldSolve`, "host" (``PlasmaPoisson``'s
    SuperLU: the charge to the host and the potential back), or the solve on the device (:mod:`.device_solve`:
    "device" picks its method, or "cg", "dense").
    """

    def __init__(self, field: PlasmaPoisson, particles: Particles, macro_charge: wp.array, background_density: float,
                 gather: Gather, phases: PhaseTimes, field_solve: FieldSolve = FieldSolve.HOST):
        model: MLSModel = field.model
        dev = particles.launcher.device
        self.field = field
        self.model = model
        self.launcher = particles.launcher
        self.particles = particles
        self.macro_charge = macro_charge
        self.background_density = background_density
        self.gather = Gather.of("gather", gather)
        self.phases = phases
        self.kernels = pk.mls_kernels(*model.settings.kernel_key())
        self.node_set = model.node_set()
        # the nodes gather from the particles: a grid over the particles, queried at the nodes' static periodic
        # copies (those of the model's node grid), so a step's build only sorts
        self.particle_grid = GatherGrid(model.grid)
        self.inv_scale = wp.float64(1.0 / float(np.mean(model.support_np[:, 0])))
        self._flag_max = Reduction(self.launcher, wp.int32, "max")
        self.charge = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
        self.field_solve = field_solve = FieldSolve.of("field_solve", field_solve)
        self.device_solve = None
        if field_solve is not FieldSolve.HOST:
            self.device_solve = DeviceFieldSolve(field, background_density, self.gather is Gather.MOMENTUM,
                                                 self.launcher, field_solve)
            self.potential_wp, self.nodal_field = self.device_solve.potential, self.device_solve.nodal_field
        else:
            self.potential_wp = wp.zeros(model.node_count, dtype=wp.float64, device=dev)
            self.nodal_field = wp.zeros(model.node_count, dtype=wp.vec2d, device=dev)
        self._potential: np.ndarray | None = np.zeros(model.node_count)
        #: a distributed run's combination of the ranks' nodal charges (each rank deposits on its own nodes): the
        #: deposit's charges -> the whole vector (None in one process)
        self.whole_charge = None
        self.charge_host = np.zeros(model.node_count)  # the last deposit, when the host solved (read for it)
        self.allocate(particles.state.capacity)

    def allocate(self, capacity: int) -> None:
        """The per-particle fits, node counts and check flags for ``capacity`` slots (rebuilt every step)."""
        dev = self.launcher.device
        self.fit = wp.zeros(capacity, dtype=mk.MLSFit, device=dev)
        self.node_count_of = wp.zeros(capacity, dtype=wp.int32, device=dev)
        self._flags = wp.zeros(capacity, dtype=wp.int32, device=dev)

    def fields_at_particles(self) -> None:
        """Neighbours, fits, deposit, solve and gather at x^n (E into ``particles.e_field``) for the live particles."""
        self.build_grid()
        self.fields_from_grid()

    def build_grid(self) -> None:
        """The particles' grid at x^n (:class:`~warpfree.neighbours.GatherGrid`; Warp's build: a sort, not a plain
        launch)."""
        n = self.particles.count
        with self.phases("neighbours"):
            if n:
                self.particle_grid.build(self.particles.position32[:n])

    def fields_from_grid(self) -> None:
        """Fits, deposit, solve and gather over the built grid: launches only, with the device solve (a graph can
        record them)."""
        m, L, pa = self.model, self.launcher, self.particles
        n, state = pa.count, pa.state
        with self.phases("fits"):
            L.launch(self.kernels.particle_fits, n, [self.node_set, pa.position32, state.position, self.inv_scale,
                                                      self.fit, self.node_count_of])
        with self.phases("deposit"):
            if n:
                L.launch(self.kernels.deposit, m.node_count,
                         [self.node_set, self.particle_grid.copies, pa.position32, state.position, state.species,
                          self.macro_charge, self.inv_scale, self.fit, self.charge])
            else:
                self.charge.zero_()
            if self.whole_charge is not None:
                self.charge.assign(self.whole_charge(self.charge.numpy()))
        with self.phases("solve"):
            if self.device_solve is not None:
                self.device_solve.solve(self.charge)
                self._potential = None  # on the device: read when asked for
            else:
                self.charge_host = charge = self.charge.numpy()
                self._potential = self.field.solve(charge, self.background_density)
                self.potential_wp.assign(self._potential)
                if self.gather is Gather.MOMENTUM:
                    self.nodal_field.assign(self.field.nodal_field(self._potential, charge))
        with self.phases("gather"):
            L.launch(self.kernels.particle_field, n, [self.node_set, pa.position32, state.position, self.inv_scale,
                                                       self.fit, self.potential_wp, self.nodal_field,
                                                       int(self.gather is Gather.MOMENTUM), pa.e_field])

    @property
    def potential(self) -> np.ndarray:
        """The nodal potential u_I of the last solve (host; read from the device, once per solve, when it solved
        there)."""
        if self._potential is None:
            self._potential = self.potential_wp.numpy().copy()
        return self._potential

    @property
    def net_charge_density(self) -> float:
        """The last solve's net charge density (a periodic box; 0 between walls)."""
        if self.device_solve is not None:
            return 0.0 if self.field.walled else float(self.device_solve.net.numpy()[0])
        return self.field.net_charge_density

    def launch_flags(self) -> wp.array:
        """Flag, on the device, each live particle whose MLS fit is ill-posed (too few nodes in reach, or a singular
        moment matrix) or whose velocity is not finite; returns the flags (their maximum goes into the step report)."""
        terms = self.model.settings.terms
        n, state = self.particles.count, self.particles.state
        if n:
            self.launcher.launch(pk.flag_bad_particles, n, [terms, wp.float64(RCOND_LIMIT), self.node_count_of,
                                                            self.fit, state.velocity, self._flags])
        return self._flags

    def bad_particle(self) -> str | None:
        """A message naming the first particle :meth:`launch_flags` flags, else None (the flags' maximum read once;
        the arrays come to the host only when something is wrong)."""
        n = self.particles.count
        if not n:
            return None
        self.launch_flags()
        self._flag_max.launch(self._flags, n)
        if not self._flag_max.value():
            return None
        return self.describe_bad()

    def describe_bad(self) -> str:
        """The message for the first flagged particle (reads the flags and that particle's values)."""
        terms = self.model.settings.terms
        n, state = self.particles.count, self.particles.state
        bad = np.flatnonzero(self._flags[:n].numpy())
        i = int(bad[0])
        x = state.position.numpy()[i]
        v = state.velocity.numpy()[i]
        if not np.all(np.isfinite(v)):
            return f"particle {i} at ({x[0]:.6g}, {x[1]:.6g}) has a non-finite velocity {v.tolist()}"
        count = int(self.node_count_of.numpy()[i])
        rcond = float(self.fit.numpy()["rcond"][i])
        return (f"particle {i} at ({x[0]:.6g}, {x[1]:.6g}) lies in the support of {count} node(s) (scaled pivot "
                f"{rcond:.1e}); the {self.model.settings.basis} basis needs {terms} nodes around it: raise d_max "
                f"(now {self.model.settings.d_max}) or add nodes ({bad.size} such particles)")
