"""The memory traffic a step must move, per kernel: the floor of a bandwidth roofline.

What it measures
    Each family's benchmark scene at its middle size (``BENCHMARK``), built on the CPU and stepped a few times; then one
    step (a static scene: one solve) with every launch recorded: per kernel, the items launched and the bytes of every
    array it is given (Warp arrays and the arrays inside Warp structs; each array once per launch, whole). That sum is
    the compulsory traffic when every array is read or written once and every gather hits the cache: the fewest bytes
    a GPU must move, so bytes per item over a GPU's bandwidth is the least time the kernel can take (H100 SXM
    3.35 TB/s, H200 4.8 TB/s). A kernel given whole arrays it touches only in part (a row of a table) is counted
    whole: the floor is an upper bound on that kernel's compulsory bytes. Operations per item are counted from the C++
    Warp generates for the kernel (``operations.py``: loops at their measured trips); the arithmetic floor is the
    operations over the GPU's FP32 and FP64 peaks, and the kernel's floor the larger of the two. On a GPU
    (``--device cuda``) each kernel's time over the step is measured too (synchronised launches, median of 5 steps)
    and its fraction of the roofline given.

Usage
    python bench/core/roofline.py                 # the CPU: bytes and operations per item, the floors, about a minute
    python bench/core/roofline.py --device cuda   # on a GPU: with each kernel's time and its fraction
Writes bench/results/roofline.{json,md} (``--device cuda``: roofline_gpu.{json,md}).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402
import operations  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

#: GPU memory bandwidths (bytes/s) the floors are given for
BANDWIDTH = {"H100 SXM": 3.35e12, "H200": 4.8e12}
#: GPU arithmetic peaks (operations/s, no tensor cores; NVIDIA's H100 SXM and H200 data sheets: FP32 67, FP64 34 TFLOPS)
PEAK = {"H100 SXM": {"f32": 67e12, "f64": 34e12}, "H200": {"f32": 67e12, "f64": 34e12}}


def floors(bytes_: float, f32: float, f64: float, gpu: str) -> dict:
    """The least time ``bytes_`` of traffic and ``f32`` + ``f64`` operations take on ``gpu`` (s): the bandwidth's,
    the arithmetic's (float32 and float64 units in turn) and the roofline's, the larger of the two, with its bound."""
    memory = bytes_ / BANDWIDTH[gpu]
    arithmetic = f32 / PEAK[gpu]["f32"] + f64 / PEAK[gpu]["f64"]
    return {"memory_s": memory, "arithmetic_s": arithmetic, "floor_s": max(memory, arithmetic),
            "bound": "arithmetic" if arithmetic > memory else "memory"}


def _array_bytes(value, seen: set) -> int:
    """Bytes of the Warp arrays in a launch argument (a struct's fields included), each array once."""
    import warp as wp

    if isinstance(value, wp.array):
        if value.ptr is None or value.ptr in seen:
            return 0
        seen.add(value.ptr)
        return int(value.capacity)
    if hasattr(value, "_ctype") and type(value).__module__.startswith("warp"):  # a Warp struct
        return sum(_array_bytes(v, seen) for k, v in vars(value).items() if k != "_ctype")
    return 0


class Recorder:
    """Wraps a launcher's ``launch``: per kernel, launches, items and compulsory bytes (and, timed, seconds)."""

    def __init__(self, launcher, timed: bool):
        self.launcher, self.timed = launcher, timed
        self.rows = defaultdict(lambda: {"launches": 0, "items": 0, "bytes": 0, "s": 0.0, "f32": 0.0, "f64": 0.0,
                                         "special": 0.0, "unresolved": set()})
        self.on = False
        self._launch = launcher.launch

        def launch(kernel, n, inputs, once=False):
            if not self.on:
                return self._launch(kernel, n, inputs, once=once)
            row = self.rows[kernel.key]
            row["launches"] += 1
            row["items"] += int(n)
            row["bytes"] += sum(_array_bytes(v, set()) for v in inputs)
            if self.timed:
                launcher.synchronize()
                t0 = time.perf_counter()
            out = self._launch(kernel, n, inputs, once=once)
            if self.timed:
                launcher.synchronize()
                row["s"] += time.perf_counter() - t0
            ops = operations.kernel_operations(kernel, inputs, int(n))  # the module is loaded now: its C++ is cached
            for k in ("f32", "f64", "special"):
                row[k] += ops[k] * int(n)
            row["unresolved"].update(ops["unresolved"])
            return out

        launcher.launch = launch


def one(family: str, scene: str, param: str, value, device: str, settings: dict | None = None) -> list[dict]:
    """Per kernel of one step of ``scene`` at ``param`` = ``value`` (``settings``: its other parameters): launches,
    items, bytes and operations per work item, the floors."""
    import warpfree.device

    run = common.build_scene(scene, common.cpu_count(), device=device, **{param: value, **(settings or {})})
    solver = run.solver
    recorder = Recorder(warpfree.device.current_launcher(), timed=device != "cpu")
    static = hasattr(solver, "solve")
    if not static:
        dt = run.step_size or solver.stable_dt()
        for _ in range(3):
            solver.step(dt)
    steps = 1 if static or device == "cpu" else 5
    recorder.on = True
    for _ in range(steps):
        solver.solve() if static else solver.step(dt)
    recorder.on = False
    items = int(solver.work_items)
    out = []
    for name, r in sorted(recorder.rows.items(), key=lambda kv: -kv[1]["bytes"]):
        row = {"family": family, "case": f"{scene} {param}={value}", "work_items": items, "kernel": name,
               "launches": r["launches"] / steps, "items": r["items"] / steps, "bytes": r["bytes"] / steps,
               "bytes_per_work_item": r["bytes"] / steps / items,
               "ops_f32_per_work_item": r["f32"] / steps / items, "ops_f64_per_work_item": r["f64"] / steps / items,
               "special_per_work_item": r["special"] / steps / items, "loops_unresolved": sorted(r["unresolved"])}
        for gpu in BANDWIDTH:
            f = floors(row["bytes"], r["f32"] / steps, r["f64"] / steps, gpu)
            row[f"floor_s_{gpu}"], row[f"bound_{gpu}"] = f["floor_s"], f["bound"]
            row[f"memory_floor_s_{gpu}"], row[f"arithmetic_floor_s_{gpu}"] = f["memory_s"], f["arithmetic_s"]
        if device != "cpu":
            row["s"] = r["s"] / steps
            row["achieved_bytes_per_s"] = row["bytes"] / row["s"] if row["s"] > 0 else None
        out.append(row)
    return out


def markdown(result: dict) -> str:
    gpu = result["device"] != "cpu"
    rows = []
    for r in result["rows"]:
        ops = r["ops_f32_per_work_item"] + r["ops_f64_per_work_item"]
        line = [r["family"], r["case"], r["kernel"], f"{r['launches']:.0f}", f"{r['bytes_per_work_item']:.1f}",
                f"{ops:.0f}" + ("*" if r["loops_unresolved"] else ""), f"{r['ops_f64_per_work_item']:.0f}",
                f"{r['special_per_work_item']:.0f}",
                "–" if not r["bytes_per_work_item"] else f"{ops / r['bytes_per_work_item']:.2f}",
                r["bound_H100 SXM"], f"{1e6 * r['floor_s_H100 SXM']:.1f}", f"{1e6 * r['floor_s_H200']:.1f}"]
        if gpu:
            line += [f"{1e6 * r['s']:.1f}", "–" if not r.get("achieved_bytes_per_s") else
                     f"{r['achieved_bytes_per_s'] / 1e9:.0f}"]
        rows.append(line)
    head = ["family", "case", "kernel", "launches a step", "bytes per work item", "operations per work item",
            "of them float64", "special functions", "operations per byte", "bound on an H100",
            "floor on an H100 (µs)", "floor on an H200 (µs)"] + (["measured (µs)", "achieved GB/s"] if gpu else [])
    total = defaultdict(lambda: [0.0, 0.0, 0.0, 0.0, 0.0])
    for r in result["rows"]:
        t = total[(r["family"], r["case"])]
        t[0] += r["bytes_per_work_item"]
        t[1] += r["ops_f32_per_work_item"] + r["ops_f64_per_work_item"]
        t[2] += r["ops_f64_per_work_item"]
        t[3] += r["memory_floor_s_H100 SXM"] / r["work_items"]
        t[4] += r["arithmetic_floor_s_H100 SXM"] / r["work_items"]
    lines = ["# Memory traffic and arithmetic per step, by kernel (the floors of a roofline)", "",
             "Bytes: every array a launch is given, once (compulsory traffic). Operations: counted from the C++ Warp "
             "generates (`operations.py`); * marks a kernel with a loop whose trips could not be read (counted once). "
             "The floor is the larger of the bytes over the bandwidth (H100 SXM 3.35 TB/s, H200 4.8 TB/s) and the "
             "operations over the arithmetic peak (FP32 67, FP64 34 TFLOPS, both cards).", "",
             common.md_table(head, rows), "", "Per work item, all kernels of a step (a static case: of a solve):"]
    lines += [f"- {f}, {c}: {b:.0f} bytes, {o:.0f} operations ({o64:.0f} float64); on an H100 the bytes need "
              f"{1e9 * m:.3f} ns, the operations {1e9 * a:.3f} ns"
              for (f, c), (b, o, o64, m, a) in total.items()]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cpu")
    args = p.parse_args(argv)
    rows = []
    for family, b in common.benchmarks().items():
        value = b["values"][len(b["values"]) // 2]
        rows += one(family, b["scene"], b["parameter"], value, args.device)
        print(f"  {family}: {len([r for r in rows if r['family'] == family])} kernels", flush=True)
    result = {"device": args.device, "bandwidth": BANDWIDTH, "rows": rows, "machine": common.machine_info()}
    common.write_results("roofline" if args.device == "cpu" else "roofline_gpu", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
