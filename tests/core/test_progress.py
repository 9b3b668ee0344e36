"""Progress a user can read: set-up phases announced with their times, the final line's whole time, a progress bar in
a readable unit that never runs past its end, and no GPU warning on a CPU run."""

import json
import re
import subprocess
import sys
import warnings

import pytest
import warp as wp

from warpfree import progress
from warpfree.time_loop import _Bar


def cli(*args):
    """``warpfree run ...`` in a fresh process (stderr as a user's terminal gets it, Warp initialised from scratch)."""
    return subprocess.run([sys.executable, "-m", "warpfree.cli", "run", *args], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture
def announcing():
    """Announcements on for one test, off again afterwards."""
    progress.enable(True)
    yield
    progress.enable(False)


def test_small_run_announces_set_up_and_states_the_whole_time(tmp_path):
    out = tmp_path / "db"
    res = cli("dam_break_2d", "--set", "dx=0.1", "--set", "t_end=0.04", "--set", "output_interval=0.02",
              "--no-frames", "--out", str(out), "--threads", "2")
    assert res.returncode == 0, res.stderr
    ready = re.search(r"^  set-up: done, dam_break_2d ready (\d+\.\d) s$", res.stderr, re.M)
    assert ready, res.stderr
    summary = json.loads((out / "summary.json").read_text())
    setup, run_s, total = summary["phases_s"]["setup"], summary["wall_s"], summary["total_s"]
    assert total >= setup + run_s > 0
    assert float(ready.group(1)) == pytest.approx(setup, abs=0.051)  # the line prints the set-up it timed
    first = res.stdout.splitlines()[0]
    line = re.search(r" in (\d+\.\d) s \(set-up (\d+\.\d) s, run (\d+\.\d) s", first)
    assert line, first
    shown_total, shown_setup, shown_run = map(float, line.groups())
    assert shown_total == pytest.approx(total, abs=0.051) and shown_setup == pytest.approx(setup, abs=0.051)
    assert shown_run == pytest.approx(run_s, abs=0.051)


def test_no_progress_announces_nothing(tmp_path):
    res = cli("dam_break_2d", "--set", "dx=0.1", "--set", "t_end=0.02", "--set", "output_interval=0.02",
              "--no-frames", "--no-progress", "--out", str(tmp_path / "db"))
    assert res.returncode == 0, res.stderr
    assert "set-up:" not in res.stderr and "%|" not in res.stderr


@pytest.mark.skipif(wp.is_cuda_available(), reason="a machine with a CUDA driver has no missing-driver warning")
def test_cpu_run_prints_no_gpu_warning_and_cuda_says_why_it_cannot(tmp_path):
    res = cli("em_line_1d", "--no-frames", "--out", str(tmp_path / "em"))
    assert res.returncode == 0, res.stderr
    assert "cuda" not in res.stderr.lower() and "warning" not in res.stderr.lower(), res.stderr
    refused = cli("em_line_1d", "--device", "cuda", "--out", str(tmp_path / "gpu"))
    assert refused.returncode == 2
    error = refused.stderr.strip().splitlines()[-1]
    assert error.startswith("warpfree: error: device: 'cuda' was asked for but no CUDA device is present"), error
    assert "Warp CUDA warning" not in refused.stderr  # said once, inside the error


def test_em_progress_bar_reads_nanoseconds_without_warning_or_negative_time(tmp_path):
    res = cli("em_line_1d", "--no-frames", "--set", "vtk=false", "--out", str(tmp_path / "em"))
    assert res.returncode == 0, res.stderr
    bar = res.stderr.replace("\r", "\n")
    assert "TqdmWarning" not in bar and "<-" not in bar, bar
    assert "t=4.75/4.75 ns" in bar, bar  # not 0.0000/0.0000 s
    # the time reached: the first of SPEM's constant steps at or after the end
    assert re.search(r"to t = 4\.75\d* ns", res.stdout.splitlines()[0]), res.stdout


def test_bar_set_past_its_end_by_rounding_stays_at_the_end(capsys):
    """Steps whose sum rounds past t_end (the EM line: 180 steps of 2.64e-11 s) leave the bar at 100 %, with no
    TqdmWarning and no negative time left."""
    t_end, n = 4.75e-9, 180
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bar = _Bar(t_end, 0.0, "em", "s")
        bar.bar.mininterval = 0.0  # draw at every update
        t = 0.0
        for _ in range(n + 2):
            t += t_end / n * (1 + 1e-7)
            bar.update(t)
        assert bar.bar.n == pytest.approx(4.75) and bar.bar.n <= bar.total
        bar.close()
    err = capsys.readouterr().err.replace("\r", "\n")
    assert "<-" not in err and "101%" not in err and "t=4.75/4.75 ns" in err


def test_time_scale_puts_the_end_in_a_readable_unit():
    assert progress.time_scale(4.75e-9, "s") == (1e-9, "ns")
    assert progress.time_scale(0.8, "s") == (1.0, "s")
    assert progress.time_scale(5e-4, "s") == (1e-3, "ms")
    assert progress.time_scale(25.0, "/ω_pe") == (1.0, "/ω_pe")


def test_announce_prints_slow_phases_nested_and_nothing_when_off(capsys, monkeypatch, announcing):
    monkeypatch.setattr(progress, "THRESHOLD_S", 0.0)
    progress.stage("set-up")
    with progress.announce("outer phase"):
        with progress.announce("inner phase"):
            pass
    lines = capsys.readouterr().err.splitlines()
    assert re.fullmatch(r"    set-up: inner phase \d+\.\d s", lines[0]), lines
    assert re.fullmatch(r"  set-up: outer phase \d+\.\d s", lines[1]), lines
    monkeypatch.setattr(progress, "THRESHOLD_S", 3600.0)
    with progress.announce("quick phase"):
        pass
    with progress.announce("listed phase", always=True):
        pass
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and re.fullmatch(r"  set-up: listed phase \d+\.\d s", lines[0]), lines
    progress.enable(False)
    monkeypatch.setattr(progress, "THRESHOLD_S", 0.0)
    with progress.announce("silent phase"):
        pass
    assert capsys.readouterr().err == ""


def test_announced_names_the_call_and_passes_its_result(capsys, monkeypatch, announcing):
    monkeypatch.setattr(progress, "THRESHOLD_S", 0.0)
    progress.stage("set-up")

    @progress.announced(lambda items: f"{progress.group_digits(len(items))} items counted")
    def count(items):
        return len(items)

    assert count(list(range(4096))) == 4096
    assert re.fullmatch(r"  set-up: 4 096 items counted \d+\.\d s", capsys.readouterr().err.rstrip("\n"))
