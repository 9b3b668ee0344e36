"""Runs over several processes (MPI ranks): the ranks (:mod:`.world`), the cut of space between them
(:mod:`.decomposition`), the items each rank holds with their ghosts (:mod:`.halo`) and the items that move between
them (:mod:`.moving`)."""

from .decomposition import CutMethod, Decomposition, Mirrors, imbalance
from .halo import Partition
from .moving import MovingSpread, points3
from .world import MPI_EXTRA, World, launched_ranks, world

__all__ = ["CutMethod", "Decomposition", "Mirrors", "Partition", "MovingSpread", "points3", "World", "world", "launched_ranks",
           "imbalance", "MPI_EXTRA"]
