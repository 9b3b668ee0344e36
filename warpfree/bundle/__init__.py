"""Offline bundles: warpfree and the packages a machine lacks, built on a connected machine for a target Python and
platform, cut into parts of a given size, and installed on the target (a cluster's GPU node with no package index) by
a script that needs only the standard library.

:mod:`warpfree.bundle.build` makes a bundle (``warpfree bundle build``); :mod:`warpfree.bundle.install` is the
installer shipped in it as ``install_bundle.py``. The documentation's page "Installing without a package index" walks
through both.
"""
