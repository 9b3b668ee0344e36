"""The parameters the EFG scenes share, each declared once (:mod:`warpfree.parameters`): a scene's ``build()``
annotates ``method: Method = EssentialMethod.LAGRANGE`` and ``--list``, the docs and the checks before set-up read
the unit, meaning and allowed values from here. The MLS model's own (basis, weight, d_max) are declared beside it, in
:mod:`warpfree.galerkin.mls` (``Basis``, ``Weight``, ``SupportScale``), which the PIC scenes share."""

from __future__ import annotations

from typing import Annotated

from warpfree.galerkin.node_layouts import NodePlacement
from warpfree.galerkin.shapes import ShapeFunctions
from warpfree.parameters import Param

from .boundary import EssentialMethod
from .solver import Integration

__all__ = ["Layout", "LayoutSeed", "CellGauss", "Method", "DomainIntegration", "ModelIntegration", "Model",
           "Magnify"]

Layout = Annotated[NodePlacement, Param("", "where the nodes sit on the layout's grid")]
LayoutSeed = Annotated[int, Param("", "seed of the random node layout (layout=random)", "[0, inf)")]
CellGauss = Annotated[int | None, Param("", "Gauss points per background-cell side (none: the basis's, 2 linear, "
                                            "3 quadratic)", "[1, inf)")]
Method = Annotated[EssentialMethod, Param("", "how essential conditions (prescribed values) are imposed")]
DomainIntegration = Annotated[Integration, Param("", "how the weak form is integrated over the domain")]
ModelIntegration = Annotated[Integration | None, Param("", "how the weak form is integrated over the domain (none: "
                                                           "consistent for EFG, scni for NEM)")]
Model = Annotated[ShapeFunctions, Param("", "shape functions: EFG (MLS) or NEM (Laplace) on the same nodes")]
Magnify = Annotated[float, Param("", "displacement magnification in deformed.png", "(0, inf)")]
