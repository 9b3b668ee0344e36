"""Starting ranks (``warpfree.parallel.launch.run_ranks``): an ``mpiexec`` that failed to start itself is started
again; a program that failed is not. A stand-in ``mpiexec`` (a shell script) counts its starts."""

from __future__ import annotations

import stat

from warpfree.parallel import launch

FAKE_MPIEXEC = """#!/bin/sh
n=$(cat "$STARTS" 2>/dev/null || echo 0); echo $((n + 1)) > "$STARTS"
if [ "$n" -lt "$FAIL_STARTS" ]; then
  echo "The PMIx server's listener thread failed to start. We cannot" >&2; exit 213
fi
shift 2; exec "$@"
"""


def _fake(tmp_path, monkeypatch, fail_starts: int):
    script = tmp_path / "mpiexec"
    script.write_text(FAKE_MPIEXEC)
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setattr(launch, "find_mpiexec", lambda: str(script))
    monkeypatch.setattr(launch.time, "sleep", lambda s: None)
    monkeypatch.setenv("STARTS", str(tmp_path / "starts"))
    monkeypatch.setenv("FAIL_STARTS", str(fail_starts))
    return tmp_path / "starts"


def test_a_launcher_that_failed_to_start_is_started_again(tmp_path, monkeypatch):
    starts = _fake(tmp_path, monkeypatch, fail_starts=2)
    done = launch.run_ranks(2, ["-c", "print('ran')"], timeout=60)
    assert done.returncode == 0 and done.stdout.strip() == "ran"
    assert starts.read_text().strip() == "3"


def test_a_launcher_that_never_starts_is_reported_after_the_attempts(tmp_path, monkeypatch):
    starts = _fake(tmp_path, monkeypatch, fail_starts=99)
    done = launch.run_ranks(2, ["-c", "print('ran')"], timeout=60)
    assert done.returncode == 213 and launch.LAUNCHER_FAILURES[0] in done.stderr
    assert starts.read_text().strip() == str(launch.LAUNCH_ATTEMPTS)


def test_a_program_that_failed_is_not_started_again(tmp_path, monkeypatch):
    starts = _fake(tmp_path, monkeypatch, fail_starts=0)
    done = launch.run_ranks(2, ["-c", "import sys; sys.exit(3)"], timeout=60)
    assert done.returncode == 3 and starts.read_text().strip() == "1"
