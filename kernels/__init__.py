"""Warp kernels of warpfree (installed as ``warpfree.kernels``).

Only ``@wp.kernel``, ``@wp.func`` and ``@wp.struct`` live here (and the factories that make them); a
kernel module imports Warp and other kernel modules, never the orchestration layer. Shared modules:
``smoothing``, ``space``, ``neighbours``, ``reduce``, ``assembly``; one module per method family,
named after its solver (``wcsph``).

Warp is configured here, once, before any kernel module is defined: quiet unless ``WARPFREE_VERBOSE=1``, and
without gradient (backward) kernels: Warp would generate and compile an adjoint beside every kernel, which the
engine never launches (nothing here is differentiated), at the cost of a slower first compile.
"""

import os as _os

import warp as _wp

if _os.environ.get("WARPFREE_VERBOSE", "0") in ("", "0"):
    _wp.config.log_level = _wp.LOG_WARNING
_wp.config.enable_backward = False
