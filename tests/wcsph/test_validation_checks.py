"""Each fluid scene's QUICK run, in memory: its validation block names its checked quantities and passes."""

import pytest

from warpfree import device
from warpfree.scene_loader import load_scene

CASES = {
    "dam_break_2d": {"front.dZ_max_martin_moyce", "front.dZ_collapse_martin_moyce"},
    "dam_break_3d": {"obstacle.fluid_particles_inside", "spheric2.H2_rms_of_range", "spheric2.H4_rms_of_range"},
    "dam_break_wall_2d": {"wall_pressure.arrival_T", "wall_pressure.negative_mean_impact", "wall_pressure.peak1",
                          "wall_pressure.mean_run_up"},
    "tank_at_rest_2d": {"hydrostatic.pressure_error_max", "hydrostatic.kinetic_energy_max",
                        "hydrostatic.surface_spread_max"},
    "standing_wave_2d": {"standing_wave.frequency_error", "standing_wave.amplitude_ratio", "standing_wave.decay_rate",
                         "standing_wave.fit_residual"},
    "poiseuille_2d": {"poiseuille.profile_error_max"},
    "taylor_green_2d": {"taylor_green.energy_error", "taylor_green.velocity_l2_error"},
    "heat_conduction_2d": {"decay.rate_rel_error", "decay.amplitude_error_max", "decay.heat_content_drift"},
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_quick_run_in_memory_passes_its_checks(name):
    device.use("cpu", 2)
    module = load_scene(name)
    summary = module.build(**module.QUICK, frames=False, vtk=False).run(None, progress=False)
    validation = summary["validation"]
    assert set(validation["checks"]) == CASES[name]
    for check in validation["checks"].values():
        assert check["source"] and check["basis"]
    assert validation["passed"], {k: c["value"] for k, c in validation["checks"].items() if not c["passed"]}
