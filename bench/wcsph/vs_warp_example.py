"""Our 3D WCSPH solver against Warp's bundled SPH example (``warp/examples/core/example_sph.py``),
side by side in one run, on the CPU.

What it measures
    Particle-steps per second of
    * ours: the 3D dam break with obstacle (``scenes/dam_break_3d.py``) with dx chosen so that
      fluid + boundary particles come closest to the example's particle count (``--match total``)
      and, as a second comparison, so that the fluid count does (``--match fluid``, a 2.8x larger
      run; both by default), at threads = 1 and at all cores;
    * Warp's example at ~``--n`` particles (default 50 000 -> 48 668, see
      ``bench/wcsph/peers/warp_example_sph.py``), which on the CPU runs every launch on one thread.
    The ratio ours / theirs is reported at equal threads (1) and for ours at all cores, counting our
    particles as fluid + boundary (every particle our kernels touch) and as fluid only. Mean neighbour
    counts of both are reported, because the per-particle work differs a lot (see Physics).

How
    Each side runs in a fresh subprocess (``--worker``), alternating ours(1 thread) / Warp / ours(all
    cores) for ``--rounds`` rounds. Ours: build, ``--warmup`` untimed steps (kernel loading), then
    ``--repeats`` timed blocks of ``--steps`` calls of ``solver.step(dt)`` with dt = ``stable_dt()`` at
    t = 0 (``bench/common.py: time_solver``, which forces a neighbour-list rebuild every 7 steps, the
    rate of the developed flow; Warp's example rebuilds its hash grid every substep). Warp's: ``run_warp_example_sph`` from the peers module,
    called ``--repeats`` times per worker, each call = 1 warm-up frame then ``--frames`` timed frames
    (one frame = 40 substeps; a substep is their step, with one hash-grid build and two neighbour
    passes). The figure per side is the median over all its timed blocks.

Physics (not the same model: the ratio is a cost-per-particle-step comparison, not like for like)
    theirs: Müller et al. 2003 kernels (poly6 density, spiky pressure, viscosity Laplacian), linear EOS
    p = 20 (rho - 1), symplectic Euler with fixed dt, walls by clamping positions to the box and
    reflecting the velocity, no boundary particles, smoothing radius = particle spacing (~3.5
    neighbours within h, ~109 hash-grid candidates visited per query), density and forces in two
    passes. Ours: Wendland C2 with h = 1.3 dx, support 2h (~75 neighbours per fluid particle in 3D),
    Tait EOS (gamma = 7), delta-SPH density diffusion, Monaghan artificial + Morris laminar viscosity,
    Adami 2012 dynamic wall particles (3 layers, a wall-pressure pass over them every step), leapfrog
    (kick-drift-kick) with the CFL step, status checks every step.

Usage
    python bench/wcsph/vs_warp_example.py            # full (both matches, 3 rounds), ~6 min on 2 cores
    python bench/wcsph/vs_warp_example.py --quick    # smoke run (~4 000 particles, total match only)
    python bench/wcsph/vs_warp_example.py --match total --rounds 2
Writes bench/results/vs_warp_example[_quick].{json,md,png}.
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
RUN_ALL = [[]]

SCENE = "dam_break_3d"


# -- workers ----------------------------------------------------------------------------------------
def worker_ours(cfg: dict) -> dict:
    run = common.build_scene(SCENE, cfg["threads"], dx=cfg["dx"], t_end=10.0)
    s = run.solver
    dt = cfg.get("dt") or s.stable_dt()
    res = common.time_solver(s, dt, cfg["steps"], cfg["warmup"], cfg["repeats"])
    from warpfree.neighbours import NeighbourGrid, NeighbourList

    # neighbours within the support among all particles (fluid + wall), now
    x, nf = s.state.position, s.model.nf
    grid = NeighbourGrid(s.launcher, s.model.params.support, s.model.space, x)
    counts = NeighbourList(grid, x, exclude_self=True).counts()
    res.update(threads=s.launcher.threads, dx=cfg["dx"], mean_neighbours_fluid=float(counts[:nf].mean()),
               mean_neighbours_boundary=float(counts[nf:].mean()) if s.model.nb else 0.0, loadavg=common.loadavg())
    return res


def worker_warp(cfg: dict) -> dict:
    from peers.warp_example_sph import run_warp_example_sph

    runs = [run_warp_example_sph(cfg["n"], cfg["frames"], "cpu", cfg["warmup_frames"])
            for _ in range(cfg["repeats"])]
    out = dict(runs[0])
    out["block_s"] = [r["wall_s"] for r in runs]
    out["steps_per_block"] = runs[0]["steps"]
    out["loadavg"] = common.loadavg()
    return out


def worker_count(cfg: dict) -> dict:
    """Particle counts of our scene for a list of dx (build only)."""
    out = []
    for dx in cfg["dxs"]:
        run = common.build_scene(SCENE, 1, dx=dx, t_end=10.0)
        out.append(dict(dx=dx, **common.work_counts(run.solver)))
    return {"counts": out}


# -- driver -------------------------------------------------------------------------------------------
def match_dx(n_target: int, key: str, dx0: float = 0.035) -> dict:
    """dx of our 3D scene whose particle count (``key``: total or fluid) is closest to ``n_target``."""
    field = "n_particles" if key == "total" else "n_fluid"
    power = 2.5 if key == "total" else 3.0  # boundary ~ dx^-2, fluid ~ dx^-3
    dx = dx0
    for _ in range(3):
        c = common.run_worker(__file__, ["--worker", json.dumps({"kind": "count", "dxs": [dx]})])["counts"][0]
        dx = round(dx * (c[field] / n_target) ** (1.0 / power), 5)
    step = dx * 0.0075
    cands = [round(dx + k * step, 5) for k in range(-4, 5)]
    counts = common.run_worker(__file__, ["--worker", json.dumps({"kind": "count", "dxs": cands})])["counts"]
    best = min(counts, key=lambda c: abs(c[field] - n_target))
    return best


def collect(blocks: list[float], steps: int, n: int, nf: int) -> dict:
    med = common.median(blocks)
    return dict(median_block_s=med, blocks_s=blocks, steps_per_block=steps,
                **common.particle_throughput(n, nf, steps, med))


def compare(args, match: str, threads_all: int) -> dict:
    # Warp's count first (it fixes the target)
    from peers.warp_example_sph import lattice_k

    n_warp = 4 * lattice_k(args.n) ** 3
    best = match_dx(n_warp, match, dx0=0.035 if not args.quick else 0.08)
    dx = args.dx or best["dx"]
    print(f"match={match}: Warp example n = {n_warp}; ours dx = {dx} -> {best}", flush=True)
    ours_threads = sorted({1, threads_all})
    blocks = {("ours", t): [] for t in ours_threads}
    blocks[("warp", 1)] = []
    raw: dict = {str(k): [] for k in blocks}
    dt = None
    for r in range(args.rounds):
        order = [("ours", 1), ("warp", 1)] + [("ours", t) for t in ours_threads if t != 1]
        if r % 2:
            order = order[::-1]
        for who, t in order:
            if who == "ours":
                cfg = dict(kind="ours", threads=t, dx=dx, steps=args.steps, warmup=args.warmup,
                           repeats=args.repeats, dt=dt)
            else:
                cfg = dict(kind="warp", n=args.n, frames=args.frames, warmup_frames=1, repeats=args.repeats)
            res = common.run_worker(__file__, ["--worker", json.dumps(cfg)])
            if who == "ours":
                dt = res["dt"]
            blocks[(who, t)].extend(res["block_s"])
            raw[str((who, t))].append(res)
            print(f"  {who} threads={t} round={r}: {common.fmt_rate(res.get('particle_steps_per_s', res.get('work_per_s')))} "
                  f"particle-steps/s (blocks {[round(b, 3) for b in res['block_s']]} s, load {res['loadavg']})",
                  flush=True)
    o1 = raw[str(("ours", 1))][0]
    w = raw[str(("warp", 1))][0]
    rows = []
    warp_row = dict(code="Warp example_sph", threads=1, n_particles=w["n_particles"], n_fluid=w["n_particles"],
                    n_boundary=0, mean_neighbours=w["mean_neighbours_within_h"],
                    candidates_visited=w["mean_candidates_visited"],
                    **collect(blocks[("warp", 1)], w["steps_per_block"], w["n_particles"], w["n_particles"]))
    for t in ours_threads:
        rows.append(dict(code="warpfree WCSPH 3D", threads=t, n_particles=o1["n_particles"], n_fluid=o1["n_fluid"],
                         n_boundary=o1["n_boundary"], mean_neighbours=o1["mean_neighbours_fluid"],
                         mean_neighbours_boundary=o1["mean_neighbours_boundary"],
                         rebuild_every=o1["rebuild_every"],
                         **collect(blocks[("ours", t)], o1["steps"], o1["n_particles"], o1["n_fluid"])))
    rows.append(warp_row)
    wp_rate = warp_row["particle_steps_per_s"]
    for row in rows:
        row["ratio_vs_warp"] = row["particle_steps_per_s"] / wp_rate
        row["ratio_vs_warp_fluid_only"] = row["fluid_particle_steps_per_s"] / wp_rate
    return dict(match=match, dx=dx, dt=dt, warp_n=w["n_particles"], warp_dt=w["dt"], rows=rows,
                warp_physics=w["physics"], raw=raw)


def markdown(comps: list[dict]) -> str:
    out = ["## Ours (3D dam break) vs Warp's example_sph, CPU\n"]
    for c in comps:
        out.append(f"Matched on **{c['match']}** particle count: ours dx = {c['dx']} "
                   f"(dt = {c['dt']:.4g} s), Warp's example n = {c['warp_n']} (h = 0.8, dt = {c['warp_dt']:.3g}, "
                   f"arbitrary units).\n")
        rows = []
        for r in c["rows"]:
            rows.append([r["code"], r["threads"], f"{r['n_fluid']} + {r['n_boundary']} = {r['n_particles']}",
                         f"{r['mean_neighbours']:.1f}", f"{r['s_per_step'] * 1e3:.1f}",
                         common.fmt_rate(r["particle_steps_per_s"]), common.fmt_rate(r["fluid_particle_steps_per_s"]),
                         common.fmt(r["ratio_vs_warp"]), common.fmt(r["ratio_vs_warp_fluid_only"])])
        out.append(common.md_table(["code", "threads", "particles (fluid + boundary)", "mean neighbours (fluid)",
                                    "ms/step", "particle-steps/s (all)", "particle-steps/s (fluid)",
                                    "ratio vs Warp (all)", "ratio vs Warp (fluid)"], rows))
        out.append("")
    out.append("Physics differ (the ratio compares cost per particle-step, not like for like): Warp's example uses "
               "Müller 2003 kernels with radius = spacing (~3.5 neighbours), a linear EOS and box clamping (no wall "
               "particles); ours uses Wendland C2 with support 2.6 dx (~75 neighbours), Tait EOS, δ-SPH, artificial + "
               "laminar viscosity and Adami wall particles with a wall-pressure pass.")
    return "\n".join(out)


def plot(comps: list[dict]):
    fig, ax = common.new_figure(figsize=(7, 4))
    labels, vals, vals_f = [], [], []
    for c in comps:
        for r in c["rows"]:
            labels.append(f"{'ours' if r['code'].startswith('warpfree') else 'Warp ex.'}\n{r['threads']}T"
                          + (f"\n({c['match']})" if len(comps) > 1 else ""))
            vals.append(r["particle_steps_per_s"])
            vals_f.append(r["fluid_particle_steps_per_s"])
    import numpy as np

    x = np.arange(len(labels))
    ax.bar(x - 0.2, vals, 0.4, label="all particles")
    ax.bar(x + 0.2, vals_f, 0.4, label="fluid only")
    ax.set_xticks(x)
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_ylabel("particle-steps / s")
    ax.set_title("3D SPH on the CPU: warpfree vs Warp example_sph")
    ax.legend()
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, default=None, help="Warp example particle target (default 50000; quick 4000)")
    ap.add_argument("--match", nargs="+", default=["total", "fluid"], choices=["total", "fluid"])
    ap.add_argument("--dx", type=float, default=None, help="force our dx (skips matching)")
    ap.add_argument("--steps", type=int, default=None, help="our steps per block (default 10; quick 3)")
    ap.add_argument("--frames", type=int, default=1, help="Warp example frames (x40 substeps) per block")
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=None, help="timed blocks per worker (default 3; quick 1)")
    ap.add_argument("--rounds", type=int, default=None, help="default 3; quick 1")
    ap.add_argument("--threads", type=int, default=None, help="'all cores' thread count (default: cores)")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        cfg = json.loads(args.worker)
        fn = {"ours": worker_ours, "warp": worker_warp, "count": worker_count}[cfg["kind"]]
        common.emit_worker_result(fn(cfg))
        return 0
    q = args.quick
    args.n = args.n or (4000 if q else 50_000)
    if q and "--match" not in (argv if argv is not None else sys.argv):
        args.match = ["total"]
    args.steps = args.steps or (3 if q else 10)
    args.repeats = args.repeats or (1 if q else 3)
    args.rounds = args.rounds or (1 if q else 3)
    machine = common.machine_info()
    comps = [compare(args, m, args.threads or common.cpu_count()) for m in args.match]
    common.write_results("vs_warp_example", {"machine": machine, "comparisons": comps}, markdown(comps),
                         plot(comps), quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
