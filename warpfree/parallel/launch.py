"""Starting a distributed run from Python (the tests, the scaling benchmarks): ``mpiexec -n N`` with this
interpreter, and what Open MPI needs to run as root and with more ranks than cores.

The MPI wheels of the ``mpi`` extra put ``mpiexec`` beside the interpreter (``.venv/bin``); one on the PATH
serves otherwise. Open MPI refuses to run as root, and to start more ranks than cores, unless told:
:func:`mpiexec_environment` tells it (``OMPI_ALLOW_RUN_AS_ROOT``, and ``PRTE_MCA_rmaps_default_mapping_policy``
``=:oversubscribe`` on Open MPI 5); MPICH needs neither. Open MPI's launcher itself sometimes fails to start
(its PMIx server's listener thread, on a loaded machine) before any rank runs: :func:`run_ranks` starts it again.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from .world import MPI_EXTRA

__all__ = ["find_mpiexec", "mpiexec_environment", "run_ranks", "LAUNCHER_FAILURES", "LAUNCH_ATTEMPTS"]

#: what ``mpiexec`` prints when it failed to start itself, before any rank ran (so starting it again is safe)
LAUNCHER_FAILURES = ("The PMIx server's listener thread failed to start",)
#: how many times :func:`run_ranks` starts ``mpiexec`` when it fails to start itself
LAUNCH_ATTEMPTS = 3


def find_mpiexec() -> str | None:
    """``mpiexec`` beside this interpreter, else on the PATH; None when there is none (or no mpi4py)."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return None
    beside = Path(sys.executable).parent / "mpiexec"
    if beside.exists():
        return str(beside)
    return shutil.which("mpiexec")


def mpiexec_environment(oversubscribe: bool = True) -> dict[str, str]:
    """This environment, with what lets Open MPI run as root and (``oversubscribe``) more ranks than cores."""
    env = dict(os.environ)
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    if oversubscribe:
        env.setdefault("PRTE_MCA_rmaps_default_mapping_policy", ":oversubscribe")
        env.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    return env


def run_ranks(ranks: int, args: list[str], timeout: float | None = None, **kwargs) -> subprocess.CompletedProcess:
    """``mpiexec -n ranks python ARGS`` (output captured as text), started again (up to :data:`LAUNCH_ATTEMPTS` times)
    when ``mpiexec`` failed to start itself (:data:`LAUNCHER_FAILURES`); raises RuntimeError naming the extra when
    there is no MPI."""
    mpiexec = find_mpiexec()
    if mpiexec is None:
        raise RuntimeError(f"no mpiexec with mpi4py here: {MPI_EXTRA}")
    cmd = [mpiexec, "-n", str(int(ranks)), sys.executable, *args]
    for attempt in range(LAUNCH_ATTEMPTS):
        done = subprocess.run(cmd, env=mpiexec_environment(), capture_output=True, text=True, timeout=timeout,
                              **kwargs)
        if done.returncode == 0 or not any(f in (done.stdout or "") + (done.stderr or "") for f in LAUNCHER_FAILURES):
            return done
        time.sleep(1.0 + attempt)  # the launcher did not start: nothing ran, start it again
    return done
