"""Peer benchmark: PySPH 1.0b2's ``dam_break_2d`` example, run in its own venv.

How PySPH is invoked
--------------------
PySPH lives in a separate virtualenv (default ``/work/peers-venv``, made with
``python3 -m venv`` + ``pip install --no-build-isolation pysph==1.0b2`` after
``numpy Cython mako cyarray compyle wheel setuptools``), never in warpfree's venv.  We run, in a
subprocess with ``OMP_NUM_THREADS=<threads>`` (and ``OMP_WAIT_POLICY=passive``
when threads > 1, see ``omp_environment``), a tiny driver (``_DRIVER``
below) that does exactly what ``python -m pysph.examples.dam_break_2d ARGS``
does -- ``DamBreak2D().run(ARGS)``, i.e. ``setup()`` then ``solve()`` -- but:

* skips the example's ``post_process`` (a matplotlib plot; matplotlib is not
  in the peer venv and the plot is irrelevant here), and instead reads the
  dumps with PySPH's own loader and writes ``peer_summary.json``;
* by default fixes a resolution bug of the example (``consistent_resolution``):
  the example sets the particle arrays' ``h`` and ``m`` from *module* constants
  computed for the default ``dx = 0.03`` (``h = 1.3*0.03``, ``m = 0.03**2*1000``),
  so ``--dx 0.02`` keeps ``h = 0.039 = 1.95 dx`` and a 2.25x too large mass
  (it still *prints* ``Using h = 0.026``).  ``update_h`` (Ferrari) then keeps
  ``h = 1.3 sqrt(m/rho) = 0.039``.  The fix sets the module's ``h = hdx*dx``
  and ``m = dx**2*rho0`` before the app is built; ``consistent_resolution=False``
  runs the example verbatim.  At ``dx = 0.03`` both are identical.  Verbatim
  ``--dx 0.02`` is not a usable benchmark: measured here, its adaptive dt
  collapsed to ~1e-9..1e-10 s at t = 0.066 (5 000 steps, still stuck).

ARGS = ``--dx D --tf T -d OUT --pfreq P`` plus ``--openmp`` when threads > 1
(``--openmp`` comes from compyle's ArgumentParser; without it PySPH compiles
the serial variant).  The example dumps every ``pfreq`` steps, at its own
``output_at_times = [0.4, 0.6, 0.8, 1.0]`` (it shortens dt to land on them,
as the example always does), and at t=0 and t=tf.  We pick ``pfreq`` so that
about ``n_dumps`` dumps are written; each dump of a few thousand particles
costs ~5 ms and is inside the timed run (reported separately, see below).

Geometry and physics (read from pysph/examples/dam_break_2d.py, 1.0b2)
---------------------------------------------------------------------
* Fluid column W x H = 1 x 2 (``get_2d_block``: ``int(1/dx)+1`` by
  ``int(2/dx)+1`` points spanning the block exactly, so the spacing is
  ``1/int(1/dx)``, slightly above dx), shifted by +dx in x and y.
* Tank 4 x 4, open top, inner wall rows at x = 0, x ~ 4, y = 0; 4 layers of
  boundary particles on a dx lattice outside (``get_2d_tank``, non-staggered).
* Default scheme ``wcsph`` (WCSPHScheme): Tait EOS, rho0 = 1000, gamma = 7,
  c0 = 10 sqrt(2 g H) = 62.64 m/s, g = 9.81, artificial viscosity alpha = 0.1,
  beta = 0, Hughes-Graham correction on the walls, continuity equation for
  density, ``update_h`` (Ferrari), WendlandQuintic kernel (support 2h),
  h = hdx * dx with hdx = 1.3 (see the resolution note above).
* Integrator: ``PECIntegrator`` (predict - evaluate - correct) with
  ``WCSPHStep`` -- ONE acceleration evaluation (one NNPS update + one pass of
  the equation groups) per step, plus one initial evaluation before step 1.
  Not EPEC (which would do 2).  We read the actual count of evaluations from
  PySPH's ``profile_info.csv`` rather than assuming it.
* Adaptive dt: ``cfl (0.3) * min(h / (c0 + |h v.r/r^2|), sqrt(h/|a|))`` -- so
  roughly 0.3*1.3*dx/c0 -- ramped up over the first 50 steps (``n_damp``).

What counts as a step and as wall time
--------------------------------------
``steps`` = ``solver.count``: completed integrator steps (time levels), each
with one force evaluation (PEC).  ``wall_s`` = PySPH's own "Run took" (the
``cpu_time`` in ``dam_break_2d.info``; it is ``time.time()`` around
``solver.solve()``, so wall-clock): it EXCLUDES setup and code generation /
compilation, and INCLUDES the initial acceleration and the npz dumps
(``dump_s``, subtracted in ``wall_s_excl_output``).  ``setup_s`` is the
driver's timing of ``app.setup()``, which includes the Cython/C++ build when
the cache (``$HOME/.pysph/source/...``) misses; ``compiled`` says whether it
did.  ``cold_cache=True`` points ``HOME`` at a fresh folder to time a cold
build without touching the real cache.

CLI: ``python bench/wcsph/peers/pysph_dam_break.py --dx 0.03 --tf 0.5 --threads 1``
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

DEFAULT_PYTHON = "/work/peers-venv/bin/python"
FNAME = "dam_break_2d"

# Constants of the example, used only to estimate the step count for --pfreq.
HDX = 1.3
C0 = 10.0 * math.sqrt(2.0 * 9.81 * 2.0)
CFL = 0.3
N_DAMP = 50
EXAMPLE_DX = 0.03

# Fallback when profile_info.csv is missing: evaluations per step by integrator.
EVALS_PER_STEP = {
    "EulerIntegrator": 1,
    "PECIntegrator": 1,
    "LeapFrogIntegrator": 1,
    "EPECIntegrator": 2,
    "TVDRK3Integrator": 3,
    "PEFRLIntegrator": 4,
}

_DRIVER = r"""
import json, sys, time
cfg = json.loads(sys.argv[1])
import pysph.examples.dam_break_2d as db
if cfg["consistent_resolution"]:
    db.h = db.hdx * cfg["dx"]
    db.m = cfg["dx"] ** 2 * db.ro
app = db.DamBreak2D(fname=cfg["fname"])
t0 = time.perf_counter()
app.setup(cfg["argv"])
t1 = time.perf_counter()
app.solve()
t2 = time.perf_counter()

from compyle.config import get_config
from pysph.solver.utils import get_files, load
front = []
for f in get_files(app.output_dir, app.fname):
    d = load(f)
    sd = d["solver_data"]
    front.append([float(sd["t"]), float(d["arrays"]["fluid"].get("x").max()),
                  int(sd["count"])])
fluid = [p for p in app.particles if p.name == "fluid"][0]
summary = dict(
    counts={p.name: int(p.get_number_of_particles()) for p in app.particles},
    steps=int(app.solver.count), t_final=float(app.solver.t),
    integrator=type(app.solver.integrator).__name__,
    kernel=type(app.solver.kernel).__name__, nnps=type(app.nnps).__name__,
    use_openmp=bool(get_config().use_openmp),
    h_fluid=float(fluid.get("h")[0]), m_fluid=float(fluid.get("m")[0]),
    setup_s=t1 - t0, solve_s=t2 - t1, front=front,
)
with open(cfg["summary"], "w") as fp:
    json.dump(summary, fp)
"""


def estimate_steps(dx: float, tf: float, consistent_resolution: bool = True) -> int:
    """Rough number of PEC steps the example takes (dt ~ 0.3 h / c0)."""
    h = HDX * (dx if consistent_resolution else EXAMPLE_DX)
    return int(tf / (CFL * h / C0)) + N_DAMP // 2


def build_argv(dx: float, tf: float, threads: int, out_dir: str, pfreq: int) -> list[str]:
    """Command-line arguments handed to ``DamBreak2D.run``."""
    argv = ["--dx", repr(dx), "--tf", repr(tf), "-d", str(out_dir), "--pfreq", str(pfreq)]
    if threads > 1:
        argv.append("--openmp")
    return argv


def omp_environment(threads: int, extra_env: dict | None = None) -> dict[str, str]:
    """OpenMP variables for the PySPH subprocess (plus ``extra_env``).

    With threads > 1 ``OMP_WAIT_POLICY`` defaults to ``passive``: libgomp's
    default spin-waiting makes a 2-thread run 5-15x SLOWER than the serial
    one as soon as another process holds one of this host's 2 cores, while
    on an idle host passive and active measured the same (4.2 s vs 4.15 s).
    """
    env = {"OMP_NUM_THREADS": str(threads)}
    if threads > 1:
        env["OMP_WAIT_POLICY"] = os.environ.get("OMP_WAIT_POLICY", "passive")
    env.update(extra_env or {})
    return env


def clear_previous_output(out_dir: Path) -> None:
    """Remove a previous run's dumps and summaries so they are not re-read."""
    patterns = [f"{FNAME}_*.npz", f"{FNAME}_*.hdf5", f"{FNAME}.info", f"{FNAME}.log",
                "profile_info.csv", "peer_summary.json", "driver_stdout.txt"]
    for pattern in patterns:
        for path in out_dir.glob(pattern):
            path.unlink()


def _cache_listing(home: str) -> set[str]:
    """Compiled extension modules in PySPH's code cache under ``home``."""
    root = Path(home) / ".pysph" / "source"
    return {str(p) for p in root.rglob("*.so")} if root.exists() else set()


def _children_cpu_s() -> float:
    """User + system CPU seconds of this process's reaped children so far."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _run_driver(python: str, cfg: dict, env: dict, out_dir: Path,
                timeout: float | None) -> float:
    """Run the driver subprocess; return its total wall time (s)."""
    t0 = time.perf_counter()
    with open(out_dir / "driver_stdout.txt", "w") as log:
        proc = subprocess.run([python, "-c", _DRIVER, json.dumps(cfg)], env=env,
                              stdout=log, stderr=subprocess.STDOUT, timeout=timeout)
    total = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = (out_dir / "driver_stdout.txt").read_text()[-3000:]
        raise RuntimeError(f"PySPH driver failed (rc={proc.returncode}):\n{tail}")
    return total


def read_profile(out_dir: Path) -> dict[str, tuple[int, float]]:
    """PySPH's ``profile_info.csv``: function -> (calls, seconds), rank 0."""
    path = out_dir / "profile_info.csv"
    if not path.exists():
        return {}
    with open(path) as fp:
        return {r["function"]: (int(r["calls"]), float(r["time"]))
                for r in csv.DictReader(fp) if r["rank"] == "0"}


def read_run_time(out_dir: Path) -> float:
    """PySPH's own "Run took" seconds (``cpu_time`` in the .info file)."""
    info = json.loads((out_dir / f"{FNAME}.info").read_text())
    if not info.get("completed"):
        raise RuntimeError("PySPH run did not complete")
    return float(info["cpu_time"])


def force_evals(profile: dict, integrator: str, steps: int) -> tuple[int | None, int | None]:
    """Acceleration evaluations in the steps (measured) and per step.

    Counted from PySPH's profile (``acceleration_eval_*`` calls inside the
    integrator's steps; the one initial evaluation is profiled separately);
    falls back to the integrator's nominal count when no profile was written.
    """
    calls = sum(c for name, (c, _) in profile.items() if name.startswith("acceleration_eval_"))
    if calls and steps:
        return calls, round(calls / steps)
    per = EVALS_PER_STEP.get(integrator)
    return (per * steps if per else None), per


def run_pysph_dam_break(dx: float, tf: float, threads: int, out_dir: str,
                        python: str = DEFAULT_PYTHON, *, n_dumps: int = 25,
                        consistent_resolution: bool = True, cold_cache: bool = False,
                        extra_env: dict | None = None, timeout: float | None = None) -> dict:
    """Run PySPH's 2-D dam break and return its size, cost and front history.

    Returns a dict with n_fluid, n_solid, n_particles, steps, wall_s (PySPH's
    "Run took", compilation excluded), wall_s_excl_output, dump_s, setup_s,
    compiled, particle_steps_per_s (all particles), fluid_particle_steps_per_s,
    front [(t, x_front)], integrator, force_evals_per_step and context fields
    (1-min load average before/after, the subprocess's CPU seconds: on a shared
    2-core host other processes skew timings, OpenMP ones most).  ``extra_env``
    is added to the subprocess environment (see ``omp_environment``).
    """
    out = Path(out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    clear_previous_output(out)
    home = str(out / "home") if cold_cache else os.path.expanduser("~")
    omp_env = omp_environment(threads, extra_env)
    env = {**os.environ, "HOME": home, **omp_env}
    pfreq = max(1, estimate_steps(dx, tf, consistent_resolution) // max(n_dumps, 1))
    cfg = dict(dx=dx, fname=FNAME, consistent_resolution=consistent_resolution,
               argv=build_argv(dx, tf, threads, str(out), pfreq),
               summary=str(out / "peer_summary.json"))

    cache_before = _cache_listing(home)
    load_before = os.getloadavg()
    cpu_before = _children_cpu_s()
    total_s = _run_driver(python, cfg, env, out, timeout)
    cpu_s = _children_cpu_s() - cpu_before
    load_after = os.getloadavg()
    compiled = bool(_cache_listing(home) - cache_before)

    s = json.loads(Path(cfg["summary"]).read_text())
    wall = read_run_time(out)
    profile = read_profile(out)
    dump_s = profile.get("Solver.dump_output", (0, 0.0))[1]
    n_fluid, n_solid = s["counts"]["fluid"], s["counts"]["boundary"]
    n_total = n_fluid + n_solid
    steps = s["steps"]
    evals, per_step = force_evals(profile, s["integrator"], steps)
    return dict(
        code="PySPH 1.0b2 examples.dam_break_2d (wcsph)",
        dx=dx, tf=tf, t_final=s["t_final"], threads=threads, openmp=s["use_openmp"],
        consistent_resolution=consistent_resolution, h=s["h_fluid"], m=s["m_fluid"],
        n_fluid=n_fluid, n_solid=n_solid, n_particles=n_total, steps=steps,
        wall_s=wall, wall_s_excl_output=wall - dump_s, dump_s=dump_s,
        setup_s=s["setup_s"], compiled=compiled, subprocess_total_s=total_s,
        subprocess_cpu_s=cpu_s, omp_env=omp_env,
        particle_steps_per_s=n_total * steps / wall,
        fluid_particle_steps_per_s=n_fluid * steps / wall,
        integrator=s["integrator"], force_evals=evals, force_evals_per_step=per_step,
        kernel=s["kernel"], nnps=s["nnps"], pfreq=pfreq,
        front=[(t, x) for t, x, _ in s["front"]],
        loadavg_1min=(load_before[0], load_after[0]), out_dir=str(out),
    )


def _format(res: dict) -> str:
    """Human-readable one-run summary."""
    keys = ["n_fluid", "n_solid", "n_particles", "steps", "t_final", "h", "m", "openmp",
            "wall_s", "wall_s_excl_output", "setup_s", "compiled", "subprocess_cpu_s", "omp_env",
            "particle_steps_per_s", "fluid_particle_steps_per_s", "integrator",
            "force_evals_per_step", "kernel", "nnps", "loadavg_1min"]
    lines = [f"{k:>28}: {res[k]}" for k in keys]
    front = ", ".join(f"({t:.3f}, {x:.3f})" for t, x in res["front"])
    return "\n".join(lines + [f"{'front (t, x_front)':>28}: {front}"])


def main(argv: list[str] | None = None) -> int:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--tf", type=float, default=0.5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out-dir", default=None, help="default: /tmp/pysph_dam_break_dx<dx>_t<threads>")
    ap.add_argument("--python", default=DEFAULT_PYTHON)
    ap.add_argument("--n-dumps", type=int, default=25)
    ap.add_argument("--verbatim", action="store_true",
                    help="keep the example's dx-independent h and m (its resolution bug)")
    ap.add_argument("--cold-cache", action="store_true", help="compile into a fresh HOME")
    ap.add_argument("--env", action="append", default=[], metavar="KEY=VALUE",
                    help="extra environment for PySPH, e.g. OMP_WAIT_POLICY=passive")
    ap.add_argument("--json", action="store_true", help="print the result dict as JSON")
    args = ap.parse_args(argv)
    extra_env = dict(kv.split("=", 1) for kv in args.env)
    out_dir = args.out_dir or f"/tmp/pysph_dam_break_dx{args.dx}_t{args.threads}"
    res = run_pysph_dam_break(args.dx, args.tf, args.threads, out_dir, args.python,
                              n_dumps=args.n_dumps, consistent_resolution=not args.verbatim,
                              cold_cache=args.cold_cache, extra_env=extra_env)
    print(json.dumps(res, indent=1) if args.json else _format(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
