"""Runs over several processes (MPI ranks): the ranks (:mod:`.world`), the cut of space between them
(:mod:`.decomposition`) and the items each rank holds with their ghosts (:mod:`.halo`)."""

from .decomposition import CutMethod, Decomposition, imbalance
from .halo import Partition
from .world import MPI_EXTRA, World, launched_ranks, world

__all__ = ["CutMethod", "Decomposition", "Partition", "World", "world", "launched_ranks", "imbalance", "MPI_EXTRA"]
