"""SPEM against Yee FDTD on the same problem: error against wall time, and the time ratio at equal error.

What it measures
    ``--case waveguide`` (default): the waveguide of ``scenes/em_waveguide_2d.py`` (plates 0.5 m apart, TM1 at 1.2 f_c driven from y = 0, PML of
    0.1 m beyond y = 0.4 m) to t = 4.1 ns, at several particles (cells) per wavelength, with SPEM (FPM, uniform
    layout) and with the Yee FDTD of ``bench/spem/fdtd_yee.py`` (same PML grading, same source profile, same
    threads, dt = T / ceil(T / (0.95 × each method's stable step))). Error: mean |Ez - exact| / E0 along the
    column nearest x = 0.244 m, 0 <= y <= 0.4 m, against the exact TM1 solution
    (``warpfree.validation.em_waveguide_2d``). Time: the steps only (set-up excluded), median of ``--repeats``
    runs. The ratio SPEM/FDTD at equal error is read off the two error-time curves (log-log interpolation).

    ``--case line``: the 1D line of ``scenes/em_line_1d.py`` (1.8 GHz hard sine source at the centre of [0, π] m,
    PEC ends) to t = 4.75 ns, SPEM against the 1D Yee grid of ``fdtd_yee.YeeLine`` with the same nodes, source and
    step; error: the scene's mean |Ez - exact| on (0.5, 1.5) m (``warpfree.validation.em_line_1d``). On a uniform
    line SPEM's FPM pair is Yee's difference, so the errors agree and the ratio is the cost of a step.

    ``--case cavity``: the circular cavity of ``scenes/em_cavity_2d.py`` (r0 = 0.1 m, εr = 10, PEC wall, the
    initial profile 1 - r²/r0²) to t = 5.5 ns at 10, 20, 40, 80 cells per radius, SPEM (E particles on the true
    circle) against ``fdtd_yee.YeeCavity`` (the wall staircased: nodes at r >= r0 held at 0), both at 0.9 of their
    stable step; error: mean |Ez - exact| over the E points in the disk against the Bessel series (4.5).

    ``--case scatterer``: the dielectric cylinder of ``scenes/em_scatterer_2d.py`` (εr = 4, k0 a = 2.5, 30 periods,
    DFT over the last 4) at 10 to 56 particles per wavelength in the dielectric, SPEM against
    ``fdtd_yee.YeeScatterer`` on the same lattice with the same averaged permittivity, PML and TF/SF box (both
    second order at the interface, so the errors agree and the ratio is the cost of a step), and SPEM with Fang's
    fourth-order difference (``order=4``, the scene's default) beside them; error: the relative L2 error of Ez's
    complex amplitude on the ring r = 1.5 a against the Bessel series, as the scene computes it.

Usage
    python bench/spem/spem_vs_fdtd.py                 # waveguide, 1 thread, ppw 20 40 80 160 320, 3 repeats
    python bench/spem/spem_vs_fdtd.py --case line     # the 1D line, ppw 10 20 40 80 160 320
    python bench/spem/spem_vs_fdtd.py --case cavity   # the circular cavity, 10 20 40 80 cells per radius
    python bench/spem/spem_vs_fdtd.py --case scatterer  # the dielectric cylinder, 10 to 56 per wavelength
    python bench/spem/spem_vs_fdtd.py --threads 2
    python bench/spem/spem_vs_fdtd.py --quick         # smoke run: ppw 20 40 (line: 10 20), 1 repeat
Writes bench/results/spem_vs_fdtd[_quick].{json,md,png} (the line: spem_vs_fdtd_line[_quick].*, the cavity:
spem_vs_fdtd_cavity[_quick].*, the cylinder: spem_vs_fdtd_scatterer[_quick].*).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]  # bench/ (common.py) and this family's folder (sibling modules)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[], ["--case", "line"], ["--case", "cavity"], ["--case", "scatterer"]]


def timed_spem_run(s, t_end: float) -> tuple[float, float, int]:
    """Steps of 0.95 x the stable limit dividing t_end, timed from rest after one untimed step (kernel loading):
    (wall s, dt, steps)."""
    steps = math.ceil(t_end / (0.95 * s.stable_dt()))
    dt = t_end / steps
    s.step(dt)
    for a in (s.state.ez, s.state.ezx, s.state.hx, s.state.hy):
        a.zero_()
    s.state.time = 0.0  # the time of H (SPEMSolver.t reads it)
    t0 = time.perf_counter()
    for _ in range(steps):
        s.step(dt)
    return time.perf_counter() - t0, dt, steps


def run_spem(ppw: float, t_end: float, threads: int) -> tuple[float, float, int]:
    from warpfree.validation.em_waveguide_2d import tm1_field

    loop = common.build_scene("em_waveguide_2d", threads, particles_per_wavelength=ppw, t_end=t_end)
    s = loop.solver
    src = s.sources[0].source
    wall, dt, steps = timed_spem_run(s, t_end)
    e = s.model.layout.e_position
    width, amp = loop.params["width"], loop.params["amplitude"]
    x0 = e[np.argmin(np.abs(e[:, 0] - 0.244)), 0]
    col = np.flatnonzero((np.abs(e[:, 0] - x0) < 1e-9) & (e[:, 1] <= 0.4 + 1e-9))
    ez = s.electric.numpy("ez")[col]
    exact = amp * math.sin(math.pi * x0 / width) * tm1_field(e[col, 1], t_end - 0.5 * dt, width, src.waveform,
                                                             src.waveform.frequency)
    return wall, float(np.mean(np.abs(ez - exact)) / amp), steps


def run_fdtd(ppw: float, t_end: float, threads: int) -> tuple[float, float, int]:
    import warpfree.device
    from fdtd_yee import YeeWaveguide
    from warpfree.solvers.spem import C0, PML, Waveform
    from warpfree.validation.em_waveguide_2d import cutoff_frequency, tm1_field

    launcher = warpfree.device.use("cpu", threads)
    width, length, delta, amp = 0.5, 0.4, 0.1, 0.2
    f = 1.2 * cutoff_frequency(width)
    wave = Waveform(f)
    g = YeeWaveguide(launcher, width, length, delta, C0 / f / ppw, amp, PML(delta, sides=("y+",)))
    steps = math.ceil(t_end / (0.95 * g.stable_dt()))
    dt = t_end / steps
    g.step(dt, wave)  # kernel loading, then start again
    g.reset()
    t0 = time.perf_counter()
    for _ in range(steps):
        g.step(dt, wave)
    wall = time.perf_counter() - t0
    x0, y, ez = g.column(0.244)
    keep = y <= length + 1e-9
    exact = amp * math.sin(math.pi * x0 / width) * tm1_field(y[keep], t_end - 0.5 * dt, width, wave, f)
    return wall, float(np.mean(np.abs(ez[keep] - exact)) / amp), steps


LINE = dict(frequency=1.8e9, length=math.pi, window=(0.5, 1.5))


def run_spem_line(ppw: float, t_end: float, threads: int) -> tuple[float, float, int]:
    from warpfree.validation.em_line_1d import mean_error

    loop = common.build_scene("em_line_1d", threads, particles_per_wavelength=ppw, t_end=t_end)
    s = loop.solver
    wall, dt, steps = timed_spem_run(s, t_end)
    x = s.model.layout.e_position[:, 0]
    source = int(s.sources[0].index[0])
    err = mean_error(x, s.electric.numpy("ez"), t_end - 0.5 * dt, x[source], LINE["frequency"], LINE["window"])
    return wall, float(err), steps


def run_fdtd_line(ppw: float, t_end: float, threads: int) -> tuple[float, float, int]:
    import warpfree.device
    from fdtd_yee import YeeLine
    from warpfree.solvers.spem import C0, Waveform
    from warpfree.validation.em_line_1d import mean_error

    launcher = warpfree.device.use("cpu", threads)
    f = LINE["frequency"]
    g = YeeLine(launcher, LINE["length"], C0 / f / ppw)
    wave = Waveform(f)
    steps = math.ceil(t_end / (0.95 * g.stable_dt()))
    dt = t_end / steps
    g.step(dt, wave)
    g.reset()
    t0 = time.perf_counter()
    for _ in range(steps):
        g.step(dt, wave)
    wall = time.perf_counter() - t0
    err = mean_error(g.x, g.ez.numpy(), t_end - 0.5 * dt, g.x[g.source], f, LINE["window"])
    return wall, float(err), steps


CAVITY = dict(radius=0.1, eps_r=10.0)


def cavity_error(r: np.ndarray, ez: np.ndarray, t: float) -> float:
    """The scene's measure: mean |Ez - exact| over the points (the initial peak is 1), the Bessel series (4.5)."""
    from warpfree.validation.em_cavity_2d import cavity_field

    return float(np.mean(np.abs(ez - cavity_field(r, t, CAVITY["radius"], CAVITY["eps_r"]))))


def run_spem_cavity(cells: float, t_end: float, threads: int) -> tuple[float, float, int]:
    loop = common.build_scene("em_cavity_2d", threads, cells_per_radius=int(cells), t_end=t_end)
    s = loop.solver
    start = [a.numpy().copy() for a in (s.state.ez, s.state.ezx, s.state.hx, s.state.hy)]
    steps = math.ceil(t_end / (0.9 * s.stable_dt()))
    dt = t_end / steps
    s.step(dt)  # kernel loading, then the initial state again
    for a, v in zip((s.state.ez, s.state.ezx, s.state.hx, s.state.hy), start):
        a.assign(v)
    s.state.time = 0.0
    t0 = time.perf_counter()
    for _ in range(steps):
        s.step(dt)
    wall = time.perf_counter() - t0
    e = s.model.layout.e_position
    r = np.hypot(e[:, 0] - CAVITY["radius"], e[:, 1] - CAVITY["radius"])
    return wall, cavity_error(r, s.electric.numpy("ez"), t_end - 0.5 * dt), steps


def run_fdtd_cavity(cells: float, t_end: float, threads: int) -> tuple[float, float, int]:
    import warpfree.device
    from fdtd_yee import YeeCavity

    g = YeeCavity(warpfree.device.use("cpu", threads), CAVITY["radius"], CAVITY["eps_r"], int(cells))
    steps = math.ceil(t_end / (0.9 * g.stable_dt()))
    dt = t_end / steps
    g.step(dt)
    g.reset()
    t0 = time.perf_counter()
    for _ in range(steps):
        g.step(dt)
    wall = time.perf_counter() - t0
    inside = g.r <= CAVITY["radius"]
    return wall, cavity_error(g.r[inside], g.ez.numpy()[inside], t_end - 0.5 * dt), steps


def _scatterer_scene(ppw: float, threads: int, order: int = 2):
    """The dielectric cylinder of ``scenes/em_scatterer_2d.py`` at ``ppw`` per wavelength in the dielectric, its kernels
    loaded by one step of its smallest run; and the step: whole steps per period at 0.95 of the stable limit."""
    common.build_scene("em_scatterer_2d", threads, particles_per_wavelength=8, periods=2, window=1).solver.step(1e-12)
    loop = common.build_scene("em_scatterer_2d", threads, particles_per_wavelength=ppw, order=order)
    period = 1.0 / loop.params["frequency"]
    return loop, period / math.ceil(period / (0.95 * loop.solver.stable_dt())), period


def run_spem_scatterer(ppw: float, t_end: float, threads: int, order: int = 2) -> tuple[float, float, int]:
    loop, dt, period = _scatterer_scene(ppw, threads, order)
    s = loop.solver
    steps = int(round(loop.params["periods"] * period / dt))
    s.use_step(dt)
    t0 = time.perf_counter()
    for _ in range(steps):
        s.step(dt)
    wall = time.perf_counter() - t0
    result = loop.analyses[0](loop, None)["scatterer"]
    return wall, result["ring_error"], steps


def run_fdtd_scatterer(ppw: float, t_end: float, threads: int) -> tuple[float, float, int]:
    """Yee's grid on the scene's lattice, permittivity (averaged) and PML, the DFT at the nodes the scene's ring
    points read (its interpolation), the ring error as the scene computes it."""
    import warpfree.device
    from fdtd_yee import YeeScatterer
    from warpfree.solvers.spem.monitors import interpolation_rows
    from warpfree.validation.em_scatterer_2d import total_field

    loop, _, period = _scatterer_scene(ppw, threads)
    p = loop.params
    model, wave = loop.solver.model, loop.solver.plane_waves[0].wave
    monitor = loop.solver.monitors["near_field"][0].monitor
    lay = model.layout
    ring = monitor.points[:p["ring_points"]]
    rows = interpolation_rows(lay.e_position, ring, 2, lay.spacing).tocsc()
    nodes = np.flatnonzero(np.diff(rows.indptr) > 0)
    launcher = warpfree.device.use("cpu", threads)
    half = model.interior[1][0]
    g = YeeScatterer(launcher, lay.e_position, model.eps_r, lay.spacing, model.pml, half, wave.upper[0],
                     p["frequency"], p["ramp"], nodes, (p["periods"] - p["window"]) * period)
    dt = period / math.ceil(period / (0.95 * g.stable_dt()))
    steps = int(round(p["periods"] * period / dt))
    g.step(dt)  # kernel loading, then from rest
    g.__init__(launcher, lay.e_position, model.eps_r, lay.spacing, model.pml, half, wave.upper[0], p["frequency"],
               p["ramp"], nodes, (p["periods"] - p["window"]) * period)
    t0 = time.perf_counter()
    for _ in range(steps):
        g.step(dt)
    wall = time.perf_counter() - t0
    transform = np.zeros(lay.n_e, complex)
    transform[nodes] = g.real.numpy() + 1j * g.imag.numpy()
    window = p["window"] * period
    k0 = 2.0 * math.pi * p["frequency"] / common_c0()
    field = (rows.tocsr() @ transform) * 2.0j / window * np.exp(-1j * k0 * wave.front_start(2))
    radius = p["k0a"] / k0
    exact = total_field(ring, (0.0, 0.0), radius, k0, p["eps_r"])
    return wall, float(np.linalg.norm(field - exact) / np.linalg.norm(exact)), steps


def common_c0() -> float:
    from warpfree.solvers.spem import C0

    return C0


RUNNERS = {"waveguide": (run_spem, run_fdtd), "line": (run_spem_line, run_fdtd_line),
           "cavity": (run_spem_cavity, run_fdtd_cavity), "scatterer": (run_spem_scatterer, run_fdtd_scatterer)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: the two coarsest ppw, 1 repeat (unless given)")
    ap.add_argument("--case", choices=sorted(RUNNERS), default="waveguide")
    ap.add_argument("--ppw", type=float, nargs="+", default=None,
                    help="default: 20 40 80 160 320 (line: 10 20 40 80 160 320)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=None, help="default 3; quick 1")
    ap.add_argument("--t-end", type=float, default=None, help="default: 4.1e-9 s (line: 4.75e-9 s)")
    ap.add_argument("--worker", default=None)
    args = ap.parse_args()
    default_ppw = {"line": [10, 20, 40, 80, 160, 320], "cavity": [10, 20, 40, 80],
                   "scatterer": [10, 14, 20, 28, 40, 56]}.get(args.case, [20, 40, 80, 160, 320])
    args.ppw = args.ppw or default_ppw[:2 if args.quick else None]
    args.repeats = args.repeats or (1 if args.quick else 3)
    args.t_end = args.t_end or {"line": 4.75e-9, "cavity": 5.5e-9, "scatterer": 30e-9}.get(args.case, 4.1e-9)
    if args.worker:
        cfg = json.loads(args.worker)
        spem, fdtd = RUNNERS[cfg["case"]]
        if cfg["code"] == "spem4":  # the scatterer's fourth-order difference
            wall, err, steps = run_spem_scatterer(cfg["ppw"], cfg["t_end"], cfg["threads"], order=4)
        else:
            wall, err, steps = (spem if cfg["code"] == "spem" else fdtd)(cfg["ppw"], cfg["t_end"], cfg["threads"])
        common.emit_worker_result({"wall_s": wall, "error": err, "steps": steps})
        return
    codes = ("spem", "fdtd", "spem4") if args.case == "scatterer" else ("spem", "fdtd")
    rows = {code: [] for code in codes}
    for ppw in args.ppw:
        for code in codes:
            walls, res = [], None
            for r in range(args.repeats):
                res = common.run_worker(__file__, ["--worker", json.dumps(dict(case=args.case, code=code, ppw=ppw,
                                                                                t_end=args.t_end,
                                                                                threads=args.threads))])
                walls.append(res["wall_s"])
            row = dict(ppw=ppw, wall_s=float(np.median(walls)), walls_s=walls, error=res["error"], steps=res["steps"])
            rows[code].append(row)
            print(f"  {code} ppw={ppw}: error {row['error']:.3e}, {row['steps']} steps, {row['wall_s']:.3f} s", flush=True)
    ratios = common.equal_error_ratio(rows["spem"], rows["fdtd"])
    md = [f"## SPEM against Yee FDTD, {args.case} to t = {args.t_end:.3g} s ({args.threads} thread(s), "
                  f"median of {args.repeats} runs, steps only)", "",
          f"| {'cells per radius' if args.case == 'cavity' else 'particles (cells) per λ'} | SPEM error | SPEM s | FDTD error | FDTD s |",
          "| --: | --: | --: | --: | --: |"]
    for a, b in zip(rows["spem"], rows["fdtd"]):
        md.append(f"| {a['ppw']:g} | {a['error']:.3e} | {a['wall_s']:.3f} | {b['error']:.3e} | {b['wall_s']:.3f} |")
    md += ["", "SPEM time / FDTD time at SPEM's error (FDTD interpolated log-log): " +
           (", ".join(f"{r['ratio']:.2f} (error {r['error']:.2e})" for r in ratios) or "no overlap of the error ranges")]
    ratios4 = []
    if "spem4" in rows:
        ratios4 = common.equal_error_ratio(rows["spem4"], rows["fdtd"])
        md += ["", "SPEM with the fourth-order difference (`order=4`):", "",
               "| particles per λ | SPEM (order 4) error | SPEM (order 4) s |", "| --: | --: | --: |"]
        md += [f"| {a['ppw']:g} | {a['error']:.3e} | {a['wall_s']:.3f} |" for a in rows["spem4"]]
        md += ["", "SPEM (order 4) time / FDTD time at SPEM's error (FDTD interpolated log-log): " +
               (", ".join(f"{r['ratio']:.2f} (error {r['error']:.2e})" for r in ratios4) or
                "no overlap of the error ranges")]
    fig, ax = common.new_figure(figsize=(6, 4.2))
    for code, mark in (("spem", "o-"), ("fdtd", "s--"), ("spem4", "^-")):
        if code not in rows:
            continue
        ax.loglog([r["wall_s"] for r in rows[code]], [r["error"] for r in rows[code]], mark,
                  label={"spem4": "SPEM, order 4"}.get(code, code.upper()))
    ax.set_xlabel("wall s (steps only)")
    ax.set_ylabel("mean |Ez - exact| / amplitude")
    title = {"line": "1D line", "cavity": "Cavity, FDTD wall staircased,",
             "scatterer": "Dielectric cylinder, both averaged,"}.get(args.case, "Waveguide")
    ax.set_title(f"{title} to {args.t_end * 1e9:.3g} ns: error vs wall time")
    ax.legend()
    fig.tight_layout()
    common.write_results({"line": "spem_vs_fdtd_line", "cavity": "spem_vs_fdtd_cavity",
                          "scatterer": "spem_vs_fdtd_scatterer"}.get(args.case, "spem_vs_fdtd"),
                         {"case": args.case, "rows": rows, "ratios": ratios, "ratios_order_4": ratios4,
                          "threads": args.threads}, "\n".join(md),
                         fig, quick=args.quick)

if __name__ == "__main__":
    main()
