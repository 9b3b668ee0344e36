"""Particle sources on a region's boundary (a field on a region, ``warpfree.solvers.pic.electrodes``): a cathode, a
plasma source, any tagged pieces of any shape.

Two ways to emit (:class:`Emission`):

- "beam": a fixed flux Γ per unit length and time along the pieces, of a cold beam (Γ = n v_n, every particle leaving
  along the inward normal at v_n) or a thermal source (the half-Maxwellian flux Γ = n v_th / sqrt(2π), as the box's
  wall sources: ``warpfree.solvers.pic.injection``), spread by length;
- "space_charge_limited": the pieces are an electrode's; each step every chord emits the charge σ ΔL that the
  electrode's surface charge σ holds there (its Lagrange multipliers, ``warpfree.solvers.pic.electrodes``: ε0 E·n
  at the conductor), where σ has the sign of the species' charge (an electron is pulled off where the conductor holds
  negative charge): charge set down at the conductor takes the place of its surface charge (its image), so the
  electrode's charge and the field at it fall to zero, which is the space-charge limit (Gauss's-law emission;
  Watrous, Luginsland & Sasser 2001, Phys. Plasmas 8, 289). The particles leave at the given speed (nearly at rest:
  a small fraction of the gap's speed). Measured against a local estimate of σ instead, -∇u^h·n at the chords'
  midpoints: the particles' own smoothed charge overshoots the field there, each step's emission is pushed back
  into the cathode the next, and the current fell with Δt without converging (cylindrical diode: 1.029, 1.012,
  0.985, 0.961 of Langmuir–Blodgett's at Δt 0.04 to 0.005, most of the emission returned).

A step emits the whole particles owed (the fraction left carried to the next step, so the counts are deterministic),
stratified over the chords by their share (length, or charge): particle i of n at (i + U)/n of the cumulative share,
so the emission follows the share with no more noise than one particle's. The macro weight is the source's (``charge_per_step`` / ``particles_per_step``: for "space_charge_limited" an estimate of the
current, which only sets how many particles carry it). The chords lie within 1e-7 of the exact curve; particles start
``inset`` inside it, beyond that. float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpfree.device import Launcher
from warpfree.errors import ParameterError, require_finite, require_integer, require_positive
from warpfree.kernels import pic as pk
from warpfree.parameters import Choice

from .electrodes import piece_tags
from .species import Species

__all__ = ["Emission", "SurfaceSource", "SurfaceEmitter", "INSET"]

#: how far inside the exact curve an emitted particle starts, as a fraction of the region's size (the chords lie within
#: 1e-7 of a piece's length of it)
INSET = 1e-6


class Emission(Choice):
    """How a surface source emits."""

    BEAM = "beam", "a fixed flux: a cold beam (density × normal speed) or a thermal half-Maxwellian flux"
    SPACE_CHARGE_LIMITED = "space_charge_limited", ("each step the charge the surface field holds there (Gauss's "
                                                    "law): the space-charge limit")


@dataclass(frozen=True)
class SurfaceSource:
    """A source of ``species`` on the region's pieces tagged ``tags``, emitting as ``emission`` says
    (:class:`Emission`). "beam": the species' density and ``speed`` (its cold normal speed; its temperature > 0: a
    thermal flux instead) set the flux. "space_charge_limited": particles leave at ``speed`` (a small one), and
    ``current`` (charge per unit time and depth, the species' sign or not) estimates the current so that a step's
    emission is about ``particles_per_step`` particles. ``seed``: the random positions' and velocities' (counter-based:
    the same for any thread count)."""

    species: Species
    tags: tuple
    emission: Emission = Emission.BEAM
    speed: float = 1.0
    current: float | None = None
    particles_per_step: float = 20.0
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "tags", piece_tags(self.tags, "a surface source"))
        object.__setattr__(self, "emission", Emission.of("emission", self.emission))
        speed = require_finite("speed", self.speed)
        if speed < 0.0:
            raise ParameterError("speed", f"the emission speed is a magnitude (along the inward normal), got {speed}")
        require_positive("particles_per_step", self.particles_per_step)
        require_integer("seed", self.seed, minimum=0, maximum=2 ** 31 - 1)
        if self.emission is Emission.SPACE_CHARGE_LIMITED:
            if self.current is None or not math.isfinite(self.current) or self.current == 0.0:
                raise ParameterError("current", "a space-charge-limited source needs an estimate of its current (charge "
                                                "per unit time and depth): it sets the macro-particles' weight")
        elif self.species.temperature == 0.0 and speed == 0.0:
            raise ParameterError("speed", f"species {self.species.name!r}: a cold beam needs a normal speed > 0")

    @property
    def warm(self) -> bool:
        """A thermal (half-Maxwellian) beam."""
        return self.emission is Emission.BEAM and self.species.temperature > 0.0

    def flux(self) -> float:
        """A beam's Γ: particles per unit length and time (n v_n cold, n v_th / sqrt(2π) thermal)."""
        sp = self.species
        return sp.density * (sp.thermal_speed / math.sqrt(2.0 * math.pi) if self.warm else self.speed)


class SurfaceEmitter:
    """The chords of one :class:`SurfaceSource`'s pieces, how many particles each emits a step, and the kernel's
    bundle. ``index``: the source's species index in the solver; ``field``: the region's
    :class:`~.electrodes.ElectrodeField`; ``length``: the pieces' length; ``weight``: real particles (per unit depth) a
    macro-particle carries."""

    def __init__(self, source: SurfaceSource, index: int, field, dt: float, launcher: Launcher):
        region = field.region
        for t in source.tags:
            if t not in region.tags:
                raise ParameterError("tags", f"source of {source.species.name!r}: no piece is tagged {t!r}; the "
                                             f"region's tags: {region.tags}")
        start, end, piece = region.chords()
        tags = np.array([p.tag for p in region.pieces], dtype=object)
        keep = np.isin(tags[piece], list(source.tags))
        start, end = start[keep], end[keep]
        chord = end - start
        self.chord_length = np.linalg.norm(chord, axis=1)
        self.inward = np.column_stack([-chord[:, 1], chord[:, 0]]) / self.chord_length[:, None]  # region on the left
        self.length = float(self.chord_length.sum())
        self.source, self.dt = source, float(dt)
        q = source.species.charge
        if source.emission is Emission.BEAM:
            self.weight = source.flux() * self.length * self.dt / source.particles_per_step
            self._rate = source.particles_per_step * self.chord_length / self.length   # particles a step
            self._gradient = None
        else:
            self.weight = abs(source.current) * self.dt / (abs(q) * source.particles_per_step)
            with_name = f"source of {source.species.name!r}"
            try:
                self._electrode = field.electrode_of(source.tags)
            except ParameterError as exc:
                raise ParameterError("tags", f"{with_name}: space-charge-limited emission draws on an electrode's "
                                             f"surface charge: {exc.args[-1] if exc.args else exc}") from None
            if field.electrodes[self._electrode].floating:
                raise ParameterError("tags", f"{with_name}: the emitting electrode must be held at a potential")
            self._field = field
            self._gradient = field.surface_charge_near(self._electrode, 0.5 * (start + end))
        self.macro_charge = q * self.weight
        self.chords = len(start)
        dev = launcher.device
        bundle = pk.SurfaceSourceArrays()
        bundle.chord_start = wp.array(start, dtype=wp.vec2d, device=dev)
        bundle.chord_end = wp.array(end, dtype=wp.vec2d, device=dev)
        bundle.inward = wp.array(self.inward, dtype=wp.vec2d, device=dev)
        bundle.share = wp.zeros(len(start) + 1, dtype=wp.float64, device=dev)
        bundle.chords = int(len(start))
        bundle.count = 0
        bundle.species = int(index)
        bundle.seed = int(source.seed)
        bundle.normal_speed = wp.float64(0.0 if source.warm else source.speed)
        bundle.thermal_speed = wp.float64(source.species.thermal_speed if source.warm else 0.0)
        lo, hi = region.bounds()
        bundle.inset = wp.float64(INSET * float(np.max(hi - lo)))
        #: the kernel's view of the source (its shares and count refreshed each step)
        self.bundle = bundle

    def surface_charge(self) -> np.ndarray:
        """σ at each chord's midpoint: the emitting electrode's surface charge of the last solve (its multipliers)."""
        return self._gradient @ self._field.surface_charge[self._electrode]

    def count(self, owed: np.ndarray) -> int:
        """This step's particles (their count and the chords' cumulative shares into the bundle); returns the count.
        A beam emits its particles a step, spread by length; a space-charge-limited source the charge σ ΔL of the
        chords where σ has the species' sign (the last solve's), over its macro-charge, spread by that charge.
        ``owed``: the source's fraction of a particle carried from the last step (the
        state's, one value, updated in place)."""
        if self._gradient is None:
            share = self.chord_length
            rate = self.source.particles_per_step
        else:
            share = np.maximum(self.surface_charge() * self.chord_length / self.macro_charge, 0.0)
            rate = float(share.sum())
        total = float(owed[0]) + rate
        count = int(math.floor(total))
        owed[0] = total - count
        cumulative = np.concatenate([[0.0], np.cumsum(share)])
        if count >= 2 ** 31:
            raise ParameterError("particles_per_step", f"a step's emission of {count} particles overflows int32")
        if cumulative[-1] > 0.0:
            self.bundle.share.assign(cumulative / cumulative[-1])
        self.bundle.count = count
        return count

    def describe(self) -> dict:
        """The source for ``summary.json``."""
        s = self.source
        return {"species": s.species.name, "tags": list(s.tags), "emission": s.emission, "speed": s.speed,
                "particles_per_step": s.particles_per_step, "weight": self.weight, "length": self.length,
                "chords": int(len(self.chord_length))}
