"""Weakly-compressible SPH solver (seed 004): orders the launches of :mod:`warpfree.kernels.wcsph`.

One step reads as the scheme: drift (half kick, drift, predictor), rebuild the neighbour tables if a
particle may have moved half the skin, wall pressure (dynamic walls), rates, kick (which also writes
the step report), and a device reduction of the report. The host reads that one reduced value per
step (largest displacement since the build, speed, acceleration, worst status): it gives the next
stable step, the rebuild decision and the run's health. Fluid particles are indices ``[0, nf)`` of
the combined arrays, walls ``[nf, n)``; :attr:`fluid` and :attr:`boundary` expose them as views.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError, RunError, require_memory, require_positive
from warpfree.kernels import wcsph as K
from warpfree.neighbours import MovingNeighbours, NeighbourGrid, NeighbourList, empty_rows
from warpfree.particles import ParticleSet, to_vec3
from warpfree.clock import DeviceClock
from warpfree.graph import StepGraph
from warpfree.kernels import clock as ck
from warpfree.reduce import Reduction
from warpfree.kernels.wcsph_solids import add_surface_penalty
from warpfree.solver import OutputSet, State, TimeDependentSolver

from .model import WCSPHModel

__all__ = ["WCSPHSolver", "WCSPHState"]

#: minimum neighbour count of the best-surrounded fluid particle (seed §5.5 recommends 20 in 2D, 56 in
#: 3D; a lattice with h = 1.3 dx and support 2h has 20 and 80). Below this, h is too small for dx.
MIN_NEIGHBOURS = {1: 4, 2: 20, 3: 56}


class WCSPHState(State):
    """What changes in time (the checkpoint): combined fluid + wall arrays and the fluid's rates.

    position, velocity, density, pressure (n); acceleration, density_rate (nf); position_at_build (nf):
    the fluid positions of the last neighbour-table build (the tables are rebuilt from it on resume); clock: the
    device clock's array (``warpfree.clock``: t, Δt, the next stable step and the last step report).
    """

    def __init__(self, position, velocity, density, pressure, acceleration, density_rate, position_at_build, clock):
        self.position = position
        self.velocity = velocity
        self.density = density
        self.pressure = pressure
        self.acceleration = acceleration
        self.density_rate = density_rate
        self.position_at_build = position_at_build
        self.clock = clock


class WCSPHSolver(TimeDependentSolver):
    """WCSPH fluid with dynamic (Adami) or Lennard-Jones boundary particles, on a :class:`WCSPHModel` (the layout,
    the parameters, the walls and the solid surfaces).

    Parameters
    ----------
    model: :class:`WCSPHModel`.
    density: optional (N,) initial fluid densities (e.g. hydrostatic); default ρ0.
    velocity: optional (N, dim) initial velocities (m/s); default 0.
    """

    name = "wcsph"
    work_unit = "particle-steps"

    def __init__(self, model: WCSPHModel, density=None, velocity=None, launcher: Launcher | None = None):
        if not isinstance(model, WCSPHModel):
            raise ParameterError("model", f"a WCSPHSolver takes a WCSPHModel, got {type(model).__name__}")
        launcher = launcher or model.launcher
        dev = launcher.device
        params = model.params
        super().__init__(model, launcher)
        nf, nb, n = model.nf, model.nb, model.n
        rho_f = np.full(nf, params.rho0) if density is None else np.asarray(density, float)
        if rho_f.shape != (nf,) or not np.all(np.isfinite(rho_f)) or np.any(rho_f <= 0):
            raise ParameterError("density", f"must be {nf} finite positive values")
        v_f = np.zeros((nf, 3)) if velocity is None else to_vec3(velocity, "velocity")
        if v_f.shape != (nf, 3):
            raise ParameterError("velocity", f"must have {nf} rows")

        def arr(values, dtype):
            return wp.array(values, dtype=dtype, device=dev)

        position = arr(model.position_np, wp.vec3)
        self.clock = DeviceClock(launcher, K.REPORT_SLOTS)
        self.state = WCSPHState(
            position=position,
            velocity=arr(np.vstack([v_f, np.zeros((nb, 3))]).astype(np.float32), wp.vec3),
            density=arr(np.concatenate([rho_f, np.full(nb, params.rho0)]).astype(np.float32), float),
            pressure=wp.zeros(n, dtype=float, device=dev),
            acceleration=wp.zeros(nf, dtype=wp.vec3, device=dev),
            density_rate=wp.zeros(nf, dtype=float, device=dev),
            position_at_build=wp.zeros(nf, dtype=wp.vec3, device=dev),
            clock=self.clock.values)
        S = self.state
        self.arrays = K.FluidArrays()
        a = self.arrays
        a.nf = nf
        a.position, a.velocity, a.density, a.pressure = S.position, S.velocity, S.density, S.pressure
        a.mass = model.mass
        a.acceleration, a.density_rate = S.acceleration, S.density_rate
        a.velocity_eval = wp.zeros(nf, dtype=wp.vec3, device=dev)
        a.density_eval = wp.zeros(nf, dtype=float, device=dev)
        a.ghost_velocity = wp.zeros(max(nb, 1), dtype=wp.vec3, device=dev)
        a.report = wp.zeros(nf, dtype=wp.vec4, device=dev)
        n_shift = nf if model.terms.shifting else 1  # scratch of this step's shift (written by rates, used by kick)
        a.shift_velocity = wp.zeros(n_shift, dtype=wp.vec3, device=dev)
        a.shift_acceleration = wp.zeros(n_shift, dtype=wp.vec3, device=dev)
        a.shift_density_rate = wp.zeros(n_shift, dtype=float, device=dev)
        self.kernels = K.make_kernels(model.terms)

        def part(array, start, stop):  # a view of rows [start, stop); Warp refuses empty slices
            return array[start:stop] if stop > start else wp.zeros(0, dtype=array.dtype, device=dev)

        walls = nf + model.n_container_walls
        f, b, o = (0, nf), (nf, walls), (walls, n)
        #: the fluid, the container walls and the obstacles' walls: named views into the combined arrays
        self.fluid = ParticleSet.view("fluid", params.dim, {
            "position": part(S.position, *f), "velocity": part(S.velocity, *f), "density": part(S.density, *f),
            "pressure": part(S.pressure, *f), "mass": part(model.mass, *f)})
        self.boundary, self.obstacle = (ParticleSet.view(name, params.dim, {
            "position": part(S.position, *r), "density": part(S.density, *r), "pressure": part(S.pressure, *r),
            "mass": part(model.mass, *r)}) for name, r in (("boundary", b), ("obstacle", o)))
        #: all wall particles (containers, then obstacles): the static set the fluid's tables query
        self.walls = part(S.position, nf, n)

        self.max_neighbours = self._check_neighbours()
        # Neighbour candidates within support + skin, rebuilt once a fluid particle may have moved skin/2.
        self.moving_neighbours = MovingNeighbours(
            launcher, model.space, self.fluid.position, params.support, model.skin,
            static_sets={"walls": self.walls} if nb else None, position_at_build=S.position_at_build)
        a.position_at_build = S.position_at_build
        cap = int(self.max_neighbours * (1.0 + params.skin) ** params.dim * 1.2) + 8  # grows if ever too small
        # the tables (3 of int32 rows of ``cap``) and about 25 float32 per particle of state and scratch
        require_memory("dx", n, 100.0 + 12.0 * cap, "particles (fluid + wall) with their neighbour tables")
        self.fluid_fluid = self.moving_neighbours.add_table("fluid_fluid", "moving", "moving", cap, exclude_self=True)
        if nb:
            self.fluid_wall = self.moving_neighbours.add_table("fluid_wall", "moving", "walls", cap)
            self.wall_fluid = self.moving_neighbours.add_table("wall_fluid", "walls", "moving", cap)
        else:  # valid empty rows for the kernels
            self.fluid_wall = self.wall_fluid = SimpleNamespace(rows=empty_rows(nf, dev))
        self._report = Reduction(launcher, wp.vec4, "max")
        self._limits = self._step_limits()
        self.solids = model.solids
        if self.solids is not None:
            inside = self.solids.penetration(self.fluid.position)
            if inside:
                raise ParameterError("fluid", f"{inside.count} fluid particle(s) start inside a solid (deepest "
                                              f"{inside.max_depth:.3g} m {inside.where}, particle {inside.first_index})")
            # the fluid starts dx/2 clear of the surfaces (like its first wall layer on the other side)
            self._penalty = self.solids.penalty(0.5 * params.dx, params.c0)
        self.initialise()

    # -- set-up --------------------------------------------------------------------------------
    def _check_neighbours(self) -> int:
        """Reject an h too small for the spacing, reporting the neighbour count (fluid–fluid)."""
        P = self.model.params
        x = wp.clone(self.fluid.position)
        counts = NeighbourList(NeighbourGrid(self.launcher, P.support, self.model.space, x), x,
                               exclude_self=True).counts()
        need = MIN_NEIGHBOURS[P.dim]
        best = int(counts.max())
        if best < need and self.model.nf > 8 * need:
            raise ParameterError(
                "h_factor", f"h = {P.h:.4g} is too small for dx = {P.dx:.4g}: the best-surrounded "
                f"fluid particle has {best} neighbours, need >= {need} in {P.dim}D "
                f"(use h_factor >= 1.2 with support 2h)")
        return best

    def initialise(self) -> None:
        """Pressure from the EOS, the tables and the rates at t = 0 (the leapfrog start-up, seed 5-5)."""
        a, c = self.arrays, self.model.constants
        wp.copy(a.velocity_eval, self.fluid["velocity"])
        wp.copy(a.density_eval, self.fluid["density"])
        self.launcher.launch(K.equation_of_state, self.model.nf, [c, a.density_eval, self.state.pressure])
        with self.phases("neighbours"):
            self.moving_neighbours.rebuild()
        self.compute_rates()
        self._launch_report()

    def settle(self, duration: float, damping: float) -> dict:
        """Let the fluid come to rest in its own discretisation before t = 0: ``duration`` seconds of steps with
        every velocity damped as v ← v e^(-γΔt) (γ = ``damping``, 1/s), then velocities set to zero and the rates
        recomputed. Positions, densities and pressures keep what the discrete equations balance (a lattice or a
        relaxed arrangement given hydrostatic densities is only near that: its first steps would start a
        transient). Returns the step count and the kinetic energy and largest speed at the end of the settling."""
        require_positive("settle", duration)
        require_positive("damping", damping)
        c = self.model.constants
        c.damping = float(damping)
        t, steps = 0.0, 0
        try:
            while t < duration:
                dt = min(self.stable_dt(), duration - t)
                self.step(dt)
                t += dt
                steps += 1
                problem = self.problem()
                if problem:
                    raise RunError(f"settling failed at t = {t:.4g} s: {problem}")
        finally:
            c.damping = 0.0
        d = self.diagnostics()
        self.fluid["velocity"].zero_()
        self.initialise()
        return {"steps": steps, "kinetic_energy": d["kinetic_energy"], "max_speed": d["max_speed"]}

    # -- stepping --------------------------------------------------------------------------------
    def compute_rates(self) -> None:
        """Wall pressure (dynamic walls), then dρ/dt and dv/dt at the predicted state."""
        L, a, c = self.launcher, self.arrays, self.model.constants
        if self.model.terms.walls == "dynamic":
            with self.phases("boundary"):
                L.launch(self.kernels.wall_pressure, self.model.nb, [c, a, self.wall_fluid.rows])
        with self.phases("rates"):
            L.launch(self.kernels.rates, self.model.nf, [c, a, self.fluid_fluid.rows, self.fluid_wall.rows])
        if self.solids is not None:
            with self.phases("surfaces"):
                L.launch(add_surface_penalty, self.model.nf, [self._penalty, self.fluid_wall.rows.count,
                                                              self.fluid.position, a.acceleration])

    def _step_limits(self) -> K.StepLimits:
        """The stable step's terms as the device computes them (``kernels/wcsph.py: finish_step``)."""
        P = self.model.params
        limits = K.StepLimits()
        limits.cfl_h = wp.float64(P.cfl * P.h)
        limits.h = wp.float64(P.h)
        limits.c0 = wp.float64(P.c0)
        limits.viscous = wp.float64(0.125 * P.h * P.h * P.rho0 * self.model.viscosity_factor / P.mu
                                    if P.mu > 0 else math.inf)
        limits.shifting = wp.float64(0.125 * P.h / (P.shifting * P.shift_speed) if P.shifting > 0 else math.inf)
        return limits

    def _finish(self, end_of_step: bool = True) -> None:
        """The step's report reduced on the device, then copied into the clock with the next stable step; at the end
        of a step, the time moved on and the next step picked in the same launch."""
        self._report.launch(self.arrays.report)
        self.launcher.launch(K.finish_step, 1, [self._limits, self._report.result, self.clock.values,
                                                int(end_of_step)])
        self.clock.invalidate()

    def _launch_report(self) -> None:
        self.launcher.launch(K.step_report, self.model.nf, [self.model.constants, self.arrays])
        self._finish(end_of_step=False)

    def report(self) -> np.ndarray:
        """The last step's reduced report (one read per step, the clock's): max |Δx since build|², |v|², |a|², status."""
        return self.clock.report()[ck.SLOTS: ck.SLOTS + K.REPORT_SLOTS]

    def stable_dt(self) -> float:
        """Δt = min(C h/(max|v| + c0) [seed 5-12], 0.25 sqrt(h/max|a|), 0.125 h² ρ0/μ, 0.125 h²/(A h U)): the last
        two are the explicit-diffusion limits of the viscosity and of particle shifting (diffusivity A h U). Computed
        on the device from the last report (``kernels/wcsph.py: finish_step``), read with it."""
        return float(self.clock.report()[ck.LIMIT])

    def step(self, dt: float) -> None:
        """Advance one leapfrog step of ``dt`` seconds (kick–drift, rates, kick), the Δt written to the clock."""
        moved_bound = self._moved_bound(dt)
        self.clock.set_step(dt)
        self._launch_step(moved_bound)

    def advance(self) -> None:
        """One step of the Δt the device clock picks (the stable step, or the run's, landing on outputs)."""
        self._launch_step(self._moved_bound(self.clock.next_step()))

    def record_step(self) -> StepGraph:
        """:meth:`advance` as two Warp graphs around the host's rebuild decision: (drift), then a neighbour
        rebuild if the last report says a particle may have moved past the skin, then (rates, kick, report)."""
        L, a, c = self.launcher, self.arrays, self.model.constants
        with L.capturing() as first:
            with self.phases("integrate"):
                L.launch(self.kernels.drift, self.model.nf, [c, a, self.clock.values])
        with L.capturing() as second:
            self._after_drift()

        def rebuild_if_needed():
            if self.moving_neighbours.needs_rebuild(self._bound):
                with self.phases("neighbours"):
                    self.moving_neighbours.rebuild()

        def decide():
            self._bound = self._moved_bound(self.clock.next_step())

        return StepGraph([decide, first.graph, rebuild_if_needed, second.graph], after=self.clock.invalidate)

    def _moved_bound(self, dt: float) -> float:
        """Bound on the displacement since the table build after a drift of ``dt``: |Δx| <= Δt (|v| + ½Δt |a|) from
        the last report."""
        moved2, v2, a2, _ = self.report()
        return math.sqrt(moved2) + dt * (math.sqrt(v2) + 0.5 * dt * math.sqrt(a2))

    def _launch_step(self, moved_bound: float) -> None:
        with self.phases("integrate"):
            self.launcher.launch(self.kernels.drift, self.model.nf, [self.model.constants, self.arrays,
                                                                      self.clock.values])
        if self.moving_neighbours.needs_rebuild(moved_bound):
            with self.phases("neighbours"):
                self.moving_neighbours.rebuild()
        self._after_drift()

    def _after_drift(self) -> None:
        """Rates at the predicted state, the second kick, the step report and the clock's time."""
        self.compute_rates()
        with self.phases("integrate"):
            self.launcher.launch(self.kernels.kick, self.model.nf, [self.model.constants, self.arrays,
                                                                     self.clock.values])
            self._finish()  # finish_step also moves the time on and picks the next step

    def problem(self) -> str | None:
        """Non-finite values or particles outside the container after the last step (from its report)."""
        if self.report()[3] == K.STATUS_OK:
            return None
        status = self.arrays.report.numpy()[:, 3]  # only on failure: which particles
        bad = np.flatnonzero(status != K.STATUS_OK)
        kind = "non-finite values" if np.any(status[bad] == K.STATUS_NONFINITE) else "particles outside the container"
        return f"{kind} in {bad.size} fluid particle(s), first index {int(bad[0])}"

    def audit(self) -> str | None:
        """Fluid particles inside a solid (the true container and obstacle surfaces), measured on the device."""
        if self.solids is None:
            return None
        inside = self.solids.penetration(self.fluid.position)
        if not inside:
            return None
        dx = self.model.params.dx
        return (f"{inside.count} fluid particle(s) inside a solid; the deepest, fluid particle {inside.first_index} at "
                f"{tuple(round(c, 4) for c in inside.position)}, is {inside.max_depth:.3g} m ({inside.max_depth / dx:.2f} "
                f"dx) {inside.where}")

    def after_load(self) -> None:
        """After a checkpoint: the tables from the loaded ``position_at_build``, the report from the loaded state."""
        self.moving_neighbours.build_tables()
        self._launch_report()

    # -- outputs, diagnostics ------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return self.model.dim

    @property
    def work_items(self) -> int:
        """Particles a step touches (fluid + boundary: walls get a pressure pass every step)."""
        return self.model.n

    def output_sets(self) -> list[OutputSet]:
        """The fluid (coloured by speed by default) and the walls, as NumPy copies."""
        fluid = {k: self.fluid.numpy(k) for k in ("velocity", "density", "pressure")}
        fluid["speed"] = np.linalg.norm(fluid["velocity"], axis=1)
        sets = [OutputSet("fluid", self.fluid.numpy("position"), fluid, frame_field="speed"),
                OutputSet("boundary", self.boundary.numpy("position"),
                          {k: self.boundary.numpy(k) for k in ("density", "pressure")})]
        if self.obstacle.n:
            sets.append(OutputSet("obstacle", self.obstacle.numpy("position"),
                                  {k: self.obstacle.numpy(k) for k in ("density", "pressure")}, solid=True))
        return sets

    def output_fields(self) -> dict[str, list[str]]:
        fields = {"fluid": ["velocity", "density", "pressure", "speed"], "boundary": ["density", "pressure"]}
        if self.obstacle.n:
            fields["obstacle"] = ["density", "pressure"]
        return fields

    def output_meshes(self) -> dict:
        """The free surface (3D): the χ = 1/2 iso-surface of the colour function (seed eq. 5-7)."""
        if self.dim != 3:
            return {}
        from .surface import free_surface_mesh

        m = self.fluid.numpy("mass") / self.fluid.numpy("density")
        volumes = wp.array(m.astype(np.float32), dtype=float, device=self.launcher.device)
        mesh = free_surface_mesh(self.launcher, self.fluid.position, volumes, self.model.params.h,
                                 kernel=self.model.params.kernel)
        return {"surface": (mesh.vertices, mesh.faces)}

    def fluid_positions(self) -> np.ndarray:
        """(nf, 3) fluid positions (m), a copy."""
        return self.fluid.numpy("position")

    def diagnostics(self) -> dict[str, float]:
        """Kinetic energy (J, per metre of depth in 2D), fluid mass (kg), max speed (m/s), density range."""
        v = self.fluid.numpy("velocity").astype(np.float64)
        m = self.fluid.numpy("mass").astype(np.float64)
        rho = self.fluid.numpy("density")
        v2 = np.einsum("ij,ij->i", v, v)
        return {"kinetic_energy": float(0.5 * np.sum(m * v2)), "mass": float(np.sum(m)),
                "max_speed": float(np.sqrt(v2.max())), "density_min": float(rho.min()),
                "density_max": float(rho.max())}

    def describe(self) -> dict:
        d = self.model.describe()
        d.update({"max_neighbours": self.max_neighbours, "list_builds": self.moving_neighbours.builds})
        return d

