"""Compile-time terms against run-time switches: the WCSPH rates kernel of this tree against the baseline's.

What it measures
    The hottest kernel of a step, dρ/dt and dv/dt of every fluid particle (``rates`` in
    ``kernels/wcsph.py``), against the baseline's ``fluid_rates`` (``kernels/sph_fluid.py`` of an earlier
    commit, loaded by path into this process), on the same particles and the same neighbour tables, in one
    process, launches interleaved (new, baseline, new, baseline, ...) so that the machine's drift affects
    both alike. The baseline kernel takes 31 scalar parameters and switches its physics (smoothing kernel,
    viscosities, δ-SPH, wall model) with run-time integers; the new one takes two ``@wp.struct`` bundles and
    is compiled per set of terms, so a term that is off is not in its code. Two physics:

    * ``scene``: the 2D dam break's terms (Wendland C2, laminar + artificial viscosity, δ-SPH, dynamic walls
      with the Lennard-Jones safety net): the bundles and the factory should cost nothing;
    * ``plain``: every optional term off (μ = α = δ = 0, no safety net): what compiling them out saves.

    It also checks that both kernels give the same rates (largest difference relative to the largest
    rate, float32 rounding expected), so the comparison is between equal computations.

How
    ``scenes/dam_break_2d.py`` at dx = 0.006 (55 278 fluid + 8 030 wall particles), built and stepped a few
    steps (tables filled, wall pressures set); then ``--repeats`` rounds of ``--launches`` launches of each
    kernel through the same launcher at 1 and 2 threads. Figure: the median time per launch over rounds.

Usage
    python bench/wcsph/kernel_variants.py --baseline /tmp/baseline     # ~3 min on 2 cores
    python bench/wcsph/kernel_variants.py --baseline /tmp/baseline --quick
Writes bench/results/kernel_variants[_quick].{json,md}.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "needs --baseline DIR, a checkout of a commit with kernels/sph_fluid.py (see Usage)"

PHYSICS = {"scene": {}, "plain": {"alpha": 0.0, "delta": 0.0, "mu": 0.0, "wall_safety": 0.0}}


def load_baseline_kernels(root: str):
    """The baseline's ``kernels/sph_fluid.py`` as a module of its own (its smoothing imports resolve to ours,
    whose functions it uses are unchanged)."""
    path = Path(root) / "kernels" / "sph_fluid.py"
    spec = importlib.util.spec_from_file_location("baseline_sph_fluid", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def baseline_inputs(s):
    """The baseline kernel's arguments from our solver's state (combined-index arrays where it wants them)."""
    import warp as wp

    m, a, P = s.model, s.arrays, s.model.params
    nf, nb, n, dev = m.nf, m.nb, m.n, s.launcher.device
    v_eval = wp.array(np.vstack([a.velocity_eval.numpy(), np.zeros((nb, 3), np.float32)]), dtype=wp.vec3, device=dev)
    rho_eval = wp.array(np.concatenate([a.density_eval.numpy(), s.state.density.numpy()[nf:]]), dtype=float, device=dev)
    ghost = wp.array(np.vstack([np.zeros((nf, 3), np.float32), a.ghost_velocity.numpy()[:nb]]), dtype=wp.vec3, device=dev)
    wall_v = wp.zeros(n, dtype=wp.vec3, device=dev)
    drho, acc = wp.zeros(n, dtype=float, device=dev), wp.zeros(n, dtype=wp.vec3, device=dev)
    ff, fw = s.fluid_fluid, s.fluid_wall
    args = [ff.rows.count, ff.rows.index, ff.capacity, fw.rows.count, fw.rows.index, fw.capacity, nf, nb,
            s.state.position, v_eval, rho_eval, s.state.pressure, m.mass, wall_v, ghost, m.kernel_id, P.dim, P.h,
            P.support, P.rho0, P.c0, P.mu, P.alpha, P.delta, m.constants.gravity, 0, int(P.no_slip), float(P.lj_d),
            float(P.lj_r0), drho, acc]
    return args, drho, acc


def measure(physics: str, threads: int, args, old) -> dict:
    import warp as wp

    run = common.build_scene("dam_break_2d", threads, dx=args.dx, t_end=10.0, **PHYSICS[physics])
    s, L = run.solver, run.solver.launcher
    for _ in range(3):
        s.step(s.stable_dt())
    old_args, drho_old, acc_old = baseline_inputs(s)
    a, c, nf = s.arrays, s.model.constants, s.model.nf
    rows = wp.array(np.arange(nf, dtype=np.int32), dtype=wp.int32, device=L.device)
    new_launch = lambda: L.launch(s.kernels.rates, nf, [c, a, s.fluid_fluid.rows, s.fluid_wall.rows, rows])  # noqa: E731
    old_launch = lambda: L.launch(old.fluid_rates, nf, old_args)  # noqa: E731
    new_launch()
    old_launch()
    acc_new, drho_new = a.acceleration.numpy(), a.density_rate.numpy()
    agree = {"acceleration": float(np.abs(acc_new - acc_old.numpy()[:nf]).max() / np.abs(acc_new).max()),
             "density_rate": float(np.abs(drho_new - drho_old.numpy()[:nf]).max() / np.abs(drho_new).max())}
    times = {"new": [], "baseline": []}
    for r in range(args.repeats):
        for who in (("new", "baseline") if r % 2 == 0 else ("baseline", "new")):
            fn = new_launch if who == "new" else old_launch
            t0 = time.perf_counter()
            for _ in range(args.launches):
                fn()
            times[who].append((time.perf_counter() - t0) / args.launches)
    wp.synchronize()
    new_ms, old_ms = (statistics.median(times[k]) * 1e3 for k in ("new", "baseline"))
    row = dict(physics=physics, threads=threads, n_fluid=nf, n_particles=s.model.n, new_ms=new_ms, baseline_ms=old_ms,
               saving=1.0 - new_ms / old_ms, speedup=old_ms / new_ms, times_s=times, relative_difference=agree,
               terms={k: v for k, v in vars(s.model.terms).items()})
    print(f"  {physics} threads={threads}: new {new_ms:.2f} ms, baseline {old_ms:.2f} ms per launch "
          f"(x{old_ms / new_ms:.2f}); results agree to {max(agree.values()):.1e}", flush=True)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, help="a checkout of a commit with kernels/sph_fluid.py")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="default: 1 and all cores")
    ap.add_argument("--repeats", type=int, default=None, help="rounds (default 10; quick 3)")
    ap.add_argument("--launches", type=int, default=None, help="launches per round (default 10; quick 3)")
    args = ap.parse_args(argv)
    q = args.quick
    args.dx = 0.02 if q else 0.006
    args.repeats = args.repeats or (3 if q else 10)
    args.launches = args.launches or (3 if q else 10)
    threads = sorted(set(args.threads or {1, common.cpu_count()}))
    old = load_baseline_kernels(args.baseline)
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=args.baseline, capture_output=True,
                         text=True).stdout.strip()
    rows = [measure(ph, t, args, old) for ph in PHYSICS for t in threads]
    table = [[r["physics"], r["threads"], f"{r['new_ms']:.2f}", f"{r['baseline_ms']:.2f}", f"{r['speedup']:.2f}",
              f"{100 * r['saving']:+.0f}%", f"{max(r['relative_difference'].values()):.1e}"] for r in rows]
    md = (f"## Rates kernel: compile-time terms (this tree) against run-time switches (`{rev}`), "
          f"2D dam break dx = {args.dx} ({rows[0]['n_fluid']} fluid particles), CPU\n\n"
          + common.md_table(["physics", "threads", "new ms/launch", "baseline ms/launch", "baseline / new",
                             "time saved", "max relative difference of the rates"], table)
          + f"\n\nMedian of {args.repeats} interleaved rounds of {args.launches} launches each. 'scene': the dam "
            "break's terms (laminar + artificial viscosity, δ-SPH, dynamic walls with the safety net); 'plain': "
            "all of them off, which the baseline skips with run-time branches and this tree does not compile.")
    common.write_results("kernel_variants", {"machine": common.machine_info(), "baseline": {"path": args.baseline,
                                                                                          "git": rev}, "rows": rows},
                         md, quick=q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
