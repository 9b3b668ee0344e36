"""warpfree: meshfree particle methods (WCSPH, SPEM, EFG, PIC) as data-parallel NVIDIA Warp kernels.

The orchestration layer: the solver contract, the run shell and time loop, devices and threads,
particle sets, neighbours, reductions, sparse assembly, outputs and the CLI. Per-particle work lives in
:mod:`warpfree.kernels`. Importing the package itself loads nothing heavy (the output writer's worker
process imports only what it writes with).
"""

__version__ = "0.1.0"
