"""Warp kernels of warpfree (installed as ``warpfree.kernels``).

Only ``@wp.kernel`` and ``@wp.func`` live here; a kernel module imports Warp and other kernel modules,
never the orchestration layer. One module per method family keeps compile units small.
"""
