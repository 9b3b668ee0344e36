"""PIC (Marques 2008): electrostatic particle-in-cell whose field solve is EFG. Species and loading
(:mod:`.species`), wall sources (:mod:`.injection`), the EFG Poisson solve (:mod:`.field`); the solver (:mod:`.solver`)
and its parts: the particles and their state (:mod:`.particles`), the particle-node coupling (:mod:`.coupling`:
fits, deposit, solve, gather) and the per-step history (:mod:`.history`). Kernels: ``warpfree.kernels.pic``.
Normalised units: ε0 = 1, charges in e, masses in m_e, ω_pe = 1 for n_ref."""

from .coupling import FieldSolve, Gather
from .field import PlasmaPoisson
from .injection import Injection, SourceWall
from .solver import ParticleWall, PICSolver, PICState
from .species import ParticleLoad, Species, lattice_positions, load_species, random_positions

__all__ = ["FieldSolve", "Gather", "Injection", "SourceWall", "ParticleWall", "PlasmaPoisson", "PICSolver",
           "PICState", "ParticleLoad", "Species", "lattice_positions", "load_species", "random_positions"]
