"""The parameters the PIC scenes share, each declared once (:mod:`warpfree.parameters`): a scene's ``build()``
annotates ``gather: ParticleGather = Gather.MOMENTUM`` and ``--list``, the docs and the checks before set-up read
the unit, meaning and allowed values from here. Normalised units (:mod:`.species`): lengths in λ_D, times in 1/ω_pe,
speeds in λ_D ω_pe. The support scale d_max is the MLS model's (``warpfree.galerkin.mls.SupportScale``)."""

from __future__ import annotations

from typing import Annotated

from warpfree.parameters import Param

from .coupling import FieldSolve, Gather

__all__ = ["NodeSpacing", "TimeStep", "EndTime", "Periods", "LengthY", "OutputEvery",
           "ParticleGather", "FieldSolveAt", "Density", "ElectronTemperature"]

NodeSpacing = Annotated[float, Param("λ_D", "spacing of the lattice of EFG nodes", "(0, inf)")]
TimeStep = Annotated[float, Param("1/ω_pe", "time step Δt of the leapfrog (ω_p Δt < 2)", "(0, inf)")]
EndTime = Annotated[float, Param("1/ω_pe", "time at which the run ends", "(0, inf)")]
Periods = Annotated[float, Param("2π/ω_pe", "length of the run, in plasma periods", "(0, inf)")]
LengthY = Annotated[float, Param("λ_D", "height Ly of the periodic box", "(0, inf)")]
OutputEvery = Annotated[int, Param("", "steps between outputs", "[1, inf)")]
ParticleGather = Annotated[Gather, Param("", "how the particles take the field from the nodes")]
FieldSolveAt = Annotated[FieldSolve | None, Param("", "where the field is solved each step (none: host on the CPU, "
                                                      "device on a GPU)")]
#: a plasma's density and temperature together give the normalised scenes' results in SI (:mod:`.units`)
Density = Annotated[float | None, Param("1/m³", "electron density n0 of the plasma, with electron_temperature: the "
                                                "results also in SI (none: normalised units only)", "(0, inf)")]
ElectronTemperature = Annotated[float | None, Param("eV", "electron temperature T_e of the plasma, with density: the "
                                                          "results also in SI (none: normalised units only)",
                                                    "(0, inf)")]
