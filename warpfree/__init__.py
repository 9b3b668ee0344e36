"""warpfree: meshfree particle methods (WCSPH, SPEM, EFG, PIDC) as data-parallel NVIDIA Warp kernels.

The orchestration layer: devices and threads, particle sets, neighbour grids, solvers, the simulation
loop, outputs and the CLI. Per-particle work lives in :mod:`warpfree.kernels`.
"""

import os as _os

import warp as _wp

# Quiet by default (no banner, no per-module compile lines); WARPFREE_VERBOSE=1 restores them.
if _os.environ.get("WARPFREE_VERBOSE", "0") in ("", "0"):
    _wp.config.log_level = _wp.LOG_WARNING

__version__ = "0.1.0"
