"""The static model of a WCSPH fluid: parameters, derived constants, what is compiled in, particle masses.

:class:`FluidParams` is what a scene sets (SI units). :class:`WCSPHModel` derives from it, once, the
``@wp.struct`` constants every kernel takes (:class:`~warpfree.kernels.wcsph.FluidConstants`) and the
compile-time switches (:class:`~warpfree.kernels.wcsph.FluidTerms`): a term whose coefficient is 0
(μ, α, δ, the wall safety net) is not compiled into the scene's kernels.

The laminar viscosity (Morris 1997) is scaled by 1/S, S = -(1/d) Σ_j V r_j dW/dr r_j²/(r_j² + 0.01 h²) its
discrete second moment on the particles' initial lattice (:func:`lattice_second_moment`): exact for a
linear shear on the lattice, 1 in the continuum. Without it the term gives S μ at every resolution
(Wendland C2, h = 1.3 dx, 2D: S = 0.9627; cubic spline 0.9998), a viscous error that does not converge
(measured on transient Poiseuille flow: stalled at 2.4% of the centre velocity).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import warp as wp

from warpfree.device import Launcher, current_launcher
from warpfree.progress import announced, group_digits
from warpfree.errors import ParameterError, require_positive
from warpfree.kernels.smoothing import kernel_id, kernel_profile, normalisation, support_factor
from warpfree.kernels.wcsph import FluidConstants, FluidTerms
from warpfree.parameters import Choice
from warpfree.particles import to_vec3
from warpfree.smoothing import SmoothingKernel
from warpfree.space import Space

from .bodies import Bodies
from .openings import Openings
from .solids import Solids

__all__ = ["FluidParams", "WCSPHModel", "BoundaryModel", "FluidPairs", "lattice_second_moment"]


class BoundaryModel(Choice):
    """How wall particles act on the fluid."""

    DYNAMIC = "dynamic", ("dynamic wall particles (Adami, Hu & Adams 2012): pressure extrapolated from the fluid, "
                          "no-slip ghost velocity")
    LENNARD_JONES = "lennard_jones", "a Lennard-Jones repulsive force from one layer of wall particles (Monaghan 1994)"

#: h/dx by dimension when a model does not set it: about 30 neighbours in 2D (1.6: 31 on the lattice), 80 in 3D
#: (1.3). Measured in 2D: at 1.3 (20 neighbours, the 1.2-1.3 of the SPH-fluids thesis, ch. 5) the error of a
#: disordered arrangement does not converge (Taylor-Green with shifting: -7 % at t_e for n = 50 and 100) and a
#: relaxed tank at rest keeps a kinetic energy noise floor ten times higher; at 1.6 the Taylor-Green error converges
#: (2.4, 0.9, 0.45 % at n = 25, 50, 100) and the default dam break costs the same (fewer, longer steps) with a
#: slightly closer front.
DEFAULT_H_FACTOR = {2: 1.6, 3: 1.3}

#: particle shifting removes the normal component where ∇·r is below this fraction of its full-support lattice
#: value: on the lattice the first two rows under a free surface (0.64 and 0.96 of it), no row deeper (1.00)
SURFACE_DIV_FRACTION = 0.975


def lattice_second_moment(kernel: SmoothingKernel, dim: int, h_factor: float, eps: float = 0.01) -> float:
    """S = -(1/d) Σ_{j≠0} V r_j (dW/dr)(r_j) r_j² / (r_j² + eps h²) over the square lattice of spacing dx (V = dx^d),
    with the normalised kernel of ``warpfree.kernels.smoothing`` and h = h_factor dx: the factor by which the
    Morris/Brookshaw Laplacian of a quadratic field falls short on the lattice (dimensionless, dx-independent)."""
    m = int(math.ceil(support_factor(kernel) * h_factor)) + 1
    k = np.arange(-m, m + 1, dtype=np.float64)
    offsets = np.stack(np.meshgrid(*[k] * dim, indexing="ij"), -1).reshape(-1, dim)
    r = np.linalg.norm(offsets, axis=1)
    r = r[r > 0]
    dwdr = kernel_profile(kernel, dim, r, "dwdr", float(h_factor))
    h = float(h_factor)
    return float(-np.sum(r * dwdr * r * r / (r * r + eps * h * h)) / dim)


class FluidPairs(Choice):
    """Where the rates kernels find a fluid particle's fluid neighbours."""

    ROWS = "rows", ("a neighbour table's rows, kept between rebuilds (the candidates within support + skin, about "
                    "100 four-byte entries a particle in 3D)")
    GRID = "grid", ("the neighbour grid of the last rebuild, queried at every sweep (no table: about 200 bytes a "
                    "particle less in 3D; more candidates tested a step)")


@dataclass
class FluidParams:
    """Model parameters of a WCSPH fluid (SI units)."""

    dim: int = 2
    dx: float = 0.02                 # initial particle spacing (m)
    h_factor: float | None = None    # h = h_factor * dx; None: DEFAULT_H_FACTOR[dim]
    kernel: SmoothingKernel = SmoothingKernel.WENDLAND_C2
    rho0: float = 1000.0             # reference density (kg/m³)
    c0: float = 40.0                 # numerical speed of sound (m/s), ~10 × the largest flow speed
    gamma: float = 7.0               # Tait exponent
    tension: bool = True             # the EOS gives negative pressures (False: p >= 0, a fluid without tension)
    mu: float = 1.0e-3               # dynamic viscosity (Pa·s), laminar term of Morris 1997 (0 = off)
    alpha: float = 0.0               # Monaghan artificial viscosity (0 = off)
    delta: float = 0.0               # δ-SPH density diffusion coefficient (0 = off; 0.1 typical)
    delta_gradient: bool = False     # δ-SPH corrected by the renormalised density gradient (Antuono et al. 2010)
                                     # instead of the hydrostatic one: a pass more per step (kernels/wcsph.py)
    gravity: tuple = (0.0, -9.81, 0.0)
    boundary_model: BoundaryModel = BoundaryModel.DYNAMIC
    no_slip: bool = True             # walls enter the viscous terms with a no-slip ghost velocity
    wall_artificial_viscosity: bool = False  # artificial viscosity on fluid-wall pairs too (default: fluid pairs only)
    riemann: float = 0.0             # η of the Riemann pair pressure's dissipation limiter (0 = off, Monaghan's pair
                                     # pressure; 3 is Zhang, Hu & Adams 2017's): kernels/wcsph.py
    shifting: float = 0.0            # particle shifting coefficient A (0 = off; 2 is Lind et al. 2012's and
                                     # DualSPHysics' choice): δu = -A h U ∇C̃ (kernels/wcsph.py)
    shifting_speed: float = 0.0      # U of the shifting (m/s); 0 = c0/10, the flow speed c0 was chosen for
    lj_d: float = 0.0                # Lennard-Jones strength D (m²/s²), ~ (largest speed)²
    lj_r0: float = 0.0               # Lennard-Jones range r0 (m): ~ dx for "lennard_jones" walls; with
                                     # "dynamic" walls a safety net when > 0 (e.g. 0.75 dx), 0 = off
    skin: float = 0.15               # neighbour-list skin as a fraction of the support (0 = rebuild every step)
    cfl: float = 0.1                 # Courant number C of the CFL condition Δt = C h/(c0 + max|v|)
    container_lo: tuple = (-1e30, -1e30, -1e30)   # fluid must stay inside this box (m)
    container_hi: tuple = (1e30, 1e30, 1e30)
    periodic: tuple = (False, False, False)       # periodic axes; their period is the container box
    fluid_pairs: FluidPairs = FluidPairs.ROWS  # the fluid pairs from a table's rows or the grid's (kernels/wcsph.py)

    def __post_init__(self):
        if self.h_factor is None:
            self.h_factor = DEFAULT_H_FACTOR.get(self.dim, 1.3)
        self.kernel = SmoothingKernel.of("kernel", self.kernel)
        self.boundary_model = BoundaryModel.of("boundary_model", self.boundary_model)
        self.fluid_pairs = FluidPairs.of("fluid_pairs", self.fluid_pairs)

    @property
    def h(self) -> float:
        """The smoothing length h = h_factor dx (m)."""
        return self.h_factor * self.dx

    @property
    def b(self) -> float:
        """Tait stiffness B = ρ0 c0²/γ (Pa)."""
        return self.rho0 * self.c0 ** 2 / self.gamma

    @property
    def support(self) -> float:
        """The kernel's support radius (m): its support factor times h."""
        return support_factor(self.kernel) * self.h

    @property
    def shift_speed(self) -> float:
        """U of the particle shifting (m/s): ``shifting_speed``, or c0/10 when 0."""
        return self.shifting_speed or 0.1 * self.c0

    def validate(self) -> None:
        """Refuse a bad parameter by name (dimension, spacing, kernel, EOS, viscosities, shifting, ...)."""
        if self.dim not in (2, 3):
            raise ParameterError("dim", f"must be 2 or 3, got {self.dim!r}")
        require_positive("dx", self.dx)
        require_positive("h_factor", self.h_factor)
        for name in ("rho0", "c0", "gamma"):
            require_positive(name, getattr(self, name))
        for name in ("mu", "alpha", "delta", "skin", "shifting", "shifting_speed", "riemann"):
            require_positive(name, getattr(self, name), allow_zero=True)
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ParameterError("gravity", f"must be 3 finite numbers, got {self.gravity!r}")
        if self.boundary_model is BoundaryModel.LENNARD_JONES:
            require_positive("lj_d", self.lj_d)
            require_positive("lj_r0", self.lj_r0)
        else:
            require_positive("lj_d", self.lj_d, allow_zero=True)
            require_positive("lj_r0", self.lj_r0, allow_zero=True)
            if self.lj_r0 >= self.dx:
                raise ParameterError("lj_r0", f"the safety net of dynamic walls must act below dx = {self.dx}, "
                                              f"got {self.lj_r0}")
        if self.shifting > 0 and self.boundary_model is not BoundaryModel.DYNAMIC:
            raise ParameterError("shifting", "needs dynamic walls (boundary_model='dynamic'): shifting counts the "
                                             "wall particles' volume so that the fluid is not pushed into the walls")
        cfl = require_positive("cfl", self.cfl)
        if cfl > 1.0:
            raise ParameterError("cfl", f"must be in (0, 1], got {cfl}")
        lo = np.asarray(self.container_lo, dtype=float)
        hi = np.asarray(self.container_hi, dtype=float)
        if lo.shape != (3,) or hi.shape != (3,) or np.any(hi <= lo):
            raise ParameterError("container_hi", f"container box must have lo < hi, got {lo} .. {hi}")
        if len(tuple(self.periodic)) != 3:
            raise ParameterError("periodic", f"must be three booleans, got {self.periodic!r}")
        for a, p in enumerate(self.periodic):
            if p and not (np.isfinite(lo[a]) and np.isfinite(hi[a]) and hi[a] - lo[a] < 1e20):
                raise ParameterError("periodic", f"a periodic axis needs a finite container along {'xyz'[a]}")

    def space(self) -> Space:
        """The space of the fluid: the container box carries the period of the periodic axes."""
        if any(self.periodic):
            return Space(self.dim, self.container_lo, self.container_hi, self.periodic)
        return Space.free(self.dim)


class WCSPHModel:
    """The static part of a WCSPH fluid: parameters, constants, terms, the particles' layout, masses and the true
    solid surfaces.

    Parameters
    ----------
    fluid: (N, dim) initial fluid positions (m): the layout the solver's state starts from.
    boundary: (M, dim) boundary particle positions (m) of the containers; static.
    params: :class:`FluidParams`.
    obstacle_boundary: optional (K, dim) boundary particles of obstacles (appended to the walls: the same
        physics), written as their own output set ``obstacle`` and drawn as solids in frames.
    boundary_volume: volume (area in 2D) per boundary particle; default dx^dim.
    fluid_volume: volume (area in 2D) per fluid particle; default dx^dim. A relaxed fill of a region that is not a
        union of lattice cells holds fewer particles than region/dx^dim: each then stands for region/N (the mass
        ρ0 × that volume), or the pressure gradient, which counts a volume per neighbour, falls short by as much.
    wall_velocity: the walls' surface velocity (m/s): one (dim,) velocity for every wall particle or (nb, dim), one
        per wall particle in the walls' order (containers', then obstacles'); default at rest. The walls stay in
        place and the fluid sees them move along their surface (a sliding lid, a belt, a cylinder spinning about its
        axis): the velocity enters continuity and, through the no-slip ghost velocity, the viscous terms.
    wall_velocity_factor: (times (s), factors): the walls move at f(t) × ``wall_velocity``, f linear between the
        table's points and its end values beyond them (a start-up ramp, an oscillation sampled finely enough);
        default f = 1. The walls' acceleration is not in their Adami pressure (exact for a steady surface velocity,
        and for a wall oscillating in its own plane, which pushes on nothing).
    openings: inlets and outlets (:class:`~warpfree.solvers.wcsph.openings.Opening`): planes with a buffer of fluid
        particles behind each (laid out in ``fluid`` with the rest of the fluid), where fluid enters and leaves.
    containers, obstacles: the true solid surfaces (3D: watertight trimesh meshes; 2D: closed polygons) that
        the fluid must stay inside / outside. The fluid feels them through a stiff penalty within dx/2 of a
        surface (``warpfree.kernels.wcsph_solids.add_surface_penalty``: it stores the kinetic energy of a particle
        at c0, so none crosses, and a fluid at rest dx/2 clear of the walls never feels it), beside the wall
        particles; and it is checked at every output against the surfaces themselves
        (:class:`~warpfree.solvers.wcsph.solids.Solids`): fluid inside a solid stops the run with the count and the
        depth.

    ``nf`` fluid and ``nb`` wall particles (containers' first, ``n_container_walls``, then obstacles'); ``mass`` (n,
    kg): ρ0 × volume per particle. ``constants`` and ``terms`` are what the kernels take.
    """

    @announced(lambda self, fluid, boundary, *a, **k: f"fluid model made ({group_digits(len(fluid))} fluid, "
               f"{group_digits(len(boundary))} wall particles)")
    def __init__(self, fluid, boundary, params: FluidParams, obstacle_boundary=None,
                 boundary_volume: float | None = None, fluid_volume: float | None = None, containers=(),
                 obstacles=(), wall_velocity=None, wall_velocity_factor=None, bodies=(), openings=(),
                 launcher: Launcher | None = None):
        params.validate()
        self.launcher = launcher or current_launcher()
        device = self.launcher.device
        xf = to_vec3(fluid, "fluid") if np.size(fluid) else np.zeros((0, 3), np.float32)
        if xf.shape[0] == 0:
            raise ParameterError("fluid", "is empty: the scene made no fluid particles")
        xb = to_vec3(boundary, "boundary") if np.size(boundary) else np.zeros((0, 3), np.float32)
        xo = (to_vec3(obstacle_boundary, "obstacle_boundary") if obstacle_boundary is not None
              and np.size(obstacle_boundary) else np.zeros((0, 3), np.float32))
        self.n_container_walls = len(xb)
        #: the rigid bodies among the walls, or None
        self.bodies = Bodies(bodies, params.dim, len(xb) + len(xo), self.launcher) if len(bodies) else None
        xb = np.vstack([xb, xo] + ([self.bodies.particles] if self.bodies else []))
        lo, hi = np.asarray(params.container_lo, float), np.asarray(params.container_hi, float)
        outside = np.any((xf < lo) | (xf > hi), axis=1)
        if outside.any():
            raise ParameterError("fluid", f"{int(outside.sum())} of {len(xf)} fluid particles lie outside the "
                                          f"container box {lo.tolist()} .. {hi.tolist()}")
        #: (n, 3) float32 positions: the fluid's initial ones, then the walls' (static)
        self.position_np = np.vstack([xf, xb]).astype(np.float32)
        self.params = params
        self.dim = params.dim
        self.nf = len(xf)
        self.nb = len(xb)
        self.n = self.nf + self.nb
        self.space = params.space()
        #: the inlets and outlets (:class:`~warpfree.solvers.wcsph.openings.Openings`), or None
        self.openings = Openings(openings, params, self.skin, device, xf) if len(openings) else None
        self.kernel_id = kernel_id(params.kernel)
        lattice = params.dx ** params.dim
        vol_f = lattice if fluid_volume is None else require_positive("fluid_volume", fluid_volume)
        vol_b = lattice if boundary_volume is None else require_positive("boundary_volume", boundary_volume)
        self.mass = wp.array(np.concatenate([np.full(self.nf, params.rho0 * vol_f),
                                             np.full(self.nb, params.rho0 * vol_b)]).astype(np.float32),
                             dtype=float, device=device)
        #: (nb, 3) float32 surface velocity of every wall particle (m/s), containers' then obstacles'
        self.wall_velocity_np = self._wall_velocity(wall_velocity)
        if self.bodies is not None and np.any(self.wall_velocity_np[self.bodies.wall_body >= 0] != 0.0):
            raise ParameterError("wall_velocity", "a body's walls move with the body: give them no surface velocity")
        #: (times (s), factors) of the walls' velocity factor f(t), or None: the walls move at v0 throughout
        self.wall_velocity_factor = self._velocity_factor(wall_velocity_factor)
        #: the laminar term's lattice second moment S: the kernels take μ/S (see the module docstring)
        self.viscosity_factor = lattice_second_moment(params.kernel, params.dim, params.h_factor)
        self.terms = FluidTerms(
            kernel=self.kernel_id, dim=params.dim, laminar=params.mu > 0.0, artificial=params.alpha > 0.0,
            delta_sph=params.delta > 0.0, delta_gradient=params.delta > 0.0 and bool(params.delta_gradient),
            walls="none" if self.nb == 0 else params.boundary_model.value,
            wall_safety=params.boundary_model is BoundaryModel.DYNAMIC and params.lj_r0 > 0.0,
            no_slip=bool(params.no_slip), wall_artificial=bool(params.wall_artificial_viscosity),
            riemann=params.riemann > 0.0, moving_walls=self.bodies is not None,
            shifting=params.shifting > 0.0, open_boundaries=self.openings is not None, periodic=self.space.periodic,
            fluid_pairs=params.fluid_pairs.value)
        self.constants = self._constants()
        body_surfaces = self.bodies.surfaces() if self.bodies is not None else []
        self.solids = (Solids(self.launcher, params.dim, containers, obstacles, body_surfaces)
                       if (containers or obstacles or body_surfaces) else None)

    def _wall_velocity(self, wall_velocity) -> np.ndarray:
        """The walls' surface velocity: zero, one velocity for all of them, or one per wall particle (``dim`` or 3
        components each), finite, and tangent to nothing in particular: the walls stay where they are."""
        if wall_velocity is None:
            return np.zeros((self.nb, 3), np.float32)
        v = np.asarray(wall_velocity, dtype=float)
        if v.ndim == 1:
            v = np.tile(v, (self.nb, 1))
        if v.ndim != 2 or v.shape[0] != self.nb or v.shape[1] not in (self.dim, 3):
            raise ParameterError("wall_velocity", f"must be one velocity or one per wall particle ({self.nb} rows of "
                                                  f"{self.dim} components), got shape {np.shape(wall_velocity)}")
        if not np.all(np.isfinite(v)):
            raise ParameterError("wall_velocity", "must be finite")
        if v.shape[1] == 2:
            v = np.hstack([v, np.zeros((self.nb, 1))])
        if self.dim == 2 and np.any(v[:, 2] != 0.0):
            raise ParameterError("wall_velocity", "a 2D wall moves in the plane (z component 0)")
        return v.astype(np.float32)

    def _velocity_factor(self, table):
        """The walls' velocity factor as (times, factors) float64/float32 arrays: times strictly increasing, both
        finite, one factor per time."""
        if table is None:
            return None
        try:
            times, factors = (np.asarray(a, dtype=float).ravel() for a in table)
        except (TypeError, ValueError):
            raise ParameterError("wall_velocity_factor", "must be (times, factors): two sequences of numbers") from None
        if len(times) == 0 or len(times) != len(factors):
            raise ParameterError("wall_velocity_factor", f"needs one factor per time, got {len(times)} times and "
                                                         f"{len(factors)} factors")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(factors))):
            raise ParameterError("wall_velocity_factor", "must be finite")
        if np.any(np.diff(times) <= 0.0):
            raise ParameterError("wall_velocity_factor", "its times must increase")
        return times.astype(np.float64), factors.astype(np.float32)

    def wall_values(self) -> dict[str, np.ndarray]:
        """All walls' arrays as the solver lays them out: position (m, at t = 0), mass (kg), surface velocity (m/s);
        with bodies, each wall's body (-1: at rest) and offset in its body's frame (m, float64)."""
        values = {"position": self.position_np[self.nf:], "mass": self.mass.numpy()[self.nf:],
                  "velocity": self.wall_velocity_np}
        if self.bodies is not None:
            values.update(body=self.bodies.wall_body, offset=self.bodies.wall_offset)
        return values

    def _constants(self) -> FluidConstants:
        P = self.params
        c = FluidConstants()
        h = P.h
        c.h = h
        c.inv_h = 1.0 / h
        c.support2 = P.support ** 2
        c.grad_factor = normalisation(P.kernel, P.dim, h) / (h * h)
        c.eps = 0.01 * h * h
        c.rho0, c.c0, c.b, c.gamma = P.rho0, P.c0, P.b, P.gamma
        c.p_floor = -3.0e38 if P.tension else 0.0
        c.mu = P.mu / self.viscosity_factor
        c.avisc = P.alpha * P.c0 * h
        c.riemann_eta = P.riemann / P.c0
        c.delta_coef = P.delta * h * P.c0
        c.inv_c2 = 1.0 / P.c0 ** 2
        c.gravity = wp.vec3(*[float(g) for g in P.gravity])
        c.lj_d, c.lj_r0 = float(P.lj_d), float(P.lj_r0)
        c.shift_coef = P.shifting * h * P.shift_speed
        c.inv_shape_dx = 1.0 / float(kernel_profile(P.kernel, P.dim, 1.0 / P.h_factor))
        #: ∇·r of a full support on the lattice is d·S (S without the 0.01h² term); a particle within about one
        #: spacing of a free surface has 96 % of it (Wendland C2, h = 1.3 dx, 2D: 1.873 against 1.948)
        c.surface_div = SURFACE_DIV_FRACTION * P.dim * lattice_second_moment(P.kernel, P.dim, P.h_factor, eps=0.0)
        lo = np.maximum(np.asarray(P.container_lo, float), -3e38)
        hi = np.minimum(np.asarray(P.container_hi, float), 3e38)
        if P.dim == 2:  # every 2D force has z = 0 exactly: a particle off the plane is a fault, stop at once
            lo[2] = hi[2] = 0.0
        c.container_lo = wp.vec3(*[float(v) for v in lo])
        c.container_hi = wp.vec3(*[float(v) for v in hi])
        c.box = self.space.box
        return c

    @property
    def skin(self) -> float:
        """Neighbour-table skin (m)."""
        return self.params.skin * self.params.support

    def describe(self) -> dict:
        """The model for ``summary.json``: its parameters with h, support, B and the particle counts."""
        P = self.params
        d = asdict(P)
        d.update({"h": P.h, "support": P.support, "B": P.b, "viscosity_factor": self.viscosity_factor,
                  "n_fluid": self.nf, "n_boundary": self.nb,
                  "n_particles": self.n, "compiled_terms": asdict(self.terms)})
        if self.bodies is not None:
            d["bodies"] = self.bodies.describe()
        if self.openings is not None:
            d["openings"] = self.openings.describe()
        return d
