"""Every shipped scene, found by discovery, runs from the command line by name at its smallest size and writes what
a run writes: summary.json with its analyses, VTU files with their PVD index, frames."""

from __future__ import annotations

import json

import numpy as np
import pytest

from warpfree.cli import main
from warpfree.io.vtk import read_pvd, read_snapshot, read_units
from warpfree.scene_loader import load_scene, scene_parameters, shipped_scenes, value_text

SCENES = sorted(shipped_scenes())


@pytest.mark.cuda
@pytest.mark.parametrize("name", SCENES)
def test_every_shipped_scene_runs_by_name_at_its_smallest_size(name, tmp_path, device_name):
    """On the CPU, or on the device ``--device`` names (the one-shot GPU check)."""
    module = load_scene(name)
    sets = [a for k, v in module.SMALLEST.items() for a in ("--set", f"{k}={value_text(v)}")]
    out = tmp_path / name
    assert main(["run", name, *sets, "--out", str(out), "--no-progress", "--threads", "2",
                 "--device", device_name]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["scene"] == name and summary["analysis"]
    assert summary["throughput"]["value"] > 0
    assert list(out.glob("*.pvd")) and list((out / "vtk").glob("*.vtu"))
    assert_outputs_complete(out, summary)
    if scene_parameters(module)["frames"].default:
        assert list((out / "frames").glob("*.png"))


def assert_outputs_complete(out, summary):
    """Every PVD lists snapshots, each with points and with a unit for the points and every field, the units the
    summary gives for its set."""
    for pvd in out.glob("*.pvd"):
        entries = read_pvd(pvd)
        assert entries, f"{pvd.name} lists no snapshot"
        expected = summary["units"]["outputs"][pvd.stem]
        for _, name in entries:
            points, fields = read_snapshot(out / name)
            assert len(points) > 0, name
            units = read_units(out / name)
            assert set(units) == {"position", *fields} and units == {k: expected[k] for k in units}, name


#: (scene, set, quantity, unit): the units each family's outputs carry (SI, the scene's own, or PIC's normalised)
UNITS = [("dam_break_2d", "fluid", "pressure", "Pa"), ("dam_break_2d", "fluid", "velocity", "m/s"),
         ("dam_break_2d", "boundary", "density", "kg/m³"), ("dam_break_2d", "fluid", "position", "m"),
         ("em_line_1d", "electric", "ez", "V/m"), ("em_line_1d", "magnetic", "hy", "A/m"),
         ("heat_conduction_2d", "particles", "temperature", "K"),
         ("efg_resistor", "gauss_points", "potential", "V"), ("efg_resistor", "gauss_points", "flux_x", "A/m²"),
         ("efg_timoshenko", "gauss_points", "von_mises", "Pa"), ("efg_timoshenko", "nodes", "parameter", "m"),
         ("efg_cook", "gauss_points", "von_mises", "consistent units"),
         ("efg_l_shape", "gauss_points", "position", "1"),
         ("pic_two_stream", "particles", "velocity", "λ_D ω_pe"), ("pic_two_stream", "particles", "position", "λ_D"),
         ("pic_two_stream", "nodes", "potential", "m_e λ_D² ω_pe²/e"),
         # a cold beam has no Debye length: the diode's lengths and times are in the units of its gap and voltage
         ("pic_diode", "particles", "position", "L"), ("pic_diode", "particles", "velocity", "L/T"),
         ("pic_diode", "nodes", "potential", "m_e L²/(e T²)")]


@pytest.mark.parametrize("name", sorted({u[0] for u in UNITS}))
def test_each_family_s_outputs_carry_their_units(name):
    """Every quantity of every output set has a unit, the one its family works in."""
    module = load_scene(name)
    run = module.build(**{**module.SMALLEST, "frames": False, "vtk": False})
    sets = {s.name: s for s in run.solver.output_sets()}
    for s in sets.values():
        units = run.units(s)
        assert {"position", *s.fields} <= set(units) and all(units.values()), (s.name, units)
    for _, set_name, quantity, unit in (u for u in UNITS if u[0] == name):
        assert run.units(sets[set_name])[quantity] == unit


def test_plasma_oscillation_frames_show_the_oscillation(tmp_path):
    """The particles coloured by their velocity along the perturbation: a quarter period in, the frame holds the
    colour map's two ends (v = ±δ ω_p on either side of the box), not one solid colour."""
    from PIL import Image

    module = load_scene("pic_plasma_oscillation")
    sets = [a for k, v in module.SMALLEST.items() for a in ("--set", f"{k}={value_text(v)}")]
    assert main(["run", "pic_plasma_oscillation", *sets, "--out", str(tmp_path), "--no-progress",
                 "--threads", "2"]) == 0
    quarter = tmp_path / "frames" / "frame_00002.png"  # t = 1.6 / ω_pe, sin(ω_p t) ≈ 1
    img = np.asarray(Image.open(quarter).convert("RGB")).astype(float) / 255.0
    coloured = img[(img.max(axis=2) - img.min(axis=2)) > 0.25]  # saturated: the particles, not axes or text
    assert len(coloured) > 1000
    dark_blue = coloured[:, 2] - coloured[:, 1]  # viridis' low end is purple-blue, its high end yellow
    assert np.percentile(dark_blue, 95) > 0.2 and np.percentile(dark_blue, 5) < -0.5
