"""SPEM (Mendes 2010): time-domain Maxwell on interleaved E and H particle sets. Layouts (:mod:`.layouts`),
the static model with its PML and derivative coefficients (:mod:`.model`), the leapfrog solver and its
sources (:mod:`.solver`, plane waves :mod:`.plane_wave`), the energy-conserving operator pair
(:mod:`.conservative`), Kronecker-delta nodal values (:mod:`.kronecker`), objects and their materials at second order
(:mod:`.materials`), running-DFT monitors (:mod:`.monitors`). Kernels: ``warpfree.kernels.spem``."""

from .layouts import HStaggering, StaggeredLayout, staggered_box, staggered_disk, staggered_line
from .model import C0, EPS0, MU0, PML, PMLSide, Scheme, SPEMModel, support_for_jitter
from .materials import PEC, EMObject, Material
from .monitors import DFTMonitor, FluxMonitor
from .plane_wave import PlaneWave
from .solver import GaussianPulse, Source, SourceKind, SPEMSolver, SPEMState, Waveform

__all__ = ["C0", "EPS0", "MU0", "PML", "PMLSide", "Scheme", "HStaggering", "DFTMonitor", "EMObject", "FluxMonitor", "Material", "PEC", "GaussianPulse", "PlaneWave", "SPEMModel",
           "SPEMSolver", "SPEMState", "Source", "SourceKind", "StaggeredLayout", "Waveform", "staggered_box",
           "staggered_disk", "staggered_line", "support_for_jitter"]
