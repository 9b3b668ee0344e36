"""A run stopped by Ctrl-C, SIGTERM or a SIGKILL of every process it has loses nothing a resume does not rewrite.

Real processes, real signals: Ctrl-C (SIGINT) mid-run ends it in one line with exit 130, its last completed step and
every output before it on disk; a resume then gives the uninterrupted run's files, byte for byte (VTU snapshots,
PVD indices and PNG frames). The worst moment for a kill is right after a checkpoint that falls on an output step
(the step's output may still be with the writer process): a SIGKILL of the run and its writer there, in one process
and on 3 ranks, must leave that output on disk, since the resume starts after it. A resume may not end before the
time its directory already holds."""

from __future__ import annotations

import filecmp
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers.runs import snapshot_differences
from warpfree.cli import main
from warpfree.io.vtk import read_pvd
from warpfree.parallel import MPI_EXTRA
from warpfree.parallel.launch import find_mpiexec, mpiexec_environment

CLI = [sys.executable, "-m", "warpfree"]


def same_outputs(a: Path, b: Path) -> list[str]:
    """What differs between two run directories' outputs: the snapshots (bitwise), the PVD indices and every frame
    (byte for byte); empty when nothing does."""
    out = snapshot_differences(a, b)
    frames_a = sorted(p.name for p in (a / "frames").glob("*.png"))
    frames_b = sorted(p.name for p in (b / "frames").glob("*.png"))
    if frames_a != frames_b:
        out.append(f"frames {sorted(set(frames_a) ^ set(frames_b))} in one run only")
    out += [f"frame {name} differs" for name in frames_a if name in frames_b
            and not filecmp.cmp(a / "frames" / name, b / "frames" / name, shallow=False)]
    return out


def indexed_files_exist(run: Path) -> list[str]:
    """The files the run's PVD indices name that are not on disk (a .pvtu's pieces included)."""
    missing = []
    for index in run.glob("*.pvd"):
        for _, name in read_pvd(index):
            path = run / name
            if not path.is_file():
                missing.append(name)
            elif path.suffix == ".pvtu":
                pieces = [line.split('Source="')[1].split('"')[0] for line in path.read_text().splitlines()
                          if "<Piece Source=" in line]
                missing += [p for p in pieces if not (path.parent / p).is_file()]
    return missing


def wait_for(condition, proc: subprocess.Popen, timeout: float = 300.0, poll: float = 0.001) -> None:
    """Poll ``condition()`` until it holds (the process must still be running)."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, f"the run ended (exit {proc.returncode}) before the moment to stop it"
        assert time.monotonic() < deadline, "the moment to stop the run never came"
        time.sleep(poll)


def checkpoint_steps(run: Path) -> list[int]:
    folder = run / "checkpoints"
    names = [p.name for p in folder.glob("step_*.npz")] if folder.is_dir() else []
    return sorted({int(n[5:13]) for n in names})


@pytest.mark.slow
def test_ctrl_c_stops_in_one_line_keeps_the_last_step_and_the_resume_gives_the_uninterrupted_files(tmp_path):
    scene = ["dam_break_2d", "--set", "dx=0.1", "--set", "t_end=0.5", "--no-progress", "--threads", "1"]
    ref, run = tmp_path / "ref", tmp_path / "run"
    assert main(["run", *scene, "--out", str(ref)]) == 0
    proc = subprocess.Popen([*CLI, "run", *scene, "--out", str(run)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    # mid-run: once the fifth snapshot is indexed (the run has 26)
    wait_for(lambda: (run / "fluid.pvd").is_file() and len(read_pvd(run / "fluid.pvd")) >= 5, proc, poll=0.01)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warpfree: stopped by Ctrl-C (SIGINT) after step"), err
    assert f"warpfree run --resume {run}" in lines[0] and "Traceback" not in out + err
    summary = json.loads((run / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["interrupted_by"] == "SIGINT"
    assert checkpoint_steps(run)[-1] == summary["steps"] and summary["time"] < 0.5
    assert indexed_files_exist(run) == []
    assert main(["run", "--resume", str(run), "--no-progress", "--threads", "1"]) == 0
    assert json.loads((run / "summary.json").read_text())["status"] == "ok"
    assert same_outputs(ref, run) == []


def test_ctrl_c_during_set_up_ends_in_one_line_and_writes_nothing(tmp_path):
    """The standing wave relaxes and settles its water for a minute or more before its first step: Ctrl-C then ends
    the command at once, in one line, exit 130, with no run directory made."""
    run = tmp_path / "run"
    proc = subprocess.Popen([*CLI, "run", "standing_wave_2d", "--out", str(run), "--no-progress", "--threads", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)  # the scene is loaded (about a second) and setting up
    assert proc.poll() is None
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().splitlines() == [
        "warpfree: interrupted by Ctrl-C (SIGINT); what the run had written stays as it was"], err
    assert not (run / "summary.json").exists() and not (run / "run.json").exists()


def test_a_resume_cannot_end_before_the_time_its_run_reached(tmp_path, capsys):
    run = tmp_path / "run"
    scene = ["heat_conduction_2d", "--set", "n=16", "--set", "t_end=0.5", "--set", "output_interval=0.1"]
    assert main(["run", *scene, "--checkpoint-every", "7", "--no-frames", "--no-progress", "--out", str(run)]) == 0
    before = (run / "summary.json").read_bytes()
    assert main(["run", "--resume", str(run), "--set", "t_end=0.3", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warpfree: error: t_end: 0.3 is before the time this run already "
                                               "reached (0.5"), err
    assert (run / "summary.json").read_bytes() == before  # nothing rewound


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (children, their children, ...), read from /proc."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            parent = int(stat.rsplit(")", 1)[1].split()[1])
            children.setdefault(parent, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def kill_everything(proc: subprocess.Popen) -> None:
    """SIGKILL the run and every process below it at once (its writer; under mpiexec each rank by its id: Open MPI 5
    leaves the ranks running when only mpiexec is killed)."""
    for pid in [proc.pid, *descendants(proc.pid)]:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    proc.wait(timeout=60)


def em_line_settings() -> list[str]:
    """The 1D line at 10 particles per wavelength with an output every 4 of its constant steps and 20 outputs: SPEM's
    step is its stable limit whatever the output interval, so the interval is made of the step (read from the scene
    built here)."""
    from warpfree.scene_loader import load_scene

    step = load_scene("em_line_1d").build(particles_per_wavelength=10, frames=False, vtk=False).step_size
    return ["em_line_1d", "--set", "particles_per_wavelength=10", "--set", f"output_interval={4 * step!r}",
            "--set", f"t_end={80 * step!r}"]


#: (scene settings, checkpoint every K steps, ranks): the heat scene's constant step makes an output every 8 steps
#: (n = 16: 0.1 s of output interval / 8 steps) and the 1D line's every 4; K is that, so every checkpoint falls on an
#: output step
KILL_CASES = [(["heat_conduction_2d", "--set", "n=16", "--set", "t_end=1.5", "--set", "output_interval=0.1"], 1),
              (em_line_settings, 3)]


@pytest.mark.slow
@pytest.mark.parametrize("scene,ranks", KILL_CASES, ids=["one_process", "three_ranks"])
def test_a_kill_right_after_a_checkpoint_on_an_output_step_loses_no_output(scene, ranks, tmp_path):
    if ranks > 1 and find_mpiexec() is None:
        pytest.skip(f"no MPI here: {MPI_EXTRA}")
    scene = scene() if callable(scene) else scene
    ref, run = tmp_path / "ref", tmp_path / "run"
    launcher, env = ([find_mpiexec(), "-n", str(ranks)], mpiexec_environment()) if ranks > 1 else ([], None)
    threads = [] if ranks > 1 else ["--threads", "1"]
    made = subprocess.run([*launcher, *CLI, "run", *scene, "--no-progress", *threads, "--out", str(ref)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert made.returncode == 0, made.stderr[-2000:]
    done = json.loads((ref / "summary.json").read_text())
    every = done["steps"] // (len(done["probes"]["time"]) - 1)  # steps between outputs (a constant step)
    assert every * (len(done["probes"]["time"]) - 1) == done["steps"]
    cmd = [*launcher, *CLI, "run", *scene, "--no-progress", *threads, "--checkpoint-every", str(every),
           "--out", str(run)]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # the moment its third checkpoint (an output step's) is complete on every rank: kill it all
    wait_for(lambda: len([p for p in (run / "checkpoints").glob(f"step_{3 * every:08d}*.npz")]) == ranks
             if (run / "checkpoints").is_dir() else False, proc)
    kill_everything(proc)
    assert checkpoint_steps(run)[-1] < done["steps"]  # killed before the end
    resumed = subprocess.run([*launcher, *CLI, "run", "--resume", str(run), "--no-progress", *threads], env=env,
                             capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert indexed_files_exist(run) == []
    assert same_outputs(ref, run) == []
