"""WCSPH fluids (Monaghan 1994): the model (:mod:`.model`), the solver (:mod:`.solver`), free surfaces
(:mod:`.surface`), rigid bodies among the walls (:mod:`.bodies`), inlets and outlets
(:mod:`.openings`) and the helpers of the fluid scenes (:mod:`.scene_tools`). Kernels:
``warpfree.kernels.wcsph``."""

from .bodies import PrescribedMotion, RigidBody
from .openings import Opening
from .model import BoundaryModel, FluidPairs, FluidParams, WCSPHModel
from .solver import FluidField, WCSPHSolver, WCSPHState

__all__ = ["BoundaryModel", "FluidField", "FluidPairs", "FluidParams", "Opening", "PrescribedMotion", "RigidBody", "WCSPHModel", "WCSPHSolver",
           "WCSPHState"]
