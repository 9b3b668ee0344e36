"""Peer-benchmark runners (PySPH, Warp's bundled SPH example).

Used only by the bench harness for side-by-side comparisons; never imported by
the ``warpfree`` package or its tests.  Each module is also a CLI script.
"""
