"""Particle injection from a wall: a source plasma behind the lower or upper wall (y) emits particles
into the box at the one-sided flux of its velocity distribution.

A source of number density n (n_ref), seen through the wall, emits per unit wall length and time (normalised units,
``warpfree.solvers.pic.species``):

- a cold beam (temperature 0, drift v_d with normal component v_n > 0 into the box): Γ = n v_n, every particle with
  velocity v_d;
- a thermal source (temperature T, no drift across the wall): the half-Maxwellian flux Γ = n v_th / sqrt(2π), normal
  speeds from the flux-weighted distribution f(v_n) ∝ v_n exp(-v_n²/2v_th²) (sampled as v_th sqrt(-2 ln U)), the
  tangential ones Maxwellian about the drift along the wall (Birdsall & Langdon §16-3; Cartwright, Verboncoeur &
  Birdsall 2000, J. Comput. Phys. 162, 483).

A warm source drifting across the wall (a shifted flux Maxwellian) is not modelled: give temperature 0 for a beam.

Each step the source emits ``particles_per_step`` macro-particles on average (each of weight W = Γ L_x Δt /
``particles_per_step``); the fractional part carries over to the next step, so the count per step is deterministic.
A particle emitted during the step enters at a uniformly random time within it: it starts a distance v_n Δt U
(U uniform in [0, 1)) inside the wall, at a uniformly random x, with its emission velocity as v^{n+1/2} (the field's
kick over the part of the step it spent inside is neglected: an O(q E Δt) error in its first velocity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from warpfree.errors import ParameterError, require_finite, require_integer, require_positive
from warpfree.parameters import Choice

from .species import Species

__all__ = ["Injection", "SourceWall"]


class SourceWall(Choice):
    """The wall a source sits on."""

    LOWER = "lower", "y = y_min, emitting along +y"
    UPPER = "upper", "y = y_max, emitting along -y"


@dataclass(frozen=True)
class Injection:
    """A source on ``wall`` (a :class:`SourceWall`: "lower", y = y_min, emitting along +y; "upper", y = y_max, along
    -y) of ``species`` (its ``density`` and ``drift``/``temperature`` describe the source plasma), emitting
    ``particles_per_step`` macro-particles per step on average; ``seed`` for its random positions and velocities
    (counter-based: the same particles for any thread count and after a resume)."""

    species: Species
    wall: SourceWall = SourceWall.LOWER
    particles_per_step: float = 10.0
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "wall", SourceWall.of("wall", self.wall))
        require_positive("particles_per_step", self.particles_per_step)
        require_finite("particles_per_step", self.particles_per_step)
        require_integer("seed", self.seed, minimum=0, maximum=2 ** 31 - 1)
        normal = self.inward * self.species.drift[1]
        if self.species.temperature == 0.0 and normal <= 0.0:
            raise ParameterError("drift", f"species {self.species.name!r}: a cold source on the {self.wall} wall must "
                                          f"drift into the box (drift_y {'>' if self.inward > 0 else '<'} 0), got "
                                          f"drift = {tuple(self.species.drift)}")
        if self.species.temperature > 0.0 and self.species.drift[1] != 0.0:
            raise ParameterError("drift", f"species {self.species.name!r}: a warm source drifting across the wall is "
                                          "not modelled; give temperature 0 (a cold beam) or drift along x only")

    @property
    def inward(self) -> float:
        """+1 for the lower wall (emits along +y), -1 for the upper."""
        return 1.0 if self.wall is SourceWall.LOWER else -1.0

    @property
    def warm(self) -> bool:
        """True when the source injects a thermal (half-Maxwellian) flux, False for a cold beam."""
        return self.species.temperature > 0.0

    @property
    def normal_speed(self) -> float:
        """The cold beam's speed into the box, v_n (0 for a thermal source)."""
        return 0.0 if self.warm else self.inward * self.species.drift[1]

    @property
    def flux(self) -> float:
        """Γ: particles per unit wall length and time (n_ref v_ref): n v_n (cold) or n v_th / sqrt(2π) (thermal)."""
        sp = self.species
        return sp.density * (sp.thermal_speed / math.sqrt(2.0 * math.pi) if self.warm else self.normal_speed)

    def weight(self, wall_length: float, dt: float) -> float:
        """W = Γ L Δt / ``particles_per_step``: real particles (per unit depth) per macro-particle."""
        return self.flux * wall_length * dt / self.particles_per_step
