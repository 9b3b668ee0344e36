"""Starting a distributed run from Python (the tests, the scaling benchmarks): ``mpiexec -n N`` with this
interpreter, and what Open MPI needs to run as root and with more ranks than cores.

The MPI wheels of the ``mpi`` extra put ``mpiexec`` beside the interpreter (``.venv/bin``); one on the PATH
serves otherwise. Open MPI refuses to run as root, and to start more ranks than cores, unless told:
:func:`mpiexec_environment` tells it (``OMPI_ALLOW_RUN_AS_ROOT``, and ``PRTE_MCA_rmaps_default_mapping_policy``
``=:oversubscribe`` on Open MPI 5); MPICH needs neither.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from .world import MPI_EXTRA

__all__ = ["find_mpiexec", "mpiexec_environment", "run_ranks"]


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
    """``mpiexec -n ranks python ARGS`` (output captured as text); raises RuntimeError naming the extra when there
    is no MPI."""
    mpiexec = find_mpiexec()
    if mpiexec is None:
        raise RuntimeError(f"no mpiexec with mpi4py here: {MPI_EXTRA}")
    cmd = [mpiexec, "-n", str(int(ranks)), sys.executable, *args]
    return subprocess.run(cmd, env=mpiexec_environment(), capture_output=True, text=True, timeout=timeout, **kwargs)
