"""The SPH smoothing kernels a scene chooses from (:class:`SmoothingKernel`); their formulas, support radii and
normalisations are in :mod:`warpfree.kernels.smoothing`, keyed by the same names."""

from __future__ import annotations

from .parameters import Choice

__all__ = ["SmoothingKernel"]


class SmoothingKernel(Choice):
    """The SPH smoothing kernel W(r, h)."""

    CUBIC_SPLINE = "cubic_spline", "cubic B-spline (Monaghan & Lattanzio 1985), support 2h"
    WENDLAND_C2 = "wendland_c2", "Wendland C2 (Wendland 1995), support 2h"
    QUINTIC_SPLINE = "quintic_spline", "quintic B-spline (Morris, Fox & Zhu 1997), support 3h"

    @property
    def support(self) -> float:
        """The support radius in units of h (2 for the cubic spline and Wendland C2, 3 for the quintic spline)."""
        from .kernels.smoothing import support_factor

        return support_factor(self.value)
