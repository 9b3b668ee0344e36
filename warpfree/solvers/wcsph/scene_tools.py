"""Helpers shared by the fluid scenes: hydrostatic initial density, box walls, walls from a mesh section, front
probe, and the quiet start of water at rest (relaxed arrangement, then settled in its own discretisation)."""

from __future__ import annotations

import numpy as np

from warpfree.errors import ParameterError, require_positive

from .model import BoundaryModel


def require_whole_spacings(lengths: dict, per_unit: int, unit: str, per_name: str) -> None:
    """Each of ``lengths`` (name -> value in ``unit``) is a whole number of spacings at ``per_unit`` spacings a
    ``unit`` (its lattice then ends on a row): else ParameterError naming the length."""
    for name, value in lengths.items():
        spacings = value * per_unit
        if abs(spacings - round(spacings)) > 1e-6 * spacings:
            raise ParameterError(name, f"must be whole spacings: {value} {unit} is {spacings:.6g} spacings at "
                                       f"{per_name} = {per_unit}")


def require_wall_cover(wall_layers: int, dx: float, support: float,
                       boundary_model: BoundaryModel = BoundaryModel.DYNAMIC) -> None:
    """Dynamic walls must fill the kernel support (m) of the fluid row nearest them, which stands dx/2 from the wall:
    ``wall_layers`` dx >= support - dx/2. Thinner walls leave part of that row's support empty, and the pressure term
    pushes the row into the wall. The error names ``wall_layers``."""
    if BoundaryModel.of("boundary_model", boundary_model) is not BoundaryModel.DYNAMIC:
        return
    need = int(np.ceil((support - 0.5 * dx) / dx - 1e-9))
    if wall_layers < need:
        raise ParameterError("wall_layers", f"{wall_layers} layers of dx = {dx:.6g} m do not cover the kernel support "
                                            f"{support:.6g} m of the fluid row dx/2 from a wall: need >= {need}")


def hydrostatic_density(y: np.ndarray, surface: float, rho0: float, c0: float, g: float,
                        gamma: float = 7.0) -> np.ndarray:
    """ρ(y) = ρ0 [1 + ρ0 g (surface - y)/B]^(1/γ), B = ρ0 c0²/γ: the Tait EOS inverted for p = ρ0 g depth."""
    b = rho0 * c0 ** 2 / gamma
    return rho0 * (1.0 + rho0 * g * (surface - np.asarray(y)) / b) ** (1.0 / gamma)


def sloshing_frequency(length: float, depth: float, g: float) -> float:
    """ω1 = sqrt(g k tanh(k d)), k = π/length (rad/s): the first sloshing mode of water of ``depth`` d with a free
    surface ``length`` long between walls (linear theory), the slowest motion of water at rest."""
    k = np.pi / require_positive("length", length)
    return float(np.sqrt(require_positive("g", g) * k * np.tanh(k * require_positive("depth", depth))))


def settle_water(solver, surface_length: float, depth: float, g: float, periods: float) -> dict:
    """Settle water at rest before t = 0 (:meth:`WCSPHSolver.settle`) for ``periods`` periods of its first sloshing
    mode, with the damping rate 2ω1 that damps that mode critically (its amplitude falls as e^(-ω1 t): e^(-2π)
    per period). Returns the settling report with the duration and damping used."""
    omega = sloshing_frequency(surface_length, depth, g)
    duration = require_positive("settle_periods", periods) * 2.0 * np.pi / omega
    report = solver.settle(duration, 2.0 * omega)
    report.update({"duration": duration, "damping": 2.0 * omega})
    return report


def still_water_2d(tank: np.ndarray, level: float, dx: float, fluid: dict, wall_layers: int = 3, relax: bool = True,
                   settle_periods: float = 3.0):
    """Water at rest filling the 2D container polygon ``tank`` up to the height y = ``level`` (m).

    Wall particles along the tank's true sides (``wall_layers`` layers); the water's region is the tank below the
    level (:func:`warpfree.geometry.clip_polygon`), filled with a clearance of dx/2. With ``relax``, the
    particles are relaxed to a uniform concentration against the walls and the empty space above
    (:func:`warpfree.solvers.wcsph.relaxation.relax_particles`), each then standing for the region's area over their count (a
    tilted tank's lattice fill holds up to 10 % fewer than area/dx²: with the mass of dx² the water would stand on
    a pressure 7 % too high); the densities are hydrostatic; with ``settle_periods`` > 0 the
    water then settles in its own discretisation (:func:`settle_water`). ``fluid``: the other
    :class:`FluidParams` fields (c0, gravity (0, -g, 0), viscosities, ...); the container box is the tank's.
    Returns (solver, the water's polygon, the settling report or None).
    """
    from warpfree.geometry import clip_polygon, fill_polygon, polygon_area
    from warpfree.solvers.wcsph.relaxation import relax_particles
    from warpfree.solvers.wcsph.surface_layers import surface_layers

    from .model import FluidParams, WCSPHModel
    from .solver import WCSPHSolver

    require_positive("settle_periods", settle_periods, allow_zero=True)
    water = clip_polygon(tank, (0.0, 1.0), level)
    particles = fill_polygon(water, dx, origin=(0.0, 0.0), clearance=0.5 * dx)
    walls = surface_layers(tank, dx, wall_layers, "outside")
    params = FluidParams(dim=2, dx=dx, container_lo=(*tank.min(axis=0), -1.0), container_hi=(*tank.max(axis=0), 1.0),
                         **fluid)
    params.validate()
    require_wall_cover(wall_layers, dx, params.support, params.boundary_model)
    if relax:
        particles = relax_particles(particles, dx, water, walls=walls, containers=[tank], kernel=params.kernel,
                                    h_factor=params.h_factor).positions
    g = -float(params.gravity[1])
    model = WCSPHModel(particles, walls, params, containers=[tank],
                       fluid_volume=polygon_area(water) / len(particles) if relax else None)
    solver = WCSPHSolver(model, density=hydrostatic_density(particles[:, 1], level, params.rho0, params.c0, g,
                                                            params.gamma))
    settled = None
    if settle_periods > 0:
        surface = water[np.abs(water[:, 1] - level) < 1e-6 * max(abs(level), 1.0), 0]
        settled = settle_water(solver, float(surface.max() - surface.min()), level - float(water[:, 1].min()), g,
                               settle_periods)
    return solver, water, settled


def box_2d(width: float, height: float) -> np.ndarray:
    """The rectangle [0, width] x [0, height] as a polygon (a container for ``WCSPHSolver(containers=...)``)."""
    return np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])


def box_walls_2d(width: float, height: float, dx: float, layers: int) -> np.ndarray:
    """Boundary particles in ``layers`` layers outside the rectangle [0, width] x [0, height], layer k at
    (k + 1/2) dx from its sides (:func:`warpfree.solvers.wcsph.surface_layers.surface_layers`)."""
    from warpfree.solvers.wcsph.surface_layers import surface_layers

    return surface_layers(box_2d(width, height), dx, layers, "outside")


def front_position(solver, t: float) -> float:
    """Surge front: the largest x of any fluid particle (m)."""
    return float(solver.fluid_positions()[:, 0].max())


def walls_from_section(mesh, plane_origin, plane_normal, dx: float, layers: int) -> tuple[np.ndarray, list]:
    """2D boundary particles from the cross-section of a 3D container mesh (a path or trimesh mesh).

    The section's polygons (see :func:`warpfree.geometry.mesh_section` for the in-plane axes) get ``layers``
    layers outside them along their true edges (:func:`warpfree.solvers.wcsph.surface_layers.surface_layers`, any
    orientation). Returns (walls (N, 2), the polygons) — the polygons are the containers to check the fluid
    against and to fill (``fill_polygon(..., clearance=dx/2)``).
    """
    from warpfree.geometry import load_mesh, mesh_section
    from warpfree.solvers.wcsph.surface_layers import surface_layers

    polygons = mesh_section(load_mesh(mesh), plane_origin, plane_normal)
    if not polygons:
        raise ParameterError("plane_origin", "the plane does not cut the mesh")
    return np.vstack([surface_layers(p, dx, layers, "outside") for p in polygons]), polygons


def clear_of(points: np.ndarray, solid, clearance: float) -> np.ndarray:
    """The points at least ``clearance`` (m) outside ``solid`` (a watertight trimesh mesh or a 2D polygon):
    fluid filled around an obstacle, measured against its true surface on the device."""
    from warpfree.device import current_launcher
    from warpfree.solvers.wcsph.solids import Solids

    dim = 3 if not isinstance(solid, np.ndarray) else 2
    p3 = points if points.shape[1] == 3 else np.column_stack([points, np.zeros(len(points))])
    signed = Solids(current_launcher(), dim, containers=[solid]).signed_distance(p3)
    return points[signed >= clearance * (1.0 - 1e-6)]


#: the filled support (:func:`filled_support`) from which a particle is in the water's body: not in a free
#: surface's layer (about 1/2 there), a thin sheet or a spray
BODY_FILLED = 0.9


def pressure_noise(solver, body_only: bool = False) -> float:
    """The pressure's noise (Pa): the rms over the fluid of :func:`pressure_residuals`; ``body_only``: over the
    particles in the water's body only (:func:`filled_support` >= BODY_FILLED), without the free surface's layer,
    thin sheets and spray, whose supports the water does not fill (0 if there are none)."""
    residuals = pressure_residuals(solver)
    if body_only:
        residuals = residuals[filled_support(solver) >= BODY_FILLED]
        if residuals.size == 0:
            return 0.0
    return float(np.sqrt(np.mean(residuals ** 2)))


def filled_support(solver) -> np.ndarray:
    """Per fluid particle, Σ_j V_j W(r_ij, h) over the fluid and the wall particles within its support
    (dimensionless, V_j = m_j/ρ_j): about 1 inside the water and against a wall under water, 1/2 at a flat free
    surface, less in a sheet thinner than the support or a spray. Host, float64, the whole sets in one process."""
    from scipy.spatial import cKDTree

    from warpfree.kernels.smoothing import kernel_profile, normalisation, support_factor

    params = solver.model.params
    dim, h = params.dim, params.h
    x = solver.fluid_positions()[:, :dim].astype(np.float64)
    sets = [(x, solver.fluid.numpy("mass"), solver.fluid.numpy("density"))]
    for walls in (solver.boundary, solver.obstacle):
        if len(walls.numpy("position")):
            sets.append((walls.numpy("position")[:, :dim].astype(np.float64), walls.numpy("mass"),
                         walls.numpy("density")))
    filled = np.zeros(len(x))
    sigma = normalisation(params.kernel, dim, h)
    for k, (positions, mass, density) in enumerate(sets):
        pairs = cKDTree(x).sparse_distance_matrix(cKDTree(positions), support_factor(params.kernel) * h,
                                                  output_type="ndarray")
        if k == 0:  # each particle itself is added below, once
            pairs = pairs[pairs["i"] != pairs["j"]]
        volume = mass.astype(np.float64) / density.astype(np.float64)
        w = sigma * kernel_profile(params.kernel, dim, pairs["v"] / h) * volume[pairs["j"]]
        filled += np.bincount(pairs["i"], weights=w, minlength=len(x))
    own = sets[0][1].astype(np.float64) / sets[0][2].astype(np.float64)
    return filled + sigma * kernel_profile(params.kernel, dim, np.zeros(1))[0] * own


def pressure_residuals(solver) -> np.ndarray:
    """Per fluid particle, p_i - p̂_i (Pa), where p̂_i is the value at x_i of the linear
    fit a + b·(x - x_i) of the fluid's pressures weighted by V_j W(r_ij, 2h) (the fluid's own kernel at twice the
    smoothing length, V_j = m_j/ρ_j; the average where the fit is singular). A linear field is fitted exactly, also
    where a wall or the free surface cuts the support (a hydrostatic pressure has no noise), so what is left is what
    varies on the scale of the particles. Host, float64, over the fluid particles this process holds."""
    from scipy.spatial import cKDTree

    from warpfree.kernels.smoothing import kernel_profile, support_factor

    params = solver.model.params
    dim = params.dim
    x = solver.fluid_positions()[:, :dim].astype(np.float64)
    p = solver.fluid.numpy("pressure").astype(np.float64)
    v = solver.fluid.numpy("mass").astype(np.float64) / solver.fluid.numpy("density").astype(np.float64)
    h2 = 2.0 * params.h
    tree = cKDTree(x)
    pairs = tree.query_pairs(support_factor(params.kernel) * h2, output_type="ndarray")
    i = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(len(x))])   # both directions and each particle itself
    j = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(len(x))])
    d = (x[j] - x[i]) / h2
    w = kernel_profile(params.kernel, dim, np.linalg.norm(d, axis=1)) * v[j]
    basis = np.column_stack([np.ones(len(i)), d])                       # [1, (x_j - x_i)/2h]
    n = len(x)
    moments = np.zeros((n, dim + 1, dim + 1))
    rhs = np.zeros((n, dim + 1))
    for a in range(dim + 1):
        rhs[:, a] = np.bincount(i, weights=w * basis[:, a] * p[j], minlength=n)
        for b in range(a, dim + 1):
            moments[:, a, b] = moments[:, b, a] = np.bincount(i, weights=w * basis[:, a] * basis[:, b], minlength=n)
    fitted = rhs[:, 0] / moments[:, 0, 0]                                # the average, where the fit is singular
    well_posed = np.linalg.det(moments / moments[:, :1, :1]) > 1e-6
    fitted[well_posed] = np.linalg.solve(moments[well_posed], rhs[well_posed][..., None])[:, 0, 0]
    return p - fitted
