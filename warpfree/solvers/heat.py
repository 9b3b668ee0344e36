"""SPH heat conduction: the smallest complete solver on the core, written to be copied.

It shows every part of the contract (``warpfree/solver.py``) in about two hundred lines:

- a **model** (:class:`HeatModel`): the static part — particles, volumes, the ``@wp.struct`` constants
  the kernels take, a static neighbour list (the particles do not move), the space (periodic boxes);
- a **state** (:class:`HeatState`): what changes — here one array, ``temperature``, made beside the model (the model
  is never changed), and which particles it holds (``particle_id``, ``particle_owned``); a checkpoint saves exactly
  this, and :meth:`HeatSolver.restore_pieces` reads one written by any number of processes;
- a **solver** (:class:`HeatSolver`): ``advance()`` orders the launches of ``warpfree.kernels.heat`` for one step of
  the Δt its clock holds (``self.clock``, made by the core: the time loop sets its landing times) and ends by moving
  the clock on; ``stable_dt()`` gives the largest stable step, ``output_sets()``, ``diagnostics()``, ``describe()``.
  ``step(dt)``, for scripts, is the core's: Δt written to the clock, then ``advance()``;
- **ranks** (``distributes = True``; ``mpiexec -n N warpfree run ...``): the particles are cut once
  (:class:`~warpfree.parallel.Decomposition`) and each rank holds a :class:`~warpfree.parallel.Partition`, its own
  particles and, as ghosts, those within one support of its box; it takes its own particles' rows of the model's
  neighbour list (:func:`~warpfree.parallel.halo.take_rows`), launches over its own particles only, refreshes the
  ghosts' temperature after each update and reduces the stable step over the ranks (``world.allreduce``). The sums
  run over the one process's rows in its order, so a distributed run gives its results bitwise. One process is a
  one-rank partition: the whole set, the model's own arrays and rows, refreshes that do nothing;
- **threads**: each launch runs over ``order``, the rank's own particles in the load distribution
  (``distribution``, ``warpfree/distribution.py``); the results are bitwise the same for every distribution.

Equation (kernels/heat.py): dT_i/dt = 2α Σ_j V_j (T_i - T_j) F_ij / N_i, F_ij = (r_ij·∇_i W_ij)/(r_ij² + η²),
N_i the operator's discrete second moment (exact for quadratic fields), forward Euler. Units: SI (m, s, α in m²/s, T in
K). ``scenes/heat_conduction_2d.py`` runs it against the exact decay of a sine mode, exp(-α k² t).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.distribution import Distribution, launch_order
from warpfree.errors import ParameterError, require_positive
from warpfree.kernels import heat as K
from warpfree.kernels.smoothing import kernel_id, normalisation, support_factor
from warpfree.neighbours import NeighbourGrid, NeighbourList, host_rows
from warpfree.parallel import CutMethod, Decomposition, Partition
from warpfree.parallel import world as ranks_of_run
from warpfree.parallel.halo import take_rows, whole_from_pieces
from warpfree.particles import ParticleSet
from warpfree.reduce import reduce
from warpfree.smoothing import SmoothingKernel
from warpfree.solver import OutputSet, State, TimeDependentSolver
from warpfree.space import Space

__all__ = ["HeatModel", "HeatState", "HeatSolver"]


class HeatModel:
    """Particles at ``positions`` (N, dim) with spacing ``dx`` (volume dx^dim each), diffusivity ``alpha``
    (m²/s), smoothing length ``h_factor · dx``, in ``space`` (its periodic axes wrap). Every rank builds the whole
    model (the particles are static: the neighbour list is built once)."""

    def __init__(self, positions, dx: float, alpha: float, space: Space, launcher: Launcher | None = None,
                 h_factor: float = 1.3, kernel: SmoothingKernel = SmoothingKernel.WENDLAND_C2):
        launcher = launcher or current_launcher()
        self.dx = require_positive("dx", dx)
        self.alpha = require_positive("alpha", alpha)
        self.h = require_positive("h_factor", h_factor) * dx
        self.kernel = kernel = SmoothingKernel.of("kernel", kernel)
        self.dim = space.dim
        self.space = space
        self.particles = ParticleSet("particles", space.wrap(np.asarray(positions, float)), space.dim, launcher.device)
        self.particles.add("volume", dx ** space.dim)
        self.support = support = support_factor(kernel) * self.h
        grid = NeighbourGrid(launcher, support, space, self.particles.position)
        self.neighbours = NeighbourList(grid, self.particles.position)  # built once: the particles are static
        c = K.HeatConstants()
        c.alpha, c.h, c.inv_h, c.support2, c.eta2 = alpha, self.h, 1.0 / self.h, support ** 2, 0.01 * self.h ** 2
        c.grad_factor = normalisation(kernel, space.dim, self.h) / self.h ** 2
        c.kind, c.dim, c.box = kernel_id(kernel), space.dim, space.box
        self.constants = c


class HeatState(State):
    """The temperature (K) of the particles this process holds (all of them in one process), and which they are:
    ``particle_id`` (their indices in the whole set) and ``particle_owned`` (1: this rank's own, 0: a ghost), so that
    a checkpoint reads back on any number of processes."""

    def __init__(self, temperature: wp.array, part: Partition):
        self.temperature = temperature
        self.particle_id = part.ids.astype(np.int64)
        self.particle_owned = part.owned.astype(np.int8)


class HeatSolver(TimeDependentSolver):
    """Forward-Euler SPH heat conduction on static particles; ``temperature`` (N,) is the initial field of every
    particle. ``distribution``: which particles each thread updates (``warpfree/distribution.py``: "blocks",
    "alternating", "random", "neighbours"); the results are bitwise the same for all."""

    name = "heat"
    work_unit = "particle-steps"
    distributes = True

    def __init__(self, model: HeatModel, temperature, launcher: Launcher | None = None,
                 distribution: Distribution = Distribution.BLOCKS):
        super().__init__(model, launcher or current_launcher())  # the launcher the model was built with
        t = np.asarray(temperature, dtype=np.float32)
        if t.shape != (model.particles.n,) or not np.all(np.isfinite(t)):
            raise ParameterError("temperature", f"must be {model.particles.n} finite values")
        self.distribution = Distribution.of("distribution", distribution)
        dev = self.launcher.device
        self.world = ranks_of_run()
        #: this rank's particles (its own and, as ghosts, those within one support of its box): cut once, the
        #: particles being static; in one process the whole set
        self.part = part = self._partition(model)
        self.particles, self.rows = self._held(model, part)
        self.state = HeatState(wp.array(part.take(t), dtype=float, device=dev), part)  # the model stays as made
        self.rate = wp.zeros(part.n, dtype=float, device=dev)
        # each thread's particles among this rank's own (``distribution``), weighed by their neighbour counts
        own = part.owned_index
        order = own[launch_order(self.distribution, own.size, self.launcher.threads,
                                 cost=model.neighbours.counts()[part.ids[own]])]
        self.order = wp.array(order.astype(np.int32), dtype=wp.int32, device=dev)
        # the operator's normalisation and the largest stable step (Gershgorin, the largest bound of every rank),
        # once: the particles are static
        bound = wp.zeros(part.n, dtype=float, device=dev)   # 0 on the ghosts: the max is the own particles'
        self.normalisation = wp.zeros(part.n, dtype=float, device=dev)
        self.launcher.launch(K.operator_geometry, own.size, [self.order, model.constants, self.rows,
                                                             self.particles.position, self.particles["volume"],
                                                             self.normalisation, bound])
        largest = reduce(self.launcher, bound, "max") if part.n else 0.0
        self.dt_max = 1.0 / float(self.world.allreduce(largest, "max"))

    def _partition(self, model: HeatModel) -> Partition:
        """The cut of space between the ranks (boxes of whole supports, weighed by the neighbour counts) and this
        rank's part of the particles, with ghosts within one support (a hair more: the rows were found in float32)."""
        x = model.particles.numpy("position").astype(np.float64)
        space = model.space
        decomposition = Decomposition.build(self.world.size, x, model.neighbours.counts() + 1.0, model.support,
                                            model.dim, CutMethod.RCB, space.lower, space.upper, space.periodic)
        return Partition.of_all(self.world, decomposition, model.support * (1.0 + 1e-6), x)

    def _held(self, model: HeatModel, part: Partition) -> tuple[ParticleSet, object]:
        """The particles this rank holds and their rows: the model's own in one process (no copy); else the held rows
        of the model's arrays and the own particles' rows of the model's neighbour list, kept in their order with
        their columns renumbered to held indices (a ghost's row is empty: it is never updated here)."""
        if part.whole:
            return model.particles, model.neighbours.rows
        dev = self.launcher.device
        fields = {k: wp.array(part.take(v.numpy()), dtype=v.dtype, device=dev) for k, v in model.particles.fields.items()}
        r = model.neighbours.rows
        counts, columns, _ = take_rows(r.start.numpy(), r.count.numpy(), r.index.numpy(), part.ids[part.owned_index],
                                       part)
        per_row = np.zeros(part.n, dtype=np.int64)
        per_row[part.owned_index] = counts
        return ParticleSet.view("particles", model.dim, fields, partition=part), host_rows(per_row, columns, dev)

    def advance(self) -> None:
        """T ← T + Δt dT/dt with the Δt the clock holds: the rate sweep over the neighbour list and the update, on this
        rank's own particles; the ghosts' new temperature from their owners; then the clock's time moved on and its
        next step picked."""
        p, st, n = self.particles, self.state, self.order.shape[0]
        with self.phases("rates"):
            self.launcher.launch(K.temperature_rate, n, [self.order, self.model.constants, self.rows, p.position,
                                                         p["volume"], self.normalisation, st.temperature, self.rate])
        with self.phases("integrate"):
            self.launcher.launch(K.euler_update, n, [self.order, float(self.clock.step), self.rate, st.temperature])
        with self.phases("exchange"):
            self.part.refresh(st.temperature)   # nothing to do in one process
        self.clock.launch_advance_and_choose()

    def temperature(self) -> np.ndarray:
        """A copy of every particle's temperature (K), in the whole set's order (gathered from every rank)."""
        return self.part.gather(self.state.temperature)

    def stable_dt(self) -> float:
        """The largest explicit step, fixed at set-up (s): the diffusion limit of the particle spacing."""
        return self.dt_max

    @property
    def dim(self) -> int:
        """The space's dimension."""
        return self.model.dim

    @property
    def work_items(self) -> int:
        """Particles of the whole set (the unit of the throughput)."""
        return self.model.particles.n

    def restore_pieces(self, pieces: list[dict]) -> None:
        """The whole temperature from the checkpoint of any number of processes (each piece its own particles, by
        ``particle_id`` and ``particle_owned``), then this rank's held rows of it: the run continues bitwise."""
        whole = whole_from_pieces(pieces, ["temperature"], "particle_id", self.part.count, owned="particle_owned")
        self.state.temperature.assign(self.part.take(whole["temperature"]))
        self.after_load()

    def output_sets(self) -> list[OutputSet]:
        """The particles with their temperature (K), the field frames colour: this rank's own (``ids``: their indices
        in the whole set; every particle in one process)."""
        part = self.part
        return [OutputSet("particles", part.owned_values(self.particles.position),
                          {"temperature": part.owned_values(self.state.temperature)}, frame_field="temperature",
                          ids=part.ids[part.owned_index], units={"position": "m", "temperature": "K"})]

    def diagnostics(self) -> dict[str, float]:
        """Heat content Σ V_j T_j (K·m^dim; conserved by the symmetric operator) and the extremes of T, from the
        gathered field, summed in the one process's order (a distributed run reports them bitwise)."""
        t = self.temperature().astype(np.float64)
        return {"heat_content": float(np.sum(t) * self.model.dx ** self.dim), "temperature_min": float(t.min()),
                "temperature_max": float(t.max())}

    def describe(self) -> dict:
        """The model for ``summary.json``: particles, spacing, h, diffusivity, kernel, space, neighbour pairs, step;
        in a distributed run the layout too (``distributed``: particles owned and ghosts per rank, the cut)."""
        m = self.model
        d = {"n_particles": m.particles.n, "dx": m.dx, "h": m.h, "alpha": m.alpha, "kernel": m.kernel,
             "space": m.space.describe(), "neighbour_pairs": m.neighbours.n_pairs, "dt_max": self.dt_max,
             "diffusion_number": m.alpha * self.dt_max / m.dx ** 2 if math.isfinite(self.dt_max) else None}
        if not self.part.whole:
            counts = np.concatenate(self.world.allgather(np.array([self.part.n_owned, self.part.n_ghosts],
                                                                  dtype=np.int64))).reshape(self.world.size, 2)
            d["distributed"] = {"ranks": self.world.size, "depth": self.part.depth,
                                "particles_owned": counts[:, 0].tolist(), "particles_ghosts": counts[:, 1].tolist(),
                                "ghost_fraction": float(counts[:, 1].sum() / max(counts.sum(), 1)),
                                "decomposition": self.part.decomposition.describe()}
        return d
