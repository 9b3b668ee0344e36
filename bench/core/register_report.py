"""Registers, stack and local memory of every kernel on the GPU, read from CUDA binaries compiled without a GPU.

What it measures
    Every shipped scene runs at its smallest size on the CPU (``warpfree run NAME --set ...SMALLEST``, in this
    process), and at each of its ``KERNEL_VARIANTS``, which loads every kernel module and compile-time variant the
    scenes use; each ``warpfree`` module
    loaded is then compiled for ``--arch`` (default sm_90) with the wheel's NVRTC (``warpfree.cuda_compile``), and
    ``cuobjdump --dump-resource-usage`` (pip ``nvidia-cuda-cuobjdump``, in the bench extra) reads each kernel's
    registers per thread (REG), stack frame (STACK, bytes per thread: spilled registers and local arrays) and
    local memory. A kernel at 255 registers, or with a stack, runs at low occupancy on a GPU (an SM holds 64 K
    registers: 128 per thread keeps 512 threads, 16 warps, resident).

    The hot kernels (:data:`HOT`: those each kernel module names in its ``HOT_KERNELS``) are checked against the
    budget: at most :data:`REGISTER_BUDGET` registers and no stack.

Usage
    python bench/core/register_report.py [--arch 90] [--cuobjdump PATH]
Writes bench/results/register_report.{json,md}.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

#: registers per thread a hot kernel may use (an SM's 64 K registers then hold 512 threads)
REGISTER_BUDGET = 128

#: kernel module (``wcsph``, ``mls``) -> the kernels that carry a step or a solve, by the name Warp gives them (before
#: its hash suffix): what each module of kernels/ names in its ``HOT_KERNELS`` (``common.hot_kernels``)
HOT = common.hot_kernels()

_FUNCTION = re.compile(r"Function (\S+?)_[0-9a-f]{8}_cuda_kernel_forward:")
_USAGE = re.compile(r"REG:(\d+) STACK:(\d+) SHARED:(\d+) LOCAL:(\d+)")


def find_cuobjdump(given: str | None) -> str:
    """``--cuobjdump``, else the pip package's binary (``nvidia/cu*/bin/cuobjdump`` under site-packages), else PATH."""
    if given:
        return given
    import site

    for root in site.getsitepackages() + [site.getusersitepackages()]:
        for path in sorted(Path(root).glob("nvidia/cu*/bin/cuobjdump")):
            return str(path)
    found = shutil.which("cuobjdump")
    if not found:
        raise SystemExit("cuobjdump not found: pip install nvidia-cuda-cuobjdump (warpfree[bench]) or pass --cuobjdump")
    return found


#: runs besides the scenes' smallest: (scene, settings) for each of the ``KERNEL_VARIANTS`` a scene declares (settings
#: other than its defaults that load kernels its smallest run does not)
EXTRA = [(name, variant) for name, path in common.scene_files().items()
         for variant in common.declared(path, "KERNEL_VARIANTS") or []]


def load_scene_modules() -> list[str]:
    """Run every shipped scene at its smallest size in this process (its kernels load on the CPU), and the
    :data:`EXTRA` variants."""
    from warpfree.cli import main
    from warpfree.scene_loader import load_scene, shipped_scenes, value_text

    names = sorted(shipped_scenes())
    runs = [(name, {}) for name in names] + EXTRA
    with tempfile.TemporaryDirectory() as out:
        for i, (name, extra) in enumerate(runs):
            settings = {**load_scene(name).SMALLEST, **extra}
            sets = [a for k, v in settings.items() for a in ("--set", f"{k}={value_text(v)}")]
            with contextlib.redirect_stdout(io.StringIO()):
                code = main(["run", name, *sets, "--out", f"{out}/{i}", "--no-progress", "--no-frames"])
            if code != 0:
                raise SystemExit(f"scene {name} {extra} failed at its smallest size (exit {code})")
    return [f"{name} {extra}" if extra else name for name, extra in runs]


def resource_usage(cuobjdump: str, cubin: str) -> list[dict]:
    text = subprocess.run([cuobjdump, "--dump-resource-usage", cubin], capture_output=True, text=True,
                          check=True).stdout
    rows, name = [], None
    for line in text.splitlines():
        m = _FUNCTION.search(line)
        if m:
            name = m.group(1)
            continue
        u = _USAGE.search(line)
        if u and name:
            reg, stack, shared, local = map(int, u.groups())
            rows.append({"kernel": name, "registers": reg, "stack": stack, "shared": shared, "local": local})
            name = None
    return rows


def _base(kernel: str) -> str:
    """A factory-made kernel's own name: ``make_kernels__locals__rates`` -> ``rates``."""
    return kernel.rsplit("__locals__", 1)[-1]


def markdown(result: dict) -> str:
    hot = [r for r in result["kernels"] if r["hot"]]

    def verdict(r):
        if r.get("cpu_only"):
            return "CPU only (a GPU runs the staged kernels)"
        return "yes" if r["registers"] <= REGISTER_BUDGET and r["stack"] == 0 else "**no**"

    rows = [[r["kernel"], r["module"], r["registers"], r["stack"], r["local"], verdict(r)] for r in hot]
    others = [r for r in result["kernels"] if not r["hot"]]
    worst = sorted(others, key=lambda r: (-r["registers"], -r["stack"]))[:15]
    return "\n".join([
        f"# Registers and stack per kernel, sm_{result['arch']} (compiled without a GPU)", "",
        f"{len(result['modules'])} modules (kernel modules and compile-time variants) loaded by the shipped scenes at "
        f"their smallest size and by {', '.join(s for s in result['scenes'] if '{' in s)}; {len(result['kernels'])} "
        f"kernels; compiling took {result['compile_s']:.0f} s. A kernel listed twice is two variants.", "",
        f"## Hot kernels (budget: <= {REGISTER_BUDGET} registers, no stack)", "",
        common.md_table(["kernel", "module", "registers", "stack (B)", "local (B)", "within budget"], rows), "",
        "What sets them: the MLS kernels are compiled for one weight and support shape each (a weight picked at run "
        "time carried every weight's code: 158 registers for the loop over a point's nodes alone), on vectors of the "
        "basis size (3 or 6) and symmetric matrices packed as their lower triangle. ``shape_functions`` takes three "
        "passes over its row (A, then -∂A γ, then the shape functions) instead of holding ∂A: linear basis 122; the "
        "quadratic one needs 166 (capped at 128 it spills 128 B a thread: its factor, γ and both slope right-hand "
        "sides are live together), so a GPU runs it as four kernels meeting through a per-point buffer of the fit "
        "(``moment_factors``, ``slope_fits`` once per axis, ``slope_solves``, ``shape_values``; bitwise the same "
        "results), and the CPU keeps the single kernel (the staged form took 1.3-1.6x its time there). NEM's "
        "``laplace_rows`` and ``edge_gradients`` walk the natural-neighbour cavity's boundary instead of keeping "
        "per-thread lists of its triangles and neighbours (255 registers and 2.8 KB of stack with the lists).", "",
        "## The other kernels with the most registers", "",
        common.md_table(["kernel", "module", "registers", "stack (B)", "local (B)"],
                        [[r["kernel"], r["module"], r["registers"], r["stack"], r["local"]] for r in worst]), ""])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--arch", type=int, default=90)
    p.add_argument("--cuobjdump", default=None)
    args = p.parse_args(argv)
    cuobjdump = find_cuobjdump(args.cuobjdump)
    scenes = load_scene_modules()
    from warpfree import cuda_compile

    from warpfree.kernels import mls

    modules = cuda_compile.loaded_modules()
    replaced = {m.name for m in mls.REPLACED_ON_GPU}
    with tempfile.TemporaryDirectory() as folder:
        results = cuda_compile.compile_modules(modules, (args.arch,), folder)
        failed = [r for r in results if r.error]
        if failed:
            raise SystemExit("CUDA compile failed: " + "; ".join(f"{r.module}: {r.error}" for r in failed))
        kernels = []
        for r in results:
            for cubin in r.paths:
                for row in resource_usage(cuobjdump, cubin):
                    row.update(kernel=_base(row["kernel"]), module=r.origin.removeprefix("warpfree.kernels."))
                    row["hot"] = row["kernel"] in HOT.get(row["module"], ())
                    row["cpu_only"] = r.module in replaced
                    kernels.append(row)
    kernels.sort(key=lambda r: (r["module"], r["kernel"]))
    result = {"arch": args.arch, "scenes": scenes, "modules": [r.module for r in results],
              "compile_s": sum(r.seconds for r in results), "kernels": kernels, "budget": REGISTER_BUDGET}
    common.write_results("register_report", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
