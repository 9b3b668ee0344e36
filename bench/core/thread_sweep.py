"""Thread sweep: work items per second of any scene against the CPU thread count.

What it measures
    For threads = 1 .. N (N = the cores this process may use), the throughput of a scene's solver in
    its own unit (``solver.work_unit``: particle-steps/s for WCSPH and the heat example), seconds per
    step, speed-up against 1 thread, parallel efficiency (speed-up / threads) and the solver's own
    per-phase times per step (``solver.phases``). Default cases:

    * ``control``: a compute-bound Warp kernel (a sin loop, no memory traffic) launched through the same
      ``Launcher``: what the machine delivered to two threads during the run (on a shared 2-core machine
      well below 2 whenever anything else runs);
    * ``control_memory`` (on request): a memory-bound Warp kernel, the STREAM triad a = b + s c over 3 arrays
      of 8 M floats (96 MB, far beyond the caches), through the same launcher with every launch split: what the
      machine's memory delivers to 1..N threads (GB/s), the ceiling of a gather such as SPEM's update;
    * ``2d_default``: the default scene as it ships (``scenes/dam_break_2d.py``, dx = 0.025: 3 200 fluid +
      1 948 boundary), where launch and hand-over overheads weigh most;
    * ``2d``: the 2D dam break (``scenes/dam_break_2d.py``, dx = 0.006: 55 278 fluid + 8 030 boundary);
    * ``3d``: the 3D dam break with obstacle (``scenes/dam_break_3d.py``, dx = 0.035: 15 680 fluid +
      41 259 boundary);
    * ``heat`` (on request): the example solver (``scenes/heat_conduction_2d.py``, n = 400: 160 000 particles);
    * ``waveguide`` (on request): SPEM (``scenes/em_waveguide_2d.py`` at 375 particles per wavelength: 51 076 E +
      50 625 H particles, PML included); ``waveguide_alternating``, ``_random``, ``_neighbours``: the same with
      Mendes's (2010) other load distributions (§3.2.2, ``warpfree/distribution.py``); ``jittered_pml_<kind>``
      for the four kinds: 30 %-jittered particles with a PML all round (``scenes/em_plane_wave_2d.py`` on a
      0.2 m square: 14 161 E + 14 400 H particles);
    * ``pic_thermal`` (on request): PIC's thermal plasma (``scenes/pic_thermal_plasma.py`` on 64 x 64 λ_D: 4 096
      nodes, 131 072 particles; work unit particle pushes);
    * any other scene: ``--scene PATH --set name=value ...`` (a ``custom`` case).

How
    Every (case, thread count) is measured in a FRESH SUBPROCESS (this script re-invoked with
    ``--worker``): ``warpfree.device.use('cpu', threads)``, build the scene (no frames, no VTU), ``--warmup``
    untimed steps (kernel loading happens here), then ``--repeats`` timed blocks of ``--steps`` calls of
    ``solver.step(dt)`` and ``solver.problem()`` (``bench/common.py: time_solver``). Solvers with moving
    neighbour tables get a rebuild forced every 8 steps (the dam breaks' developed-flow interval), the
    step counts rounded to whole periods. ``dt`` is the solver's ``stable_dt()`` at t = 0, measured by the
    first worker and passed to all others, so every thread count does the same steps (results are
    bitwise identical across thread counts). With ``--rounds`` > 1 the sweep is repeated in alternating
    order so that a drift in machine load favours no thread count; the figure per thread count is the
    median over all its blocks (rounds x repeats = 15 by default).

Usage
    python bench/core/thread_sweep.py            # full: control, 2D, 3D; 5 rounds x 3 blocks, ~4 min on 2 cores
    python bench/core/thread_sweep.py --quick    # smoke run, small sizes (~30 s)
    python bench/core/thread_sweep.py --cases heat --rounds 3 --name thread_sweep_heat
    python bench/core/thread_sweep.py --scene scenes/tank_at_rest_2d.py --set dx=0.005
Writes bench/results/<name>[_quick].{json,md,png} (name: thread_sweep by default).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [
    [],
    ["--cases", "control", "heat", "--rounds", "3", "--name", "thread_sweep_heat"],
    ["--cases", "control", "pic_thermal", "--rounds", "4", "--steps", "10", "--repeats", "2",
     "--name", "thread_sweep_pic"],
    ["--scene", "scenes/pic_diode.py", "--set", "particles_per_step=400", "--set", "injected_fraction=2",
     "--warmup", "400", "--rounds", "3", "--name", "thread_sweep_pic_diode"],
    ["--cases", "control", "control_memory", "waveguide", "waveguide_alternating", "waveguide_random",
     "waveguide_neighbours", "jittered_pml_blocks", "jittered_pml_alternating", "jittered_pml_random",
     "jittered_pml_neighbours", "--rounds", "2", "--warmup", "150", "--name", "thread_sweep_spem"],
]


def _plural(unit: str) -> str:
    """'particle' -> 'particles'; 'particle pushes' stays."""
    return unit if unit.endswith("s") else unit + "s"


CASES = {
    # name: (scene, full parameters, quick parameters)
    "control": ("control", {}, {}),
    "control_memory": ("control_memory", {}, {}),
    "2d_default": ("dam_break_2d", {"dx": 0.025}, {"dx": 0.05}),
    "2d": ("dam_break_2d", {"dx": 0.006}, {"dx": 0.02}),
    "3d": ("dam_break_3d", {"dx": 0.035}, {"dx": 0.07}),
    "heat": ("heat_conduction_2d", {"n": 400}, {"n": 100}),
    "waveguide": ("em_waveguide_2d", {"particles_per_wavelength": 375}, {"particles_per_wavelength": 60}),
    # PIC: the thermal plasma on 64 x 64 Debye lengths (4 096 nodes, 131 072 particles, both species moving)
    "pic_thermal": ("pic_thermal_plasma", {"box": (64.0, 64.0)}, {"box": (16.0, 16.0)}),
}
# SPEM's load distributions (Mendes 2010, §3.2.2; ``warpfree/distribution.py``): the waveguide ("waveguide" above is
# "blocks") and a jittered layout with a PML all round (the plane-wave scene on a 0.2 m square, conservative pair)
for _kind in ("blocks", "alternating", "random", "neighbours"):
    if _kind != "blocks":
        CASES[f"waveguide_{_kind}"] = ("em_waveguide_2d", {"particles_per_wavelength": 375, "distribution": _kind},
                                       {"particles_per_wavelength": 60, "distribution": _kind})
    CASES[f"jittered_pml_{_kind}"] = ("em_plane_wave_2d", {"size": 0.2, "margin": 0.03, "jitter": 0.3,
                                                           "distribution": _kind},
                                      {"size": 0.2, "margin": 0.03, "jitter": 0.3, "particles_per_wavelength": 20,
                                       "distribution": _kind})


def _control_kernel():
    import warp as wp

    @wp.kernel
    def spin(first: int, iters: int, out: wp.array(dtype=float)):
        i = first + wp.tid()
        s = float(0.0)
        for k in range(iters):
            s = s + wp.sin(float(k + i) * 0.001)
        out[i] = s

    return spin


def _triad_kernel():
    import warp as wp

    @wp.kernel
    def triad(first: int, a: wp.array(dtype=float), b: wp.array(dtype=float), c: wp.array(dtype=float), s: float):
        i = first + wp.tid()
        a[i] = b[i] + s * c[i]

    return triad


def worker_control_memory(cfg: dict) -> dict:
    """Memory-bound control: the STREAM triad through the same launcher, every launch split over the threads."""
    import warp as wp

    import warpfree.device

    launcher = warpfree.device.use("cpu", cfg["threads"], min_items_per_thread=1)
    kernel = _triad_kernel()
    n = cfg["n"]
    a, b, c = (wp.zeros(n, dtype=float, device="cpu") for _ in range(3))
    res = common.time_steps(lambda: launcher.launch(kernel, n, [a, b, c, 1.5]), cfg["steps"], 1, cfg["repeats"])
    counts = {"work_items": n, "work_unit": "items"}
    res.update(threads=launcher.threads, dt=0.0, phase_s_per_step={}, loadavg=common.loadavg(), rebuild_every=None,
               bytes_per_launch=3 * 4 * n, **counts)
    res.update(common.throughput(counts, cfg["steps"], res["median_s"]))
    return res


def worker_control(cfg: dict) -> dict:
    """Compute-bound control: a Warp kernel with no memory traffic, through the same launcher."""
    import warp as wp

    import warpfree.device

    if cfg["scene"] == "control_memory":
        return worker_control_memory(cfg)
    launcher = warpfree.device.use("cpu", cfg["threads"])
    kernel = _control_kernel()
    n, iters = cfg["n"], cfg["iters"]
    out = wp.zeros(n, dtype=float, device="cpu")
    res = common.time_steps(lambda: launcher.launch(kernel, n, [iters, out]), cfg["steps"], 1, cfg["repeats"])
    counts = {"work_items": n, "work_unit": "items"}
    res.update(threads=launcher.threads, dt=0.0, phase_s_per_step={}, loadavg=common.loadavg(), rebuild_every=None,
               **counts)
    res.update(common.throughput(counts, cfg["steps"], res["median_s"]))
    return res


def worker(cfg: dict) -> dict:
    if cfg["scene"] in ("control", "control_memory"):
        return worker_control(cfg)
    run = common.build_scene(cfg["scene"], cfg["threads"], **cfg["params"])
    solver = run.solver
    dt = cfg.get("dt") or solver.stable_dt()
    res = common.time_solver(solver, dt, cfg["steps"], cfg["warmup"], cfg["repeats"])
    res.update(threads=solver.launcher.threads, scene=cfg["scene"], loadavg=common.loadavg(),
               time_unit=getattr(solver, "time_unit", "s"))
    return res


def sweep_case(name: str, scene: str, params: dict, threads: list[int], args) -> dict:
    blocks: dict[int, list[float]] = {t: [] for t in threads}
    runs: dict[int, list[dict]] = {t: [] for t in threads}
    dt = args.dt
    for r in range(args.rounds):
        order = threads if r % 2 == 0 else threads[::-1]
        for t in order:
            cfg = dict(scene=scene, params=params, threads=t, steps=args.steps, warmup=args.warmup,
                       repeats=args.repeats, dt=dt)
            if scene == "control":
                cfg.update(n=16384, iters=2000 if not args.quick else 500, steps=3)
            if scene == "control_memory":
                cfg.update(n=8_000_000 if not args.quick else 1_000_000, steps=5)
            res = common.run_worker(__file__, ["--worker", json.dumps(cfg)])
            dt = res["dt"]
            blocks[t].extend(res["block_s"])
            runs[t].append(res)
            print(f"  {name} threads={t} round={r}: {common.fmt_rate(res['work_per_s'])} {res['unit']} "
                  f"(blocks {[round(b, 3) for b in res['block_s']]} s, load {res['loadavg']})", flush=True)
    first = runs[threads[0]][0]
    counts = {k: first[k] for k in ("work_items", "work_unit", "n_fluid", "n_boundary", "n_particles", "time_unit")
              if k in first}
    rows = []
    for t in threads:
        med = common.median(blocks[t])
        phases = {k: common.median([x["phase_s_per_step"][k] for x in runs[t]]) for k in runs[t][0]["phase_s_per_step"]}
        rows.append(dict(threads=t, median_block_s=med, blocks_s=blocks[t],
                         **common.throughput(counts, runs[t][0]["steps"], med), phase_s_per_step=phases,
                         loadavg=[x["loadavg"] for x in runs[t]]))
    base = rows[0]["work_per_s"] if threads[0] == 1 else None
    for row in rows:
        row["speedup"] = row["work_per_s"] / base if base else None
        row["efficiency"] = row["speedup"] / row["threads"] if base else None
    return dict(case=name, scene=scene, params=params, dt=dt, **counts, steps_per_block=first["steps"],
                rebuild_every=first["rebuild_every"], warmup=args.warmup, repeats=args.repeats, rounds=args.rounds,
                rows=rows)


def markdown(cases: list[dict]) -> str:
    out = []
    for c in cases:
        if c["scene"] == "control":
            out.append(f"**Control**: a compute-bound Warp kernel (sin loop, no memory traffic) over {c['work_items']} "
                       f"items through the same launcher: the parallelism the machine delivered during this run "
                       f"(median of {c['rounds'] * c['repeats']} blocks).\n")
            out.append(common.md_table(["threads", "ms/launch", "speed-up", "efficiency"],
                                       [[r["threads"], f"{r['s_per_step'] * 1e3:.1f}", common.fmt(r["speedup"]),
                                         common.fmt(r["efficiency"])] for r in c["rows"]]))
            out.append("")
            continue
        if c["scene"] == "control_memory":
            out.append(f"**Memory control**: the STREAM triad a = b + s c over 3 x {c['work_items']} floats through the "
                       f"same launcher, split over the threads: the memory bandwidth the machine delivered (median of "
                       f"{c['rounds'] * c['repeats']} blocks).\n")
            out.append(common.md_table(["threads", "ms/launch", "GB/s", "speed-up"],
                                       [[r["threads"], f"{r['s_per_step'] * 1e3:.2f}",
                                         f"{12 * c['work_items'] / r['s_per_step'] / 1e9:.2f}", common.fmt(r["speedup"])]
                                        for r in c["rows"]]))
            out.append("")
            continue
        reb = (f"a neighbour-table rebuild forced every {c['rebuild_every']} steps (developed-flow rate)"
               if c.get("rebuild_every") else "no forced rebuilds")
        size = (f"{c['n_fluid']} fluid + {c['n_boundary']} boundary = {c['n_particles']} particles"
                if "n_fluid" in c else f"{c['work_items']} {_plural(c['work_unit'].split('-')[0])} per step")
        params = ", ".join(f"{k} = {v}" for k, v in c["params"].items())
        unit = c.get("time_unit", "s")
        out.append(f"**{c['case']}** (`{c['scene']}`, {params}: {size}; dt = {c['dt']:.4g} {unit}; median of "
                   f"{c['rounds'] * c['repeats']} blocks of {c['steps_per_block']} steps; {reb})\n")
        phase_names = sorted(c["rows"][0]["phase_s_per_step"])
        rows = []
        for r in c["rows"]:
            ph = r["phase_s_per_step"]
            rows.append([r["threads"], f"{r['s_per_step'] * 1e3:.1f}", common.fmt_rate(r["work_per_s"]),
                         common.fmt_rate(r.get("fluid_particle_steps_per_s")), common.fmt(r["speedup"]),
                         common.fmt(r["efficiency"]), " / ".join(f"{ph[k] * 1e3:.2f}" for k in phase_names)])
        out.append(common.md_table(["threads", "ms/step", c["rows"][0]["unit"], "fluid-particle-steps/s",
                                    "speed-up", "efficiency", "ms/step: " + " / ".join(phase_names)], rows))
        out.append("")
    return "\n".join(out)


def plot(cases: list[dict]):
    fig, (a1, a2) = common.new_figure(1, 2, figsize=(10, 4))
    tmax = 1
    for i, c in enumerate(cases):
        th = [r["threads"] for r in c["rows"]]
        tmax = max(tmax, max(th))
        if c["scene"] in ("control", "control_memory"):
            if c["rows"][0]["speedup"] is not None:
                a1.plot(th, [r["speedup"] for r in c["rows"]], "x--" if c["scene"] == "control" else "s--",
                        color="0.4" if c["scene"] == "control" else "0.7",
                        label="control (compute-bound kernel)" if c["scene"] == "control" else
                        "memory control (STREAM triad)")
            continue
        lab = f"{c['case']} ({c['work_items']} items/step)"
        if c["rows"][0]["speedup"] is not None:
            a1.plot(th, [r["speedup"] for r in c["rows"]], "o-", color=f"C{i}", label=lab)
        a2.plot(th, [r["work_per_s"] for r in c["rows"]], "o-", color=f"C{i}", label=f"{lab}, {c['rows'][0]['unit']}")
    a1.plot([1, tmax], [1, tmax], "k:", label="ideal")
    a1.set_ylim(0, tmax + 0.2)
    a1.set_xlabel("threads")
    a1.set_ylabel("speed-up vs 1 thread")
    a1.set_title("CPU thread sweep")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3)
    a2.set_xlabel("threads")
    a2.set_ylabel("work items / s")
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3)
    for a in (a1, a2):
        a.set_xticks(range(1, tmax + 1))
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, few steps (smoke run)")
    ap.add_argument("--cases", nargs="+", default=None, choices=sorted(CASES),
                    help="default: control 2d_default 2d 3d (control only with --scene)")
    ap.add_argument("--scene", default=None, help="any scene file: a 'custom' case")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                    help="a parameter of --scene (repeatable)")
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="default: 1 .. cores")
    ap.add_argument("--steps", type=int, default=None, help="steps per timed block (default 20; quick 5)")
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=None, help="timed blocks per worker (default 3; quick 2)")
    ap.add_argument("--rounds", type=int, default=None, help="sweeps over the thread counts (default 5; quick 1)")
    ap.add_argument("--dt", type=float, default=None, help="fixed dt (default: stable_dt() at t = 0)")
    ap.add_argument("--name", default="thread_sweep", help="results file stem (default thread_sweep)")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        common.emit_worker_result(worker(json.loads(args.worker)))
        return 0
    q = args.quick
    args.steps = args.steps or (5 if q else 20)
    args.repeats = args.repeats or (2 if q else 3)
    args.rounds = args.rounds or (1 if q else 5)
    threads = sorted(set(args.threads or range(1, common.cpu_count() + 1)))
    cases_to_run = [(name, *CASES[name][:1], CASES[name][2 if q else 1])
                    for name in (args.cases or (["control"] if args.scene else ["control", "2d_default", "2d", "3d"]))]
    if args.scene:
        cases_to_run.append(("custom", args.scene, common.parse_sets(args.scene, args.overrides)))
    machine = common.machine_info()
    cases = []
    for name, scene, params in cases_to_run:
        print(f"{name}: {scene} {params}, threads {threads}", flush=True)
        cases.append(sweep_case(name, scene, params, threads, args))
    md = "## Thread sweep (CPU)\n\n" + markdown(cases)
    common.write_results(args.name, {"machine": machine, "cases": cases}, md, plot(cases), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
