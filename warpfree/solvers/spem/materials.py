"""Materials and objects of an EM scene, and each particle's effective material at second order.

An :class:`EMObject` is a shape (``warpfree.shapes``: a disc, ellipse, polygon, any closed curve, a mesh's section; an
interval in 1D) filled with a :class:`Material` (relative permittivity εr, relative permeability μr, conductivity σ in
S/m). Objects are layered in the order given: a later one covers an earlier one where they overlap; outside every
object the model's background (``eps_r``, ``mu_r``) holds.

Perfect conductors (:data:`PEC`) cover every other object: the model cuts them out of the layout and holds a row of E
particles on their surface at Ez = 0 (:func:`~.layouts.carve_conductors`), so the wall sits where the geometry puts
it.

A particle set on a material interface reads the material of its cell, not of its centre (which staircases the
interface: first order, and erratic with resolution). Its effective values are averages over its cell (a square of
its spacing about it; :func:`warpfree.shapes.cell_means`), the subpixel averaging of Farjadpour et al. (2006, Meep's
default), exact to second order for a field's component:

- along the interface (TMz's Ez always, in 1D both fields): the mean, ε_eff = ⟨ε⟩, σ_eff = ⟨σ⟩, μ_eff = ⟨μ⟩;
- across it: the harmonic mean, 1/μ_eff = ⟨1/μ⟩;
- an H particle of Yee's staggering carries one in-plane component, along axis a, at an angle to the interface:
  1/μ_eff = n_a² ⟨1/μ⟩ + (1 - n_a²)/⟨μ⟩, n the interface's unit normal in the cell (the diagonal term of the averaged
  inverse tensor; H particles carrying both components take ⟨μ⟩).

The conductivity enters the E update as a loss rate σ_eff/ε_eff on both parts of the split field (the exponential
step of ``kernels/spem.py``, unconditionally stable for any σ). A Drude material's susceptibility is averaged as the
permittivity is (⟨ωp²⟩, Ez along the interface), its collision rate weighted by it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from warpfree.errors import ParameterError, require_finite
from warpfree.shapes import Shape, cell_means

from .layouts import HX, StaggeredLayout

__all__ = ["Material", "PEC", "EMObject", "EffectiveMaterials", "effective_materials"]

#: times each cell is split where a boundary crosses it (pieces of 1/16 of the spacing: the fraction's error from a
#: curved boundary then ~ (Δ/16)² κ per piece, far below the field's own)
DEPTH = 4


@dataclass(frozen=True)
class Material:
    """Relative permittivity ``eps_r`` (> 0; the high-frequency ε∞ of a dispersive material), relative permeability
    ``mu_r`` (> 0) and conductivity ``conductivity`` (S/m, >= 0); a Drude dispersion, ε(ω) = εr - ωp²/(ω² - iγω)
    (time dependence e^{iωt}), of ``plasma_frequency`` ωp (rad/s, >= 0) and ``collision_rate`` γ (1/s, >= 0), by an
    auxiliary current (``kernels/spem_dispersive.py``); or a perfect conductor (``perfect_conductor``: :data:`PEC`),
    which the model cuts out of the layout with its surface held at Ez = 0 (:func:`~.layouts.carve_conductors`)."""

    eps_r: float = 1.0
    mu_r: float = 1.0
    conductivity: float = 0.0
    plasma_frequency: float = 0.0
    collision_rate: float = 0.0
    perfect_conductor: bool = False

    def permittivity(self, frequency) -> np.ndarray:
        """ε(ω)/ε0 at ``frequency`` (Hz), e^{iωt}: εr - ωp²/(ω² - iγω) - iσ/(ωε0)."""
        w = 2.0 * math.pi * np.asarray(frequency, dtype=np.float64)
        eps0 = 1.0 / (4e-7 * math.pi * 299_792_458.0 ** 2)
        return (self.eps_r - self.plasma_frequency ** 2 / (w * w - 1j * self.collision_rate * w)
                - 1j * self.conductivity / (w * eps0))

    def check(self, name: str) -> "Material":
        """Refuse, naming ``name.eps_r`` (and so on), a value out of its range."""
        if self.perfect_conductor:
            return self
        for attr in ("eps_r", "mu_r"):
            v = require_finite(f"{name}.{attr}", getattr(self, attr))
            if v <= 0.0:
                raise ParameterError(f"{name}.{attr}", f"must be > 0 (a passive, non-dispersive medium), got {v}")
        for attr, unit in (("conductivity", "S/m"), ("plasma_frequency", "rad/s"), ("collision_rate", "1/s")):
            if require_finite(f"{name}.{attr}", getattr(self, attr)) < 0.0:
                raise ParameterError(f"{name}.{attr}", f"must be >= 0 {unit}, got {getattr(self, attr)}")
        return self


#: a perfect electric conductor
PEC = Material(perfect_conductor=True)


@dataclass(frozen=True)
class EMObject:
    """A ``shape`` filled with ``material``; ``name`` labels it in ``summary.json``."""

    shape: Shape
    material: Material = field(default_factory=Material)
    name: str = ""

    def describe(self) -> dict:
        """The object for ``summary.json``."""
        if self.material.perfect_conductor:
            return {"name": self.name, "shape": self.shape.describe(), "material": "perfect conductor"}
        return {"name": self.name, "shape": self.shape.describe(), "eps_r": self.material.eps_r,
                "mu_r": self.material.mu_r, "conductivity": self.material.conductivity}


@dataclass
class EffectiveMaterials:
    """Per particle: ``eps_r`` and ``conductivity`` (S/m) on the E set, ``mu_r`` on the H set, and for each set how many
    particles sit on an interface (their cell holds more than one material)."""

    eps_r: np.ndarray
    conductivity: np.ndarray
    mu_r: np.ndarray
    e_on_interface: int
    h_on_interface: int
    #: per E particle, ⟨ωp²⟩ over its cell (rad²/s²) and the collision rate weighted by it, ⟨ωp² γ⟩/⟨ωp²⟩ (1/s)
    plasma_frequency_squared: np.ndarray | None = None
    collision_rate: np.ndarray | None = None


def check_objects(objects, layout: StaggeredLayout) -> list[EMObject]:
    """The objects checked: each an :class:`EMObject` of the layout's dimension, its material in range, its shape
    inside the layout's region (naming ``objects[k]``)."""
    checked = []
    for k, obj in enumerate(objects or []):
        name = f"objects[{k}]"
        if not isinstance(obj, EMObject):
            raise ParameterError(name, f"must be an EMObject (a shape and a material), got {type(obj).__name__}")
        if not isinstance(obj.shape, Shape) or obj.shape.dim != layout.dim:
            raise ParameterError(f"{name}.shape", f"must be a {layout.dim}D shape of warpfree.shapes, got "
                                                  f"{type(obj.shape).__name__}")
        if not isinstance(obj.material, Material):
            raise ParameterError(f"{name}.material", f"must be a Material, got {type(obj.material).__name__}")
        obj.material.check(f"{name}.material")
        lo, hi = obj.shape.bounds()
        if layout.lower is not None:
            tol = 1e-9 * layout.spacing
            if np.any(hi[:layout.dim] <= layout.lower[:layout.dim] + tol) or \
                    np.any(lo[:layout.dim] >= layout.upper[:layout.dim] - tol):
                raise ParameterError(f"{name}.shape", f"lies outside the domain ({lo.tolist()} to {hi.tolist()} "
                                                      f"against {layout.lower.tolist()} to {layout.upper.tolist()})")
        checked.append(obj)
    return checked


def effective_materials(objects: list[EMObject], layout: StaggeredLayout, eps_background: np.ndarray,
                        mu_background: np.ndarray) -> EffectiveMaterials:
    """Each particle's effective εr, σ (E set) and μr (H set) over its cell (module docstring); the backgrounds are the
    model's ``eps_r`` at the E particles and ``mu_r`` at the H particles. float64, set-up."""
    shapes = [o.shape for o in objects]
    dim = layout.dim
    # E: ⟨εr⟩ and ⟨σ⟩ over the cell (Ez along every interface in TMz and in 1D)
    e_values = np.array([[o.material.eps_r, o.material.conductivity, o.material.plasma_frequency ** 2,
                          o.material.plasma_frequency ** 2 * o.material.collision_rate] for o in objects])
    e_back = np.column_stack([eps_background, np.zeros((layout.n_e, 3))])
    e_mean, _ = cell_means(shapes, e_values, layout.e_position, layout.e_spacing, e_back, depth=DEPTH)
    plasma = e_mean[:, 2]
    rate = np.divide(e_mean[:, 3], plasma, out=np.zeros(layout.n_e), where=plasma > 0)
    e_mixed = _mixed(shapes, layout.e_position, layout.e_spacing)
    # H: ⟨μr⟩ and ⟨1/μr⟩, and the interface's normal for the direction of the component each carries
    h_values = np.array([[o.material.mu_r, 1.0 / o.material.mu_r] for o in objects])
    h_back = np.stack([mu_background, 1.0 / mu_background], axis=1)
    h_mean, normal = cell_means(shapes, h_values, layout.h_position, layout.h_spacing, h_back, depth=DEPTH)
    mean_mu, mean_inverse = h_mean[:, 0], h_mean[:, 1]
    if dim == 2 and layout.h_carries is not None:
        axis = np.where(layout.h_carries == HX, 0, 1)
        n_along = normal[np.arange(layout.n_h), axis] ** 2  # n_a²: the part of the component across the interface
        mu_r = 1.0 / (n_along * mean_inverse + (1.0 - n_along) / mean_mu)
    else:
        mu_r = mean_mu
    h_mixed = _mixed(shapes, layout.h_position, layout.h_spacing)
    return EffectiveMaterials(e_mean[:, 0], e_mean[:, 1], mu_r, int(e_mixed.sum()), int(h_mixed.sum()),
                              plasma if np.any(plasma > 0) else None, rate if np.any(plasma > 0) else None)


def _mixed(shapes, points: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """(N,) bool: a boundary passes within the half-diagonal of the particle's cell."""
    out = np.zeros(points.shape[0], bool)
    for s in shapes:
        out |= np.abs(s.signed_distance(points)) < 0.5 * math.sqrt(s.dim) * spacing
    return out
