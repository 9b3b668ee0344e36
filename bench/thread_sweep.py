"""Thread sweep: particle-steps per second of the WCSPH solver against the CPU thread count.

What it measures
    The 2D dam break (``scenes/dam_break_2d.py``, dx = 0.006 with a = 1: 55 278 fluid + 8 030 boundary
    = 63 308 particles) and, as a second set of rows, the 3D dam break with obstacle
    (``scenes/dam_break_3d.py``, dx = 0.035: 15 680 fluid + 41 259 boundary = 56 939 particles), for
    threads = 1 .. N (N = the cores this process may use). Reported per thread count: particle-steps/s
    with particles = fluid + boundary and with fluid only, seconds per step, speed-up against 1 thread
    and parallel efficiency (speed-up / threads), and the solver's own per-phase times per step
    (rates, wall pressure, neighbour lists, integration).

    A control case comes first: a compute-bound Warp kernel (a sin loop, no memory traffic) launched
    through the same ``Launcher``. Its speed-up is what the machine delivered to two threads during the
    run; on a shared 2-core machine that is well below 2 whenever anything else runs.

How
    Every (case, thread count) is measured in a FRESH SUBPROCESS (this script re-invoked with
    ``--worker``): it calls ``warpfree.device.use('cpu', threads)``, builds the scene (no frames, no
    VTU), runs ``--warmup`` untimed steps (kernel loading / compilation happens here, never inside a
    timing), then ``--repeats`` timed blocks of ``--steps`` calls of ``solver.step(dt)``
    (``bench/common.py: time_solver``). The solver rebuilds its neighbour lists only once a particle
    has used up half the skin, which from rest takes hundreds of steps, so a rebuild is forced every
    k steps, k = floor(skin / 2 / (v dt)) with v = c0/10 the developed flow speed (k = 7 here), and
    the step counts are rounded up to whole periods of k. ``dt`` is the solver's ``stable_dt()`` at t = 0, measured by
    the first worker and passed to all others, so every thread count does exactly the same steps
    (the launcher's chunking keeps results bitwise identical across thread counts). With ``--rounds``
    > 1 the sweep over thread counts is repeated, alternating ascending and descending order, so a
    drift in machine load does not favour one thread count. The figure reported per thread count is
    the median over all its timed blocks (rounds x repeats = 15 by default).

Target (issue): speed-up >= 1.85 on 2 cores for the 2D case.

Usage
    python bench/thread_sweep.py            # full: control, 2D, 3D; 5 rounds x 3 blocks, ~3 min on 2 cores
    python bench/thread_sweep.py --quick    # smoke run, small sizes (~20 s)
    python bench/thread_sweep.py --cases 2d --threads 1 2 --rounds 3
Writes bench/results/thread_sweep[_quick].{json,md,png}.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

CASES = {
    # name: (scene, full dx, quick dx)
    "control": ("control", None, None),
    "2d": ("dam_break_2d", 0.006, 0.02),
    "3d": ("dam_break_3d", 0.035, 0.07),
}


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


def worker_control(cfg: dict) -> dict:
    """Compute-bound control: a Warp kernel with no memory traffic, through the same launcher."""
    import warp as wp

    import warpfree.device

    launcher = warpfree.device.use("cpu", cfg["threads"])
    kernel = _control_kernel()
    n, iters = cfg["n"], cfg["iters"]
    out = wp.zeros(n, dtype=float, device="cpu")
    res = common.time_steps(lambda: launcher.launch(kernel, n, [iters, out]), cfg["steps"], 1, cfg["repeats"])
    res.update(threads=launcher.threads, n_particles=n, n_fluid=n, n_boundary=0, dt=0.0, phase_s_per_step={},
               loadavg=common.loadavg(), rebuild_every=None)
    res.update(common.throughput(n, n, cfg["steps"], res["median_s"]))
    return res


def worker(cfg: dict) -> dict:
    if cfg["scene"] == "control":
        return worker_control(cfg)
    sim = common.build_scene(cfg["scene"], cfg["threads"], dx=cfg["dx"], t_end=10.0)
    solver = sim.solver
    dt = cfg.get("dt") or solver.stable_dt()
    res = common.time_solver(solver, dt, cfg["steps"], cfg["warmup"], cfg["repeats"])
    res.update(threads=solver.launcher.threads, scene=cfg["scene"], dx=cfg["dx"], loadavg=common.loadavg())
    return res


def sweep_case(name: str, dx: float, threads: list[int], args) -> dict:
    scene = CASES[name][0]
    blocks: dict[int, list[float]] = {t: [] for t in threads}
    runs: dict[int, list[dict]] = {t: [] for t in threads}
    dt = args.dt
    for r in range(args.rounds):
        order = threads if r % 2 == 0 else threads[::-1]
        for t in order:
            cfg = dict(scene=scene, dx=dx, threads=t, steps=args.steps, warmup=args.warmup,
                       repeats=args.repeats, dt=dt)
            if scene == "control":
                cfg.update(n=16384, iters=2000 if not args.quick else 500, steps=3)
            res = common.run_worker(__file__, ["--worker", json.dumps(cfg)])
            dt = res["dt"]
            blocks[t].extend(res["block_s"])
            runs[t].append(res)
            print(f"  {name} threads={t} round={r}: {common.fmt_rate(res['particle_steps_per_s'])} "
                  f"particle-steps/s (blocks {[round(b, 3) for b in res['block_s']]} s, load {res['loadavg']})",
                  flush=True)
    first = runs[threads[0]][0]
    n, nf, nb = first["n_particles"], first["n_fluid"], first["n_boundary"]
    rows = []
    for t in threads:
        med = common.median(blocks[t])
        thr = common.throughput(n, nf, runs[t][0]["steps"], med)
        phases = {}
        for k in runs[t][0]["phase_s_per_step"]:
            phases[k] = common.median([x["phase_s_per_step"][k] for x in runs[t]])
        rows.append(dict(threads=t, median_block_s=med, blocks_s=blocks[t], **thr, phase_s_per_step=phases,
                         loadavg=[x["loadavg"] for x in runs[t]]))
    base = rows[0]["particle_steps_per_s"] if threads[0] == 1 else None
    for row in rows:
        row["speedup"] = row["particle_steps_per_s"] / base if base else None
        row["efficiency"] = row["speedup"] / row["threads"] if base else None
    return dict(case=name, scene=scene, dx=dx, dt=dt, n_particles=n, n_fluid=nf, n_boundary=nb,
                steps_per_block=first["steps"], rebuild_every=first["rebuild_every"], warmup=args.warmup, repeats=args.repeats, rounds=args.rounds,
                rows=rows)


def markdown(cases: list[dict]) -> str:
    out = []
    for c in cases:
        if c["scene"] == "control":
            out.append(f"**Control**: a compute-bound Warp kernel (sin loop, no memory traffic) over {c['n_particles']} "
                       f"items through the same launcher: the parallelism the machine delivered during this run "
                       f"(median of {c['rounds'] * c['repeats']} blocks).\n")
            out.append(common.md_table(["threads", "ms/launch", "speed-up", "efficiency"],
                                       [[r["threads"], f"{r['s_per_step'] * 1e3:.1f}", common.fmt(r["speedup"]),
                                         common.fmt(r["efficiency"])] for r in c["rows"]]))
            out.append("")
            continue
        reb = (f"a neighbour-list rebuild forced every {c['rebuild_every']} steps (developed-flow rate)"
               if c.get("rebuild_every") else "no forced list rebuilds")
        out.append(f"**{c['case'].upper()} dam break** (`{c['scene']}`, dx = {c['dx']}: {c['n_fluid']} fluid + "
                   f"{c['n_boundary']} boundary = {c['n_particles']} particles; dt = {c['dt']:.4g} s; median of "
                   f"{c['rounds'] * c['repeats']} blocks of {c['steps_per_block']} steps; {reb})\n")
        rows = []
        for r in c["rows"]:
            ph = r["phase_s_per_step"]
            rows.append([r["threads"], f"{r['s_per_step'] * 1e3:.1f}", common.fmt_rate(r["particle_steps_per_s"]),
                         common.fmt_rate(r["fluid_particle_steps_per_s"]), common.fmt(r["speedup"]),
                         common.fmt(r["efficiency"]),
                         " / ".join(f"{ph.get(k, 0) * 1e3:.1f}" for k in ("rates", "boundary", "neighbours",
                                                                           "integrate"))])
        out.append(common.md_table(["threads", "ms/step", "particle-steps/s (all)", "particle-steps/s (fluid)",
                                    "speed-up", "efficiency", "ms/step: rates / wall p / lists / integrate"],
                                   rows))
        out.append("")
    return "\n".join(out)


def plot(cases: list[dict]):
    fig, (a1, a2) = common.new_figure(1, 2, figsize=(10, 4))
    tmax = 1
    for i, c in enumerate(cases):
        th = [r["threads"] for r in c["rows"]]
        if c["scene"] == "control":
            if c["rows"][0]["speedup"] is not None:
                a1.plot(th, [r["speedup"] for r in c["rows"]], "x--", color="0.4", label="control (compute-bound kernel)")
            continue
        tmax = max(tmax, max(th))
        lab = f"{c['case'].upper()} ({c['n_particles']} particles)"
        if c["rows"][0]["speedup"] is not None:
            a1.plot(th, [r["speedup"] for r in c["rows"]], "o-", color=f"C{i}", label=lab)
        a2.plot(th, [r["particle_steps_per_s"] for r in c["rows"]], "o-", color=f"C{i}", label=lab + ", all")
        a2.plot(th, [r["fluid_particle_steps_per_s"] for r in c["rows"]], "s--", color=f"C{i}", mfc="none",
                label=lab + ", fluid only")
    a1.plot([1, tmax], [1, tmax], "k:", label="ideal")
    a1.set_ylim(0, tmax + 0.2)
    a1.set_xlabel("threads")
    a1.set_ylabel("speed-up vs 1 thread")
    a1.set_title("WCSPH dam break, CPU")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3)
    a2.set_xlabel("threads")
    a2.set_ylabel("particle-steps / s")
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3)
    for a in (a1, a2):
        a.set_xticks(range(1, tmax + 1))
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, few steps (smoke run)")
    ap.add_argument("--cases", nargs="+", default=["control", "2d", "3d"], choices=sorted(CASES))
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="default: 1 .. cores")
    ap.add_argument("--dx2d", type=float, default=None)
    ap.add_argument("--dx3d", type=float, default=None)
    ap.add_argument("--steps", type=int, default=None, help="steps per timed block (default 20; quick 5)")
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=None, help="timed blocks per worker (default 3; quick 2)")
    ap.add_argument("--rounds", type=int, default=None, help="sweeps over the thread counts (default 5; quick 1)")
    ap.add_argument("--dt", type=float, default=None, help="fixed dt (default: stable_dt() at t = 0)")
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
    machine = common.machine_info()
    cases = []
    for name in args.cases:
        dx = {"2d": args.dx2d, "3d": args.dx3d}.get(name) or CASES[name][2 if q else 1]
        print(f"{name}: dx = {dx}, threads {threads}", flush=True)
        cases.append(sweep_case(name, dx, threads, args))
    md = "## Thread sweep (CPU)\n\n" + markdown(cases)
    common.write_results("thread_sweep", {"machine": machine, "cases": cases,
                                          "target": "2D speed-up >= 1.85 on 2 cores"}, md, plot(cases), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
