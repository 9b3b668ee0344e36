"""Every scene runs from the CLI with tiny sizes and writes its outputs; the CLI explains itself."""

import json
import os
import subprocess
import sys

import pytest

from warpfree.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args):
    return main(["run", *args, "--no-progress"])


def test_dam_break_2d_cli_writes_vtu_frames_front_plot_and_summary(tmp_path):
    out = tmp_path / "db"
    assert run_cli(os.path.join(ROOT, "scenes", "dam_break_2d.py"), "--set", "dx=0.1", "--set", "t_end=0.04",
                   "--set", "output_interval=0.02", "--out", str(out), "--threads", "2") == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["threads"] == 2
    assert summary["throughput"]["unit"] == "particle-steps/s" and summary["throughput"]["value"] > 0
    assert summary["params"]["dx"] == 0.1
    assert len(list((out / "frames").glob("*.png"))) == 3
    assert len(list((out / "vtk").glob("fluid_*.vtu"))) == 3 and (out / "fluid.pvd").is_file()
    assert (out / "front.png").is_file()


def test_dam_break_3d_cli_with_free_surface(tmp_path):
    out = tmp_path / "db3"
    assert run_cli(os.path.join(ROOT, "scenes", "dam_break_3d.py"), "--set", "dx=0.1", "--set", "t_end=0.02",
                   "--set", "output_interval=0.02", "--set", "surface=true", "--out", str(out)) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["analysis"]["obstacle"]["max_fluid_particles_inside"] == 0
    assert len(list((out / "surface").glob("*.ply"))) == 2
    assert len(list((out / "frames").glob("*.png"))) == 2


def test_tank_at_rest_cli_no_frames(tmp_path):
    out = tmp_path / "tank"
    assert run_cli(os.path.join(ROOT, "scenes", "tank_at_rest_2d.py"), "--set", "dx=0.05", "--set", "t_end=0.02",
                   "--set", "output_interval=0.01", "--no-frames", "--out", str(out)) == 0
    assert not (out / "frames").exists() and (out / "pressure.png").is_file()


def test_cli_errors_name_the_parameter(tmp_path, capsys):
    assert run_cli(os.path.join(ROOT, "scenes", "dam_break_2d.py"), "--set", "dx=-1", "--out", str(tmp_path)) == 2
    assert "dx" in capsys.readouterr().err
    assert run_cli(os.path.join(ROOT, "scenes", "nope.py")) == 2
    assert run_cli(os.path.join(ROOT, "scenes", "dam_break_2d.py"), "--threads", "0", "--out", str(tmp_path)) == 2
    assert "threads" in capsys.readouterr().err


@pytest.mark.parametrize("args", [["--help"], ["run", "--help"]])
def test_help_explains_commands(args):
    res = subprocess.run([sys.executable, "-m", "warpfree.cli", *args], capture_output=True, text=True)
    assert res.returncode == 0
    assert "warpfree run" in res.stdout or "--resume" in res.stdout


def test_cli_resume_continues_from_the_last_checkpoint(tmp_path):
    out = tmp_path / "db"
    scene = os.path.join(ROOT, "scenes", "dam_break_2d.py")
    assert run_cli(scene, "--set", "dx=0.1", "--set", "t_end=0.03", "--checkpoint-every", "10",
                   "--no-frames", "--out", str(out)) == 0
    first = json.loads((out / "summary.json").read_text())
    checkpoints = sorted((out / "checkpoints").glob("step_*.npz"))
    assert checkpoints and len(checkpoints) <= 2
    assert run_cli("--resume", str(out), "--no-frames") == 0
    again = json.loads((out / "summary.json").read_text())
    assert again["steps"] == first["steps"] and again["steps_this_run"] < first["steps"]
    assert again["probes"]["front"] == first["probes"]["front"]
