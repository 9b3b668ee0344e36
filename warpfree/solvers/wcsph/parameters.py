"""The parameters the fluid scenes share, each declared once (:mod:`warpfree.parameters`): a scene's ``build()``
annotates ``kernel: Kernel = SmoothingKernel.WENDLAND_C2`` and ``--list``, the docs and the checks before set-up read
the unit, meaning and allowed values from here."""

from __future__ import annotations

from typing import Annotated

from warpfree.parameters import Param
from warpfree.smoothing import SmoothingKernel

from .model import BoundaryModel, FluidPairs
from .solver import FluidField

__all__ = ["Spacing", "EndTime", "OutputInterval", "FixedStep", "HFactor", "Kernel", "ArtificialViscosity",
           "DensityDiffusion", "DynamicViscosity", "Walls", "WallSafety", "Courant", "Gravity", "RestDensity",
           "WallLayers", "FrameField", "Shifting", "SettlePeriods", "SoundSpeed", "Riemann", "Tension"]

Spacing = Annotated[float, Param("m", "initial particle spacing dx", "(0, inf)")]
EndTime = Annotated[float, Param("s", "simulated time at which the run ends", "(0, inf)")]
OutputInterval = Annotated[float, Param("s", "simulated time between outputs (snapshots, frames, probes)", "(0, inf)")]
FixedStep = Annotated[float | None, Param("s", "a fixed time step within the stable limit (none: the stable step "
                                               "C h/(c0 + max|v|) each step)", "(0, inf)")]
HFactor = Annotated[float, Param("dx", "smoothing length h = h_factor dx", "(0, inf)")]
Kernel = Annotated[SmoothingKernel, Param("", "smoothing kernel W(r, h)")]
ArtificialViscosity = Annotated[float, Param("", "Monaghan artificial viscosity α (0: off)", "[0, inf)")]
DensityDiffusion = Annotated[float, Param("", "δ-SPH density diffusion δ (0: off)", "[0, inf)")]
DensityGradient = Annotated[bool, Param("", "δ-SPH corrected by the renormalised density gradient (Antuono et al. "
                                            "2010; false: by the hydrostatic gradient)")]
DynamicViscosity = Annotated[float, Param("Pa·s", "dynamic viscosity μ of the laminar term (0: inviscid)", "[0, inf)")]
Walls = Annotated[BoundaryModel, Param("", "how wall particles act on the fluid")]
WallSafety = Annotated[float, Param("dx", "range r0 of the Lennard-Jones safety net of dynamic walls (0: off)",
                                    "[0, 1)")]
Courant = Annotated[float, Param("", "Courant number C of the step dt = C h/(c0 + max|v|)", "(0, 1]")]
Gravity = Annotated[float, Param("m/s²", "gravitational acceleration g", "(0, inf)")]
RestDensity = Annotated[float, Param("kg/m³", "rest density ρ0 of the water", "(0, inf)")]
WallLayers = Annotated[int, Param("", "layers of wall particles (they must cover the kernel support)", "[1, inf)")]
FrameField = Annotated[FluidField, Param("", "the fluid field frames colour by")]
Shifting = Annotated[float, Param("", "particle shifting coefficient A (Lind et al. 2012; 0: off)", "[0, inf)")]
SoundSpeed = Annotated[float, Param("sqrt(2gH)", "numerical speed of sound c0, in units of the water's largest free-fall "
                                                 "speed sqrt(2 g H) (the flow's Mach number is about its inverse)",
                                    "(0, inf)")]
SettlePeriods = Annotated[float, Param("", "settling of the water at rest before t = 0, in periods of its slowest "
                                           "sloshing mode", "[0, inf)")]
Riemann = Annotated[float, Param("", "limiter η of the pair pressure from a low-dissipation Riemann solver (Zhang, Hu & "
                                      "Adams 2017; 0: off, Monaghan's pair pressure)", "[0, inf)")]
Tension = Annotated[bool, Param("", "the equation of state gives negative pressures (false: p >= 0, a fluid without "
                                    "tension)")]
Pairs = Annotated[FluidPairs, Param("", "where the rates find a particle's fluid neighbours: a table's rows (faster on a "
                                        "CPU) or the neighbour grid (no table: about 200 bytes a particle less in 3D)")]
