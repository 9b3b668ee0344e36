"""Compile Warp kernel modules for CUDA without a GPU, with the NVRTC compiler the warp-lang wheel carries.

A module is compiled for a GPU only when it is first launched there, so a kernel that compiles for the CPU can still
fail for CUDA (a construct NVRTC refuses, a type the CUDA path lacks), and a CPU-only machine would never know.
:func:`compile_modules` compiles modules ahead of time (``wp.compile_aot_module``) for the given GPU architectures
(cubins) into a scratch folder and reports, per module and architecture, the time and any error.
:func:`loaded_modules` lists what this process has loaded: every ``warpfree`` kernel module and every compile-time
variant a factory made (``FluidTerms`` switches, reductions per type, PIC fits per basis size). The test suite
compiles, at its end, everything its tests and the shipped scenes' smoke runs loaded, when
``WARPFREE_CUDA_COMPILE`` names the architectures (``tests/conftest.py``; CI sets ``80,90``), so a new variant is
checked without anyone listing it.
"""

from __future__ import annotations

import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import warp as wp

__all__ = ["CompileResult", "compile_modules", "loaded_modules", "parse_archs"]


@dataclass
class CompileResult:
    """One module compiled for one list of architectures: ``error`` is None when every target compiled."""

    module: str
    origin: str  # the Python module that defined its kernels
    archs: tuple[int, ...]
    seconds: float
    error: str | None
    paths: list[str]


def parse_archs(text: str) -> tuple[int, ...]:
    """``"80,90"`` or ``"sm_80 sm_90"`` -> (80, 90)."""
    out = []
    for part in text.replace(",", " ").split():
        part = part.strip().lower().removeprefix("sm_").removeprefix("sm")
        if not part.isdigit():
            raise ValueError(f"WARPFREE_CUDA_COMPILE: an architecture is a number such as 80 or sm_90, got {text!r}")
        out.append(int(part))
    if not out:
        raise ValueError("WARPFREE_CUDA_COMPILE: no architecture given (e.g. 80,90)")
    return tuple(out)


def _origin(module) -> str:
    """The Python module that defined the Warp module's kernels (a factory's ``module="unique"`` variant is named
    after its kernel, not after the file that made it)."""
    for kernel in module.kernels.values():
        return getattr(getattr(kernel, "func", None), "__module__", "") or ""
    return ""


def loaded_modules(prefix: str = "warpfree") -> list:
    """Warp modules whose kernels come from a Python module under ``prefix`` and that this process has loaded (on
    any device), in name order: the kernel modules and every compile-time variant a factory made; with them the
    kernels a GPU runs in place of a loaded CPU kernel (``warpfree.kernels.mls.DEVICE_VARIANTS``)."""
    from warp._src.context import user_modules

    from warpfree.kernels import mls

    mods = {m.name: m for m in list(user_modules.values()) if m.execs and m.kernels and _origin(m).startswith(prefix)}
    for m in mls.DEVICE_VARIANTS:
        if _origin(m).startswith(prefix):
            mods.setdefault(m.name, m)
    return [mods[name] for name in sorted(mods)]


def _compile(module, archs: tuple[int, ...], folder: str) -> CompileResult:
    start = time.perf_counter()
    try:
        paths = wp.compile_aot_module(module, arch=list(archs), module_dir=folder, use_ptx=False)
        error = None
    except Exception as exc:  # NVRTC's message, or Warp's code generation refusing the CUDA path
        paths, error = [], f"{type(exc).__name__}: {exc}"
    return CompileResult(module.name, _origin(module), archs, time.perf_counter() - start, error,
                         [str(p) for p in paths])


def compile_modules(modules, archs=(80, 90), folder: str | None = None, workers: int = 2) -> list[CompileResult]:
    """Compile ``modules`` for every architecture in ``archs`` (cubins in ``folder``, a scratch folder by default),
    ``workers`` modules at a time (NVRTC runs outside the GIL). Never raises for a module that fails: its
    :class:`CompileResult` carries the error."""
    archs = tuple(int(a) for a in archs)
    folder = folder or tempfile.mkdtemp(prefix="warpfree_cuda_")
    if workers <= 1 or len(modules) < 2:
        return [_compile(m, archs, folder) for m in modules]
    with ThreadPoolExecutor(workers) as pool:
        return list(pool.map(lambda m: _compile(m, archs, folder), modules))
