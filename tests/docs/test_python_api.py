"""The Python API the documentation describes: a scene built and run in memory hands back its fields
(``Run.fields()``), its series and its analysis with the validation block."""

import numpy as np

from warpfree.scene_loader import load_scene


def test_fields_are_copies_of_the_final_state_by_set_name():
    scene = load_scene("heat_conduction_2d")
    run = scene.build(**scene.SMALLEST)
    summary = run.run(None, progress=False)
    fields = run.fields()
    assert set(fields) == set(run.solver.output_fields()) == {"particles"}
    particles = fields["particles"]
    assert particles.name == "particles" and particles.points.shape == (16 * 16, 3)
    temperature = run.solver.temperature()
    assert temperature.min() > 200.0  # about 300 K: the zeros written below would show
    np.testing.assert_array_equal(particles.fields["temperature"], temperature)
    particles.fields["temperature"][:] = 0.0  # a copy: the solver's state is untouched
    np.testing.assert_array_equal(run.fields()["particles"].fields["temperature"], temperature)
    assert len(run.series["time"]) == len(run.series["amplitude"]) == 9  # t = 0, 0.25, ..., 2
    assert summary["analysis"]["decay"]["rate"] > 0 and "validation" in summary
