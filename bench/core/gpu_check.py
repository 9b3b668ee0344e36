"""The one-shot GPU check: what warpfree does on a CUDA device, in at most about 8 minutes.

What it does, in order, each part within its share of ``--budget`` seconds (the shares of the parts that run, made to
sum to one: ``--skip`` gives the others the time; a part that would pass its share stops and the report says what
was left out):

1. **Tests** (``--tests``, 15 %): ``pytest -m cuda --device cuda``: every shipped scene at its smallest size through the
   command line, and the device steps' checks (one read and no write per step, replayed graphs bitwise equal to
   stepping) for WCSPH, SPEM and PIC, on the GPU.
2. **Scenes** (27 %): every shipped scene at its default on the GPU (frames and VTU off), cheapest first (by the
   reference's wall times, :func:`scene_order`); each
   analysis figure (the numbers under ``summary["analysis"]``) against the CPU's from ``--reference`` (written on a
   CPU machine by ``--device cpu --write-reference``): the relative difference per figure. A scene's checks against
   its tolerances (``summary["checks"]``) are reported as they are.
3. **Throughput** (14 %): work items per second at three sizes per family (the scene of each family whose module
   declares ``BENCHMARK``: its ``parameter``, ``values`` and ``steps``; ``common.benchmarks``), on the CPU with all
   its threads and on the GPU, measured side by side in one run (``bench/common.py``: warm-up first, median of timed
   blocks).
4. **Scale** (25 %): the sizes a CPU cannot reach in a test, on the GPU (:data:`SCALE`): the 3D dam break at about
   10^6 (on the CPU with all its threads too, for the ratio; and with its fluid pairs from the grid, no table) and
   10^7 particles, SPEM and PIC at about 10^7 particles,
   the EFG beam at about 10^6 Gauss points: work items per second, the device memory per item
   (``warpfree.memory``) and the fraction of the roofline (the case's compulsory bytes and counted operations a step
   per item, ``roofline.py`` at its small size: the larger of the bytes over the GPU's bandwidth and the operations
   over its arithmetic peak, times the items per second) with the bound it meets and, for PIC, the field
   solve's share of the step, cut by the budget. ``--scale-dry-run`` runs the same code at small sizes (a
   CPU's check of the part).
5. **Roofline** (5 %): per kernel of a step of each family's benchmark scene (``roofline.py``), the compulsory
   bytes and operations per work item, the kernel's measured time on the GPU and its fraction of the roofline's
   floor (the larger of the bandwidth's and the arithmetic's).
6. **Choices** (8 %): the forms a GPU could run, timed side by side on it: the quadratic MLS shape functions as one
   kernel (166 registers) or four within 128 (``MLSModel.shape_at(staged=)``; a GPU's default is staged), at the
   beam's Gauss points (192 x 48 cells, d_max 2.5, 3 x 3 points); and locality, the 2D dam break's step with its
   fluid stored in lattice, random and cell order (``particle_order.py``, :data:`ORDER_CASE`).
7. **The cylindrical diode at scale** (6 %): ``pic_cylindrical_diode`` (a graded EFG layout, the field solved on the
   host) at cathode spacings the CPU reaches only in minutes or more (:data:`DIODE_SCALE`, finest last, each only if
   the budget left holds twice what the last took): the anode current against Langmuir–Blodgett's, the run's wall
   time, nodes and particles, and the host field solve's share of the step (what a device solve could save). Its
   set-up (the layout's check and the field's factorisation, on the host) grows faster than the nodes: the whole
   budget goes to it in a run of its own (``--skip tests,scenes,throughput,scale,roofline,choices``). The CPU's side: ``bench/results/pic_diode_vs_mesh.md`` (+1.9 %, +1.3 %, +0.77 % at
   0.05, 0.025, 0.0125 in 11, 40, 113 s on 2 threads, to t = 10).

Usage (on a machine with a GPU and warpfree installed: ``pip install -e '.[test]'``)
    python bench/core/gpu_check.py                      # everything, --budget 480
    python bench/core/gpu_check.py --device cpu --write-reference    # the CPU figures (bench/results), no GPU
    python bench/core/gpu_check.py --device cpu --write-reference --leave-out pic_thermal_plasma,dam_break_3d
    python bench/core/gpu_check.py --skip tests,scenes,throughput,scale,roofline,choices --budget 480   # the diode
Writes bench/results/gpu_check.{json,md} (``--write-reference``: bench/results/default_figures.json).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "needs a GPU: run it once on a machine with one (python bench/core/gpu_check.py)"

REFERENCE = common.RESULTS / "default_figures.json"
#: the parts' shares of the budget
SHARES = {"tests": 0.15, "scenes": 0.27, "throughput": 0.14, "scale": 0.25, "roofline": 0.05, "choices": 0.08,
          "diode": 0.06}
#: the sizes a CPU cannot reach in a test: (family, scene, parameter, value, small value for ``--scale-dry-run``, steps
#: timed a block, on the CPU too, other settings of the scene: the 3D dam break's fluid pairs from the grid, no table,
#: beside the default). Sizes from the counts at smaller ones (``bench/results/memory.md``): the 3D dam
#: break has 26 349 particles at dx = 0.05 m (N ~ dx^-3: 1.0e6 at 0.015, 1.0e7 at 0.007); the cavity 60 484 at 80
#: cells per radius (N ~ c^2: 1.0e7 at 1 030); the thermal plasma 262 144 in a 64 x 128 box (N ~ area: 1.0e7 in
#: 400 x 800); the beam 4 608 Gauss points at 96 cells (N ~ c^2: 1.0e6 at 1 400)
SCALE = [("wcsph", "dam_break_3d", "dx", 0.015, 0.06, 20, True, {}),
         ("wcsph", "dam_break_3d", "dx", 0.015, 0.06, 20, False, {"fluid_pairs": "grid"}),
         ("wcsph", "dam_break_3d", "dx", 0.007, 0.05, 10, False, {}),
         ("spem", "em_cavity_2d", "cells_per_radius", 1030, 20, 20, False, {}),
         ("pic", "pic_thermal_plasma", "box", (400.0, 800.0), (16.0, 32.0), 10, False, {}),
         ("efg", "efg_timoshenko", "cells_x", 1400, 24, 1, False, {})]
#: the cylindrical diode's settings at scale, finest last (the current converges at first order in the cathode's
#: spacing: +0.77 % at 0.0125 with 200 particles a step; twice the particles as the spacing halves), and the small ones
#: of ``--scale-dry-run``; to t = 10 T (steady from t = 5), frames and VTU off
DIODE_SCALE = [{"cathode_spacing": 0.00625, "particles_per_step": 400.0, "t_end": 10.0},
               {"cathode_spacing": 0.003125, "particles_per_step": 800.0, "t_end": 10.0}]
DIODE_DRY_RUN = [{"node_spacing": 0.1, "cathode_spacing": 0.05, "particles_per_step": 20.0, "t_end": 2.0}]

#: family -> (scene, the parameter that sets the size, three values, steps timed per block): what the scene of each
#: family declares in ``BENCHMARK`` (``common.benchmarks``)
SIZES = {family: (b["scene"], b["parameter"], b["values"], b["steps"]) for family, b in common.benchmarks().items()}


def scene_order(reference: dict | None) -> list[str]:
    """Every shipped scene, cheapest first by the wall time of its default in ``reference`` (a CPU's, from
    ``--write-reference``); the scenes it lacks last, by name. A budget cut drops the dearest."""
    cost = {name: entry["wall_s"] for name, entry in (reference or {}).items()
            if isinstance(entry, dict) and "wall_s" in entry}
    return sorted(common.scene_files(), key=lambda name: (name not in cost, cost.get(name, 0.0), name))


def run_tests(device: str, budget: float) -> dict:
    cmd = [common.PYTHON, "-m", "pytest", "-q", "-m", "cuda", "--device", device, "-p", "no:cacheprovider"]
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd, cwd=common.ROOT, capture_output=True, text=True, timeout=budget)
        tail = proc.stdout.strip().splitlines()[-1:] or [""]
        return {"command": " ".join(cmd[2:]), "returncode": proc.returncode, "summary": tail[0],
                "wall_s": time.perf_counter() - start, "output": proc.stdout[-4000:] + proc.stderr[-2000:]}
    except subprocess.TimeoutExpired:
        return {"command": " ".join(cmd[2:]), "returncode": None, "summary": f"cut at the budget ({budget:.0f} s)",
                "wall_s": time.perf_counter() - start}


def _numbers(tree, prefix: str = "") -> dict[str, float]:
    """The finite numbers of a summary section, flattened to 'a/b/c' keys (lists: their first 3 items)."""
    out = {}
    if isinstance(tree, dict):
        for k, v in tree.items():
            out.update(_numbers(v, f"{prefix}{k}/"))
    elif isinstance(tree, list):
        for i, v in enumerate(tree[:3]):
            out.update(_numbers(v, f"{prefix}{i}/"))
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool) and math.isfinite(tree):
        out[prefix.rstrip("/")] = float(tree)
    return out


def run_scene(name: str, device: str, timeout: float, settings: dict | None = None) -> dict:
    """One scene at its default (or ``settings``) on ``device`` through the command line; its analysis figures and
    checks."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [common.PYTHON, "-m", "warpfree", "run", name, "--out", f"{out}/{name}", "--no-frames", "--no-progress",
               "--set", "vtk=false", "--device", device]
        cmd += [a for k, v in (settings or {}).items() for a in ("--set", f"{k}={v}")]
        start = time.perf_counter()
        try:
            proc = subprocess.run(cmd, cwd=common.ROOT, capture_output=True, text=True,
                                  timeout=timeout if math.isfinite(timeout) else None)
        except subprocess.TimeoutExpired:
            return {"scene": name, "status": f"cut at {timeout:.0f} s"}
        wall = time.perf_counter() - start
        summary_path = Path(out) / name / "summary.json"
        if proc.returncode != 0 or not summary_path.exists():
            return {"scene": name, "status": f"exit {proc.returncode}", "wall_s": wall,
                    "output": (proc.stdout + proc.stderr)[-2000:]}
        summary = json.loads(summary_path.read_text())
    return {"scene": name, "status": summary.get("status"), "wall_s": wall,
            "figures": _numbers(summary.get("analysis", {})), "checks": summary.get("checks"),
            "phases_s": summary.get("phases_s", {})}


def compare(figures: dict[str, float], reference: dict[str, float]) -> dict:
    """The relative difference of every figure both runs have: |a - b| / max(|b|, 1e-300)."""
    diffs = {k: abs(v - reference[k]) / max(abs(reference[k]), 1e-300) for k, v in figures.items() if k in reference}
    worst = max(diffs.items(), key=lambda kv: kv[1]) if diffs else (None, None)
    return {"compared": len(diffs), "largest": worst[1], "largest_figure": worst[0], "differences": diffs}


def run_scenes(device: str, budget: float, reference: dict | None, scenes: list[str]) -> list[dict]:
    rows, start = [], time.perf_counter()
    for name in scenes:
        left = budget - (time.perf_counter() - start)
        if left <= 5:
            rows.append({"scene": name, "status": "not run (budget)"})
            continue
        row = run_scene(name, device, left)
        if reference and name in reference and "figures" in row:
            row["against_cpu"] = compare(row["figures"], reference[name]["figures"])
        rows.append(row)
        print(f"  {name}: {row['status']} in {row.get('wall_s', 0):.1f} s", flush=True)
    return rows


def measure(family: str, value, device: str, threads: int | None, scene: str | None = None,
            param: str | None = None, steps: int | None = None, settings: dict | None = None) -> dict:
    """Work items per second of one size of a family on ``device`` (in this process; the family's benchmark scene
    unless ``scene``, ``param`` and ``steps`` are given; ``settings``: the scene's other parameters), and the device
    memory per item."""
    from warpfree.memory import solver_memory

    if scene is None:
        scene, param, _, steps = SIZES[family]
    run = common.build_scene(scene, threads or common.cpu_count(), device=device, **{param: value, **(settings or {})})
    solver = run.solver
    if hasattr(solver, "solve"):  # a static solve: the solve timed, work items = its Gauss points
        timing = common.time_steps(solver.solve, 1, warmup=1, repeats=3)
        return {"work_items": solver.work_items, "unit": f"{solver.work_unit}/s",
                "work_per_s": solver.work_items / timing["median_s"], "s": timing["median_s"],
                "bytes_per_item": solver_memory(solver)["per_item"]}
    dt = run.step_size or solver.stable_dt()
    timing = common.time_solver(solver, dt, steps, warmup=3, repeats=3)
    phases = timing.get("phase_s_per_step", {})
    return {"work_items": timing["work_items"], "unit": timing["unit"], "work_per_s": timing["work_per_s"],
            "s": timing["s_per_step"], "bytes_per_item": solver_memory(solver)["per_item"],
            # each phase's share of the step (PIC's field solve: "solve")
            "phase_share": {k: v / timing["s_per_step"] for k, v in phases.items()} if timing["s_per_step"] else {}}


def run_throughput(device: str, budget: float) -> list[dict]:
    rows, start = [], time.perf_counter()
    for family, (scene, param, values, _) in SIZES.items():
        for value in values:
            if time.perf_counter() - start > budget:
                rows.append({"family": family, "scene": scene, param: value, "status": "not run (budget)"})
                continue
            row = {"family": family, "scene": scene, "size": f"{param}={value}"}
            for where in ("cpu", device) if device != "cpu" else ("cpu",):
                try:
                    row[where] = measure(family, value, where, None)
                except Exception as exc:  # a size a device cannot hold: said, not fatal
                    row[where] = {"error": f"{type(exc).__name__}: {exc}"[:300]}
            rows.append(row)
            print(f"  {family} {row['size']}: " + ", ".join(
                f"{w} {row[w].get('work_per_s', float('nan')):.3g}/s" for w in ("cpu", device) if w in row), flush=True)
    return rows


def run_scale(device: str, budget: float, dry_run: bool = False) -> list[dict]:
    """:data:`SCALE` on ``device`` (and the CPU where a row says so), in order, each only if the budget left holds
    twice what the last took (the sizes grow)."""
    rows, start, last = [], time.perf_counter(), 0.0
    for family, scene, param, value, small, steps, on_cpu, settings in SCALE:
        size = small if dry_run else value
        row = {"family": family, "scene": scene,
               "size": " ".join([f"{param}={size}"] + [f"{k}={v}" for k, v in settings.items()])}
        left = budget - (time.perf_counter() - start)
        if left < 2.0 * last:
            row["status"] = "not run (budget)"
            rows.append(row)
            continue
        began = time.perf_counter()
        for where in ((device, "cpu") if on_cpu and device != "cpu" else (device,)):
            try:
                row[where] = measure(family, size, where, None, scene, param, steps, settings)
            except Exception as exc:  # a size a device cannot hold: said, not fatal
                row[where] = {"error": f"{type(exc).__name__}: {exc}"[:300]}
        try:  # the case's own compulsory bytes per work item a step, from its small size (per item, size-free)
            import roofline

            kernels = roofline.one(family, scene, param, small, device, settings)
            for key, name in (("traffic_bytes_per_item", "bytes_per_work_item"),
                              ("ops_f32_per_item", "ops_f32_per_work_item"), ("ops_f64_per_item", "ops_f64_per_work_item")):
                row[key] = sum(r[name] for r in kernels)
        except Exception as exc:  # said, not fatal
            row["traffic_error"] = f"{type(exc).__name__}: {exc}"[:300]
        last = time.perf_counter() - began
        rows.append(row)
        print(f"  scale {family} {row['size']}: " + ", ".join(
            f"{w} {row[w].get('work_per_s', float('nan')):.3g}/s, {row[w].get('bytes_per_item') or float('nan'):.0f} B"
            for w in (device, "cpu") if w in row), flush=True)
    return rows


def run_diode(device: str, budget: float, dry_run: bool = False) -> list[dict]:
    """The cylindrical diode at :data:`DIODE_SCALE` (``dry_run``: :data:`DIODE_DRY_RUN`) on ``device``, each only if the
    budget left holds twice what the last took."""
    rows, start, last = [], time.perf_counter(), 0.0
    for settings in DIODE_DRY_RUN if dry_run else DIODE_SCALE:
        left = budget - (time.perf_counter() - start)
        if left < max(2.0 * last, 5.0):
            rows.append({"settings": settings, "status": "not run (budget)"})
            continue
        row = {"settings": settings, **run_scene("pic_cylindrical_diode", device, left, settings)}
        last = row.get("wall_s", left)
        rows.append(row)
        figures = row.get("figures", {})
        print(f"  diode {settings}: {row['status']}, anode current / Langmuir–Blodgett "
              f"{figures.get('diode/anode_over_langmuir_blodgett', float('nan')):.4f} in {last:.0f} s", flush=True)
    return rows


def run_roofline(device: str, budget: float) -> list[dict]:
    """``roofline.py``'s rows for each family's middle benchmark size on ``device``, within the budget."""
    import roofline

    rows, start = [], time.perf_counter()
    for family, (scene, param, values, _) in SIZES.items():
        if time.perf_counter() - start > budget:
            rows.append({"family": family, "status": "not run (budget)"})
            continue
        try:
            rows += roofline.one(family, scene, param, values[len(values) // 2], device)
        except Exception as exc:  # said, not fatal
            rows.append({"family": family, "error": f"{type(exc).__name__}: {exc}"[:300]})
    return rows


def run_choices(device: str, budget: float) -> list[dict]:
    """The quadratic shape functions as one kernel and as four on ``device``: median seconds of ``shape_at``."""
    sys.path.insert(0, str(common.SCENES))
    from warpfree import device as devices

    import efg_timoshenko

    devices.use(device, None)
    beam = efg_timoshenko.beam_solver(192, 48, basis="quadratic", d_max=2.5, gauss=3)
    points = beam.cells.position
    row = {"choice": "quadratic shape functions", "points": len(points)}
    start = time.perf_counter()
    for staged in (False, True, False, True):
        if time.perf_counter() - start > budget / 2:
            break
        timing = common.time_steps(lambda: beam.model.shape_at(points, staged=staged), 1, warmup=1, repeats=3)
        row.setdefault("staged" if staged else "single", []).append(timing["median_s"])
    print(f"  {row}", flush=True)
    return [row, particle_orders(device, budget - (time.perf_counter() - start))]


#: the 2D dam break of ``particle_order.py`` on the GPU: spacing (m; 221 k fluid particles), steps a block, blocks
ORDER_CASE = {"dx": 0.003, "steps": 40, "repeats": 3}


def particle_orders(device: str, budget: float) -> dict:
    """Locality on ``device``: the 2D dam break's step with its fluid stored in lattice, random and cell order
    (``particle_order.py``'s worker, in this process), within ``budget`` seconds: s a step in each order."""
    import particle_order

    row = {"choice": "particle order", **ORDER_CASE}
    start = time.perf_counter()
    for order in particle_order.ORDERS:
        if time.perf_counter() - start > budget:
            row.setdefault("not run (budget)", []).append(order)
            continue
        res = particle_order.worker({"order": order, "threads": common.cpu_count(), "device": device, **ORDER_CASE})
        row[order] = res["median_s"] / res["steps"]
    print(f"  {row}", flush=True)
    return row


def markdown(result: dict) -> str:
    device = result["device"]
    lines = [f"# GPU check on {result.get('gpu') or device}", "",
             f"Budget {result['budget_s']:.0f} s; took {result['wall_s']:.0f} s.", ""]
    t = result.get("tests")
    if t:
        lines += ["## Tests marked cuda", "", f"`{t['command']}`: {t['summary']} ({t['wall_s']:.0f} s)", ""]
    rows = []
    for r in result.get("scenes", []):
        c = r.get("against_cpu") or {}
        rows.append([r["scene"], r["status"], common.fmt(r.get("wall_s")), c.get("compared", "–"),
                     "–" if c.get("largest") is None else f"{c['largest']:.2e} ({c['largest_figure']})"])
    if rows:
        lines += ["## Scenes at their defaults", "",
                  common.md_table(["scene", "status", "wall s", "figures compared", "largest relative difference "
                                   "from the CPU"], rows), ""]
    rows = []
    for r in result.get("throughput", []):
        cpu, gpu = r.get("cpu", {}), r.get(device, {}) if device != "cpu" else {}
        ratio = (gpu["work_per_s"] / cpu["work_per_s"]) if "work_per_s" in gpu and "work_per_s" in cpu else None
        rows.append([r["family"], r.get("size", r.get("status")), cpu.get("work_items", "–"), cpu.get("unit", "–"),
                     common.fmt_rate(cpu.get("work_per_s")), common.fmt_rate(gpu.get("work_per_s")),
                     "–" if ratio is None else f"{ratio:.1f}"])
    if rows:
        lines += ["## Throughput, CPU (all threads) against the GPU, same run", "",
                  common.md_table(["family", "size", "work items", "unit", "CPU", "GPU", "GPU / CPU"], rows), ""]
    import roofline

    card = "H200" if "H200" in str(result.get("gpu")) else "H100 SXM"
    rows = []
    for r in result.get("scale", []):
        gpu, cpu = r.get(device, {}), r.get("cpu", {}) if device != "cpu" else {}
        ratio = (gpu["work_per_s"] / cpu["work_per_s"]) if "work_per_s" in gpu and "work_per_s" in cpu else None
        floor = (roofline.floors(r["traffic_bytes_per_item"], r.get("ops_f32_per_item", 0.0),
                                 r.get("ops_f64_per_item", 0.0), card) if "traffic_bytes_per_item" in r else None)
        roof = (gpu["work_per_s"] * floor["floor_s"] if "work_per_s" in gpu and floor and device != "cpu" else None)
        rows.append([r["family"], f"{r['scene']} {r['size']}", gpu.get("work_items", r.get("status", "–")),
                     gpu.get("unit", "–"), common.fmt_rate(gpu.get("work_per_s")),
                     "–" if gpu.get("bytes_per_item") is None else f"{gpu['bytes_per_item']:.0f}",
                     common.fmt_rate(cpu.get("work_per_s")), "–" if ratio is None else f"{ratio:.1f}",
                     "–" if roof is None else f"{roof:.2f}", "–" if floor is None else floor["bound"],
                     "–" if "solve" not in gpu.get("phase_share", {}) else f"{gpu['phase_share']['solve']:.2f}"])
    if rows:
        lines += ["## At scale", "",
                  common.md_table(["family", "case", "work items", "unit", "device", "bytes / item", "CPU (all threads)",
                                   "device / CPU", "fraction of the roofline", "bound",
                                   "field solve's share of the step"], rows), ""]
    rows = []
    for r in result.get("roofline", []):
        if "kernel" not in r:
            rows.append([r["family"], r.get("status", r.get("error", "")), "–", "–", "–", "–", "–", "–"])
            continue
        floor, bound = r[f"floor_s_{card}"], r[f"bound_{card}"]
        s = r.get("s")
        rows.append([r["family"], r["kernel"], f"{r['bytes_per_work_item']:.1f}",
                     f"{r['ops_f32_per_work_item'] + r['ops_f64_per_work_item']:.0f}", bound,
                     "–" if s is None else f"{1e6 * s:.1f}", f"{1e6 * floor:.1f}", "–" if not s else f"{floor / s:.2f}"])
    if rows:
        lines += ["## Roofline: each kernel's time against the least its bytes and operations need", "",
                  common.md_table(["family", "kernel", "bytes per work item", "operations per work item", "bound",
                                   "measured (µs)", "floor (µs)", "fraction of the roofline"], rows), ""]
    rows = []
    orders = []
    for r in result.get("choices", []):
        if r.get("choice") == "particle order":
            orders.append(r)
            continue
        single, staged = r.get("single", []), r.get("staged", [])
        ratio = (min(staged) / min(single)) if single and staged else None
        rows.append([r["choice"], r["points"], ", ".join(f"{1e3 * s:.1f}" for s in single),
                     ", ".join(f"{1e3 * s:.1f}" for s in staged), "–" if ratio is None else f"{ratio:.2f}"])
    if rows:
        lines += ["## Choices: the forms a GPU could run, side by side (ms, in turn)", "",
                  common.md_table(["what", "points", "one kernel", "staged", "staged / one"], rows), ""]
    for r in orders:
        cells = [f"{1e3 * r[o]:.2f}" if o in r else "not run" for o in ("lattice", "random", "cell")]
        ratio = f"{r['random'] / r['lattice']:.2f}" if "random" in r and "lattice" in r else "–"
        lines += [f"## Locality: the 2D dam break (dx = {r['dx']} m) with its fluid stored in three orders", "",
                  common.md_table(["lattice (ms a step)", "random", "cell", "random / lattice"], [cells + [ratio]]),
                  ""]
    rows = []
    for r in result.get("diode", []):
        f = r.get("figures", {})
        ratio = f.get("diode/anode_over_langmuir_blodgett")
        phases = r.get("phases_s") or {}
        share = phases["solve"] / phases["step"] if phases.get("step") and "solve" in phases else None
        rows.append([", ".join(f"{k} {v:g}" for k, v in r["settings"].items()), r.get("status", "–"),
                     "–" if ratio is None else f"{100 * (ratio - 1):+.2f} %", common.fmt(r.get("wall_s")),
                     *(f"{f[k]:.0f}" if k in f else "–" for k in ("diode/nodes", "diode/particles")),
                     "–" if share is None else f"{share:.2f}"])
    if rows:
        lines += ["## The cylindrical diode at a size the CPU cannot reach", "",
                  "On the CPU (2 threads, `bench/results/pic_diode_vs_mesh.md`): +1.9 %, +1.3 %, +0.77 % at cathode "
                  "spacings 0.05, 0.025, 0.0125 in 11, 40, 113 s to t = 10.", "",
                  common.md_table(["settings", "status", "anode current against Langmuir–Blodgett", "wall s",
                                   "nodes", "particles at the end", "field solve's share of the step (host)"],
                                  rows), ""]
    return "\n".join(lines) + "\n"


def part_budgets(budget: float, skip: set[str]) -> dict[str, float]:
    """Each part's seconds: its share of ``budget`` among the parts not in ``skip`` (the shares made to sum to one)."""
    running = {part: s for part, s in SHARES.items() if part not in skip}
    total = sum(running.values())
    return {part: budget * s / total for part, s in running.items()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cuda")
    p.add_argument("--budget", type=float, default=480.0, help="seconds for the parts together")
    p.add_argument("--write-reference", action="store_true",
                   help="run the scenes' defaults on --device and write their figures to " + str(REFERENCE))
    p.add_argument("--reference", default=str(REFERENCE))
    p.add_argument("--skip", default="", help="parts to leave out: tests,scenes,throughput,scale,roofline,choices,"
                                              "diode")
    p.add_argument("--scale-dry-run", action="store_true",
                   help="the scale and diode parts at small sizes (a CPU's check)")
    p.add_argument("--leave-out", default="", help="scenes to leave out of the scenes' part (comma-separated)")
    args = p.parse_args(argv)
    skip = set(filter(None, args.skip.split(",")))
    left_out = set(filter(None, args.leave_out.split(",")))
    reference = json.loads(Path(args.reference).read_text()) if Path(args.reference).exists() else None
    scenes = [name for name in scene_order(reference) if name not in left_out]
    start = time.perf_counter()
    if args.write_reference:
        rows = run_scenes(args.device, math.inf, None, scenes)
        ref = {r["scene"]: {"figures": r["figures"], "wall_s": r["wall_s"]} for r in rows if "figures" in r}
        REFERENCE.write_text(json.dumps({"machine": common.machine_info(), "device": args.device, **ref}, indent=1))
        print(f"wrote {REFERENCE.relative_to(common.ROOT)}")
        return 0
    result = {"machine": common.machine_info(), "device": args.device, "budget_s": args.budget}
    share = part_budgets(args.budget, skip)
    try:
        import warp as wp

        wp.init()
        result["gpu"] = str(wp.get_device(args.device).name) if args.device != "cpu" else None
    except Exception as exc:
        result["gpu"] = f"no such device ({exc})"
    if "tests" not in skip:
        result["tests"] = run_tests(args.device, share["tests"])
    if "scenes" not in skip:
        result["scenes"] = run_scenes(args.device, share["scenes"], reference, scenes)
    if "throughput" not in skip:
        result["throughput"] = run_throughput(args.device, share["throughput"])
    if "scale" not in skip:
        result["scale"] = run_scale(args.device, share["scale"], args.scale_dry_run)
    if "roofline" not in skip:
        result["roofline"] = run_roofline(args.device, share["roofline"])
    if "choices" not in skip:
        result["choices"] = run_choices(args.device, share["choices"])
    if "diode" not in skip:
        result["diode"] = run_diode(args.device, share["diode"], args.scale_dry_run)
    result["wall_s"] = time.perf_counter() - start
    common.write_results("gpu_check", result, markdown(result))
    return 0 if (result.get("tests") or {}).get("returncode", 0) == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
