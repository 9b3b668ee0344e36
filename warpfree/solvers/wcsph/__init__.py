"""WCSPH fluids (seed 004): the model (:mod:`.model`), the solver (:mod:`.solver`), free surfaces
(:mod:`.surface`) and the helpers of the fluid scenes (:mod:`.scene_tools`). Kernels:
``warpfree.kernels.wcsph``."""

from .model import FluidParams, WCSPHModel
from .solver import WCSPHSolver, WCSPHState

__all__ = ["FluidParams", "WCSPHModel", "WCSPHSolver", "WCSPHState"]
