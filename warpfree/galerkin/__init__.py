"""The meshfree-Galerkin floor: what EFG, NEM and the PIC field solve share.

- :mod:`.shapes`: shape functions at points whatever model made them (:class:`~.shapes.ShapeData`), and what a
  Galerkin solver needs of a model (:class:`~.shapes.ShapeModel`);
- :mod:`.mls`: the MLS model (bases, weights, supports; Rocha 2012; Marques 2008), the EFG and PIC shape functions;
- :mod:`.quadrature`: integration cells and Gauss rules (rectangles, mapped quadrilaterals, ring sectors,
  triangles, boundary segments and arcs);
- :mod:`.consistent_integration`: test gradients that restore the discrete divergence theorem;
- :mod:`.nodal_integration`: stabilized conforming nodal integration (smoothing cells of a triangulation, smoothed
  gradients as shape data);
- :mod:`.assembly`: stiffness matrices (node rows or triplets) and load vectors;
- :mod:`.node_layouts`: regular and stratified-random node grids on boxes, quadrilaterals and ring sectors;
- :mod:`.curves`, :mod:`.region`, :mod:`.region_files`: regions bounded by exact curves (shapes, booleans, files),
  their nodes, integration cells and boundary conditions on the true curves.

Kernels: ``kernels/mls.py`` and ``kernels/galerkin.py``. float64 throughout.
"""
