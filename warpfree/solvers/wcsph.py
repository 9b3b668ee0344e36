"""Weakly-compressible SPH solver (seed 004): orders the launches of :mod:`warpfree.kernels.sph_fluid`.

The solver owns its static model (kernel, h, constants, boundary model) and its state (positions,
velocities, densities, pressures, rates). One step is four launches: drift, wall pressure (dynamic
boundaries only), rates, kick; the neighbour lists are rebuilt only when a fluid particle has moved
more than half the skin since the last build. Fluid particles are indices ``[0, nf)`` of the
combined arrays and boundary particles ``[nf, n)``; :attr:`fluid` and :attr:`boundary` expose them
as views.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.errors import ParameterError, require_positive
from warpfree.kernels import sph_fluid as K
from warpfree.kernels.smoothing import kernel_id, support_factor
from warpfree.neighbours import NeighbourGrid, NeighbourTable, neighbour_counts
from warpfree.particles import ParticleSet, to_vec3

#: minimum neighbour count of the best-surrounded fluid particle (seed §5.5 recommends 20 in 2D, 56 in
#: 3D; a lattice with h = 1.3 dx and support 2h has 20 and 80). Below this, h is too small for dx.
MIN_NEIGHBOURS = {1: 4, 2: 20, 3: 56}


@dataclass
class FluidParams:
    """Model parameters of a WCSPH fluid (SI units)."""

    dim: int = 2
    dx: float = 0.02                 # initial particle spacing (m)
    h_factor: float = 1.3            # h = h_factor * dx
    kernel: str = "wendland_c2"
    rho0: float = 1000.0             # reference density (kg/m³)
    c0: float = 40.0                 # numerical speed of sound (m/s), ~10 × the largest flow speed
    gamma: float = 7.0               # Tait exponent
    mu: float = 1.0e-3               # dynamic viscosity (Pa·s), laminar term of Morris 1997
    alpha: float = 0.0               # Monaghan artificial viscosity (0 = off)
    delta: float = 0.0               # δ-SPH density diffusion coefficient (0 = off; 0.1 typical)
    gravity: tuple = (0.0, -9.81, 0.0)
    boundary_model: str = "dynamic"  # "dynamic" (Adami 2012) or "lennard_jones" (seed 5-6)
    no_slip: bool = True             # walls enter the viscous terms with a no-slip ghost velocity
    lj_d: float = 0.0                # Lennard-Jones strength D (m²/s²), ~ (largest speed)²
    lj_r0: float = 0.0               # Lennard-Jones range r0 (m): ~ dx for "lennard_jones" walls; with
                                     # "dynamic" walls a safety net when > 0 (e.g. 0.75 dx), 0 = off
    skin: float = 0.15               # neighbour-list skin as a fraction of the support (0 = rebuild every step)
    cfl: float = 0.1                 # Courant number of seed eq. 5-12
    dt: float | None = None          # fixed time step (s); None = the stable step every step
    container_lo: tuple = (-1e30, -1e30, -1e30)   # fluid must stay inside this box (m)
    container_hi: tuple = (1e30, 1e30, 1e30)

    @property
    def h(self) -> float:
        return self.h_factor * self.dx

    @property
    def b(self) -> float:
        """Tait stiffness B = ρ0 c0²/γ (Pa)."""
        return self.rho0 * self.c0 ** 2 / self.gamma

    @property
    def support(self) -> float:
        return support_factor(self.kernel) * self.h

    def validate(self) -> None:
        if self.dim not in (2, 3):
            raise ParameterError("dim", f"must be 2 or 3, got {self.dim!r}")
        require_positive("dx", self.dx)
        require_positive("h_factor", self.h_factor)
        if self.kernel not in ("cubic_spline", "wendland_c2", "quintic_spline"):
            raise ParameterError("kernel", f"must be cubic_spline, wendland_c2 or quintic_spline, got {self.kernel!r}")
        for name in ("rho0", "c0", "gamma"):
            require_positive(name, getattr(self, name))
        for name in ("mu", "alpha", "delta", "skin"):
            require_positive(name, getattr(self, name), allow_zero=True)
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ParameterError("gravity", f"must be 3 finite numbers, got {self.gravity!r}")
        if self.boundary_model not in ("dynamic", "lennard_jones"):
            raise ParameterError("boundary_model", f"must be 'dynamic' or 'lennard_jones', got {self.boundary_model!r}")
        if self.boundary_model == "lennard_jones":
            require_positive("lj_d", self.lj_d)
            require_positive("lj_r0", self.lj_r0)
        else:
            require_positive("lj_d", self.lj_d, allow_zero=True)
            require_positive("lj_r0", self.lj_r0, allow_zero=True)
            if self.lj_r0 >= self.dx:
                raise ParameterError("lj_r0", f"the safety net of dynamic walls must act below dx = {self.dx}, "
                                              f"got {self.lj_r0}")
        cfl = require_positive("cfl", self.cfl)
        if cfl > 1.0:
            raise ParameterError("cfl", f"must be in (0, 1], got {cfl}")
        if self.dt is not None:
            require_positive("dt", self.dt)
        lo = np.asarray(self.container_lo, dtype=float)
        hi = np.asarray(self.container_hi, dtype=float)
        if lo.shape != (3,) or hi.shape != (3,) or np.any(hi <= lo):
            raise ParameterError("container_hi", f"container box must have lo < hi, got {lo} .. {hi}")


class WCSPHSolver:
    """WCSPH fluid with dynamic (Adami) or Lennard-Jones boundary particles.

    Parameters
    ----------
    fluid: (N, dim) initial fluid positions (m).
    boundary: (M, dim) boundary particle positions (m); static.
    params: :class:`FluidParams`.
    density: optional (N,) initial fluid densities (e.g. hydrostatic); default ρ0.
    velocity: optional (N, dim) initial velocities (m/s); default 0.
    boundary_volume: volume (area in 2D) per boundary particle; default dx^dim.
    """

    name = "wcsph"

    def __init__(self, fluid, boundary, params: FluidParams, density=None, velocity=None,
                 boundary_volume: float | None = None, launcher: Launcher | None = None):
        params.validate()
        self.params = params
        self.launcher = launcher or current_launcher()
        dev = self.launcher.device
        d = params.dim
        xf = to_vec3(fluid, "fluid") if np.size(fluid) else np.zeros((0, 3), np.float32)
        if xf.shape[0] == 0:
            raise ParameterError("fluid", "is empty: the scene made no fluid particles")
        xb = to_vec3(boundary, "boundary") if np.size(boundary) else np.zeros((0, 3), np.float32)
        lo = np.asarray(params.container_lo, float)
        hi = np.asarray(params.container_hi, float)
        outside = np.any((xf < lo) | (xf > hi), axis=1)
        if outside.any():
            raise ParameterError("fluid", f"{int(outside.sum())} of {len(xf)} fluid particles lie outside the "
                                          f"container box {lo.tolist()} .. {hi.tolist()}")
        self.nf = xf.shape[0]
        self.nb = xb.shape[0]
        self.n = self.nf + self.nb
        x_all = np.vstack([xf, xb]).astype(np.float32)

        rho_f = np.full(self.nf, params.rho0) if density is None else np.asarray(density, float)
        if rho_f.shape != (self.nf,) or not np.all(np.isfinite(rho_f)) or np.any(rho_f <= 0):
            raise ParameterError("density", f"must be {self.nf} finite positive values")
        v_f = np.zeros((self.nf, 3)) if velocity is None else to_vec3(velocity, "velocity")
        if v_f.shape != (self.nf, 3):
            raise ParameterError("velocity", f"must have {self.nf} rows")
        vol_f = params.dx ** d
        vol_b = vol_f if boundary_volume is None else require_positive("boundary_volume", boundary_volume)

        def arr(values, dtype):
            return wp.array(values, dtype=dtype, device=dev)

        self.x = arr(x_all, wp.vec3)
        self.v = arr(np.vstack([v_f, np.zeros((self.nb, 3))]).astype(np.float32), wp.vec3)
        self.rho = arr(np.concatenate([rho_f, np.full(self.nb, params.rho0)]).astype(np.float32), float)
        self.mass = arr(np.concatenate([np.full(self.nf, params.rho0 * vol_f),
                                        np.full(self.nb, params.rho0 * vol_b)]).astype(np.float32), float)
        self.p = wp.zeros(self.n, dtype=float, device=dev)
        self.acc = wp.zeros(self.n, dtype=wp.vec3, device=dev)
        self.drho = wp.zeros(self.n, dtype=float, device=dev)
        self.v_eval = wp.clone(self.v)
        self.rho_eval = wp.clone(self.rho)
        self.wall_v = wp.zeros(self.n, dtype=wp.vec3, device=dev)
        self.ghost_v = wp.zeros(self.n, dtype=wp.vec3, device=dev)
        self.status = wp.zeros(self.n, dtype=wp.int32, device=dev)

        def part(arr, lo, hi):  # a view of rows [lo, hi); Warp refuses empty slices
            return arr[lo:hi] if hi > lo else wp.zeros(0, dtype=arr.dtype, device=dev)

        f, b = (0, self.nf), (self.nf, self.n)
        #: the fluid and boundary particle sets: named views into the combined arrays
        self.fluid = ParticleSet.view("fluid", d, {"x": part(self.x, *f), "velocity": part(self.v, *f),
                                                   "density": part(self.rho, *f), "pressure": part(self.p, *f),
                                                   "mass": part(self.mass, *f)})
        self.boundary = ParticleSet.view("boundary", d, {"x": part(self.x, *b), "density": part(self.rho, *b),
                                                         "pressure": part(self.p, *b), "mass": part(self.mass, *b)})
        self._kind = kernel_id(params.kernel)
        self._g = wp.vec3(*[float(c) for c in params.gravity])
        self._lo = wp.vec3(*[float(c) for c in np.maximum(lo, -3e38)])
        self._hi = wp.vec3(*[float(c) for c in np.minimum(hi, 3e38)])
        # Neighbour candidates: CSR lists within support + skin, rebuilt from the fluid positions at the
        # last build (x_built) once a fluid particle moved more than skin/2; the boundary is static.
        self.skin = params.skin * params.support
        self.x_built = wp.clone(self.fluid.x)
        self.moved2 = wp.zeros(self.nf, dtype=float, device=dev)
        self.fluid_grid = NeighbourGrid(self.x_built, params.support + self.skin, d, policy="static", device=dev)
        self.wall_grid = (NeighbourGrid(self.boundary.x, params.support + self.skin, d, policy="static", device=dev)
                          if self.nb else None)
        self.list_builds = 0
        self._check_neighbours(xf)
        cap = int(self.max_neighbours * (1.0 + params.skin) ** d * 1.2) + 8  # grows if ever too small
        self.ff, self.fw, self.wf = (NeighbourTable(self.launcher, cap) for _ in range(3))
        if not self.nb:  # valid (empty) boundary tables for the kernels
            empty = wp.zeros(0, dtype=wp.vec3, device=dev)
            self.fw.fill(self.fluid_grid, empty)
            self.wf.fill(self.fluid_grid, empty)
        self.timings = {"neighbours": 0.0, "boundary": 0.0, "rates": 0.0, "integrate": 0.0}
        self.problem: str | None = None
        self.initialise()

    # -- set-up checks ---------------------------------------------------------------------------
    def _check_neighbours(self, xf: np.ndarray) -> None:
        """Reject an h too small for the spacing, reporting the neighbour count (fluid-fluid)."""
        fluid_x = wp.array(xf, dtype=wp.vec3, device=self.launcher.device)
        g = NeighbourGrid(fluid_x, self.params.support, self.params.dim, policy="static")
        counts = neighbour_counts(self.launcher, g, fluid_x, exclude_self=True)
        need = MIN_NEIGHBOURS[self.params.dim]
        self.max_neighbours = int(counts.max())
        if self.max_neighbours < need and self.nf > 8 * need:
            raise ParameterError(
                "h_factor", f"h = {self.params.h:.4g} is too small for dx = {self.params.dx:.4g}: the best-surrounded "
                f"fluid particle has {self.max_neighbours} neighbours, need >= {need} in {self.params.dim}D "
                f"(use h_factor >= 1.2 with support 2h)")

    # -- stepping --------------------------------------------------------------------------------
    def build_lists(self) -> None:
        """Neighbour tables (fluid->fluid, fluid->boundary, boundary->fluid) from the positions in ``x_built``.

        They depend on ``x_built`` alone, so a resumed run rebuilds exactly the tables it had.
        """
        t0 = time.perf_counter()
        self.fluid_grid.build()
        self.ff.fill(self.fluid_grid, self.x_built, exclude_self=True)
        if self.nb:
            self.fw.fill(self.wall_grid, self.x_built)
            self.wf.fill(self.fluid_grid, self.boundary.x)
        self.list_builds += 1
        self.timings["neighbours"] += time.perf_counter() - t0

    def update_lists(self) -> None:
        """Rebuild the lists if a fluid particle moved more than half the skin since they were built."""
        moved = float(np.max(self.moved2.numpy())) if self.nf else 0.0
        if self.skin == 0.0 or moved > (0.5 * self.skin) ** 2:
            wp.copy(self.x_built, self.fluid.x)
            self.build_lists()

    def compute_rates(self) -> None:
        """Extrapolate the wall pressure, then dρ/dt and dv/dt at the current state."""
        P, L = self.params, self.launcher
        t1 = time.perf_counter()
        if P.boundary_model == "dynamic" and self.nb:
            L.launch(K.wall_pressure_adami, self.nb,
                     [self.wf.counts, self.wf.indices, self.wf.capacity, self.nf, self.x, self.v_eval, self.rho_eval, self.p, self._kind, P.dim,
                      P.h, P.support, self._g, P.rho0, P.b, P.gamma, self.wall_v, self.ghost_v])
        t2 = time.perf_counter()
        L.launch(K.fluid_rates, self.nf,
                 [self.ff.counts, self.ff.indices, self.ff.capacity, self.fw.counts, self.fw.indices,
                  self.fw.capacity, self.nf, self.nb,
                  self.x, self.v_eval, self.rho_eval, self.p, self.mass,
                  self.wall_v, self.ghost_v, self._kind, P.dim, P.h, P.support, P.rho0, P.c0, P.mu, P.alpha,
                  P.delta, self._g, 0 if P.boundary_model == "dynamic" else 1, int(P.no_slip),
                  float(P.lj_d), float(P.lj_r0), self.drho, self.acc])
        L.synchronize()
        t3 = time.perf_counter()
        self.timings["boundary"] += t2 - t1
        self.timings["rates"] += t3 - t2

    def initialise(self) -> None:
        """Pressure from the EOS and the rates at t = 0 (the leapfrog start-up, seed 5-5)."""
        P = self.params
        wp.copy(self.v_eval, self.v)
        wp.copy(self.rho_eval, self.rho)
        self.launcher.launch(K.equation_of_state, self.nf, [self.rho, P.rho0, P.b, P.gamma, self.p])
        wp.copy(self.x_built, self.fluid.x)
        self.build_lists()
        self.compute_rates()

    def stable_dt(self) -> float:
        """Δt = min(C h/(max|v| + c0) [seed 5-12], 0.25 sqrt(h/max|a|), 0.125 h² ρ0/μ)."""
        P = self.params
        v = self.v.numpy()[: self.nf]
        a = self.acc.numpy()[: self.nf]
        vmax = float(np.sqrt(np.max(np.einsum("ij,ij->i", v, v))))
        amax = float(np.sqrt(np.max(np.einsum("ij,ij->i", a, a))))
        dt = P.cfl * P.h / (vmax + P.c0)
        if amax > 0:
            dt = min(dt, 0.25 * math.sqrt(P.h / amax))
        if P.mu > 0:
            dt = min(dt, 0.125 * P.h * P.h * P.rho0 / P.mu)
        return dt

    def step(self, dt: float) -> None:
        """Advance one leapfrog step of ``dt`` seconds (kick–drift, rates, kick)."""
        P, L = self.params, self.launcher
        t0 = time.perf_counter()
        L.launch(K.leapfrog_drift, self.nf,
                 [float(dt), self.x, self.v, self.rho, self.acc, self.drho, P.rho0, P.b, P.gamma,
                  self.v_eval, self.rho_eval, self.p, self._lo, self._hi, self.status, self.x_built, self.moved2],
                 light=True)
        t1 = time.perf_counter()
        self.update_lists()
        self.compute_rates()
        t2 = time.perf_counter()
        L.launch(K.leapfrog_kick, self.nf,
                 [float(dt), self.x, self.v, self.rho, self.acc, self.drho, self._lo, self._hi, self.status],
                 light=True)
        L.synchronize()
        self.timings["integrate"] += (t1 - t0) + (time.perf_counter() - t2)
        self.problem = self._status_problem()

    def _status_problem(self) -> str | None:
        s = self.status.numpy()[: self.nf]
        if not s.any():
            return None
        bad = np.flatnonzero(s)
        kind = "non-finite values" if np.any(s[bad] == 1) else "particles outside the container"
        return f"{kind} in {bad.size} fluid particle(s), first index {int(bad[0])}"

    # -- state, outputs, diagnostics ---------------------------------------------------------------
    def state_arrays(self) -> dict[str, wp.array]:
        """Every array that changes in time (what a checkpoint must hold for a bitwise resume)."""
        return {"x": self.x, "v": self.v, "rho": self.rho, "p": self.p, "acc": self.acc, "drho": self.drho,
                "v_eval": self.v_eval, "rho_eval": self.rho_eval, "ghost_v": self.ghost_v, "x_built": self.x_built,
                "moved2": self.moved2}

    def after_load(self) -> None:
        """Rebuild derived structures after a checkpoint was loaded: the lists, from the loaded ``x_built``."""
        self.build_lists()

    def output_sets(self) -> dict[str, dict[str, np.ndarray]]:
        """Per-set NumPy fields for VTU and frames (positions under ``points``; speed added for the fluid)."""
        out = {}
        for pset in (self.fluid, self.boundary):
            fields = {k: v.numpy() for k, v in pset.fields.items() if k != "mass"}
            fields["points"] = fields.pop("x")
            if "velocity" in fields:
                fields["speed"] = np.linalg.norm(fields["velocity"], axis=1)
            out[pset.name] = fields
        return out

    def fluid_positions(self) -> np.ndarray:
        return self.x.numpy()[: self.nf]

    def diagnostics(self) -> dict[str, float]:
        """Kinetic energy (J, per metre of depth in 2D), fluid mass (kg), max speed (m/s), density range."""
        v = self.v.numpy()[: self.nf]
        m = self.mass.numpy()[: self.nf].astype(np.float64)
        rho = self.rho.numpy()[: self.nf]
        v2 = np.einsum("ij,ij->i", v.astype(np.float64), v.astype(np.float64))
        return {
            "kinetic_energy": float(0.5 * np.sum(m * v2)),
            "mass": float(np.sum(m)),
            "max_speed": float(np.sqrt(v2.max())),
            "density_min": float(rho.min()),
            "density_max": float(rho.max()),
        }

    def describe(self) -> dict:
        P = self.params
        d = asdict(P)
        d.update({"h": P.h, "support": P.support, "B": P.b, "n_fluid": self.nf, "n_boundary": self.nb,
                  "n_particles": self.n, "max_neighbours": self.max_neighbours, "list_builds": self.list_builds})
        return d


    def surface_mesh(self):
        """Free-surface triangle mesh of the fluid (seed eq. 5-7 colour function, iso 0.5), 3D only."""
        from warpfree.io.surface import free_surface_mesh

        vol = (self.mass.numpy()[: self.nf] / self.rho.numpy()[: self.nf]).astype(np.float32)
        volumes = wp.array(vol, dtype=float, device=self.launcher.device)
        return free_surface_mesh(self.launcher, self.x[: self.nf], volumes, self.params.h, kernel=self.params.kernel,
                                 dim=self.params.dim)

    @property
    def work_items(self) -> int:
        """Particles counted in particle-steps per second (fluid + boundary)."""
        return self.n

