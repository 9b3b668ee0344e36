"""Natural element method (Rocha 2012, §3.4): Laplace (non-Sibsonian) shape functions on the Voronoi diagram.

:class:`NEMModel` (``warpfree.solvers.nem.model``) is a shape model (``warpfree.galerkin.shapes.ShapeModel``) for
the Galerkin solvers, as the MLS model is (``warpfree.solvers.efg.solver``), with :meth:`NEMModel.integration_cells` for Gauss points on its Delaunay triangles.
"""

from .model import NEMModel, NEMSettings

__all__ = ["NEMModel", "NEMSettings"]
