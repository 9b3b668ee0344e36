"""Strong and weak scaling over MPI ranks, measured at 1 and 2 ranks against controls in the same sweep, and a model
of the distributed WCSPH step to 1 024 ranks built from measured parts.

What it measures (each run a ``warpfree run`` from the command line, one CPU thread per rank, frames and VTU off;
the figure is the run's own step time, ``phases_s.step`` of ``summary.json``, or its solve for a static scene; the
configurations run in turn, ``--repeats`` times, and the medians are kept)

- strong scaling, per family: one problem on 1 rank and on 2 ranks: speed-up t(1) / t(2), beside the engine's thread
  control, the same problem on 1 rank with 2 threads (what the second core gives this machine at that moment);
- weak scaling, per family: n work items on 1 rank against 2n on 2 ranks, with the control two independent 1-rank
  runs of n at once (the same two cores busy, no communication): efficiency = the control's work rate per process
  over the 2-rank run's per rank (1: distributing costs nothing beyond what two busy cores cost anyway).

The model (WCSPH, :func:`model_step`): a rank's step is the compute of what it holds, t_p (n + g) (t_p measured on 1
rank; a rank's kernels run over its ghosts too, whose results the exchange then overwrites), plus the exchange of its
g ghosts, each packing and unpacking their bytes
(c_pack per byte, measured on one rank), sending them (α per message and β per byte, measured by a ping-pong between
two ranks here, or given for a cluster's network) to its neighbours, and one reduction (α log2 P). The ghosts of an
interior cubic (square in 2D) box of n particles are the particles within the ghost depth d of it:
(n^(1/D) + 2 d/dx)^D - n. The prediction for the measured 2D dam break at 2 ranks is compared with the measurement;
the 3D dam break is then modelled at 10^6 to 10^9 particles on 1 to 1 024 ranks.

Usage
    python bench/core/scaling.py [--repeats 3] [--families wcsph,efg,spem,pic] [--size large|small]
(families: those whose scene declares ``BENCHMARK["scaling"]``, all by default)
Writes bench/results/scaling.{json,md,png}. Needs MPI (pip install 'warpfree[mpi]').
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]

#: sweep size -> family -> (scene, the settings of n work items, those of 2n): what the scene of each family declares
#: in ``BENCHMARK["scaling"]`` (``common.benchmarks``; a family whose solver does not distribute declares none), for
#: the sizes the sweep measures ("large", the default: 2n about 20 000 to 130 000 work items; "small": the smallest
#: sizes at which each family's step is still mostly compute, a minute's sweep)
SIZES = {size: {family: (b["scene"], *b["scaling"][size]) for family, b in common.benchmarks().items()
                if "scaling" in b} for size in ("large", "small")}
CASES = SIZES["large"]

PINGPONG = r'''
import sys, time, json
import numpy as np
from mpi4py import MPI
c = MPI.COMM_WORLD
out = {}
for size in (8, 1024, 65536, 1 << 20, 8 << 20):
    buf = np.zeros(size, np.uint8)
    reps = 200 if size < 65536 else 20
    c.Barrier()
    t0 = time.perf_counter()
    for _ in range(reps):
        if c.rank == 0:
            c.Send(buf, 1); c.Recv(buf, 1)
        else:
            c.Recv(buf, 0); c.Send(buf, 0)
    out[size] = (time.perf_counter() - t0) / (2 * reps)
c.Barrier()
t0 = time.perf_counter()
mine, every = np.zeros(4), np.zeros(4)
for _ in range(500):
    c.Allreduce(mine, every, op=MPI.MAX)
out["allreduce"] = (time.perf_counter() - t0) / 500
if c.rank == 0:
    print(json.dumps(out))
'''


def run_scene(scene: str, settings: dict, ranks: int, threads: int = 1, timeout: float = 1800) -> dict:
    """One run from the command line (``ranks`` > 1: under mpiexec); its summary's step (or solve) seconds, work
    items and, distributed, its ghost counts and exchange seconds."""
    from warpfree.parallel.launch import mpiexec_environment, run_ranks
    from warpfree.scene_loader import value_text

    with tempfile.TemporaryDirectory() as out:
        args = ["-m", "warpfree", "run", scene, "--out", f"{out}/run", "--no-progress", "--no-frames",
                "--threads", str(threads), "--set", "vtk=false"]
        for k, v in settings.items():
            args += ["--set", f"{k}={value_text(v)}"]
        if ranks > 1:
            done = run_ranks(ranks, args, timeout=timeout)
        else:
            done = subprocess.run([common.PYTHON, *args], capture_output=True, text=True, timeout=timeout,
                                  env=mpiexec_environment())
        if done.returncode != 0:
            raise RuntimeError(f"{scene} {settings} on {ranks} rank(s) failed:\n{done.stderr[-3000:]}")
        summary = json.loads(Path(out, "run", "summary.json").read_text())
    return _figures(summary)


def _figures(summary: dict) -> dict:
    phases = summary["phases_s"]
    static = "step" not in phases
    seconds = sum(phases.get(k, 0.0) for k in ("shape functions", "assembly", "boundary", "factorisation", "solve")) \
        if static else phases["step"]
    steps = 1 if static else summary["steps_this_run"]
    fig = {"seconds": seconds, "steps": steps, "work_items": summary["throughput"]["work_items"],
           "unit": summary["throughput"]["unit"]}
    ranks = summary.get("ranks")
    if ranks:
        fig["rank_seconds"] = [(sum(p.get(k, 0.0) for k in ("shape functions", "assembly", "boundary",
                                                            "factorisation", "solve")) if static else p["step"])
                               for p in ranks["phases_s"]]
        fig["exchange_seconds"] = [p.get("exchange", 0.0) for p in ranks["phases_s"]]
        spread = summary["model"].get("distributed", {})
        fig["ghost_fraction"] = spread.get("ghost_fraction")
        for key in ("fluid_owned", "fluid_ghosts", "walls_owned", "walls_ghosts"):
            if key in spread:
                fig[key] = spread[key]
    return fig


def rate(fig: dict) -> float:
    """Work items per second (item-steps for a time-dependent scene)."""
    return fig["work_items"] * fig["steps"] / fig["seconds"]


def concurrent_pair(scene: str, settings: dict) -> list[dict]:
    """The weak control: two 1-rank runs of the same size at once (both cores busy, no communication)."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:
        return list(pool.map(lambda _: run_scene(scene, settings, 1), range(2)))


def measure_family(family: str, repeats: int, size: str = "large") -> dict:
    scene, n1, n2 = SIZES[size][family]
    runs = {"strong_1": [], "strong_2": [], "threads_2": [], "weak_1x2": [], "weak_2": []}
    for r in range(repeats):  # in turn: a drift of the machine's speed touches every configuration alike
        runs["strong_1"].append(run_scene(scene, n2, 1))
        runs["strong_2"].append(run_scene(scene, n2, 2))
        runs["threads_2"].append(run_scene(scene, n2, 1, threads=2))
        runs["weak_1x2"].append(concurrent_pair(scene, n1))
        runs["weak_2"].append(runs["strong_2"][-1])  # the 2n problem on 2 ranks is also the weak case's
        print(f"  {family} repeat {r + 1}/{repeats}", flush=True)
    med = {k: statistics.median(rate(f) if not isinstance(f, list) else statistics.mean(rate(x) for x in f)
                                for f in v) for k, v in runs.items()}
    return {"scene": scene, "n": n1, "2n": n2, "runs": runs, "rates": med,
            "strong_speedup": med["strong_2"] / med["strong_1"],
            "thread_speedup": med["threads_2"] / med["strong_1"],
            "weak_efficiency": (med["weak_2"] / 2.0) / med["weak_1x2"],
            "weak_efficiency_vs_one_alone": (med["weak_2"] / 2.0) / med["strong_1"] * 2.0}


def pingpong() -> dict:
    from warpfree.parallel.launch import run_ranks

    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(PINGPONG)
    done = run_ranks(2, [f.name], timeout=300)
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-2000:])
    times = json.loads(done.stdout.strip().splitlines()[-1])
    sizes = np.array([int(k) for k in times if k != "allreduce"], dtype=float)
    t = np.array([times[str(int(s))] for s in sizes])
    beta_inv, alpha = np.polyfit(sizes, t, 1)
    return {"alpha_s": float(max(alpha, t[0])), "seconds_per_byte": float(beta_inv),
            "allreduce_s": float(times["allreduce"]), "one_way_s": {str(int(s)): float(v) for s, v in zip(sizes, t)}}


def pack_cost() -> float:
    """Seconds per byte of packing the ghosts' rows and unpacking them (``Partition.refresh``'s host work), over a
    6-field fluid row of 60 bytes, 20 000 ghosts of 200 000 rows."""
    rng = np.random.default_rng(0)
    n, g = 200_000, 20_000
    fields = [np.zeros((n, 3), np.float32), np.zeros((n, 3), np.float32), np.zeros(n, np.float32),
              np.zeros((n, 3), np.float32), np.zeros(n, np.float32), np.zeros((n, 4), np.float32)]
    send, recv = rng.choice(n, g, replace=False), rng.choice(n, g, replace=False)
    from warpfree.parallel.halo import _rows

    t0 = time.perf_counter()
    reps = 20
    for _ in range(reps):
        table = np.hstack([_rows(f[send]) for f in fields])
        at = 0
        for f in fields:
            w = _rows(f[:0]).shape[1]
            f[recv] = np.ascontiguousarray(table[:, at:at + w]).view(f.dtype).reshape((-1,) + f.shape[1:])
            at += w
    return (time.perf_counter() - t0) / reps / (g * 60)


#: the fluid arrays a ghost takes after each kick, bytes (spread.STEP_FIELDS: position, velocity, density,
#: acceleration, density_rate, report) and the walls' three per wall-pressure pass
GHOST_BYTES = 12 + 12 + 4 + 12 + 4 + 16
#: the ghost depth in particle spacings: support (2 h) plus skin (0.15 of it), h = 1.6 dx (2D) or 1.3 dx (3D)
DEPTH_SPACINGS = {2: 2 * 1.6 * 1.15, 3: 2 * 1.3 * 1.15}


def ghosts(n: float, dim: int) -> float:
    """Ghosts of an interior box of n particles: those within the ghost depth of it."""
    d = DEPTH_SPACINGS[dim]
    side = n ** (1.0 / dim)
    return (side + 2 * d) ** dim - n


def model_step(n: float, ranks: int, dim: int, t_particle: float, net: dict, pack_per_byte: float,
               neighbours: int | None = None) -> float:
    """A rank's step (s) with n particles of its own among ``ranks`` (module docstring)."""
    if ranks == 1:
        return n * t_particle
    g = ghosts(n, dim) if neighbours is None else ghosts(n, dim) * neighbours / (2 * dim)
    faces = 2 * dim if neighbours is None else neighbours
    per_byte = net["seconds_per_byte"] + 2.0 * pack_per_byte  # sent, packed and unpacked
    exchange = 2 * faces * net["alpha_s"] + g * GHOST_BYTES * per_byte
    return (n + g) * t_particle + exchange + net["allreduce_s"] * math.log2(ranks)


def model(measured_wcsph: dict | None, net: dict, pack_per_byte: float) -> dict:
    """The 2-rank prediction for the measured dam break, and the 3D dam break's efficiency to 1 024 ranks (for the
    measured on-node network and for a cluster's, α = 2 µs, 10 GB/s)."""
    out = {"pack_seconds_per_byte": pack_per_byte, "network": net}
    if measured_wcsph:
        one = measured_wcsph["runs"]["strong_1"]
        two = measured_wcsph["runs"]["strong_2"]
        t_particle = statistics.median(f["seconds"] / (f["steps"] * f["work_items"]) for f in one)
        owned = np.mean([np.mean(np.array(f["fluid_owned"]) + np.array(f["walls_owned"])) for f in two])
        ghost = np.mean([np.mean(np.array(f["fluid_ghosts"]) + np.array(f["walls_ghosts"])) for f in two])
        measured = statistics.median(max(f["rank_seconds"]) / f["steps"] for f in two)
        # a slab of 2: each rank has one neighbour; its ghosts as measured
        exchange = 2 * 2 * net["alpha_s"] + ghost * GHOST_BYTES * (net["seconds_per_byte"] + 2 * pack_per_byte)
        predicted = (owned + ghost) * t_particle + exchange + net["allreduce_s"]
        out["two_ranks"] = {"t_particle_s": t_particle, "owned_per_rank": float(owned),
                            "ghosts_per_rank": float(ghost), "predicted_step_s": predicted,
                            "measured_step_s": measured, "predicted_over_measured": predicted / measured}
        t3 = t_particle
    else:
        t3 = 2e-6
    cluster = {"alpha_s": 2e-6, "seconds_per_byte": 1e-10, "allreduce_s": 5e-6}
    curves = {}
    ranks = [2 ** k for k in range(11)]
    for total in (1e6, 1e7, 1e8, 1e9):
        for name, n_net in (("on_node", net), ("cluster", cluster)):
            t1 = model_step(total, 1, 3, t3, n_net, pack_per_byte)
            eff = [t1 / (p * model_step(total / p, p, 3, t3, n_net, pack_per_byte)) for p in ranks]
            curves[f"{int(total):.0e}_{name}"] = eff
    out["dam_break_3d"] = {"ranks": ranks, "strong_efficiency": curves,
                           "ghost_fraction_at": {f"{int(t):.0e}": {str(p): ghosts(t / p, 3) / (t / p) for p in
                                                                    (64, 1024)} for t in (1e6, 1e9)}}
    return out


def markdown(result: dict) -> str:
    lines = ["# Scaling over MPI ranks (measured at 1 and 2 ranks, modelled beyond)", "",
             f"{result['machine']['cpu']}, {result['machine']['cores']} cores; one thread per rank; "
             f"{result['repeats']} runs of each configuration in turn, medians.", "",
             "## Measured", ""]
    rows = []
    for fam, r in result["families"].items():
        when = r.get("measured", {})
        rows.append([fam, r["scene"], common.fmt(r["thread_speedup"]), common.fmt(r["strong_speedup"]),
                     common.fmt(r["weak_efficiency"]), common.fmt(r["weak_efficiency_vs_one_alone"]),
                     f"{str(when.get('date', ''))[:16]} ({when.get('git') or '?'})"])
    lines += [common.md_table(["family", "scene", "1 rank, 2 threads (control)", "2 ranks: speed-up",
                               "weak efficiency vs 2 concurrent 1-rank runs (control)", "weak vs 1 rank alone",
                               "measured (commit)"], rows), "",
              "Each family's row is measured side by side in one sweep; a run with `--families` re-measures those "
              "and keeps the other rows from the last results.", ""]
    m = result["model"]
    if "two_ranks" in m:
        t = m["two_ranks"]
        lines += ["## The model against the 2-rank measurement (2D dam break)", "",
                  f"t_p = {t['t_particle_s']:.3g} s per particle-step (1 rank); per rank {t['owned_per_rank']:.0f} "
                  f"own and {t['ghosts_per_rank']:.0f} ghost particles; network α = {m['network']['alpha_s']:.2g} s, "
                  f"{1 / m['network']['seconds_per_byte']:.3g} B/s, reduction {m['network']['allreduce_s']:.2g} s; "
                  f"packing {m['pack_seconds_per_byte']:.3g} s/B. Predicted step {t['predicted_step_s']:.4g} s, "
                  f"measured {t['measured_step_s']:.4g} s (x{t['predicted_over_measured']:.2f}).", ""]
    d = m["dam_break_3d"]
    rows = []
    for name, eff in d["strong_efficiency"].items():
        rows.append([name] + [common.fmt(eff[d["ranks"].index(p)]) for p in (2, 8, 64, 1024)])
    lines += ["## The 3D dam break, modelled: strong-scaling efficiency", "",
              common.md_table(["particles, network", "2", "8", "64", "1 024"], rows), "",
              "Ghost fraction per rank (ghosts / own): " + "; ".join(
                  f"{n} particles: " + ", ".join(f"{v:.3g} at {p} ranks" for p, v in g.items())
                  for n, g in d["ghost_fraction_at"].items()), ""]
    return "\n".join(lines)


def earlier_families(size: str, exclude) -> dict:
    """The families a run with ``--families`` leaves out, as the last results measured them (same sizes), each with
    when and at which commit: one table keeps every family, a re-measured one replacing its row."""
    path = common.RESULTS / "scaling.json"
    if not path.is_file():
        return {}
    earlier = json.loads(path.read_text())
    if earlier.get("size") != size:
        return {}
    when = {"date": earlier["machine"]["date"], "git": earlier["machine"].get("git")}
    return {fam: {"measured": when, **r} for fam, r in earlier.get("families", {}).items() if fam not in exclude}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--families", default=",".join(CASES))
    p.add_argument("--size", choices=sorted(SIZES), default="large", help="the problem sizes (SIZES)")
    p.add_argument("--model-only", action="store_true", help="the network, packing and model parts only")
    args = p.parse_args(argv)
    net = pingpong()
    pack = pack_cost()
    families = {}
    if not args.model_only:
        for fam in args.families.split(","):
            print(f"{fam}:", flush=True)
            families[fam] = measure_family(fam, args.repeats, args.size)
    machine = common.machine_info()
    for r in families.values():
        r["measured"] = {"date": machine["date"], "git": machine.get("git")}
    families = {**earlier_families(args.size, exclude=families), **families}
    result = {"machine": machine, "repeats": args.repeats, "size": args.size,
              "families": families, "model": model(families.get("wcsph"), net, pack)}
    fig, ax = common.new_figure(figsize=(7, 4.5))
    d = result["model"]["dam_break_3d"]
    for name, eff in d["strong_efficiency"].items():
        ax.plot(d["ranks"], eff, marker="o", ms=3, ls="-" if "cluster" in name else "--", label=name)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("ranks")
    ax.set_ylabel("strong-scaling efficiency (modelled)")
    ax.set_ylim(0, 1.05)
    ax.set_title("3D dam break, WCSPH: modelled from measured parts")
    ax.legend(fontsize=7)
    common.write_results("scaling", result, markdown(result), fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
