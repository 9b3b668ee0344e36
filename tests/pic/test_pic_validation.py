"""PIC scenes as validation cases: each QUICK run, in memory, returns a validation block naming its checked
quantities, and every check passes at its stated tolerance."""

import pytest

from warpfree import device
from warpfree.scene_loader import load_scene

CASES = {
    "pic_plasma_oscillation": {"charge_rel_error", "momentum_change", "frequency_rel_error"},
    "pic_two_stream": {"growth_rate_rel_error", "momentum_change_over_beam"},
    "pic_thermal_plasma": {"total_energy_drift", "momentum_change_over_thermal"},
    "pic_diode": {"charge_balance_error", "potential_max_error", "anode_over_injected"},
}
KEYS = {"pic_plasma_oscillation": "oscillation", "pic_two_stream": "two_stream", "pic_thermal_plasma": "thermal",
        "pic_diode": "diode"}


@pytest.mark.parametrize("scene", sorted(CASES))
def test_quick_run_in_memory_passes_its_checks(scene):
    device.use("cpu", 2)
    module = load_scene(scene)
    validation = module.build(**module.QUICK, frames=False, vtk=False).run(None, progress=False)["validation"]
    names = {name.split(".", 1)[1] for name in validation["checks"] if name.startswith(KEYS[scene] + ".")}
    assert names == CASES[scene]
    failed = {k: c["value"] for k, c in validation["checks"].items() if not c["passed"]}
    assert validation["passed"] and not failed, failed
    assert all(c["source"] and c["basis"] for c in validation["checks"].values())
