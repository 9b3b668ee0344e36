"""Plasma species and their loading (Marques 2008, §2.1, §5.2: uniform positions, Maxwell–Boltzmann velocities).

Normalised units (``warpfree.solvers.pic``): charge in e, mass in m_e, number density in n_ref, temperature in
T_ref with k_B T_ref = m_e v_ref² (so a species' thermal speed is v_th = sqrt(T/m)); with n_ref, e and m_e the
electron plasma frequency is 1 and the Debye length λ_D = v_th,e / ω_pe.

A macro-particle carries W real particles (``weight``): its charge q W and mass m W, so q/m stays the real
particle's (Marques 2008, §1.1). In 2D W is per unit depth: W = n · area / count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from warpfree.errors import ParameterError, require_finite, require_integer, require_memory, require_positive
from warpfree.space import Space

#: memory per macro-particle of a PIC run, bytes: position, velocity, cell keys and sort buffers, the deposit and
#: gather rows (float64); the thermal plasma's peak resident memory grows by 420 B per particle, rounded up
BYTES_PER_PARTICLE = 512.0

__all__ = ["Species", "ParticleLoad", "load_species", "load_in_region", "lattice_positions", "random_positions",
           "region_positions"]


@dataclass(frozen=True)
class Species:
    """A species: ``name``, ``charge`` (e), ``mass`` (m_e), number ``density`` (n_ref), ``temperature`` (T_ref; 0:
    cold), ``drift`` velocity (v_ref)."""

    name: str
    charge: float
    mass: float
    density: float
    temperature: float = 0.0
    drift: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        q = require_finite("charge", self.charge)
        if q == 0.0:
            raise ParameterError("charge", f"species {self.name!r}: a neutral species feels no field; got 0")
        require_positive("mass", self.mass)
        require_positive("density", self.density)
        require_positive("temperature", self.temperature, allow_zero=True)
        d = np.asarray(self.drift, dtype=np.float64)
        if d.shape != (2,) or not np.all(np.isfinite(d)):
            raise ParameterError("drift", f"species {self.name!r}: must be two finite numbers, got {self.drift!r}")

    @property
    def thermal_speed(self) -> float:
        """v_th = sqrt(T/m) (v_ref)."""
        return math.sqrt(self.temperature / self.mass)

    @property
    def plasma_frequency(self) -> float:
        """ω_p,s = sqrt(n q² / m) (ε0 = 1)."""
        return math.sqrt(self.density * self.charge ** 2 / self.mass)


@dataclass
class ParticleLoad:
    """A species with its macro-particles: ``position`` (n, 2), ``velocity`` (n, 2) float64, ``weight`` W."""

    species: Species
    position: np.ndarray
    velocity: np.ndarray
    weight: float

    @property
    def count(self) -> int:
        """The number of macro-particles loaded."""
        return int(self.position.shape[0])


def _box_of(space: Space) -> tuple[np.ndarray, np.ndarray]:
    if not space.bounded:
        raise ParameterError("space", "particles are loaded into a box: give the space lower and upper corners")
    return space.lower[:2].copy(), space.length[:2].copy()


def lattice_positions(space: Space, counts: tuple[int, int]) -> np.ndarray:
    """A quiet start: ``counts`` = (nx, ny) particles on a regular lattice, at the centres of nx × ny equal cells."""
    nx, ny = (require_integer("counts", c, minimum=1) for c in counts)  # at least one particle per axis
    require_memory("counts", float(nx) * ny, BYTES_PER_PARTICLE, "macro-particles")
    lower, length = _box_of(space)
    x = lower[0] + (np.arange(nx) + 0.5) * length[0] / nx
    y = lower[1] + (np.arange(ny) + 0.5) * length[1] / ny
    gx, gy = np.meshgrid(x, y, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def random_positions(space: Space, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` positions uniform in the box."""
    lower, length = _box_of(space)
    count = require_integer("count", count, minimum=1)
    require_memory("count", count, BYTES_PER_PARTICLE, "macro-particles")
    return lower + rng.random((count, 2)) * length


def load_species(species: Species, space: Space, position, rng: np.random.Generator | None = None,
                 velocity=None) -> ParticleLoad:
    """Macro-particles of ``species`` at ``position`` (n, 2) inside the box, with W = density · area / n and velocities
    drift + a Maxwell–Boltzmann spread at the species' temperature (``rng``, needed when T > 0), or ``velocity``
    (n, 2) given (e.g. a cold beam with a perturbation)."""
    lower, length = _box_of(space)
    p = _positions(species, position)
    outside = np.flatnonzero(np.any((p < lower) | (p >= lower + length), axis=1))
    if outside.size:
        i = int(outside[0])
        raise ParameterError("position", f"species {species.name!r}: particle {i} at {p[i].tolist()} lies outside "
                                         f"the box [{lower.tolist()}, {(lower + length).tolist()}) "
                                         f"({outside.size} such)")
    return _load(species, p, float(np.prod(length)), rng, velocity)


def load_in_region(species: Species, region, position, rng: np.random.Generator | None = None,
                   velocity=None) -> ParticleLoad:
    """As :func:`load_species`, in a :class:`~warpfree.galerkin.region.Region` (a field on a region,
    ``warpfree.solvers.pic.electrodes``): ``position`` inside it, W = density · region's area / n."""
    p = _positions(species, position)
    outside = np.flatnonzero(~region.contains(p))
    if outside.size:
        i = int(outside[0])
        raise ParameterError("position", f"species {species.name!r}: particle {i} at {p[i].tolist()} lies outside "
                                         f"the region ({outside.size} such)")
    return _load(species, p, float(region.area), rng, velocity)


def region_positions(region, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` positions uniform in a region (drawn in its bounding box, those outside drawn again)."""
    count = require_integer("count", count, minimum=1)
    require_memory("count", count, BYTES_PER_PARTICLE, "macro-particles")
    lo, hi = region.bounds()
    out = np.zeros((0, 2))
    while len(out) < count:
        p = lo + rng.random((2 * (count - len(out)) + 16, 2)) * (hi - lo)
        out = np.vstack([out, p[region.contains(p)]])
    return out[:count]


def _positions(species: Species, position) -> np.ndarray:
    p = np.asarray(position, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] == 0:
        raise ParameterError("position", f"species {species.name!r}: need an (n, 2) array, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError("position", f"species {species.name!r}: positions must be finite")
    return p


def _load(species: Species, p: np.ndarray, area: float, rng, velocity) -> ParticleLoad:
    """The load of ``p`` (checked inside) over ``area``: W = density · area / n, velocities as :func:`load_species`."""
    n = p.shape[0]
    if velocity is not None:
        v = np.asarray(velocity, dtype=np.float64)
        if v.shape != p.shape or not np.all(np.isfinite(v)):
            raise ParameterError("velocity", f"species {species.name!r}: need finite ({n}, 2), got {v.shape}")
    else:
        v = np.tile(np.asarray(species.drift, dtype=np.float64), (n, 1))
        if species.temperature > 0.0:
            if rng is None:
                raise ParameterError("rng", f"species {species.name!r} is warm: loading needs a random generator")
            v = v + species.thermal_speed * rng.standard_normal((n, 2))
    weight = species.density * area / n
    return ParticleLoad(species, np.ascontiguousarray(p), np.ascontiguousarray(v), weight)
