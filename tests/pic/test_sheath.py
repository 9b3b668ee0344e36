"""The sheath at a floating wall: the collisionless kinetic model (``warpfree.validation.pic_sheath``) and the scene
against it."""

import math

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.validation.pic_sheath import SheathModel


def test_the_model_gives_the_classic_floating_wall_potential_for_hydrogen():
    """Ions at the Bohm speed, m_i/m_e = 1836.15: φ_w = ln(Γ_i/Γ_e0) = -½ ln(μ/2π) - ln n_s, n_s = 1.0086 making the
    source neutral: -2.847 against the textbook's -2.839 (n_s = 1)."""
    model = SheathModel(1836.15, 1.0)
    classic = -0.5 * math.log(1836.15 / (2 * math.pi))
    assert model.wall_potential == pytest.approx(classic - math.log(model.source_electron_density), abs=1e-12)
    assert model.wall_potential == pytest.approx(-2.847, abs=1e-3)
    assert model.source_electron_density == pytest.approx(1.0086, abs=1e-4)
    assert model.electron_density(0.0, model.source_electron_density, model.wall_potential) == pytest.approx(1.0)
    assert model.ion_density(0.0) == pytest.approx(1.0)


@pytest.mark.parametrize("mass_ratio, mach", [(100.0, 1.0), (100.0, 1.2), (1836.15, 1.0)])
def test_the_model_s_potential_solves_poisson_s_equation_between_the_source_and_the_wall(mass_ratio, mach):
    """φ(0) = 0, φ(L) = φ_w, falling monotonically, and φ'' = n_e(φ) - n_i(φ) by central differences to 1e-4 of the
    densities (h = 1e-3 λ_D; measured 7e-7) short of the last 0.2 λ_D (the spline's knots crowd there: 1e-4)."""
    model = SheathModel(mass_ratio, mach)
    length = 20.0
    x = np.linspace(0.0, length, 20001)
    phi = model.potential(x, length)
    assert phi[0] == pytest.approx(0.0, abs=1e-12) and phi[-1] == pytest.approx(model.wall_potential, abs=1e-9)
    assert np.all(np.diff(phi) <= 1e-12)
    h = x[1] - x[0]
    second = (phi[2:] - 2 * phi[1:-1] + phi[:-2]) / h ** 2
    inner = phi[1:-1]
    residual = second - (model.electron_density(inner, model.source_electron_density, model.wall_potential)
                         - model.ion_density(inner))
    assert np.max(np.abs(residual[x[1:-1] < length - 0.2])) < 1e-4


def test_ions_below_bohm_s_speed_have_no_monotone_sheath_and_the_scene_names_the_parameter():
    """Bohm's criterion: at m_i/m_e = 100 a monotone sheath needs u0 ≥ 0.98 c_s; the scene refuses 0.9 naming
    ion_mach."""
    from warpfree.scene_loader import load_scene

    assert SheathModel(100.0, 0.98).monotone and not SheathModel(100.0, 0.97).monotone
    with pytest.raises(ValueError, match="Bohm"):
        SheathModel(100.0, 0.9).potential([0.0], 20.0)
    with pytest.raises(ParameterError, match="ion_mach"):
        load_scene("pic_sheath").build(ion_mach=0.9)


def test_below_bohm_s_speed_the_model_s_plateau_is_neutral_and_its_ions_meet_bohm_s_criterion():
    """Ions at 0.5 c_s: the plateau a source sheath would drop to (where V is least) is neutral, n_e = n_i to
    round-off, at -1.0705 T_e/e (the README's figure), the ions there at 1.55 c_s (Bohm's criterion met); at and
    above Bohm's speed there is no source sheath (φ_p = 0)."""
    model = SheathModel(100.0, 0.5)
    plateau = model.plateau_potential()
    assert plateau == pytest.approx(-1.0705, abs=1e-4)
    electrons = model.electron_density(plateau, model.source_electron_density, model.wall_potential)
    assert electrons == pytest.approx(model.ion_density(plateau), rel=1e-12)
    assert math.sqrt(0.25 - 2.0 * plateau) == pytest.approx(1.546, abs=1e-3)
    assert all(SheathModel(100.0, mach).plateau_potential() == 0.0 for mach in (0.98, 1.0, 1.2))


def test_the_floating_wall_charges_to_the_model_s_potential_and_the_sheath_follows_it(tmp_path):
    """The scene at half its particles and run (50 per λ_D², t = 300, m_i/m_e = 100, ions at c_s): the wall's mean
    potential over the second half within 0.05 T_e/e of ln(Γ_i/Γ_e0) = -1.4301 (measured -0.022), the mean potential
    over the sheath's last 5 λ_D within 0.05 of the model's (0.022), the wall's net current near zero (it floats:
    8e-5 against the ion flux 0.1), and the charge balance kept. For a plasma of 1e17 m⁻³ at 5 eV, the wall's
    potential in volts is 5 times its normalised value, the ions' current density e n0 c_s."""
    from warpfree.scene_loader import load_scene
    from warpfree.solvers.pic.units import PlasmaUnits

    summary = load_scene("pic_sheath").build(t_end=300.0, particles_per_cell=50, frames=False, vtk=False,
                                             density=1e17, electron_temperature=5.0).run(str(tmp_path),
                                                                                           progress=False)
    sheath = summary["analysis"]["sheath"]
    assert sheath["model_wall_potential"] == pytest.approx(-1.4301, abs=1e-4)
    assert abs(sheath["wall_potential_error"]) < 0.05, sheath
    assert sheath["sheath_profile_max_error"] < 0.05, sheath
    assert abs(sheath["wall_net_current"]) < 0.01 * sheath["ion_flux"]
    assert sheath["charge_balance_error"] < 1e-11
    si = sheath["si"]["results"]
    assert si["wall_potential"] == {"value": pytest.approx(5.0 * sheath["wall_potential"], rel=1e-14), "unit": "V"}
    c_s = PlasmaUnits(1e17, 5.0).thermal_speed / math.sqrt(100.0)
    assert si["ion_current_density"]["value"] == pytest.approx(1.602176634e-19 * 1e17 * c_s, rel=1e-12)
