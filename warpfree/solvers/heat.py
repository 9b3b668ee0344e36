"""SPH heat conduction: the smallest complete solver on the core, written to be copied.

It shows every part of the contract (``warpfree/solver.py``) in about a hundred lines:

- a **model** (:class:`HeatModel`): the static part — particles, volumes, the ``@wp.struct`` constants
  the kernels take, a static neighbour list (the particles do not move), the space (periodic boxes);
- a **state** (:class:`HeatState`): what changes — here one array, ``temperature``, made beside the model (the model
  is never changed); a checkpoint saves exactly this;
- a **solver** (:class:`HeatSolver`): ``advance()`` orders the launches of ``warpfree.kernels.heat`` for one step of
  the Δt its clock holds (``self.clock``, made by the core: the time loop sets its landing times) and ends by moving
  the clock on; ``stable_dt()`` gives the largest stable step, ``output_sets()``, ``diagnostics()``, ``describe()``.
  ``step(dt)``, for scripts, is the core's: Δt written to the clock, then ``advance()``.

Equation (kernels/heat.py): dT_i/dt = 2α Σ_j V_j (T_i - T_j) F_ij / N_i, F_ij = (r_ij·∇_i W_ij)/(r_ij² + η²),
N_i the operator's discrete second moment (exact for quadratic fields), forward Euler. Units: SI (m, s, α in m²/s, T in K). ``scenes/heat_conduction_2d.py`` runs it against the
exact decay of a sine mode, exp(-α k² t).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError, require_positive
from warpfree.kernels import heat as K
from warpfree.kernels.smoothing import kernel_id, normalisation, support_factor
from warpfree.neighbours import NeighbourGrid, NeighbourList
from warpfree.particles import ParticleSet
from warpfree.reduce import reduce
from warpfree.smoothing import SmoothingKernel
from warpfree.solver import OutputSet, State, TimeDependentSolver
from warpfree.space import Space

__all__ = ["HeatModel", "HeatState", "HeatSolver"]


class HeatModel:
    """Particles at ``positions`` (N, dim) with spacing ``dx`` (volume dx^dim each), diffusivity ``alpha``
    (m²/s), smoothing length ``h_factor · dx``, in ``space`` (its periodic axes wrap)."""

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
        support = support_factor(kernel) * self.h
        grid = NeighbourGrid(launcher, support, space, self.particles.position)
        self.neighbours = NeighbourList(grid, self.particles.position)  # built once: the particles are static
        c = K.HeatConstants()
        c.alpha, c.h, c.inv_h, c.support2, c.eta2 = alpha, self.h, 1.0 / self.h, support ** 2, 0.01 * self.h ** 2
        c.grad_factor = normalisation(kernel, space.dim, self.h) / self.h ** 2
        c.kind, c.dim, c.box = kernel_id(kernel), space.dim, space.box
        self.constants = c


class HeatState(State):
    """The temperature of every particle (K): the whole state."""

    def __init__(self, temperature: wp.array):
        self.temperature = temperature


class HeatSolver(TimeDependentSolver):
    """Forward-Euler SPH heat conduction on static particles; ``temperature`` (N,) is the initial field."""

    name = "heat"
    work_unit = "particle-steps"

    def __init__(self, model: HeatModel, temperature, launcher: Launcher | None = None):
        super().__init__(model, launcher or current_launcher())  # the launcher the model was built with
        t = np.asarray(temperature, dtype=np.float32)
        if t.shape != (model.particles.n,) or not np.all(np.isfinite(t)):
            raise ParameterError("temperature", f"must be {model.particles.n} finite values")
        self.state = HeatState(wp.array(t, dtype=float, device=self.launcher.device))  # the model stays as made
        self.rate = wp.zeros(model.particles.n, dtype=float, device=self.launcher.device)
        # the operator's normalisation and the largest stable step (Gershgorin), once: the particles are static
        m = self.model
        bound = wp.zeros(m.particles.n, dtype=float, device=self.launcher.device)
        self.normalisation = wp.zeros(m.particles.n, dtype=float, device=self.launcher.device)
        self.launcher.launch(K.operator_geometry, m.particles.n, [m.constants, m.neighbours.rows, m.particles.position,
                                                                  m.particles["volume"], self.normalisation, bound])
        self.dt_max = 1.0 / float(reduce(self.launcher, bound, "max"))

    def advance(self) -> None:
        """T ← T + Δt dT/dt with the Δt the clock holds: the rate sweep over the neighbour list, the update, then the
        clock's time moved on and its next step picked."""
        m, dt = self.model, self.clock.step
        with self.phases("rates"):
            self.launcher.launch(K.temperature_rate, m.particles.n, [m.constants, m.neighbours.rows,
                                                                     m.particles.position, m.particles["volume"],
                                                                     self.normalisation, self.state.temperature,
                                                                     self.rate])
        with self.phases("integrate"):
            self.launcher.launch(K.euler_update, self.model.particles.n, [float(dt), self.rate, self.state.temperature])
        self.clock.launch_advance_and_choose()

    def temperature(self) -> np.ndarray:
        """A copy of every particle's temperature (K)."""
        return self.state.temperature.numpy().copy()

    def stable_dt(self) -> float:
        """The largest explicit step, fixed at set-up (s): the diffusion limit of the particle spacing."""
        return self.dt_max

    @property
    def dim(self) -> int:
        """The space's dimension."""
        return self.model.dim

    @property
    def work_items(self) -> int:
        """Particles (the unit of the throughput)."""
        return self.model.particles.n

    def output_sets(self) -> list[OutputSet]:
        """The particles with their temperature (K), the field frames colour."""
        return [OutputSet("particles", self.model.particles.numpy("position"), {"temperature": self.temperature()},
                          frame_field="temperature", units={"position": "m", "temperature": "K"})]

    def diagnostics(self) -> dict[str, float]:
        """Heat content Σ V_j T_j (K·m^dim; conserved by the symmetric operator) and the extremes of T."""
        t = self.temperature().astype(np.float64)
        return {"heat_content": float(np.sum(t) * self.model.dx ** self.dim), "temperature_min": float(t.min()),
                "temperature_max": float(t.max())}

    def describe(self) -> dict:
        """The model for ``summary.json``: particles, spacing, h, diffusivity, kernel, space, neighbour pairs, step."""
        m = self.model
        return {"n_particles": m.particles.n, "dx": m.dx, "h": m.h, "alpha": m.alpha, "kernel": m.kernel,
                "space": m.space.describe(), "neighbour_pairs": m.neighbours.n_pairs, "dt_max": self.dt_max,
                "diffusion_number": m.alpha * self.dt_max / m.dx ** 2 if math.isfinite(self.dt_max) else None}
