"""The uniform layouts' numerical dispersion (warpfree.solvers.spem.dispersion) against its closed forms and limits."""

import math

import pytest

from warpfree.errors import ParameterError
from warpfree.solvers.spem.dispersion import largest_lag_error, phase_lag, wavenumber_ratio


def test_yee_relation_along_an_axis_and_the_diagonal():
    """Along an axis Yee's relation is the 1D one, sin(k̃Δ/2) = sin(πS/N)/S (exact at S = 1, the magic step); along
    the diagonal 2 sin²(k̃Δ/(2√2)) = sin²(πS/N)/S²; for kΔ → 0 on an axis k̃/k - 1 → (kΔ)²(1 - S²)/24."""
    for n, s in ((40.0, 0.6667), (20.0, 0.5), (10.0, 0.7)):
        axis = 2.0 * math.asin(math.sin(math.pi * s / n) / s) / (2.0 * math.pi / n)
        assert wavenumber_ratio(n, s, 0.0) == pytest.approx(axis, abs=1e-13)
        assert wavenumber_ratio(n, s, 90.0) == pytest.approx(axis, abs=1e-13)
        diagonal = 2.0 * math.sqrt(2.0) * math.asin(math.sin(math.pi * s / n) / (s * math.sqrt(2.0))) / (2 * math.pi / n)
        assert wavenumber_ratio(n, s, 45.0) == pytest.approx(diagonal, abs=1e-13)
    assert wavenumber_ratio(40.0, 1.0, 0.0) == pytest.approx(1.0, abs=1e-14)
    n, s = 400.0, 0.6
    assert wavenumber_ratio(n, s) - 1.0 == pytest.approx((2 * math.pi / n) ** 2 * (1 - s * s) / 24.0, rel=1e-3)


def test_cell_centred_layout_is_yee_rotated():
    """H at the cell centres: along an axis the 1D relation at Δ, along the diagonal Yee's axis relation at spacing
    √2 Δ (S and N scaled by 1/√2)."""
    n, s = 40.0, 0.95
    assert wavenumber_ratio(n, s, 0.0, "centres") == pytest.approx(wavenumber_ratio(n, s, 0.0, "edges"), abs=1e-13)
    r2 = math.sqrt(2.0)
    assert wavenumber_ratio(n, s, 45.0, "centres") == pytest.approx(wavenumber_ratio(n / r2, s / r2, 0.0), abs=1e-13)


def test_phase_lag_grows_with_distance_and_falls_with_resolution_squared():
    """δφ ∝ L and ∝ (kΔ)²: the plane-wave scene's default (40 per λ, S = 2/3, 4.8 λ of travel) lags by 0.0173 rad,
    the largest error 2 sin(δφ/2) = 1.73 % of A."""
    lag = phase_lag(4.8, 40.0, 2.0 / 3.0)
    assert lag == pytest.approx(2 * math.pi * 4.8 * (wavenumber_ratio(40.0, 2.0 / 3.0) - 1.0), rel=1e-14)
    assert lag == pytest.approx(0.01727, abs=1e-5)
    assert phase_lag(9.6, 40.0, 2.0 / 3.0) == pytest.approx(2.0 * lag, rel=1e-12)
    assert phase_lag(4.8, 80.0, 2.0 / 3.0) == pytest.approx(lag / 4.0, rel=2e-3)
    assert largest_lag_error(4.8, 40.0, 2.0 / 3.0) == pytest.approx(2.0 * math.sin(lag / 2.0), rel=1e-14)


def test_bad_dispersion_input_is_named():
    with pytest.raises(ParameterError, match="^particles_per_wavelength"):
        wavenumber_ratio(2.0, 0.5)
    with pytest.raises(ParameterError, match="^courant_number"):
        wavenumber_ratio(40.0, 1.2)
    with pytest.raises(ParameterError, match="^h_staggering"):
        wavenumber_ratio(40.0, 0.5, h_staggering="corners")
