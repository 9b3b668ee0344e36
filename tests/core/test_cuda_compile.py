"""Compiling kernel modules for CUDA without a GPU (``warpfree.cuda_compile``): the modules a process loaded, factory
variants included, compile to cubins with the wheel's NVRTC, and a failure is reported, not raised."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpfree import cuda_compile
from warpfree.reduce import Reduction


def test_architectures_are_parsed_or_refused():
    assert cuda_compile.parse_archs("80,90") == (80, 90)
    assert cuda_compile.parse_archs("sm_80 sm_90") == (80, 90)
    for bad in ("", "ampere", "80,x"):
        with pytest.raises(ValueError, match="WARPFREE_CUDA_COMPILE"):
            cuda_compile.parse_archs(bad)


def _loaded_reduction(launcher):
    """A reduction over int16 (a type nothing else reduces): its kernels are a factory's variant of their own."""
    r = Reduction(launcher, wp.int16, "max")
    r.launch(wp.array(np.arange(5, dtype=np.int16), dtype=wp.int16, device="cpu"))
    assert int(r.value()) == 4
    return [m for m in cuda_compile.loaded_modules() if any(k.key.endswith("block_reduce") for k in m.kernels.values())
            and m.name.startswith("block_reduce")]


def test_a_factory_variant_is_listed_and_compiles_for_the_gpu(launcher, tmp_path):
    """The int16 reduction's module is listed (named after its kernel, defined in warpfree.kernels.reduce) and
    compiles for sm_80 into a cubin."""
    variants = _loaded_reduction(launcher)
    assert variants and all(cuda_compile._origin(m) == "warpfree.kernels.reduce" for m in variants)
    (result,) = cuda_compile.compile_modules(variants[:1], (80,), str(tmp_path), workers=1)
    assert result.error is None, result.error
    assert len(result.paths) == 1 and result.paths[0].endswith(".sm80.cubin")
    assert (tmp_path / result.paths[0].split("/")[-1]).stat().st_size > 0


def test_a_failed_compile_is_reported_not_raised(launcher, tmp_path, monkeypatch):
    variants = _loaded_reduction(launcher)

    def refuse(*args, **kwargs):
        raise RuntimeError("NVRTC: error: identifier is undefined")

    monkeypatch.setattr(wp, "compile_aot_module", refuse)
    (result,) = cuda_compile.compile_modules(variants[:1], (90,), str(tmp_path), workers=1)
    assert result.paths == [] and "identifier is undefined" in result.error
