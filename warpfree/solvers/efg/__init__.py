"""Element-Free Galerkin (Rocha 2012; Marques 2008): MLS shape functions, Gauss-point assembly, Poisson and 2D elasticity."""
