"""Every shipped scene, found by discovery, runs from the command line by name at its smallest size and writes what
a run writes: summary.json with its analyses, VTU files with their PVD index, frames."""

from __future__ import annotations

import json

import pytest

from warpfree.cli import main
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
    if scene_parameters(module)["frames"].default:
        assert list((out / "frames").glob("*.png"))
