"""Heave decay of a half-immersed cylinder: Ursell's coefficients and the linear transient
(``warpfree.validation.heave_decay_2d``) against what they must satisfy, the comparison's measures, the body held
while the water settles, and the scene's bad input."""

import math

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.scene_loader import load_scene
from warpfree.validation import heave_decay_2d as ursell


@pytest.mark.parametrize("omega", [0.3, 0.893, 1.5, 2.5])
def test_the_damping_on_the_cylinder_is_the_energy_its_waves_carry_off(omega):
    """λ from the pressure on the cylinder (M0, N0) and 2 (b/l)²/(π ω̂³) from the radiated waves (A, B): two results
    of the multipole solution computed apart, equal where it holds; 8 and 12 multipoles agree."""
    c = ursell.coefficients(omega)
    assert c["damping"] == pytest.approx(c["damping_from_waves"], rel=2e-3, abs=2e-4)
    finer = ursell.coefficients(omega, multipoles=12, collocation=40)
    assert finer["added_mass"] == pytest.approx(c["added_mass"], abs=1e-4)


def test_the_added_mass_has_its_limits_and_its_least_value_near_the_natural_frequency():
    """μ → 1 (the rigid-lid value ρπa²/2) at high frequency, grows without bound at low frequency (as log 1/ω̂), and
    is least (about 0.6) near ω̂ = 0.9."""
    mu = {w: ursell.coefficients(w)["added_mass"] for w in (0.1, 0.3, 0.9, 4.0)}
    assert 0.96 < mu[4.0] < 1.0
    assert mu[0.1] > mu[0.3] > 1.0 > mu[0.9]
    assert 0.58 < mu[0.9] < 0.62


def test_the_natural_frequency_balances_the_restoring_force_with_the_inertia():
    n = ursell.natural_frequency()
    assert n["omega"] ** 2 * math.pi * (1.0 + n["added_mass"]) / 4.0 == pytest.approx(1.0, abs=1e-8)
    assert n["omega"] == pytest.approx(0.8933, abs=1e-3) and n["damping_ratio"] == pytest.approx(0.164, abs=2e-3)


def test_the_table_is_the_coefficients():
    rows = ursell.table()
    assert np.all(np.isfinite(rows)) and np.all(np.diff(rows[:, 0]) > 0)
    for k in (0, 100, 300, len(rows) - 1):
        c = ursell.coefficients(float(rows[k, 0]))
        assert rows[k, 1:] == pytest.approx([c["added_mass"], c["damping"], c["wave_ratio"]], rel=1e-6, abs=1e-9)
    assert np.max(np.abs(rows[:, 2] - 2 * rows[:, 3] ** 2 / (np.pi * rows[:, 0] ** 3))) < 1e-3


def test_the_transient_starts_with_the_rigid_lid_added_mass_and_oscillates_at_the_natural_period():
    """Just after the release the water moves as under a rigid lid: y ≈ y0 (1 - C t²/(2 (m + a33(∞)))) with
    a33(∞) = ρπa²/2, i.e. (y/y0 - 1)/t̂² = -1/π (the high-frequency end of the integral); its zero crossings come
    on average half the frequency-domain damped period (7.13 sqrt(a/g)) apart within 3 %; it decays."""
    assert (ursell.free_decay([0.1])[0] - 1.0) / 0.01 == pytest.approx(-1.0 / math.pi, rel=0.01)
    t = np.arange(0.0, 25.0, 0.05)
    y = ursell.free_decay(t)
    crossings = ursell.zero_crossings(t, y)
    assert np.mean(np.diff(crossings)) == pytest.approx(0.5 * ursell.natural_frequency()["period"], rel=0.03)
    assert np.max(np.abs(y[t > 15])) < 0.2


def test_the_comparison_finds_a_body_s_own_floating_level_and_the_period():
    """A motion about a level c = 0.25 y0, released 0.75 y0 above it, and stretched in time by 2 %: the fitted level,
    the period's error and a small rms."""
    t = np.arange(0.0, 25.0, 0.05)
    theory = ursell.free_decay(t)
    heave = 0.25 + 0.75 * ursell.free_decay(t / 1.02)
    res = ursell.compare(t, heave, theory)
    assert res["floating_level"] == pytest.approx(0.25, abs=0.02)
    assert res["period_error"] == pytest.approx(0.02, abs=0.003)
    assert res["rms_difference"] < 0.05
    same = ursell.compare(t, theory, theory)
    assert same["floating_level"] == pytest.approx(0.0, abs=1e-12) and same["rms_difference"] < 1e-12


def test_a_body_held_while_the_water_settles_is_released_where_it_was_held():
    run = load_scene("heave_decay_2d").build(**load_scene("heave_decay_2d").SMALLEST, frames=False, vtk=False)
    state = run.solver.body_state()[0]
    assert state[1] == pytest.approx(3.0 * 0.1 + 0.2 * 0.1, abs=1e-12)   # the level plus the drop: not moved
    assert np.all(state[7:10] == 0.0)                                    # and at rest


@pytest.mark.parametrize("setting, parameter", [({"drop": 0.8}, "drop"), ({"depth": 5.05}, "depth"),
                                                ({"per_radius": 2}, "per_radius")])
def test_a_bad_heave_decay_setting_is_named(setting, parameter):
    with pytest.raises(ParameterError) as err:
        load_scene("heave_decay_2d").build(**{**load_scene("heave_decay_2d").SMALLEST, **setting}, frames=False,
                                           vtk=False)
    assert err.value.name == parameter
