"""Flow past a cylinder: the measures the scene ``cylinder_flow_2d`` takes (the wake's length from a centreline
profile, the Strouhal number from the lift, the checks at the Reynolds numbers with published values) on exact
signals, and its bad parameters named before any set-up. The flow itself is checked by ``warpfree validate``."""

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.scene_loader import load_scene, shipped_scenes
from warpfree.validation import cylinder_flow_2d as cylinder


def test_the_wake_ends_where_the_centreline_velocity_turns_forward():
    """u = (x - 0.5)(x - 1.44) behind a cylinder of radius 0.5: backward from the rear to x = 1.44, so the wake is
    0.94 long (the linear interpolation between samples 0.01 apart is exact to 1e-4 on this parabola)."""
    x = np.arange(0.5, 4.0, 0.01)
    u = (x - 0.5) * (x - 1.44)
    assert cylinder.wake_length(x, u, 0.5) == pytest.approx(0.94, abs=1e-4)
    assert cylinder.wake_length(x, np.abs(u) + 0.1, 0.5) == 0.0  # attached: nothing backward
    assert np.isnan(cylinder.wake_length(x, -np.ones_like(x), 0.5))  # backward to the last sample: no end seen


def test_the_shedding_is_the_lift_s_strongest_frequency_through_the_particles_noise():
    """A lift 0.33 sin(2π 0.164 t) plus an offset and noise (normal, σ = 0.5, each sample of
    0.05 D/U its own: the particles passing a cylinder's few wall particles), over 60 D/U: St within 1 % of 0.164,
    the amplitude within 10 % of 0.33, about 9.8 cycles. D = 0.01 m and U = 2 mm/s (the times in seconds)."""
    diameter, speed = 0.01, 0.002
    tau = np.arange(0.0, 60.0, 0.05)
    lift = 0.33 * np.sin(2.0 * np.pi * 0.164 * tau + 0.3) + 0.05 + np.random.default_rng(1).normal(0.0, 0.5, tau.size)
    st, amplitude, cycles = cylinder.shedding(tau * diameter / speed, lift, diameter, speed)
    assert st == pytest.approx(0.164, rel=0.01)
    assert amplitude == pytest.approx(0.33, rel=0.1)
    assert cycles == pytest.approx(60 * 0.164, rel=0.01)
    assert np.isnan(cylinder.shedding(tau[:300] * diameter / speed, lift[:300], diameter, speed)[0])  # 15 D/U


def test_checks_are_made_where_values_are_published():
    basis = "exact signals"
    at20 = cylinder.cylinder_checks(20.0, 2.10, 0.01, 0.97, float("nan"), basis)
    assert set(at20) == {"drag", "wake_length", "lift"} and all(c["passed"] for c in at20.values())
    assert not cylinder.cylinder_checks(20.0, 2.20, 0.01, 0.97, float("nan"), basis)["drag"]["passed"]  # +7.6 %
    at100 = cylinder.cylinder_checks(100.0, 1.36, 0.0, float("nan"), 0.170, basis)
    assert set(at100) == {"drag", "strouhal"} and all(c["passed"] for c in at100.values())
    assert not cylinder.cylinder_checks(100.0, 1.36, 0.0, float("nan"), 0.180, basis)["strouhal"]["passed"]
    assert cylinder.cylinder_checks(50.0, 1.5, 0.0, 2.0, 0.13, basis) == {}


@pytest.mark.parametrize("settings,parameter", [
    ({"per_diameter": 6, "upstream": 6.1}, "upstream"),  # 36.6 spacings
    ({"per_diameter": 6, "width": 12.1}, "width"),
    ({"t_end": 5.0, "averaged": 6.0}, "averaged"),
    ({"averaged": 1.0, "output_interval": 2.0}, "output_interval"),
    ({"per_diameter": 3}, "per_diameter"),
    ({"reynolds": 0.0}, "reynolds"),
])
def test_a_bad_cylinder_scene_is_named_before_any_set_up(settings, parameter):
    scene = load_scene(shipped_scenes()["cylinder_flow_2d"])
    with pytest.raises(ParameterError) as err:
        scene.build(**settings)
    assert err.value.name == parameter
