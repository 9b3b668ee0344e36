"""Weakly-compressible SPH solver (Monaghan 1994): orders the launches of :mod:`warpfree.kernels.wcsph`.

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
from warpfree.distribution import dealt_blocks
from warpfree.parallel import world as ranks_of_run
from warpfree.parallel.halo import whole_from_pieces
from warpfree.parallel.moving import points3
from warpfree.errors import ParameterError, RunError, require_memory, require_positive
from warpfree.kernels import wcsph as K
from warpfree.parameters import Choice
from warpfree.neighbours import GridPairs, MovingNeighbours, NeighbourGrid, NeighbourList, empty_rows
from warpfree.particles import ParticleSet, to_vec3
from warpfree.progress import announced, group_digits
from warpfree.graph import StepGraph
from warpfree.kernels import clock as ck
from warpfree.reduce import Reduction
from warpfree.kernels import wcsph_bodies as bw
from warpfree.kernels.wcsph_open import make_buffer_values
from warpfree.kernels.wcsph_sensors import make_sample
from warpfree.kernels import wcsph_solids as sk
from warpfree.kernels.wcsph_solids import add_surface_penalty
from warpfree.solver import OutputSet, State, TimeDependentSolver

from .bodies import BODY_SLICES, quat_matrix, quat_multiply, rotation_quat
from .model import WCSPHModel
from .spread import STEP_FIELDS, WORK_PHASES, FluidSpread

__all__ = ["WCSPHSolver", "WCSPHState", "FluidField"]

#: minimum neighbour count of the best-surrounded fluid particle (chapter 5 of a Portuguese thesis on SPH fluids,
#: §5.5, recommends 20 in 2D, 56 in 3D; a lattice with h = 1.3 dx and support 2h has 20 and 80). Below this, h is
#: too small for dx.
MIN_NEIGHBOURS = {1: 4, 2: 20, 3: 56}

#: how far (in dx) a floating body's wall particles are kept from the static solids' surfaces: its own surface then
#: stays one spacing from theirs
CONTACT_REACH = 1.5

#: the units of the output sets' quantities (SI)
UNITS = {"position": "m", "velocity": "m/s", "speed": "m/s", "density": "kg/m³", "pressure": "Pa"}


class FluidField(Choice):
    """The fluid's field that frames colour by."""

    SPEED = "speed", "|v| (m/s)"
    PRESSURE = "pressure", "p (Pa)"
    DENSITY = "density", "ρ (kg/m³)"
    VELOCITY_X = "velocity_x", "v_x (m/s)"
    VELOCITY_Y = "velocity_y", "v_y (m/s)"
    VELOCITY_Z = "velocity_z", "v_z (m/s)"


class WCSPHState(State):
    """What changes in time (the checkpoint): combined fluid + wall arrays and the fluid's rates.

    position, velocity, density, pressure (n); acceleration, density_rate (nf); position_at_build (nf):
    the fluid positions of the last neighbour-table build (the tables are rebuilt from it on resume); clock: the
    clock's array (``warpfree.clock``: t, Δt, the next stable step, the last step report and the settling damping);
    fluid_id, fluid_owned (host, set by the layout): which fluid particles the arrays hold, and which of them this
    process owns (every one, in one process), so that a checkpoint reads on any number of processes.
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
    distributes = True
    work_unit = "particle-steps"
    report_slots = K.REPORT_SLOTS + 1  # the step report, then the settling damping (``kernels/wcsph.py``)
    limit_on_device = True

    @announced(lambda self, model, *a, **k: f"fluid solver made ({group_digits(model.nf)} fluid, "
               f"{group_digits(model.nb)} wall particles)")
    def __init__(self, model: WCSPHModel, density=None, velocity=None, launcher: Launcher | None = None):
        if not isinstance(model, WCSPHModel):
            raise ParameterError("model", f"a WCSPHSolver takes a WCSPHModel, got {type(model).__name__}")
        launcher = launcher or model.launcher
        params = model.params
        super().__init__(model, launcher)
        nf = model.nf
        rho_f = np.full(nf, params.rho0) if density is None else np.asarray(density, float)
        if rho_f.shape != (nf,) or not np.all(np.isfinite(rho_f)) or np.any(rho_f <= 0):
            raise ParameterError("density", f"must be {nf} finite positive values")
        v_f = np.zeros((nf, 3)) if velocity is None else to_vec3(velocity, "velocity")
        if v_f.shape != (nf, 3):
            raise ParameterError("velocity", f"must have {nf} rows")
        self.world = ranks_of_run()
        #: how the fluid is spread over the ranks (one process: a one-rank partition, the whole fluid)
        self.spread = FluidSpread(self.world, model)
        self.kernels = K.make_kernels(model.terms)
        #: the inlets and outlets, or None; with them, the fluid ids issued so far and each opening's particles made
        #: and taken out (over every rank: host state)
        self.openings = model.openings
        if self.openings is not None:
            self._buffer_values = make_buffer_values(model.terms.kernel, params.dim, model.space.periodic)
            self._issued = nf
            self._made = np.zeros(self.openings.count, dtype=np.int64)
            self._taken_out = np.zeros(self.openings.count, dtype=np.int64)
        self._report = Reduction(launcher, wp.vec4, "max")
        self._walls_in_order = None  # the wall-pressure pass's launch order (:meth:`_wall_order`)
        self._busy_at_rebuild = 0.0  # the work phases' seconds at the last rebuild (:meth:`_busy_since_rebuild`)
        self._limits = self._step_limits()
        #: the rigid bodies' state and its value at the tables' build ((count, BODY_COLUMNS) float64, the same on every
        #: rank; ``kernels/wcsph_bodies.py``), or None
        self._body_state = self._body_state_at_build = None
        if model.bodies is not None:
            self._body_state = wp.array(model.bodies.initial_state(), dtype=wp.float64, device=launcher.device)
            self._body_state_at_build = wp.clone(self._body_state)
            self._body_half = np.zeros((model.bodies.count, 6))  # the floating bodies' V½, Ω½ within a step
        mass = model.mass.numpy()
        fluid = {"position": model.position_np[:nf], "velocity": v_f.astype(np.float32),
                 "density": rho_f.astype(np.float32), "mass": mass[:nf]}
        fluid, walls = self.spread.held_fluid(fluid), self.spread.held_walls(model.wall_values())
        self._grid_sizes = self.spread.grid_sizes(launcher)
        self.max_neighbours = self._check_neighbours(fluid["position"])
        cap = int(self.max_neighbours * (1.0 + params.skin) ** params.dim * 1.2) + 8  # grows if ever too small
        # the tables (3 of int32 rows of ``cap``) and about 25 float32 per particle of state and scratch
        require_memory("dx", len(fluid["position"]) + len(walls["position"]), 100.0 + 12.0 * cap,
                       "particles (fluid + wall) with their neighbour tables")
        self._lay_out(fluid, walls, {"fluid_fluid": cap, "fluid_wall": cap, "wall_fluid": cap})
        self.solids = model.solids
        if self.solids is not None:
            inside = self._penetration()
            if inside:
                raise ParameterError("fluid", f"{inside.count} fluid particle(s) start inside a solid (deepest "
                                              f"{inside.max_depth:.3g} m {inside.where}, particle {inside.first_index})")
            # the fluid starts dx/2 clear of the surfaces (like its first wall layer on the other side)
            self._penalty = self.solids.penalty(0.5 * params.dx, params.c0)
            #: a floating body's contact with the static solids: its wall particles, dx/2 inside its surface, kept
            #: 1.5 dx clear of theirs (the surface penalty's stiffness over that reach, damped), so that one layer of
            #: water, dx/2 clear of both surfaces, stays between them: the last one the resolution holds (a body
            #: closer would crush it against the penalty on both sides)
            self._contact = self.solids.penalty(CONTACT_REACH * params.dx, params.c0)
        self.initialise()

    def _lay_out(self, fluid: dict[str, np.ndarray], walls: dict[str, np.ndarray], capacities: dict[str, int],
                 relayout: bool = False) -> None:
        """The held particles' arrays, [fluid | walls] (the whole sets in one process; this rank's and its ghosts in a
        distributed run), their views, and the neighbour tables of the given capacities (``relayout``: the tables
        kept, as after a migration). ``fluid``: position,
        velocity, density and mass, and optionally pressure, acceleration, density_rate, velocity_eval and
        density_eval (the predicted state a rebuild carries); ``walls``: position, mass and surface velocity
        (``WCSPHModel.wall_values``)."""
        dev = self.launcher.device
        model, params = self.model, self.model.params
        nf, nb = len(fluid["position"]), len(walls["position"])
        n = nf + nb
        self.nf, self.nb, self.n = nf, nb, n
        self.n_container_walls = self.spread.n_container_walls()

        def arr(values, dtype):
            return wp.array(values, dtype=dtype, device=dev)

        def fluid_or_zeros(name, dtype, shape):
            values = fluid.get(name)
            return arr(values, dtype) if values is not None else wp.zeros(shape, dtype=dtype, device=dev)

        self.state = WCSPHState(
            position=arr(np.vstack([fluid["position"], walls["position"]]).astype(np.float32), wp.vec3),
            velocity=arr(np.vstack([fluid["velocity"], walls["velocity"]]).astype(np.float32), wp.vec3),
            density=arr(np.concatenate([fluid["density"], np.full(nb, params.rho0)]).astype(np.float32), float),
            pressure=arr(np.concatenate([fluid.get("pressure", np.zeros(nf)), np.zeros(nb)]).astype(np.float32),
                         float),
            acceleration=fluid_or_zeros("acceleration", wp.vec3, nf),
            density_rate=fluid_or_zeros("density_rate", float, nf),
            position_at_build=arr(fluid["position_at_build"], wp.vec3) if "position_at_build" in fluid
            else wp.zeros(nf, dtype=wp.vec3, device=dev),
            clock=self.clock.values)
        S = self.state
        if model.bodies is not None:
            S.body_state, S.body_state_at_build = self._body_state, self._body_state_at_build
        # which fluid particles the arrays hold: a checkpoint read on another number of processes needs it
        S.fluid_id = self.spread.fluid.ids.astype(np.int64)
        S.fluid_owned = self.spread.fluid.owned.astype(np.int8)
        if self.openings is not None:  # the fluid's ids are sparse: those issued, and the openings' counts
            S.fluid_ids_issued = int(self._issued)
            S.opening_made, S.opening_taken_out = self._made.copy(), self._taken_out.copy()
        #: the fluid rows this rank computes rates for: its own (a ghost's come from its owner)
        self._own_rows = arr(self.spread.fluid.owned_index.astype(np.int32), wp.int32)
        self.mass = arr(np.concatenate([fluid["mass"], walls["mass"]]), float)
        self.arrays = K.FluidArrays()
        a = self.arrays
        a.nf = nf
        a.position, a.velocity, a.density, a.pressure = S.position, S.velocity, S.density, S.pressure
        a.mass = self.mass
        a.acceleration, a.density_rate = S.acceleration, S.density_rate
        a.velocity_eval = fluid_or_zeros("velocity_eval", wp.vec3, nf)
        a.density_eval = fluid_or_zeros("density_eval", float, nf)
        a.ghost_velocity = wp.zeros(max(nb, 1), dtype=wp.vec3, device=dev)
        bodies = model.bodies is not None
        a.report = wp.zeros(nf + (nb if bodies else 0), dtype=wp.vec4, device=dev)  # with bodies: their walls' rows
        a.wall_acceleration = wp.zeros(nb if bodies else 1, dtype=wp.vec3, device=dev)
        #: with bodies, each held wall's body (-1: at rest), its offset in the body's frame and its position at the
        #: tables' build
        self._wall_body = self._wall_offset = self._wall_position_at_build = None
        if bodies:
            self._wall_body = arr(walls["body"], wp.int32)
            self._wall_body_np = np.asarray(walls["body"])
            self._wall_offset = arr(walls["offset"], wp.vec3d)
            self._wall_position_at_build = wp.zeros(nb, dtype=wp.vec3, device=dev)
        n_shift = nf if model.terms.shifting else 1  # scratch of this step's shift (written by rates, used by kick)
        a.shift_velocity = wp.zeros(n_shift, dtype=wp.vec3, device=dev)
        a.shift_acceleration = wp.zeros(n_shift, dtype=wp.vec3, device=dev)
        a.shift_density_rate = wp.zeros(n_shift, dtype=float, device=dev)
        a.density_gradient = wp.zeros(nf if model.terms.delta_gradient else 1, dtype=wp.vec3, device=dev)
        a.zone = wp.zeros(nf if self.openings is not None else 1, dtype=wp.int32, device=dev)
        #: the held walls' surface velocity v0 and the velocity factor's table (walls moving as f(t) v0), or None
        self._wall_motion = None
        if model.wall_velocity_factor is not None and nb:
            times, factors = model.wall_velocity_factor
            self._wall_motion = (arr(times, wp.float64), arr(factors, float), arr(walls["velocity"], wp.vec3))

        def part(array, start, stop):  # a view of rows [start, stop); Warp refuses empty slices
            return array[start:stop] if stop > start else wp.zeros(0, dtype=array.dtype, device=dev)

        walls_end = nf + self.n_container_walls
        f, b, o = (0, nf), (nf, walls_end), (walls_end, n)
        spread = self.spread
        #: the fluid, the container walls and the obstacles' walls: named views into the combined arrays (in a
        #: distributed run a set's ``numpy`` gathers the whole set)
        self.fluid = ParticleSet.view("fluid", params.dim, {
            "position": part(S.position, *f), "velocity": part(S.velocity, *f), "density": part(S.density, *f),
            "pressure": part(S.pressure, *f), "mass": part(self.mass, *f)}, partition=spread.fluid)
        self.boundary, self.obstacle = (ParticleSet.view(name, params.dim, {
            "position": part(S.position, *r), "density": part(S.density, *r), "pressure": part(S.pressure, *r),
            "mass": part(self.mass, *r)}) for name, r in (("boundary", b), ("obstacle", o)))
        #: all wall particles (containers, then obstacles): the static set the fluid's tables query
        self.walls = part(S.position, nf, n)
        #: the held fluid arrays a ghost takes from its owner after each kick (``spread.STEP_FIELDS``)
        self._step_fields = [{"position": self.fluid.position, "velocity": self.fluid["velocity"],
                              "density": self.fluid["density"], "acceleration": S.acceleration,
                              "density_rate": S.density_rate}[k] for k in STEP_FIELDS]
        self._walls_view = {"pressure": part(S.pressure, nf, n), "density": part(S.density, nf, n),
                            "ghost_velocity": part(a.ghost_velocity, 0, nb)}

        # Neighbour candidates within support + skin, rebuilt once a fluid particle may have moved skin/2. A layout
        # after a migration keeps the grids and tables (their capacities and arrays) and fills them at the rebuild.
        a.position_at_build = S.position_at_build
        if bodies:
            self._place_walls()
        if relayout:
            self.moving_neighbours.follow(self.fluid.position, S.position_at_build,
                                          {"walls": self.walls} if model.nb else None, self._walls_at_build())
        else:
            self._make_tables(capacities)
        if not model.nb:  # valid empty rows for the kernels
            self.fluid_wall = self.wall_fluid = SimpleNamespace(rows=empty_rows(nf, dev), capacity=1)

    def _make_tables(self, capacities: dict[str, int]) -> None:
        """The neighbour grids and tables of the held particles, of the given capacities."""
        model, params, S = self.model, self.model.params, self.state
        self.moving_neighbours = MovingNeighbours(
            self.launcher, model.space, self.fluid.position, params.support, model.skin,
            static_sets={"walls": self.walls} if model.nb else None, position_at_build=S.position_at_build,
            sized_for=self._grid_sizes, static_at_build=self._walls_at_build())
        if model.terms.fluid_pairs == "grid":  # read from the moving grid at every sweep: no table
            self.fluid_fluid = GridPairs(self.moving_neighbours)
        else:
            self.fluid_fluid = self.moving_neighbours.add_table("fluid_fluid", "moving", "moving",
                                                                capacities["fluid_fluid"], exclude_self=True)
        if model.nb:
            self.fluid_wall = self.moving_neighbours.add_table("fluid_wall", "moving", "walls",
                                                               capacities["fluid_wall"])
            self.wall_fluid = self.moving_neighbours.add_table("wall_fluid", "walls", "moving",
                                                               capacities["wall_fluid"])

    def _walls_at_build(self) -> dict[str, wp.array] | None:
        """The walls' positions at the tables' build, when bodies move some of them (else the walls are static)."""
        return {"walls": self._wall_position_at_build} if self._wall_position_at_build is not None else None

    # -- rigid bodies ----------------------------------------------------------------------------
    def _move_bodies(self, at_step_end: bool) -> None:
        """The bodies' state at the time of the next rates (t + Δt after a drift, else t): the prescribed ones' from
        their motions, the floating ones' drifted (:meth:`_drift_floating`); then their walls and surfaces where it
        puts them."""
        bodies = self.model.bodies
        bodies.launch_poses(self.clock.values, at_step_end, self._body_state)
        if bodies.floating and at_step_end:
            self._drift_floating()
        self._place_walls()

    def _drift_floating(self) -> None:
        """The floating bodies' half kick and drift (float64, on the host: a few numbers a body), in step with the
        fluid's leapfrog: V½ = V + ½Δt A, c ← c + Δt V½, q ← exp(½Δt Ω½) q; their velocity at t + Δt predicted as
        V½ + ½Δt A (what the walls carry into the rates, as the fluid's v*)."""
        bodies, dt = self.model.bodies, float(self.clock.step)
        state = self._body_state.numpy()
        x, q, v, w, a, alpha = BODY_SLICES
        for b in bodies.floating:
            row = state[b]
            half_v, half_w = row[v] + 0.5 * dt * row[a], row[w] + 0.5 * dt * row[alpha]
            row[x] += dt * half_v
            turned = quat_multiply(rotation_quat(dt * half_w), row[q])
            row[q] = turned / np.linalg.norm(turned)
            row[v], row[w] = half_v + 0.5 * dt * row[a], half_w + 0.5 * dt * row[alpha]
            self._body_half[b] = np.concatenate([half_v, half_w])
        self._body_state.assign(state)

    def _kick_floating(self, initial: bool = False) -> None:
        """The floating bodies' accelerations from the fluid's load on them (:meth:`body_loads`) and their weight,
        A = F/m and α = I⁻¹ (τ - Ω × I Ω) (I turned with the body), over their free degrees of freedom; then, but for
        the ``initial`` rates, their second half kick V = V½ + ½Δt A."""
        bodies, dt = self.model.bodies, float(self.clock.step)
        state = self._body_state.numpy()
        force, moment = self.body_loads(state)
        gravity = np.asarray(self.model.params.gravity, dtype=np.float64)
        _, q, v, w, a, alpha = BODY_SLICES
        for b in bodies.floating:
            row = state[b]
            free_t, free_r = bodies.free[b, :3], bodies.free[b, 3:]
            rotation = quat_matrix(row[q])
            inertia = rotation @ bodies.inertia[b] @ rotation.T
            row[a] = (force[b] / bodies.mass[b] + gravity) * free_t
            row[alpha] = np.linalg.solve(inertia, moment[b] - np.cross(row[w], inertia @ row[w])) * free_r
            if not initial:
                half = self._body_half[b]
                row[v], row[w] = half[:3] + 0.5 * dt * row[a], half[3:] + 0.5 * dt * row[alpha]
        self._body_state.assign(state)

    def body_state(self) -> np.ndarray:
        """(count, BODY_COLUMNS) float64: every rigid body's state now (``kernels/wcsph_bodies.py``: position,
        rotation quaternion, velocity, spin, acceleration, spin rate), a copy, the same on every rank."""
        if self._body_state is None:
            return np.zeros((0, bw.BODY_COLUMNS))
        return self._body_state.numpy().copy()

    def body_loads(self, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The fluid's force (N; per metre in 2D) on each body and its moment about the body's reference point (N m),
        (count, 3) float64 each: the reaction to the wall terms of the last rates on its wall particles, summed in
        the walls' global order, the same on every rank (as :meth:`force_on`). ``state``: the bodies' state already read
        (else read here)."""
        bodies = self.model.bodies
        part = self.spread.walls
        own = part.owned_index
        mine = own[self._wall_body_np[own] >= 0]
        ids, force, where = self._wall_forces(mine, part.ids[mine], self._contact_forces(mine))
        body = bodies.wall_body[ids]
        state = self._body_state.numpy() if state is None else state
        arm = where - state[body, BODY_SLICES[0]]
        total, moment = np.zeros((bodies.count, 3)), np.zeros((bodies.count, 3))
        for b in range(bodies.count):
            on = body == b
            total[b] = force[on].sum(axis=0)
            moment[b] = np.cross(arm[on], force[on]).sum(axis=0)
        return total, moment

    def _row_scratch(self, use: str, rows: np.ndarray) -> tuple[wp.array, wp.array]:
        """``rows`` (int) on the device and a vec3 result per row, kept for ``use`` while the rows stay the same (a
        floating body's loads every step allocate nothing)."""
        key = (use, rows.astype(np.int32).tobytes())
        cache = self.__dict__.setdefault("_rows_scratch", {})
        if key not in cache:
            dev = self.launcher.device
            for old in [k for k in cache if k[0] == use]:  # the rows of this use changed (a migration): drop the old
                del cache[old]
            cache[key] = (wp.array(rows.astype(np.int32), dtype=wp.int32, device=dev),
                          wp.zeros(rows.size, dtype=wp.vec3, device=dev))
        return cache[key]

    def _contact_forces(self, rows: np.ndarray) -> np.ndarray | None:
        """The static solids' contact force (N; per metre in 2D) on each held wall of ``rows`` of a floating body
        (``kernels/wcsph_solids.py: contact_acceleration`` times its share of the body's mass; zero for the prescribed
        bodies' walls), or None without static solids."""
        solids, bodies = self.model.solids, self.model.bodies
        if solids is None or solids.static_count == 0 or not bodies.floating or not rows.size:
            return None
        on, out = self._row_scratch("contact", rows)
        self.launcher.launch(sk.contact_acceleration, rows.size, [
            self._contact, solids.static_count, on, self.nf, self.arrays.position, self.arrays.velocity, out])
        body = self._wall_body_np[rows]
        share = np.zeros(len(body))
        for b in bodies.floating:
            share[body == b] = bodies.mass[b] / np.count_nonzero(bodies.wall_body == b)
        return out.numpy().astype(np.float64) * share[:, None]

    def _wall_forces(self, rows: np.ndarray, ids: np.ndarray,
                     extra: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The fluid's force on each held wall of ``rows`` (this rank's own; global wall ``ids``), plus ``extra`` (a
        force per row) when given, and its position, gathered from every rank in the walls' global order: (ids,
        forces (m, 3), positions (m, 3)), float64."""
        force = np.zeros((0, 3))
        if rows.size:
            on, out = self._row_scratch("wall", rows)
            self.launcher.launch(self.kernels.wall_force, rows.size, [
                self.model.constants, self.arrays, self.wall_fluid.rows, on, out])
            force = out.numpy().astype(np.float64)
            if extra is not None:
                force = force + extra
        where = self.walls.numpy()[rows].astype(np.float64)
        every = self.world.allgather_objects((ids, force, where))
        ids = np.concatenate([e[0] for e in every])
        order = np.argsort(ids, kind="stable")
        return (ids[order], np.concatenate([e[1] for e in every])[order],
                np.concatenate([e[2] for e in every])[order])

    def _place_walls(self) -> None:
        """The bodies' held walls (position, velocity, acceleration, report rows) and surfaces at the bodies' state."""
        a = self.arrays
        self.launcher.launch(bw.rigid_walls, self.nb, [
            self.nf, self.model.constants.box, self._wall_body, self._wall_offset, self._body_state, a.position,
            a.velocity, a.wall_acceleration, self._wall_position_at_build, a.report])
        if self.model.solids is not None:
            self.model.solids.follow(self._body_state)

    def _build_tables(self) -> None:
        """The neighbour tables at the current positions (the fluid's and the bodies' walls'), the bodies' state at
        the build kept with them."""
        self.moving_neighbours.rebuild()
        if self._body_state is not None:
            wp.copy(self._body_state_at_build, self._body_state)
            self._place_walls()  # their report rows: moved 0 since this build

    def _tables_from_state(self) -> None:
        """After a checkpoint: the tables the run had, from the build positions in the state (the fluid's, and the
        bodies' walls where the bodies' state at the build put them)."""
        if self._body_state is not None:
            wp.copy(self._wall_position_at_build, self.walls)
            self.launcher.launch(bw.rigid_points, self.nb, [self.model.constants.box, self._wall_body,
                                                            self._wall_offset, self._body_state_at_build,
                                                            self._wall_position_at_build])
            self._place_walls()
        self.moving_neighbours.build_tables()

    def _host_wall_positions(self) -> np.ndarray:
        """(nb, 3) float64: every wall of the model where the bodies' state puts it (on the host, every rank the same):
        which rank holds which wall."""
        model = self.model
        return model.bodies.wall_positions(self._body_state.numpy(), model.position_np[model.nf:])

    # -- set-up --------------------------------------------------------------------------------
    def _check_neighbours(self, fluid_position: np.ndarray) -> int:
        """Reject an h too small for the spacing, reporting the neighbour count (fluid–fluid) of the
        best-surrounded fluid particle (over every rank)."""
        P = self.model.params
        x = wp.array(np.asarray(fluid_position, np.float32), dtype=wp.vec3, device=self.launcher.device)
        counts = NeighbourList(NeighbourGrid(self.launcher, P.support, self.model.space, x), x,
                               exclude_self=True).counts()
        counts = counts[self.spread.fluid.owned_index]
        best = int(self.world.allreduce(np.array([counts.max() if counts.size else 0]), "max")[0])
        need = MIN_NEIGHBOURS[P.dim]
        if best < need and self.model.nf > 8 * need:
            raise ParameterError(
                "h_factor", f"h = {P.h:.4g} is too small for dx = {P.dx:.4g}: the best-surrounded "
                f"fluid particle has {best} neighbours, need >= {need} in {P.dim}D "
                f"(use h_factor >= 1.2 with support 2h)")
        return best

    def initialise(self) -> None:
        """Pressure from the EOS, the tables and the rates at t = 0 (the leapfrog start-up)."""
        a, c = self.arrays, self.model.constants
        wp.copy(a.velocity_eval, self.fluid["velocity"])
        wp.copy(a.density_eval, self.fluid["density"])
        self.launcher.launch(K.equation_of_state, self.nf, [c, a.density_eval, self.state.pressure])
        if self._body_state is not None:
            with self.phases("boundary"):
                self._move_bodies(at_step_end=False)
        with self.phases("neighbours"):
            self._build_tables()
        self.compute_rates(at_step_end=False)
        if self._body_state is not None and self.model.bodies.floating:
            with self.phases("boundary"):
                self._kick_floating(initial=True)
        self.spread.fluid.refresh(self.state.acceleration, self.state.density_rate)  # the ghosts' first drift's
        self._launch_report()

    @announced(lambda self, duration, *a, **k: f"water settled before t = 0 ({duration:.3g} s of damped steps)")
    def settle(self, duration: float, damping: float, hold_bodies: bool = False) -> dict:
        """Let the fluid come to rest in its own discretisation before t = 0: ``duration`` seconds of steps with
        every velocity damped as v ← v e^(-γΔt) (γ = ``damping``, 1/s), then velocities set to zero and the rates
        recomputed. Positions, densities and pressures keep what the discrete equations balance (a lattice or a
        relaxed arrangement given hydrostatic densities is only near that: its first steps would start a
        transient). Floating bodies move with the water meanwhile and end at rest with it, or, ``hold_bodies``, are
        held where they are (released from there at t = 0: a decay test). Returns the step count and the kinetic
        energy and largest speed at the end of the settling."""
        require_positive("settle", duration)
        require_positive("damping", damping)
        self._set_damping(damping)
        bodies = self.model.bodies
        free = None
        if hold_bodies and bodies is not None and bodies.floating:
            free, bodies.free = bodies.free, np.zeros_like(bodies.free)
            state = self._body_state.numpy()   # at rest, and no acceleration left from the initial rates
            state[bodies.floating, BODY_SLICES[2].start:] = 0.0
            self._body_state.assign(state)
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
            self._set_damping(0.0)
            if free is not None:
                bodies.free = free
        d = self.diagnostics()
        self.fluid["velocity"].zero_()
        if self._body_state is not None and self.model.bodies.floating:  # the floating bodies at rest too
            state = self._body_state.numpy()
            _, _, v, w, _, _ = BODY_SLICES
            state[self.model.bodies.floating, v] = 0.0
            state[self.model.bodies.floating, w] = 0.0
            self._body_state.assign(state)
        self.initialise()
        return {"steps": steps, "kinetic_energy": d["kinetic_energy"], "max_speed": d["max_speed"]}

    def _set_damping(self, damping: float) -> None:
        """The settling damping γ (1/s) in the clock's slot (``kernels/wcsph.py: DAMPING``): state, not model."""
        values = self.clock.report().copy()
        values[K.DAMPING] = float(damping)
        self.clock.values.assign(values)
        self.clock.invalidate()

    # -- stepping --------------------------------------------------------------------------------
    def compute_rates(self, at_step_end: bool = True) -> None:
        """The buffer particles' values (openings), the walls' velocity (walls moving as f(t) v0), wall pressure
        (dynamic walls), the renormalised density
        gradient (δ-SPH's ``delta_gradient``), then dρ/dt and dv/dt at the predicted state: at t + Δt after a drift
        (``at_step_end``), at the clock's t otherwise."""
        L, a, c = self.launcher, self.arrays, self.model.constants
        if self.openings is not None:
            grid = self.moving_neighbours.grids[MovingNeighbours.MOVING]
            with self.phases("boundary"):
                L.launch(self._buffer_values, self._own_rows.shape[0], [
                    c, a, self.openings.struct, grid.id, grid.points, grid.source_id, grid.radius, self._own_rows,
                    self.clock.values, int(at_step_end)])
            with self.phases("exchange"):  # a ghost buffer particle's mirror point may lie beyond this rank's fluid
                self.spread.fluid.refresh(a.zone, self.fluid["velocity"], a.velocity_eval, self.fluid["density"],
                                          a.density_eval, self.fluid["pressure"])
        if self._wall_motion is not None:
            times, factors, surface_velocity = self._wall_motion
            with self.phases("boundary"):
                L.launch(K.wall_motion, self.nb, [self.nf, self.clock.values, int(at_step_end), times, factors,
                                                  surface_velocity, a.velocity])
        if self.model.terms.walls == "dynamic":
            with self.phases("boundary"):
                L.launch(self.kernels.wall_pressure, self.nb, [c, a, self.wall_fluid.rows, self._wall_order()])
            with self.phases("exchange"):  # a ghost wall's fluid neighbours are not all held: its owner's values
                self.spread.walls.refresh(*self._walls_view.values())
        if self.model.terms.delta_gradient:
            with self.phases("rates"):
                L.launch(self.kernels.density_gradient, self._own_rows.shape[0], [c, a, self._fluid_pairs(),
                                                                                   self._own_rows])
            with self.phases("exchange"):  # a ghost's gradient needs neighbours this rank does not hold
                self.spread.fluid.refresh(a.density_gradient)
        with self.phases("rates"):
            L.launch(self.kernels.rates, self._own_rows.shape[0], [c, a, self._fluid_pairs(), self.fluid_wall.rows,
                                                                    self._own_rows])
        if self.solids is not None:
            with self.phases("surfaces"):
                L.launch(add_surface_penalty, self.nf, [self._penalty, self.fluid_wall.rows.count,
                                                              self.fluid.position, a.acceleration])

    def _fluid_pairs(self):
        """The fluid pairs as the rates kernels take them: the table's rows, or the moving grid's (``fluid_pairs``)."""
        pairs = self.fluid_fluid
        return pairs.struct() if isinstance(pairs, GridPairs) else pairs.rows

    def _wall_order(self) -> wp.array:
        """The order the wall-pressure pass takes the held walls in: blocks of walls dealt round-robin to the
        launcher's threads (``distribution.dealt_blocks``). The walls next to the water are a run of the wall array
        (the 3D dam break: 90 % of the pass's neighbour candidates in the first of two contiguous chunks), and a
        gather gives the same values in any order. Made again when the held walls are counted anew."""
        order = self._walls_in_order
        if order is None or order.shape[0] != self.nb:
            order = wp.array(dealt_blocks(self.nb, self.launcher.threads), dtype=wp.int32, device=self.launcher.device)
            self._walls_in_order = order
        return order

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
        with self.phases("exchange"):  # the one reduction of a step: every rank's largest values
            self.world.allreduce_in_place(self._report.result, "max")
        self.launcher.launch(K.finish_step, 1, [self._limits, self._report.result, self.clock.values,
                                                int(end_of_step)])
        self.clock.invalidate()

    def _launch_report(self) -> None:
        self.launcher.launch(K.step_report, self.nf, [self.model.constants, self.arrays])
        self._finish(end_of_step=False)

    def report(self) -> np.ndarray:
        """The last step's reduced report (one read per step, the clock's): max |Δx since build|², |v|², |a|², status."""
        return self.clock.report()[ck.SLOTS: ck.SLOTS + K.REPORT_SLOTS]

    def stable_dt(self) -> float:
        """Δt = min(C h/(max|v| + c0) [CFL], 0.25 sqrt(h/max|a|), 0.125 h² ρ0/μ, 0.125 h²/(A h U)): the last
        two are the explicit-diffusion limits of the viscosity and of particle shifting (diffusivity A h U). Computed
        on the device from the last report (``kernels/wcsph.py: finish_step``), read with it."""
        return float(self.clock.report()[ck.LIMIT])

    def advance(self) -> None:
        """One leapfrog step (kick–drift, rates, kick) of the Δt the clock holds (the stable step, or the run's,
        landing on outputs); its last launch moves the time on and picks the next step."""
        self._launch_step(self._moved_bound(self.clock.step))

    def record_step(self) -> StepGraph:
        """:meth:`advance` as two Warp graphs around the host's rebuild decision: (drift), then a neighbour
        rebuild if the last report says a particle may have moved past the skin, then (rates, kick, report)."""
        L, a, c = self.launcher, self.arrays, self.model.constants
        if self._body_state is not None and self.model.bodies.floating:
            return None  # the floating bodies' step is the host's, between launches
        if self.openings is not None:
            return None  # the fluid's arrays are made anew where particles enter and leave
        with L.capturing() as first:
            self._drift()
        with L.capturing() as second:
            self._after_drift()
        recorded = {"rates": second.graph, "arrays": self._rebuilt_arrays()}

        def rebuild_if_needed():
            if self.moving_neighbours.needs_rebuild(self._bound):
                self._rebuild()
                arrays = self._rebuilt_arrays()
                if arrays != recorded["arrays"]:  # a table grew, or the grid's points moved: record the rates again
                    with L.capturing() as again:
                        self._after_drift()
                    recorded.update(rates=again.graph, arrays=arrays)

        def decide():
            self._bound = self._moved_bound(self.clock.step)

        return StepGraph([decide, first.graph, rebuild_if_needed, lambda: wp.capture_launch(recorded["rates"])],
                         after=self.clock.invalidate)

    def _rebuilt_arrays(self) -> tuple:
        """Where the arrays a rebuild may replace lie (each neighbour table's rows, each grid's points and their
        sources: address and length): a recorded step that reads them is recorded again when one moved."""
        out = []
        for table, *_ in self.moving_neighbours.tables.values():
            out += [(a.ptr, a.shape[0]) for a in (table.rows.start, table.rows.count, table.rows.index)]
        for grid in self.moving_neighbours.grids.values():
            out += [None if a is None else (a.ptr, a.shape[0]) for a in (grid.points, grid.source_id)]
        return tuple(out)

    def _moved_bound(self, dt: float) -> float:
        """Bound on the displacement since the table build after a drift of ``dt``: |Δx| <= Δt (|v| + ½Δt |a|) from
        the last report."""
        moved2, v2, a2, _ = self.report()
        return math.sqrt(moved2) + dt * (math.sqrt(v2) + 0.5 * dt * math.sqrt(a2))

    def _drift(self) -> None:
        """The fluid's drift to t + Δt, and the bodies moved there."""
        with self.phases("integrate"):
            self.launcher.launch(self.kernels.drift, self.nf, [self.model.constants, self.arrays, self.clock.values])
        if self._body_state is not None:
            with self.phases("boundary"):
                self._move_bodies(at_step_end=True)

    def _launch_step(self, moved_bound: float) -> None:
        self._drift()
        if self.moving_neighbours.needs_rebuild(moved_bound):
            self._rebuild()
        self._after_drift()

    def _rebuild(self) -> None:
        """The neighbour tables at the current positions; in a distributed run the fluid first moves to the ranks
        whose boxes now hold it (and the decomposition is cut anew when the work is out of balance)."""
        with self.phases("neighbours"):
            if self._body_state is not None and not self.spread.whole:
                self.spread.move_walls(self._host_wall_positions())
            if self.openings is not None:
                self._enter_and_leave()
            else:
                self.spread.redistribute(self._held_fluid, self._work, self._lay_out_again,
                                         self._busy_since_rebuild())
            self._build_tables()

    def _enter_and_leave(self) -> None:
        """At a rebuild with openings (``openings.py``): a buffer particle that crossed its plane into the domain since
        the last build makes a new one a buffer depth behind it (the next ids, in the crossing particles' id order over
        every rank); a particle beyond its buffer's far end is taken out; then the fluid is laid out anew (moving to
        the ranks that hold it in a distributed run). A rebuild where nothing entered or left is a plain one."""
        openings, part = self.openings, self.spread.fluid
        values = self._held_fluid()
        x = values["position"]
        was, now = openings.zone(self.state.position_at_build.numpy()), openings.zone(x)
        owned = part.owned.astype(bool)
        parents = np.flatnonzero(owned & (was >= 0) & (now < 0))
        leaving = openings.beyond(x, now)
        parent_ids = part.ids[parents].astype(np.int64)
        every = np.sort(np.concatenate(self.world.allgather(parent_ids)))
        child_ids = self._issued + np.searchsorted(every, parent_ids)
        k = openings.count
        counts = np.concatenate([np.bincount(was[parents], minlength=k),
                                 np.bincount(now[owned & leaving], minlength=k)]).astype(np.int64)
        counts = self.world.allreduce(counts, "sum")
        if not counts.any():  # nothing entered or left (every rank agrees): a plain rebuild, the arrays kept
            self.spread.redistribute(self._held_fluid, self._work, self._lay_out_again, self._busy_since_rebuild())
            return
        self._issued += every.size
        self._made += counts[:k]
        self._taken_out += counts[k:]
        keep = np.flatnonzero(~leaving)
        rows = np.concatenate([keep, parents])
        fluid = {name: v[rows] for name, v in values.items()}
        behind = (openings.thickness[was[parents], None] * openings.normal[was[parents]]).astype(np.float32)
        fluid["position"][keep.size:] -= behind
        fluid["acceleration"][keep.size:] = 0.0
        fluid["density_rate"][keep.size:] = 0.0
        ids = np.concatenate([part.ids[keep].astype(np.int64), child_ids])
        own = np.concatenate([owned[keep], np.ones(parents.size, dtype=bool)])
        fluid_cost, wall_cost = self._work()
        self.spread.redistribute_changed(fluid, ids, own, self._issued, lambda: (fluid_cost[rows], wall_cost),
                                         self._lay_out_again, self._busy_since_rebuild())

    def opening_counts(self) -> dict[str, dict[str, int]]:
        """Each opening's particles made (fluid that entered the domain through it) and taken out (fluid that left
        through it) since t = 0, over every rank, by name."""
        if self.openings is None:
            return {}
        return {name: {"made": int(self._made[k]), "taken_out": int(self._taken_out[k])}
                for k, name in enumerate(self.openings.names)}

    def _busy_since_rebuild(self) -> float:
        """Seconds of this rank's work on its particles (``spread.WORK_PHASES``) since the last rebuild."""
        busy = sum(self.phases.seconds.get(name, 0.0) for name in WORK_PHASES)
        since, self._busy_at_rebuild = busy - self._busy_at_rebuild, busy
        return since

    def _held_fluid(self) -> dict[str, np.ndarray]:
        """The held fluid rows a rebuild carries to the ranks that now hold them (``spread.MOVING_FIELDS``, after the
        drift, and the mass), as NumPy."""
        S, a = self.state, self.arrays
        return {"position": self.fluid.numpy_held("position"), "velocity": self.fluid.numpy_held("velocity"),
                "density": self.fluid.numpy_held("density"), "pressure": self.fluid.numpy_held("pressure"),
                "acceleration": S.acceleration.numpy(), "density_rate": S.density_rate.numpy(),
                "velocity_eval": a.velocity_eval.numpy(), "density_eval": a.density_eval.numpy(),
                "mass": self.fluid.numpy_held("mass")}

    def _work(self) -> tuple[np.ndarray, np.ndarray]:
        """Each held fluid and wall particle's work: its neighbour count at the last build."""
        fluid_cost = self.fluid_fluid.counts().astype(np.float64)
        wall_cost = np.zeros(self.nb)
        if self.model.nb:
            fluid_cost = fluid_cost + self.fluid_wall.counts()
            wall_cost = self.wall_fluid.counts().astype(np.float64)
        return fluid_cost, wall_cost

    def _lay_out_again(self, fluid: dict[str, np.ndarray], walls: dict[str, np.ndarray]) -> None:
        """The arrays laid out for new held rows, the grids and tables kept."""
        self._lay_out(fluid, walls, {}, relayout=True)

    def _after_drift(self) -> None:
        """Rates at the predicted state, the second kick (the floating bodies' too), the step report and the clock's
        time."""
        self.compute_rates()
        if self._body_state is not None and self.model.bodies.floating:
            with self.phases("boundary"):
                self._kick_floating()
        with self.phases("integrate"):
            self.launcher.launch(self.kernels.kick, self.nf, [self.model.constants, self.arrays,
                                                               self.clock.values])
        with self.phases("exchange"):  # every ghost as its owner: the next drift reads these
            self.spread.fluid.start_refresh(*self._step_fields)
        with self.phases("integrate"):  # while they travel: the report over owned rows (a ghost's row: 0, neutral)
            self.spread.fluid.set_ghosts(self.arrays.report, wp.vec4())
            self._finish()  # finish_step also moves the time on and picks the next step
        with self.phases("exchange"):
            self.spread.fluid.finish_refresh()

    def problem(self) -> str | None:
        """Non-finite values or particles outside the container after the last step (from its report)."""
        if self.report()[3] == K.STATUS_OK:
            return None
        status = self.arrays.report.numpy()[:, 3]  # only on failure: which particles
        rows, ids = self._own_fluid()
        bad = rows[status[rows] != K.STATUS_OK]
        message = None
        if bad.size:
            kind = ("non-finite values" if np.any(status[bad] == K.STATUS_NONFINITE)
                    else "particles outside the container")
            count = bad.size
            message = f"{kind} in {{count}} fluid particle(s), first index {int(ids[np.searchsorted(rows, bad[0])])}"
        else:
            count = 0
        total = int(self.world.allreduce(np.array([count]), "sum")[0])
        message = self.world.first_message(message)
        return message.replace("{count}", str(total)) if message else None

    def _penetration(self):
        """The fluid inside a solid, over every rank: the count, and the deepest particle (global index)."""
        rows, ids = self._own_fluid()
        inside = self.solids.penetration(wp.array(self.fluid.numpy_held("position")[rows], dtype=wp.vec3,
                                                  device=self.launcher.device))
        mine = (inside.count, inside.max_depth, int(ids[inside.first_index]) if inside else -1, inside.where,
                tuple(inside.position))
        every = self.world.allgather_objects(mine)
        count = sum(e[0] for e in every)
        deepest = max((e for e in every if e[0] > 0), key=lambda e: e[1], default=None)
        if deepest is None:
            return type(inside)(0, 0.0, -1)
        return type(inside)(count, deepest[1], deepest[2], deepest[3], deepest[4])

    def audit(self) -> str | None:
        """Fluid particles inside a solid (the true container and obstacle surfaces), measured on the device."""
        if self.solids is None:
            return None
        inside = self._penetration()
        if not inside:
            return None
        dx = self.model.params.dx
        return (f"{inside.count} fluid particle(s) inside a solid; the deepest, fluid particle {inside.first_index} at "
                f"{tuple(round(c, 4) for c in inside.position)}, is {inside.max_depth:.3g} m ({inside.max_depth / dx:.2f} "
                f"dx) {inside.where}")

    def after_load(self) -> None:
        """After a checkpoint: the tables from the loaded ``position_at_build`` (and the bodies' state at the build),
        the report from the loaded state."""
        self._tables_from_state()
        self._launch_report()

    #: the fluid arrays a checkpoint read on another number of processes carries (the walls' are recomputed by a
    #: step before they are read; the predicted values by its drift)
    RESTORED = ("position", "velocity", "density", "pressure", "acceleration", "density_rate", "position_at_build")

    def restore_pieces(self, pieces: list[dict]) -> None:
        """The whole fluid from every process's checkpoint (each its own particles, by ``fluid_id``), spread anew over
        this run's ranks as at a rebuild from the build positions: the tables, made from ``position_at_build``, are
        the ones the run had, and it continues as it would have. With openings the ids are sparse (the ids issued and
        the openings' counts come with the first piece)."""
        model = self.model
        count = model.nf
        if self.openings is not None:
            first = pieces[0]
            if "fluid_ids_issued" not in first:
                raise ParameterError("resume", "the checkpoint does not match this scene: it has no openings")
            count = int(first["fluid_ids_issued"])
            self._issued = count
            self._made = np.array(first["opening_made"], dtype=np.int64)
            self._taken_out = np.array(first["opening_taken_out"], dtype=np.int64)
        # each piece's fluid rows (its combined arrays hold its walls after them): as many as its ``fluid_id``
        whole = whole_from_pieces(pieces, self.RESTORED, "fluid_id", None if self.openings is not None else count,
                                  owned="fluid_owned")
        ids = whole.pop("fluid_id", None)
        if self._body_state is not None:  # the same on every rank: the first piece's
            self._body_state.assign(pieces[0]["body_state"])
            self._body_state_at_build.assign(pieces[0]["body_state_at_build"])
            self.spread.move_walls(self._host_wall_positions())
        rows = self.spread.respread(whole["position_at_build"].astype(np.float64), ids, count)
        fluid = {k: v[rows] for k, v in whole.items()}
        fluid["mass"] = np.full(rows.size, model.mass.numpy()[0])  # every fluid particle has the same mass
        self._lay_out_again(fluid, self.spread.held_walls(model.wall_values()))
        self.clock.values.assign(pieces[0]["clock"])
        self.clock.invalidate()
        self.after_load()

    def load_state(self, values: dict, source: str) -> None:
        """A checkpoint of this run's own layout; with openings (a fluid whose count changes) through
        :meth:`restore_pieces`, which lays the arrays out for its count."""
        if self.openings is None:
            super().load_state(values, source)
        else:
            self.restore_pieces([values])

    # -- outputs, diagnostics ------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """The dimension (2 or 3)."""
        return self.model.dim

    @property
    def work_items(self) -> int:
        """Particles a step touches (fluid + boundary: walls get a pressure pass every step)."""
        return self.model.n

    def _own_fluid(self) -> tuple[np.ndarray, np.ndarray]:
        """(held rows of this rank's own fluid particles, their global indices): every row in one process."""
        part = self.spread.fluid
        return part.owned_index, part.ids[part.owned_index]

    def _own_walls(self) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """For the container walls and the obstacles' walls: (rows in their held view, global indices in their set)."""
        ncw = self.n_container_walls
        part = self.spread.walls
        own, ids = part.owned_index, part.ids[part.owned_index]
        box, obs = own < ncw, own >= ncw
        return (own[box], ids[box]), (own[obs] - ncw, ids[obs] - self.model.n_container_walls)

    def output_sets(self) -> list[OutputSet]:
        """The fluid (coloured by speed by default) and the walls, as NumPy copies: every particle in one process;
        a rank's own in a distributed run (``OutputSet.ids``: their indices in the whole set)."""
        rows, ids = self._own_fluid()
        fluid = {k: self.fluid.numpy_held(k)[rows] for k in ("velocity", "density", "pressure")}
        fluid["speed"] = np.linalg.norm(fluid["velocity"], axis=1)
        (b_rows, b_ids), (o_rows, o_ids) = self._own_walls()
        sets = [OutputSet("fluid", self.fluid.numpy_held("position")[rows], fluid, frame_field="speed",
                          ids=ids, units=UNITS),
                OutputSet("boundary", self.boundary.numpy_held("position")[b_rows],
                          {k: self.boundary.numpy_held(k)[b_rows] for k in ("density", "pressure")},
                          ids=b_ids, units=UNITS)]
        if self.model.nb > self.model.n_container_walls:
            sets.append(OutputSet("obstacle", self.obstacle.numpy_held("position")[o_rows],
                                  {k: self.obstacle.numpy_held(k)[o_rows] for k in ("density", "pressure")}, solid=True,
                                  ids=o_ids, units=UNITS))
        return sets

    def output_fields(self) -> dict[str, list[str]]:
        """The fields each output set writes: the fluid's velocity (m/s), density (kg/m³), pressure (Pa) and speed
        (m/s); the walls' and obstacles' density and pressure."""
        fields = {"fluid": ["velocity", "density", "pressure", "speed"], "boundary": ["density", "pressure"]}
        if self.model.nb > self.model.n_container_walls:
            fields["obstacle"] = ["density", "pressure"]
        return fields

    def output_meshes(self) -> dict:
        """The free surface (3D): the χ = 1/2 iso-surface of the colour function χ = Σ_j V_j W_j."""
        if self.dim != 3:
            return {}
        from .surface import free_surface_mesh

        m = self.fluid.numpy("mass") / self.fluid.numpy("density")
        # the whole fluid's surface, on every rank (rank 0 writes it)
        positions = wp.array(self.fluid.numpy("position"), dtype=wp.vec3, device=self.launcher.device)
        volumes = wp.array(m.astype(np.float32), dtype=float, device=self.launcher.device)
        mesh = free_surface_mesh(self.launcher, positions, volumes, self.model.params.h,
                                 kernel=self.model.params.kernel)
        return {"surface": (mesh.vertices, mesh.faces)}

    def fluid_positions(self) -> np.ndarray:
        """(nf, 3) fluid positions (m), a copy."""
        return self.fluid.numpy("position")

    def field_at(self, points) -> dict[str, np.ndarray]:
        """The fluid at ``points`` ((m, dim) or (m, 3), m): ``filled`` (Σ V_j W_j: 1 inside the water, about 1/2 at
        a free surface or a wall's face, 0 in air), ``pressure`` (Pa, from the equation of state of the current
        density), ``density`` (kg/m³) and ``velocity`` ((m, 3), m/s), fitted first-order consistent from the fluid
        within the support, and ``wall_pressure`` (Pa: the average over the fluid and the wall particles within the
        support, what a pressure transducer in a wall's face reads) (``kernels/wcsph_sensors.py``; NaN where no fluid
        is). The same values on every rank: each
        point is gathered by the rank whose box holds it, from its particles and ghosts in the one process's order."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] not in (self.dim, 3) or not np.all(np.isfinite(pts)):
            raise ParameterError("points", f"must be finite (m, {self.dim}) or (m, 3) coordinates, got shape "
                                           f"{pts.shape}")
        pts = points3(pts)
        mine = np.flatnonzero(self.spread.decomposition.owner(pts) == self.world.rank)
        out = np.zeros((len(pts), 7))
        if mine.size:
            grid = self.moving_neighbours.grids[MovingNeighbours.MOVING]
            at, filled, pressure, density, velocity, surface = self._sample_arrays(pts[mine])
            terms = self.model.terms
            walls = self.moving_neighbours.grids.get("walls", grid)  # none: the fluid's grid, never queried
            sample = make_sample(terms.kernel, terms.dim, terms.periodic,
                                 "walls" in self.moving_neighbours.grids and terms.walls == "dynamic")
            self.launcher.launch(sample, mine.size, [self.model.constants, self.arrays, grid.id, grid.points,
                                                     grid.source_id, walls.id, walls.points, walls.source_id,
                                                     grid.radius, at, filled, pressure, density, velocity, surface],
                                 once=True)
            out[mine] = np.column_stack([filled.numpy(), pressure.numpy(), density.numpy(), velocity.numpy(),
                                         surface.numpy()])
        out = self.world.allreduce(out, "sum")  # each point's values from one rank, zeros from the others: exact
        return {"filled": out[:, 0], "pressure": out[:, 1], "density": out[:, 2], "velocity": out[:, 3:6],
                "wall_pressure": out[:, 6]}

    #: point sets whose sample arrays :meth:`field_at` keeps (a scene's sensors, each sampled again and again)
    SAMPLED_SETS = 8

    def _sample_arrays(self, points: np.ndarray) -> tuple[wp.array, ...]:
        """The device arrays :meth:`field_at` reads ``points`` (m, 3) with: their positions, then filled, pressure,
        density, velocity and wall pressure, kept per point set (no allocation when a sensor samples again)."""
        key = points.astype(np.float32).tobytes()
        cache = self.__dict__.setdefault("_sampled", {})
        if key not in cache:
            dev, m = self.launcher.device, points.shape[0]
            if len(cache) >= self.SAMPLED_SETS:
                del cache[next(iter(cache))]
            cache[key] = (wp.array(points.astype(np.float32), dtype=wp.vec3, device=dev),
                          *(wp.zeros(m, dtype=float, device=dev) for _ in range(3)),
                          wp.zeros(m, dtype=wp.vec3, device=dev), wp.zeros(m, dtype=float, device=dev))
        return cache[key]

    def force_on(self, walls: str, about) -> tuple[np.ndarray, np.ndarray]:
        """The fluid's force on the ``walls`` ("obstacles" or "containers": their wall particles) (N; per metre of
        depth in 2D) and its moment about the point ``about`` (N m; per metre in 2D), float64: the reaction to the
        wall terms of the last rates (``kernels/wcsph.py: wall_force``), summed in the walls' global order, the same
        on every rank."""
        (box_rows, box_ids), (obs_rows, obs_ids) = self._own_walls()
        rows, ids = (obs_rows + self.n_container_walls, obs_ids) if walls == "obstacles" else (box_rows, box_ids)
        _, force, where = self._wall_forces(rows, ids)
        arm = where - points3(np.asarray(about, dtype=np.float64).reshape(1, -1))[0]
        return force.sum(axis=0), np.cross(arm, force).sum(axis=0)

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
        """The run for ``summary.json``: the model, the neighbour capacity and rebuilds, the distributed layout."""
        d = self.model.describe()
        d.update({"max_neighbours": self.max_neighbours, "list_builds": self.moving_neighbours.builds})
        d.update(self.spread.describe())
        return d

