"""The parameters the EM scenes share, each declared once (:mod:`warpfree.parameters`): a scene's ``build()``
annotates ``scheme: DerivativeScheme = Scheme.FPM`` and ``--list``, the docs and the checks before set-up read the
unit, meaning and allowed values from here. SI units; Δ is the particle spacing."""

from __future__ import annotations

from typing import Annotated

from warpfree.distribution import Distribution
from warpfree.parameters import Param

from .layouts import HStaggering
from .model import Scheme

__all__ = ["DifferenceOrder", "Courant", "EndTime", "OutputInterval", "Frequency", "ParticlesPerWavelength", "DerivativeScheme",
           "Jitter", "HLayout", "LoadDistribution", "Ramp"]

Courant = Annotated[float, Param("", "the time step as a fraction of the stable limit (computed for the layout)",
                                 "(0, 1]")]
EndTime = Annotated[float, Param("s", "simulated time at which the run ends", "(0, inf)")]
OutputInterval = Annotated[float, Param("s", "simulated time between outputs", "(0, inf)")]
Frequency = Annotated[float, Param("Hz", "frequency f of the source", "(0, inf)")]
ParticlesPerWavelength = Annotated[float, Param("", "resolution λ/Δ: the vacuum wavelength in particle spacings",
                                                "(0, inf)")]
DerivativeScheme = Annotated[Scheme, Param("", "the derivative at a particle from the other set's particles")]
Jitter = Annotated[float, Param("Δ", "random offset of every particle off the walls, per axis, up to this fraction "
                                     "of the spacing (0: a uniform layout)", "[0, 0.5)")]
HLayout = Annotated[HStaggering, Param("", "where the H particles sit relative to the lattice of E particles")]
LoadDistribution = Annotated[Distribution, Param("", "which particles each thread updates (the results are bitwise "
                                                     "the same for all)")]
Ramp = Annotated[float, Param("periods", "sin² switch-on of the source over this many periods (0: at once)",
                              "[0, inf)")]
DifferenceOrder = Annotated[int, Param("", "order of the interior difference: 2 (Yee's, on any layout) or 4 (Fang's "
                                            "(2,4), on a uniform lattice whose only conductors are its faces)", "[2, 4]")]
