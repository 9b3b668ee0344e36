"""Every scene runs from the CLI with tiny sizes and writes its outputs; the CLI explains itself."""

import json
import subprocess
import sys

import pytest

from warpfree.cli import main



def run_cli(*args):
    return main(["run", *args, "--no-progress"])


def test_dam_break_2d_cli_writes_vtu_frames_front_plot_and_summary(tmp_path):
    out = tmp_path / "db"
    assert run_cli("dam_break_2d", "--set", "dx=0.1", "--set", "t_end=0.04",
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
    assert run_cli("dam_break_3d", "--set", "dx=0.1", "--set", "t_end=0.02",
                   "--set", "output_interval=0.02", "--set", "surface=true", "--out", str(out)) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["analysis"]["obstacle"]["max_fluid_particles_inside"] == 0
    assert len(list((out / "surface").glob("*.ply"))) == 2
    assert len(list((out / "frames").glob("*.png"))) == 2


def test_tank_at_rest_cli_no_frames(tmp_path):
    out = tmp_path / "tank"
    assert run_cli("tank_at_rest_2d", "--set", "dx=0.05", "--set", "t_end=0.02",
                   "--set", "output_interval=0.01", "--no-frames", "--out", str(out)) == 0
    assert not (out / "frames").exists() and (out / "pressure.png").is_file()


def test_cli_errors_name_the_parameter(tmp_path, capsys):
    assert run_cli("dam_break_2d", "--set", "dx=-1", "--out", str(tmp_path)) == 2
    assert "dx" in capsys.readouterr().err
    assert run_cli("nope") == 2
    assert run_cli("dam_break_2d", "--threads", "0", "--out", str(tmp_path)) == 2
    assert "threads" in capsys.readouterr().err


@pytest.mark.parametrize("args", [["--help"], ["run", "--help"]])
def test_help_explains_commands(args):
    res = subprocess.run([sys.executable, "-m", "warpfree.cli", *args], capture_output=True, text=True)
    assert res.returncode == 0
    assert "warpfree run" in res.stdout or "--resume" in res.stdout


def test_cli_resume_continues_from_the_last_checkpoint(tmp_path):
    out = tmp_path / "db"
    scene = "dam_break_2d"
    assert run_cli(scene, "--set", "dx=0.1", "--set", "t_end=0.03", "--checkpoint-every", "10",
                   "--no-frames", "--out", str(out)) == 0
    first = json.loads((out / "summary.json").read_text())
    checkpoints = sorted((out / "checkpoints").glob("step_*.npz"))
    assert checkpoints and len(checkpoints) <= 2
    assert run_cli("--resume", str(out), "--no-frames") == 0
    again = json.loads((out / "summary.json").read_text())
    assert again["steps"] == first["steps"] and again["steps_this_run"] < first["steps"]
    assert again["probes"]["front"] == first["probes"]["front"]


@pytest.mark.parametrize("args,name", [
    (["--set", "dx=1e-6"], "dx"),                       # would need ~100 TB: refused before allocating
    (["--set", "a=-1"], "a"),
    (["--set", "tank_length=0.5"], "tank_length"),
    (["--set", "wall_layers=0"], "wall_layers"),
    (["--set", "frame_field=vorticity"], "frame_field"),
])
def test_bad_scene_values_exit_2_before_any_output(args, name, tmp_path, capsys):
    out = tmp_path / "run"
    assert run_cli("dam_break_2d", *args, "--out", str(out)) == 2
    assert capsys.readouterr().err.startswith(f"warpfree: error: {name}:")
    assert not any(p.name != "run.json" for p in out.glob("*"))  # nothing written but the probe of --out


def test_3d_scene_names_its_own_parameters(capsys):
    scene = "dam_break_3d"
    assert run_cli(scene, "--set", "column_height=-0.5") == 2
    assert capsys.readouterr().err.startswith("warpfree: error: column_height:")
    assert run_cli(scene, "--set", "column_length=5") == 2
    assert capsys.readouterr().err.startswith("warpfree: error: column_length:")


def test_unloadable_scene_and_unwritable_out_exit_2(tmp_path, capsys):
    bad = tmp_path / "broken.py"
    bad.write_text("def build(:\n")
    assert run_cli(str(bad)) == 2
    assert "scene" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert run_cli("dam_break_2d", "--out", str(blocker / "run")) == 2
    assert "--out" in capsys.readouterr().err


def _listing(path):
    return sorted((p.relative_to(path).as_posix(), p.stat().st_mtime_ns, p.stat().st_size) for p in path.rglob("*"))


def test_resume_changes_only_the_end_time_and_a_refusal_touches_nothing(tmp_path, capsys):
    out = tmp_path / "db"
    scene = "dam_break_2d"
    assert run_cli(scene, "--set", "dx=0.1", "--set", "t_end=0.03", "--checkpoint-every", "10", "--no-frames",
                   "--out", str(out)) == 0
    before = _listing(out)
    assert run_cli("--resume", str(out), "--set", "dx=0.05") == 2
    assert "dx: cannot change on --resume" in capsys.readouterr().err
    assert run_cli("--resume", str(out), "--out", str(tmp_path / "elsewhere")) == 2
    assert _listing(out) == before and not (tmp_path / "elsewhere").exists()
    assert run_cli("--resume", str(out), "--set", "t_end=0.05", "--no-frames") == 0
    assert "t_end = 0.05" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["time"] == pytest.approx(0.05) and json.loads((out / "run.json").read_text())["overrides"]["t_end"] == 0.05


def test_resume_skips_a_damaged_newest_checkpoint(tmp_path, capsys):
    out = tmp_path / "db"
    scene = "dam_break_2d"
    assert run_cli(scene, "--set", "dx=0.1", "--set", "t_end=0.03", "--checkpoint-every", "10", "--no-frames",
                   "--out", str(out)) == 0
    full = json.loads((out / "summary.json").read_text())
    newest, older = sorted((out / "checkpoints").glob("step_*.npz"), reverse=True)
    newest.write_bytes(newest.read_bytes()[: 200])     # a write cut short
    assert run_cli("--resume", str(out), "--no-frames") == 0
    assert f"resuming from {older.name}; skipped the newer {newest.name}" in capsys.readouterr().err
    again = json.loads((out / "summary.json").read_text())
    assert again["probes"] == full["probes"] and again["skipped_checkpoints"][0].startswith(newest.name)


def test_kills_during_checkpoint_writes_never_break_resume(tmp_path):
    """A real process, checkpointing every step (a quarter of its time is spent writing them), killed (SIGKILL)
    three times at random moments mid-run: every --resume continues, and the run ends exactly where an
    uninterrupted one does."""
    import random
    import signal
    import time

    scene = "dam_break_2d"
    common = ["--set", "dx=0.1", "--set", "t_end=0.3", "--no-frames", "--set", "vtk=false", "--no-progress"]
    ref = tmp_path / "ref"
    assert run_cli(scene, *common, "--out", str(ref)) == 0
    steps = json.loads((ref / "summary.json").read_text())["steps"]
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "warpfree.cli", "run", scene, *common, "--checkpoint-every", "1", "--out", str(out)]
    rng = random.Random(5)
    killed = 0
    for target in (steps // 5, steps // 2, 3 * steps // 4, None):  # kill once the run has passed these steps
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if target is not None:
            while proc.poll() is None:
                names = sorted((out / "checkpoints").glob("step_*.npz")) if (out / "checkpoints").is_dir() else []
                if names and int(names[-1].name[5:13]) >= target:
                    break
                time.sleep(0.005)
            time.sleep(rng.uniform(0.0, 0.02))  # somewhere in a step or in a checkpoint write
            proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=120)
        killed += proc.returncode == -signal.SIGKILL
        cmd = [sys.executable, "-m", "warpfree.cli", "run", "--resume", str(out), "--no-progress"]
    assert killed == 3 and proc.returncode == 0
    final = json.loads((out / "summary.json").read_text())
    expect = json.loads((ref / "summary.json").read_text())
    assert final["status"] == "ok" and final["steps"] == expect["steps"] and final["probes"] == expect["probes"]
