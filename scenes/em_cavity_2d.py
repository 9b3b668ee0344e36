"""2D pulse in a circular cavity (seed 000 §4.3): SPEM against the exact Bessel series (4.5).

A disk of radius r0 = 0.1 m centred at (0.1, 0.1) m, εr = 10, perfectly conducting wall (a ring of E particles
held at Ez = 0), Ez(r, 0) = 1 - r²/r0², H = 0. Writes ``cavity.png`` (Ez along the radial line x = 0.1 m against
the series) and into ``summary.json`` the mean error over all E particles and along that line, as a fraction
of the initial peak, at every output and its largest value (``warpfree/validation/em_cavity_2d``).

Model: E particles at the nodes of a lattice of spacing Δ = r0/``cells_per_radius`` and on the wall ring, H in
Yee's staggering (Hx at the midpoints of the cell sides along y, Hy along x, each carrying its one component;
``warpfree/solvers/spem/layouts.py``); the conservative FPM pair (``warpfree/solvers/spem/conservative.py``: exact for linear fields
and energy-conserving, so the irregular neighbourhoods at the ring cannot make it grow), support 1.1 Δ (1.1 + 2
jitter on jittered particles, widened where fewer than 4 particles of the other set, or of an H component, are
inside). Errors by
resolution and jitter, and the thesis's schemes beside them: ``bench/results/scene_studies.md``.
"""

import math
import os

import numpy as np

from warpfree.errors import reported_as, require_positive
from warpfree.run import OutputOptions
from warpfree.solvers.spem import SPEMModel, SPEMSolver, staggered_disk, support_for_jitter
from warpfree.solvers.spem.kronecker import NodalValues
from warpfree.time_loop import TimeLoop
from warpfree.validation.em_cavity_2d import cavity_field


#: the smallest run of this scene worth making: the smoke tests, the installed-package test and
#: bench/compare_commits.py run it (literal values only)
SMALLEST = {"cells_per_radius": 8, "t_end": 1.0e-9, "output_interval": 0.25e-9}


def build(radius: float = 0.1, eps_r: float = 10.0, cells_per_radius: int = 20, courant: float = 0.9,
          t_end: float = 5.5e-9, output_interval: float = 0.25e-9, scheme: str = "fpm", support: float = 0.0,
          jitter: float = 0.0, seed: int = 0, conservative: bool | None = None, kronecker: bool = False,
          h_staggering: str | None = None, pair_order: int = 1, frames: bool = True, vtk: bool = True) -> TimeLoop:
    """Times in s, lengths in m; ``support`` 0: 1.1 + 2·jitter spacings (``support_for_jitter``);
    ``h_staggering``: "edges" (Yee's) or "centres" (None: Yee's for FPM, cell centres for the thesis's "cspm" and
    "sph", printed for that layout);
    ``conservative``: the model's option (None: on for FPM); ``pair_order``: the conservative pair's (2: also the
    quadratic moments, for jittered layouts); ``kronecker``: impose the initial profile as the
    SPH interpolant's values (nodal values solved once; "sph"/"cspm" only)."""
    params = dict(locals())
    require_positive("radius", radius)
    require_positive("eps_r", eps_r)
    spacing = radius / require_positive("cells_per_radius", cells_per_radius)
    centre = np.array([radius, radius])
    with reported_as(spacing="cells_per_radius"):
        layout = staggered_disk(centre, radius, spacing, jitter=jitter, seed=seed,
                                h_staggering=h_staggering or ("edges" if scheme == "fpm" else "centres"))
    model = SPEMModel(layout, scheme=scheme, support=support or support_for_jitter(jitter), eps_r=eps_r,
                      conservative=conservative, pair_order=pair_order)
    r_e = np.hypot(*(layout.e_position[:, :2] - centre).T)
    solver = SPEMSolver(model, ez=lambda p: 1.0 - np.sum((p[:, :2] - centre) ** 2, axis=1) / radius**2,
                        kronecker=kronecker, courant=courant)
    # with ``kronecker`` the particle values are nodal parameters: the field is their SPH interpolant
    field = NodalValues.from_set(model.electric, 2).field if kronecker else (lambda u: u)
    on_line = (np.abs(layout.e_position[:, 0] - centre[0]) < 0.5 * spacing) & (layout.e_position[:, 1] >= centre[1])

    def errors(s, t):
        ez = field(s.electric.numpy("ez"))
        exact = cavity_field(r_e, t - 0.5 * dt, radius, eps_r)
        return np.abs(ez - exact)

    def mean_error(s, t):
        return float(np.mean(errors(s, t))) if t > 0 else 0.0

    def line_error(s, t):
        return float(np.mean(errors(s, t)[on_line])) if t > 0 else 0.0

    def cavity_analysis(run, out_dir):
        s = run.solver
        t_e = s.t - 0.5 * dt
        ez = field(s.electric.numpy("ez"))
        order = np.argsort(r_e[on_line])
        rr = r_e[on_line][order]
        _plot(os.path.join(out_dir, "cavity.png"), rr, ez[on_line][order], cavity_field(rr, t_e, radius, eps_r), t_e)
        return {"cavity": {"mean_error": run.series["mean_error"][-1], "line_error": run.series["line_error"][-1],
                           "max_mean_error": max(run.series["mean_error"]), "max_line_error": max(run.series["line_error"]),
                           "spacing": spacing, "dt": dt, "courant": dt / s.stable_dt(),
                           "periods": t_e * 2.405 * 299_792_458.0 / (2 * math.pi * radius * math.sqrt(eps_r))}}

    run = TimeLoop(solver, t_end=t_end, output_interval=output_interval, name="em_cavity_2d", params=params,
                    probes={"mean_error": mean_error, "line_error": line_error}, analyses=[cavity_analysis],
                    output=OutputOptions(vtk=vtk, frames=frames, frame_bounds=((0.0, 2 * radius), (0.0, 2 * radius))))
    dt = run.step_size  # the constant step the loop chose: the analyses' E lags H by half of it
    return run


def _plot(path, r, ez, exact, t):
    from warpfree.io.frames import plot_series

    plot_series(path, None, {"SPEM Ez": (r, ez), "Bessel series (4.5)": (r, exact)}, xlabel="r (m)",
                ylabel="Ez (V/m)", title=f"Circular cavity, t = {t * 1e9:.2f} ns")
