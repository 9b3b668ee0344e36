"""Standing wave in a tank: the linear-theory reference (warpfree.validation.standing_wave_2d) and the scene's bad
input; the scene at its validation size is run and checked by CI's `warpfree validate --quick`."""

import math

import numpy as np
import pytest

from warpfree.scene_loader import load_scene
from warpfree.errors import ParameterError
from warpfree.validation import standing_wave_2d as linear

G = 9.81
SCENE = "standing_wave_2d"


def test_linear_theory_is_consistent():
    """ω² = g k tanh(kd) (deep and shallow limits); the start velocity is divergence-free, has no normal component
    at the walls and the bottom, and its vertical part at the surface is ∂η/∂t = A ω cos(kx); the centre-of-mass
    amplitude is the integral of (x − L/2) η over the tank."""
    L, d, A = 1.0, 0.5, 0.01
    k = math.pi / L
    omega = linear.frequency(G, L, d)
    assert omega ** 2 == pytest.approx(G * k * math.tanh(k * d), rel=1e-12)
    assert linear.frequency(G, L, 100.0) == pytest.approx(math.sqrt(G * k), rel=1e-12)
    assert linear.frequency(G, L, 1e-4) == pytest.approx(k * math.sqrt(G * 1e-4), rel=1e-6)
    x, y, e = np.array([0.3]), np.array([0.2]), 1e-6
    div = ((linear.initial_velocity(x + e, y, A, G, L, d)[0, 0] - linear.initial_velocity(x - e, y, A, G, L, d)[0, 0])
           + (linear.initial_velocity(x, y + e, A, G, L, d)[0, 1] - linear.initial_velocity(x, y - e, A, G, L, d)[0, 1]))
    assert abs(div / (2 * e)) < 1e-6
    s = np.linspace(0.0, L, 11)
    assert np.abs(linear.initial_velocity([0.0, L], [0.25, 0.25], A, G, L, d)[:, 0]).max() < 1e-15
    assert np.abs(linear.initial_velocity(s, np.zeros_like(s), A, G, L, d)[:, 1]).max() < 1e-15
    np.testing.assert_allclose(linear.initial_velocity(s, np.full_like(s, d), A, G, L, d)[:, 1],
                               A * omega * np.cos(k * s), rtol=1e-12, atol=1e-15)
    xs = (np.arange(100000) + 0.5) * L / 100000
    integral = np.sum((xs - L / 2) * A * np.cos(k * xs)) * (L / 100000) / (L * d)
    assert abs(integral) == pytest.approx(linear.centre_of_mass_amplitude(A, L, d), rel=1e-8)


def test_fit_recovers_a_damped_oscillation():
    t = np.linspace(0.0, 3.0, 121)
    s = 0.5 + 0.004 * np.exp(-0.09 * t) * np.sin(5.4 * t + 0.3)
    fit = linear.fit_damped_oscillation(t, s, 5.3)
    assert fit["omega"] == pytest.approx(5.4, rel=1e-6) and fit["beta"] == pytest.approx(0.09, rel=1e-4)
    assert abs(fit["amplitude"]) == pytest.approx(0.004, rel=1e-5) and fit["relative_residual"] < 1e-6


def test_standing_wave_bad_amplitude_is_named():
    with pytest.raises(ParameterError, match="amplitude"):
        load_scene(SCENE).build(amplitude=0.2, dx=0.05)
