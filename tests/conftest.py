"""Shared fixtures: CPU launchers (closed at teardown) and small helpers for Warp arrays."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpfree.device import Launcher, init_warp

init_warp()


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
