"""The normalised plasma scenes' SI units (``warpfree.solvers.pic.units``): the scales against the NRL Plasma
Formulary, a scene's results in SI, and the two parameters refused alone."""

import math

import pytest

from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.scene_loader import load_scene
from warpfree.solvers.pic.units import PlasmaUnits, plasma_units

#: (n in cm⁻³, T_e in eV): a glow discharge, a tokamak edge, the ionosphere's F layer
PLASMAS = [(1e10, 2.0), (1e13, 50.0), (1e6, 0.1)]
#: the formulary's three significant figures
FORMULARY_RTOL = 1e-3


@pytest.mark.parametrize("n_cm3,t_ev", PLASMAS)
def test_the_scales_are_the_nrl_plasma_formulary_s(n_cm3, t_ev):
    """NRL Plasma Formulary (2019), pp. 28-29: λ_D = 7.43e2 T_e^½ n^-½ cm, f_pe = 8.98e3 n^½ Hz,
    v_Te = 4.19e7 T_e^½ cm/s (n in cm⁻³, T_e in eV), each within its three figures."""
    units = PlasmaUnits(n_cm3 * 1e6, t_ev)
    assert units.debye_length == pytest.approx(7.43e2 * math.sqrt(t_ev / n_cm3) * 1e-2, rel=FORMULARY_RTOL)
    assert units.plasma_frequency / (2 * math.pi) == pytest.approx(8.98e3 * math.sqrt(n_cm3), rel=FORMULARY_RTOL)
    assert units.thermal_speed == pytest.approx(4.19e7 * math.sqrt(t_ev) * 1e-2, rel=FORMULARY_RTOL)
    assert units.scale("potential") == t_ev and units.scale("rate") == units.plasma_frequency


def test_density_and_temperature_are_given_together_or_not_at_all(tmp_path, capsys):
    """One alone: refused naming the other, before any set-up (the command line: exit 2, one line, nothing
    written); neither: normalised units only."""
    assert plasma_units(None, None) is None
    with pytest.raises(ParameterError, match="electron_temperature"):
        plasma_units(1e16, None)
    with pytest.raises(ParameterError, match="density"):
        plasma_units(None, 2.0)
    out = tmp_path / "run"
    assert main(["run", "pic_two_stream", "--set", "density=1e16", "--out", str(out), "--no-progress"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "warpfree: error: electron_temperature: must be given with density (the two set the SI units)"]
    assert not out.exists() or not any(out.iterdir())
    assert main(["run", "pic_sheath", "--set", "density=-1", "--set", "electron_temperature=2", "--out", str(out),
                 "--no-progress"]) == 2
    assert "density" in capsys.readouterr().err


def test_a_plasma_oscillation_reports_its_frequency_in_si(tmp_path):
    """The smallest oscillation of a plasma of 1e18 m⁻³ at 10 eV: its measured frequency in rad/s is the normalised
    one times ω_pe = 5.64e10 rad/s; its wavelength in metres the normalised one times λ_D = 23.5 μm; with no density
    given, no SI block."""
    scene = load_scene("pic_plasma_oscillation")
    smallest = dict(scene.SMALLEST, frames=False, vtk=False)
    result = scene.build(**smallest, density=1e18, electron_temperature=10.0).run(
        str(tmp_path / "si"), progress=False)["analysis"]["oscillation"]
    units = PlasmaUnits(1e18, 10.0)
    assert units.plasma_frequency == pytest.approx(5.641e10, rel=1e-3)
    assert units.debye_length == pytest.approx(23.51e-6, rel=1e-3)
    si = result["si"]["results"]
    assert si["frequency"] == {"value": pytest.approx(result["frequency"] * units.plasma_frequency, rel=1e-14),
                               "unit": "rad/s"}
    assert si["wavelength"]["value"] == pytest.approx(2 * math.pi / 0.5 * units.debye_length, rel=1e-14)
    assert result["si"]["plasma"]["density"]["value"] == 1e18
    plain = scene.build(**smallest).run(str(tmp_path / "plain"), progress=False)["analysis"]["oscillation"]
    assert "si" not in plain and plain["frequency"] == result["frequency"]


def test_the_run_prints_the_si_results_with_their_units(tmp_path, capsys):
    """``warpfree run`` ends with the SI block's scales and results, each with its unit, beside the normalised ones."""
    scene = load_scene("pic_plasma_oscillation")
    sets = [a for k, v in scene.SMALLEST.items() for a in ("--set", f"{k}={v}")]
    assert main(["run", "pic_plasma_oscillation", *sets, "--set", "density=1e18", "--set", "electron_temperature=10",
                 "--out", str(tmp_path / "run"), "--no-progress", "--no-frames"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "  oscillation.si.debye_length = 2.351e-05 m" in lines
    assert "  oscillation.si.density = 1e+18 1/m³" in lines
    assert any(line.startswith("  oscillation.si.frequency = ") and line.endswith(" rad/s") for line in lines)
