"""Element-Free Galerkin (seeds 003 and 002): MLS shape functions, Gauss-point assembly, Poisson and 2D elasticity."""
