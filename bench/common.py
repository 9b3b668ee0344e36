"""Shared helpers of the benchmark harness: scene building, the step timer, worker subprocesses,
machine information and the writers of the JSON / Markdown / PNG results.

Everything here goes through the solver contract (``warpfree/solver.py``), so any scene of any method
family can be timed: ``solver.step(dt)``, ``solver.problem()`` (the step's one read-back),
``solver.work_items`` counted in ``solver.work_unit`` (particle-steps, Gauss points, ...), the timed
``solver.phases``, and, for solvers whose particles move, ``solver.moving_neighbours``.

Timing protocol (:func:`time_steps`): ``warmup`` untimed steps first (the first launch of every kernel
loads or JIT-compiles its Warp module, so compilation never enters a timing), then ``repeats`` timed
blocks of ``steps`` steps each, every block bracketed by ``time.perf_counter``; the figure reported is
the median block. Every step of every block uses the same ``dt`` (given by the caller), so the work is
identical whatever the thread count. Each step ends with the solver's problem check, which reads the
step's reduced report back (on a GPU: the step's synchronisation), so a block's wall time is its work.

Moving sets rebuild their neighbour tables once a particle may have moved half the skin; from rest
that takes hundreds of steps, so :func:`time_solver` forces a rebuild every ``rebuild_every`` steps
(default :data:`DEVELOPED_REBUILD_EVERY`, the interval of the dam breaks' developed flow) and a block
costs what a step of a running flow costs.

Throughput is ``work_items * steps / wall`` in the solver's unit per second (for WCSPH: particle-steps/s
with particles = fluid + boundary, every particle the kernels touch) and, where the model reports a
fluid count, fluid-particle-steps/s.

Speed is measured only here, never in the tests. Absolute numbers hold only for the machine that
made them; ratios measured side by side in one run are the figures that travel.
"""

from __future__ import annotations

import ast
import datetime as _dt
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
RESULTS = BENCH / "results"
SCENES = ROOT / "scenes"
SOLVERS = ROOT / "warpfree" / "solvers"
KERNELS = ROOT / "kernels"
PYTHON = sys.executable


# -- machine ------------------------------------------------------------------------------------
def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def cpu_count() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def loadavg() -> list[float]:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return []


def git_revision() -> str | None:
    """Read-only: the commit the working tree is based on (plus '+dirty' when tracked files other than
    bench/results are modified)."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                             text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":!bench/results"],
                               cwd=ROOT,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return (rev + ("+dirty" if dirty else "")) or None
    except Exception:
        return None


def machine_info() -> dict:
    """Where and when a benchmark ran (goes into every JSON)."""
    try:
        import warp as wp

        warp_version = wp.__version__
    except Exception:  # pragma: no cover
        warp_version = None
    return {
        "date": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "cpu": cpu_model(),
        "cores": cpu_count(),
        "loadavg_start": loadavg(),
        "python": platform.python_version(),
        "warp": warp_version,
        "numpy": np.__version__,
        "git": git_revision(),
        "command": " ".join([os.path.relpath(sys.argv[0], ROOT) if sys.argv[0] else "", *sys.argv[1:]]),
    }


# -- families and what their scenes declare ----------------------------------------------------------------
# Read from the source (nothing imported), so a benchmark learns a new family, scene or hot kernel from the files that
# define it: a family is a wing under warpfree/solvers/ that defines a solver, a scene names its benchmark sizes in
# BENCHMARK and its kernel variants in KERNEL_VARIANTS, a kernel module names its hot kernels in HOT_KERNELS.

#: the contract's bases (warpfree/solver.py): a wing with a class derived from one of them is a method family
SOLVER_BASES = ("TimeDependentSolver", "StaticSolver")


def _wing_files(wing: Path) -> list[Path]:
    return sorted(wing.rglob("*.py")) if wing.is_dir() else [wing]


def declared(path: Path, name: str):
    """The literal a module assigns to ``name`` at its top level (``ast.literal_eval``), or None if it assigns none."""
    for node in ast.parse(Path(path).read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name for t in node.targets):
            return ast.literal_eval(node.value)
    return None


def wings() -> dict[str, Path]:
    """Name -> folder (or module, for the example solver) of every wing under ``warpfree/solvers/``."""
    return {p.stem: p for p in sorted(SOLVERS.iterdir())
            if not p.name.startswith("_") and p.name != "__pycache__" and (p.is_dir() or p.suffix == ".py")}


def solver_families() -> list[str]:
    """The method families: the wings that define a solver (a class whose bases name one of :data:`SOLVER_BASES`).
    A wing without one (``nem``: a shape model the EFG solver holds) serves another family's solver."""
    def defines_solver(path: Path) -> bool:
        return any(isinstance(n, ast.ClassDef) and any(ast.unparse(b).split(".")[-1] in SOLVER_BASES for b in n.bases)
                   for p in _wing_files(path) for n in ast.walk(ast.parse(p.read_text(encoding="utf-8"))))
    return [name for name, path in wings().items() if defines_solver(path)]


def scene_files() -> dict[str, Path]:
    """Name -> file of every shipped scene (the modules of ``scenes/``, as ``warpfree.scene_loader.shipped_scenes``)."""
    return {p.stem: p for p in sorted(SCENES.glob("*.py")) if not p.name.startswith("_")}


def scene_family(path: Path, families: list[str] | None = None) -> str:
    """The family a scene runs: the one solver family among the wings it imports (``warpfree.solvers.<wing>``)."""
    families = solver_families() if families is None else families
    found = set()
    for node in ast.walk(ast.parse(Path(path).read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [f"{node.module}.{a.name}" for a in node.names]  # from warpfree.solvers import heat
        else:
            continue
        found.update(n.split(".")[2] for n in names if n.startswith("warpfree.solvers.") and
                     n.split(".")[2] in families)
    if len(found) != 1:
        raise ValueError(f"{Path(path).name} imports {len(found)} solver families ({sorted(found)}), not one")
    return found.pop()


def benchmarks() -> dict[str, dict]:
    """Family -> what its benchmarks run: ``{"scene": name, **BENCHMARK}`` of the one scene of the family whose module
    declares ``BENCHMARK`` (``parameter``, ``values`` and ``steps`` for the throughput of bench/core/gpu_check.py;
    ``scaling``, the n and 2n settings per sweep size of bench/core/scaling.py, for a family whose solver
    distributes), in the scenes' name order."""
    families, out = solver_families(), {}
    for name, path in scene_files().items():
        declaration = declared(path, "BENCHMARK")
        if declaration is None:
            continue
        family = scene_family(path, families)
        if family in out:
            raise ValueError(f"two scenes declare BENCHMARK for {family}: {out[family]['scene']} and {name}")
        out[family] = {"scene": name, **declaration}
    return out


def hot_kernels() -> dict[str, tuple[str, ...]]:
    """Kernel module (``wcsph``, ``mls``) -> the names of its hot kernels (its ``HOT_KERNELS``: the kernels that carry a
    step or a solve), for every module of ``kernels/`` that declares some."""
    out = {}
    for path in sorted(KERNELS.glob("*.py")):
        hot = declared(path, "HOT_KERNELS")
        if hot:
            out[path.stem] = tuple(hot)
    return out


# -- scenes -------------------------------------------------------------------------------------
def build_scene(scene: str, threads: int, device: str = "cpu", **params):
    """Set the launcher (``warpfree.device.use(device, threads)``) and build a scene: a name under
    ``scenes/`` or a path to a scene file. Frames and VTU output are switched off when the scene has those
    parameters; every other parameter is the scene's default unless given. Returns the scene's run
    (``TimeLoop`` or ``StaticRun``)."""
    os.environ.setdefault("WARPFREE_VERBOSE", "0")
    import warpfree.device
    from warpfree.scene_loader import load_scene, scene_parameters

    warpfree.device.use(device, threads)
    path = scene if scene.endswith(".py") else str(SCENES / f"{scene}.py")
    module = load_scene(path)
    defaults = scene_parameters(module)
    for off in ("frames", "vtk"):
        if off in defaults:
            params.setdefault(off, False)
    return module.build(**params)


def parse_sets(scene: str, pairs: list[str]) -> dict:
    """``name=value`` overrides of a scene's parameters, typed as the CLI types them."""
    from warpfree.scene_loader import load_scene, parse_overrides, scene_parameters

    path = scene if scene.endswith(".py") else str(SCENES / f"{scene}.py")
    return parse_overrides(pairs, scene_parameters(load_scene(path)))


def work_counts(solver) -> dict:
    """The solver's work per step and its unit, and the model's particle counts where it reports them."""
    d = solver.describe()
    out = {"work_items": int(solver.work_items), "work_unit": solver.work_unit}
    for k in ("n_fluid", "n_boundary", "n_particles"):
        if k in d:
            out[k] = int(d[k])
    return out


# -- the timer ----------------------------------------------------------------------------------
def time_steps(step: Callable[[], None], steps: int, warmup: int = 3, repeats: int = 3,
               check: Callable[[], str | None] | None = None,
               after_warmup: Callable[[], None] | None = None) -> dict:
    """Call ``step()`` ``warmup`` times untimed, then ``repeats`` timed blocks of ``steps`` calls.

    ``check`` (optional) is called after the warm-up and after every block; a non-empty answer (a
    problem message) raises RuntimeError, so a blown-up run is never reported as a speed.
    ``after_warmup`` (optional) is called once between the warm-up and the first timed block.
    Returns ``{"warmup_s", "block_s": [...], "median_s", "min_s", "max_s", "steps", "repeats"}``.
    """
    if steps < 1 or repeats < 1 or warmup < 0:
        raise ValueError("steps and repeats must be >= 1, warmup >= 0")
    t0 = time.perf_counter()
    for _ in range(warmup):
        step()
    warm = time.perf_counter() - t0
    if check is not None and check():
        raise RuntimeError(f"problem during warm-up: {check()}")
    if after_warmup is not None:
        after_warmup()
    blocks = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            step()
        blocks.append(time.perf_counter() - t0)
        if check is not None and check():
            raise RuntimeError(f"problem during timing: {check()}")
    return {"warmup_s": warm, "block_s": blocks, "median_s": statistics.median(blocks), "min_s": min(blocks),
            "max_s": max(blocks), "steps": steps, "repeats": repeats, "warmup": warmup}


#: forced neighbour-table rebuild interval (steps) when timing from rest: the dam breaks' developed flow,
#: where particles move at v ≈ c0/10 = sqrt(2 g H) and the skin (0.15 support) lasts skin/2 / (v dt) = 7-8
#: steps at Courant number 0.2
DEVELOPED_REBUILD_EVERY = 8


def time_solver(solver, dt: float, steps: int, warmup: int = 3, repeats: int = 3,
                rebuild_every: int | None = DEVELOPED_REBUILD_EVERY) -> dict:
    """:func:`time_steps` on ``solver.step(dt)`` with a fixed ``dt``; adds the throughput and the solver's own
    per-phase wall times per step over the timed blocks (``phase_s_per_step``).

    ``rebuild_every``: for a solver with ``moving_neighbours``, force a table rebuild before every k-th step
    (None: only the solver's own rebuilds, i.e. hardly any from rest); ignored for other solvers.
    """
    moving = getattr(solver, "moving_neighbours", None)
    if moving is None:
        rebuild_every = None
    if rebuild_every:  # whole rebuild periods, so every block holds the same number of rebuilds
        steps = -(-steps // rebuild_every) * rebuild_every
        warmup = -(-warmup // rebuild_every) * rebuild_every
    before: dict = {}
    count = [0]

    def step():
        if rebuild_every and count[0] % rebuild_every == 0:
            with solver.phases("neighbours"):  # where solvers time their own rebuilds
                moving.rebuild()
        count[0] += 1
        solver.step(dt)

    res = time_steps(step, steps, warmup, repeats, check=solver.problem,
                     after_warmup=lambda: before.update(solver.phases.as_dict()))
    total = steps * repeats
    res["phase_s_per_step"] = {k: (v - before.get(k, 0.0)) / total for k, v in solver.phases.as_dict().items()}
    res["rebuild_every"] = rebuild_every
    res.update(work_counts(solver))
    res["dt"] = dt
    res.update(throughput(res, steps, res["median_s"]))
    res["block_work_per_s"] = [solver.work_items * steps / b for b in res["block_s"]]
    return res


def throughput(counts: dict, steps: int, wall_s: float) -> dict:
    """Work items per second in the solver's unit (``work_per_s``), fluid-particle-steps/s where the model
    has a fluid count, and seconds per step."""
    out = {"work_per_s": counts["work_items"] * steps / wall_s, "unit": f"{counts['work_unit']}/s",
           "s_per_step": wall_s / steps}
    if "n_fluid" in counts:
        out["fluid_particle_steps_per_s"] = counts["n_fluid"] * steps / wall_s
    return out


def particle_throughput(n_particles: int, n_fluid: int, steps: int, wall_s: float) -> dict:
    """Particle-steps/s of all particles and of the fluid alone, and seconds per step (the comparisons with
    fluid peers, whose own figures come in these units)."""
    return {"particle_steps_per_s": n_particles * steps / wall_s,
            "fluid_particle_steps_per_s": n_fluid * steps / wall_s, "s_per_step": wall_s / steps}


def equal_error_ratio(a: list[dict], b: list[dict]) -> list[dict]:
    """Time of method a / time of method b at a's errors, b's time interpolated log-log between its runs (inside
    its error range only). Rows: {"error", "wall_s"}; returns [{"error", "a_s", "b_s", "ratio"}]."""
    eb = np.log([r["error"] for r in b])
    tb = np.log([r["wall_s"] for r in b])
    order = np.argsort(eb)
    out = []
    for r in a:
        e = math.log(r["error"])
        if eb.min() <= e <= eb.max():
            t = float(np.exp(np.interp(e, eb[order], tb[order])))
            out.append({"error": r["error"], "a_s": r["wall_s"], "b_s": t, "ratio": r["wall_s"] / t})
    return out


def median(values):
    return statistics.median(values)


# -- worker subprocesses -----------------------------------------------------------------------
WORKER_TAG = "@@BENCH_RESULT@@"


def emit_worker_result(result: dict) -> None:
    """A worker prints its result as one tagged JSON line on stdout."""
    print(WORKER_TAG + json.dumps(result, default=_json_default), flush=True)


def run_worker(script: str | Path, args: list[str], timeout: float | None = None, env: dict | None = None) -> dict:
    """Run ``python script *args`` in a fresh process and return the dict it emitted.

    A fresh process per measurement gives every thread count its own Warp runtime, thread pool and
    allocator state; the Warp kernel cache on disk is shared, so no worker compiles again.
    """
    cmd = [PYTHON, str(script), *args]
    e = dict(os.environ, WARPFREE_VERBOSE="0")
    if env:
        e.update(env)
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=e, cwd=ROOT)
    for line in proc.stdout.splitlines()[::-1]:
        if line.startswith(WORKER_TAG):
            return json.loads(line[len(WORKER_TAG):])
    tail = (proc.stdout[-2000:] + "\n" + proc.stderr[-3000:]).strip()
    raise RuntimeError(f"worker {' '.join(cmd[1:])} failed (rc={proc.returncode}):\n{tail}")


# -- output -------------------------------------------------------------------------------------
def add_variant_sweep(parser, dx_default: str) -> None:
    """The arguments of a sweep over spacings and scene settings: ``--dx`` (comma-separated, m), ``--threads`` and
    ``--variant`` (space-separated name=value settings run at every dx; repeatable; ``default`` for none)."""
    parser.add_argument("--dx", default=dx_default, help="particle spacings (m), comma-separated")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--variant", action="append", default=None,
                        help="scene settings run at every dx, space-separated name=value (default: none); repeatable")


def variant_sweep(args, run_case: Callable[[float, int, tuple], dict],
                  finish: Callable[[dict], dict]) -> tuple[list[tuple], list[dict]]:
    """Each ``--variant`` at each ``--dx``, in that order: ``finish(run_case(dx, threads, settings))`` gives a case.
    Returns the variants (tuples of name=value settings, () for the scene's defaults) and the cases."""
    variants = [() if v.strip() in ("", "default") else tuple(v.split()) for v in (args.variant or ["default"])]
    cases = []
    for settings in variants:
        for dx in (float(v) for v in args.dx.split(",")):
            print(f"dx = {dx} {' '.join(settings)}", flush=True)
            cases.append(finish(run_case(dx, args.threads, settings)))
    return variants, cases


def md_table(headers: list[str], rows: list[list], align: str | None = None) -> str:
    """A GitHub Markdown table; ``align`` is one of l/r/c per column (default: first l, rest r)."""
    align = align or ("l" + "r" * (len(headers) - 1))
    sep = {"l": ":--", "r": "--:", "c": ":-:"}
    lines = ["| " + " | ".join(headers) + " |", "| " + " | ".join(sep[a] for a in align) + " |"]
    for r in rows:
        lines.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(lines)


def fmt_rate(x: float | None) -> str:
    """A rate in engineering notation (e.g. ``1.23e5``)."""
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.3g}"


def fmt(x, digits: int = 3) -> str:
    if x is None:
        return "–"
    if isinstance(x, float) and not np.isfinite(x):
        return "–"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    return f"{x:.{digits}g}"


def new_figure(*args, **kwargs):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


def write_results(name: str, data: dict, markdown: str, fig=None, quick: bool = False) -> dict:
    """Write ``bench/results/<name>[_quick].{json,md,png}``, print the Markdown, return the paths."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = name + ("_quick" if quick else "")
    paths = {"json": RESULTS / f"{stem}.json", "md": RESULTS / f"{stem}.md"}
    data = dict(data)
    data.setdefault("machine", machine_info())
    data["machine"]["loadavg_end"] = loadavg()
    with open(paths["json"], "w") as f:
        json.dump(data, f, indent=2, default=_json_default)
    m = data["machine"]
    header = (f"<!-- {stem}: {m['date']} · {m['cpu']} · {m['cores']} cores · warp {m['warp']} · "
              f"load {m['loadavg_start']} -> {m['loadavg_end']} -->\n")
    with open(paths["md"], "w") as f:
        f.write(header + markdown.rstrip() + "\n")
    if fig is not None:
        paths["png"] = RESULTS / f"{stem}.png"
        fig.savefig(paths["png"], dpi=110)
        import matplotlib.pyplot as plt

        plt.close(fig)
    print(markdown.rstrip())
    print("\nwrote " + ", ".join(os.path.relpath(p, ROOT) for p in paths.values()))
    return paths


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (tuple, set)):
        return list(o)
    if isinstance(o, Path):
        return str(o)
    return str(o)


# -- the 2D dam break run (used by vs_pysph and speed_vs_error) --------------------------------------
DAM_BREAK_A = 1.0
DAM_BREAK_G = 9.81
DAM_BREAK_T_MAX = 2.5


def dam_break_front_errors(t, x_front) -> dict:
    """``front_errors`` (T <= 2.5) of warpfree.validation.dam_break_2d for a = 1, g = 9.81."""
    from warpfree.validation.dam_break_2d import front_errors

    return front_errors(np.asarray(t, float), np.asarray(x_front, float), DAM_BREAK_A, DAM_BREAK_G,
                        t_max=DAM_BREAK_T_MAX)


def scene_run(cfg: dict) -> dict:
    """Run a scene through its run shell into a temporary directory, frames and VTU off (call it in a worker).

    cfg: scene, threads, params. Returns the work counts, steps, the run's ``wall_s`` (steps, probes and
    records; not the build, not the analysis), its phases, throughput and the scene's analysis.
    """
    import tempfile

    t0 = time.perf_counter()
    run = build_scene(cfg["scene"], cfg["threads"], **cfg["params"])
    build_s = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as out:
        summ = run.run(out, progress=False)
    counts = work_counts(run.solver)
    steps = summ.get("steps", 1)
    out = dict(scene=cfg["scene"], params=cfg["params"], threads=run.solver.launcher.threads, **counts, steps=steps,
               wall_s=summ["wall_s"], build_s=build_s, phases_s=summ["phases_s"], analysis=summ.get("analysis", {}),
               loadavg=loadavg())
    out.update(throughput(counts, steps, out["wall_s"]))
    return out


def dam_break_2d_run(cfg: dict) -> dict:
    """Run ``scenes/dam_break_2d.py`` in memory (call it in a worker process).

    cfg: dx, threads, tf, optional cfl. Wall time = the run's step time (the summary's ``phases_s["step"]``:
    every step with its read-back) plus its probe and diagnostic records every ``output_interval``
    (``phases_s["output"]``); the build, which loads the kernels, is excluded. Returns counts, steps, wall
    times, the front history [(t, x_front)] and its errors.
    """
    params = dict(dx=cfg["dx"], t_end=cfg["tf"])
    if cfg.get("cfl"):
        params["cfl"] = cfg["cfl"]
    t0 = time.perf_counter()
    run = build_scene("dam_break_2d", cfg["threads"], **params)
    build_s = time.perf_counter() - t0
    s = run.solver
    summ = run.run(None, progress=False)
    t, x = run.series["time"], run.series["front"]
    counts = work_counts(s)
    out = dict(code="warpfree WCSPH 2D", dx=cfg["dx"], threads=s.launcher.threads, cfl=s.model.params.cfl,
               **counts, steps=summ["steps"], t_final=run.time, wall_s=summ["wall_s"],
               step_wall_s=summ["phases_s"]["step"], build_s=build_s, front=list(zip(t, x)),
               errors=dam_break_front_errors(t, x), loadavg=loadavg())
    out.update(particle_throughput(counts["n_particles"], counts["n_fluid"], out["steps"], out["wall_s"]))
    return out
