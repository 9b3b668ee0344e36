"""Shared fixtures: CPU launchers (closed at teardown) and small helpers for Warp arrays; and, when
``WARPFREE_CUDA_COMPILE`` names GPU architectures (``80,90``), the CUDA compile check at the end of the session."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
import warp as wp

from warpfree.device import Launcher, init_warp

init_warp()


def pytest_addoption(parser):
    parser.addoption("--device", default="cpu", help="the device of the tests marked cuda: cpu (default), cuda or "
                                                     "cuda:N (bench/core/gpu_check.py runs them with cuda)")


@pytest.fixture
def device_name(request) -> str:
    """The device the tests marked ``cuda`` run on (``--device``, default cpu)."""
    return request.config.getoption("--device")


@pytest.fixture
def make_launcher():
    """Factory ``make_launcher(threads=2, device="cpu")``; every launcher made is closed afterwards."""
    made: list[Launcher] = []

    def make(threads: int | None = 2, device: str | None = "cpu") -> Launcher:
        launcher = Launcher(device=device, threads=threads, min_items_per_thread=1)
        made.append(launcher)
        return launcher

    yield make
    for launcher in made:
        launcher.close()


@pytest.fixture(scope="session")
def launcher():
    """One shared two-thread CPU launcher (exercises the chunked path in every test that uses it)."""
    launcher = Launcher(device="cpu", threads=2, min_items_per_thread=1)
    yield launcher
    launcher.close()


@pytest.fixture
def vec3():
    """``vec3(points)``: (N, 2) or (N, 3) NumPy points -> float32 ``wp.array(dtype=wp.vec3)`` on the CPU."""

    def convert(points) -> wp.array:
        p = np.asarray(points, dtype=np.float64)
        if p.shape[1] == 2:
            p = np.hstack([p, np.zeros((p.shape[0], 1))])
        return wp.array(p.astype(np.float32), dtype=wp.vec3, device="cpu")

    return convert


def pytest_sessionfinish(session, exitstatus):
    """With ``WARPFREE_CUDA_COMPILE=80,90`` (CI sets it): compile every ``warpfree`` Warp module this session loaded,
    each kernel module and every compile-time variant the tests and the scenes' smoke runs made, for those GPU
    architectures with the wheel's NVRTC (``warpfree.cuda_compile``); any compile error fails the session."""
    archs = os.environ.get("WARPFREE_CUDA_COMPILE", "").strip()
    if not archs:
        return
    from warpfree import cuda_compile

    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    modules = cuda_compile.loaded_modules()
    start = time.perf_counter()
    results = cuda_compile.compile_modules(modules, cuda_compile.parse_archs(archs))
    wall = time.perf_counter() - start
    failed = [r for r in results if r.error]
    seconds = sum(r.seconds for r in results)
    lines = [f"CUDA compile check: {len(results)} modules for sm_{', sm_'.join(map(str, results[0].archs))}, "
             f"{wall:.0f} s ({seconds:.0f} s of compiling on 2 threads), {len(failed)} failed" if results else
             "CUDA compile check: no warpfree module was loaded"]
    for r in failed:
        lines += [f"  FAILED {r.module} ({r.origin}):"] + [f"    {line}" for line in r.error.splitlines()[:20]]
    for line in lines:
        if reporter is not None:
            reporter.write_line(line)
        else:
            print(line)
    if failed:
        session.exitstatus = 1
