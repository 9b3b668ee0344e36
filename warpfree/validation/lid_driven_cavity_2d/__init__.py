"""Lid-driven cavity reference data: Ghia, Ghia & Shin (1982), the centreline velocities at Re = 100, 400, 1000.

A square cavity of side L, its lid sliding at U along x, the other walls at rest (no-slip); Re = U L/ν. Ghia et al.
solved the steady Navier–Stokes equations by a multigrid vorticity–stream-function method on a 129 x 129 grid and
tabled the velocity on the cavity's two centrelines (their Tables I and II):

- ``ghia_1982_u_vertical_centreline.csv`` (``y_over_L,u_over_U_Re100,u_over_U_Re400,u_over_U_Re1000``): u/U on the
  vertical centreline x = L/2 at 17 heights y/L;
- ``ghia_1982_v_horizontal_centreline.csv`` (``x_over_L,v_over_U_Re100,v_over_U_Re400,v_over_U_Re1000``): v/U on
  the horizontal centreline y = L/2 at 17 abscissae x/L.

``README.md`` next to them gives the source and the transcription. The scene's error (:func:`centreline_errors`) is
the rms over the 15 interior points of each line (the end points lie on the walls, where the velocity is the wall's),
in units of U; its check (:func:`cavity_checks`) bounds it by :data:`PROFILE_TOLERANCE` at Re = 100.
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import read_csv, tolerance_check

__all__ = ["CASE", "REYNOLDS", "U_FILE", "V_FILE", "reference", "interior_points", "centreline_errors",
           "PROFILE_TOLERANCE", "cavity_checks", "plot_cavity"]

CASE = "lid_driven_cavity_2d"
U_FILE = "ghia_1982_u_vertical_centreline.csv"
V_FILE = "ghia_1982_v_horizontal_centreline.csv"
#: the Reynolds numbers the tables hold
REYNOLDS = (100, 400, 1000)

#: the largest rms difference from Ghia et al. over both centrelines' interior points, in units of U, at Re = 100
PROFILE_TOLERANCE = 0.02


def reference(reynolds: float) -> dict[str, np.ndarray]:
    """Ghia et al.'s centreline velocities at ``reynolds`` (one of :data:`REYNOLDS`): ``y`` and ``u`` (u/U on x = L/2)
    and ``x`` and ``v`` (v/U on y = L/2), in the tables' order (from the lid down, from the right wall leftwards)."""
    if reynolds not in REYNOLDS:
        raise ValueError(f"Ghia et al. (1982) table the centrelines at Re = {', '.join(map(str, REYNOLDS))}, not "
                         f"{reynolds:g}")
    column = 1 + REYNOLDS.index(int(reynolds))
    _, u = read_csv(CASE, U_FILE)
    _, v = read_csv(CASE, V_FILE)
    return {"y": u[:, 0], "u": u[:, column], "x": v[:, 0], "v": v[:, column]}


def interior_points(reynolds: float) -> dict[str, np.ndarray]:
    """:func:`reference` without the points on the walls (y = 0, L on the vertical line, x = 0, L on the other)."""
    ref = reference(reynolds)
    iu = (ref["y"] > 0.0) & (ref["y"] < 1.0)
    iv = (ref["x"] > 0.0) & (ref["x"] < 1.0)
    return {"y": ref["y"][iu], "u": ref["u"][iu], "x": ref["x"][iv], "v": ref["v"][iv]}


def centreline_errors(u: np.ndarray, v: np.ndarray, reynolds: float) -> dict[str, float]:
    """The differences from Ghia et al. of ``u`` (u/U at :func:`interior_points`' ``y`` on x = L/2) and ``v`` (v/U
    at its ``x`` on y = L/2): rms over both lines (``rms``), over each (``u_rms``, ``v_rms``), the largest
    (``max``), all in units of U; and the smallest u on the vertical line (``u_min``) beside Ghia's."""
    ref = interior_points(reynolds)
    du = np.asarray(u, float) - ref["u"]
    dv = np.asarray(v, float) - ref["v"]
    both = np.concatenate([du, dv])
    return {"rms": float(np.sqrt(np.mean(both ** 2))), "u_rms": float(np.sqrt(np.mean(du ** 2))),
            "v_rms": float(np.sqrt(np.mean(dv ** 2))), "max": float(np.max(np.abs(both))),
            "u_min": float(np.min(u)), "u_min_ghia": float(np.min(ref["u"]))}


def cavity_checks(errors: dict, reynolds: float, n: int) -> dict:
    """The scene's check at Re = 100: the rms difference from Ghia et al. over both centrelines within
    :data:`PROFILE_TOLERANCE` of U (none at other Reynolds numbers: compared, not checked)."""
    if int(reynolds) != 100:
        return {}
    return {"centreline_rms": tolerance_check(
        errors["rms"], PROFILE_TOLERANCE,
        "Ghia, Ghia & Shin 1982 (doi:10.1016/0021-9991(82)90058-4), Tables I-II; "
        "warpfree/validation/lid_driven_cavity_2d/README.md", unit="U",
        basis=f"2 % of the lid speed over the 30 interior centreline points, time-averaged, at n = {n}")}


def plot_cavity(path: str, reynolds: float, y_line: np.ndarray, u_line: np.ndarray, x_line: np.ndarray,
                v_line: np.ndarray, errors: dict, label: str) -> None:
    """u/U against y/L on x = L/2 and v/U against x/L on y = L/2 (lines: the run's time-averaged profiles), with
    Ghia et al.'s points."""
    from warpfree.io.validation_plots import new_figure, save_figure

    ref = reference(reynolds)
    fig = new_figure(10.5, 4.4)
    a1, a2 = fig.subplots(1, 2)
    a1.plot(u_line, y_line, "-", lw=1.2, label=label)
    a1.plot(ref["u"], ref["y"], "o", ms=4, mfc="none", color="k", label="Ghia et al. 1982")
    a1.set_xlabel("u/U on x = L/2")
    a1.set_ylabel("y/L")
    a2.plot(x_line, v_line, "-", lw=1.2, label=label)
    a2.plot(ref["x"], ref["v"], "o", ms=4, mfc="none", color="k", label="Ghia et al. 1982")
    a2.set_xlabel("x/L")
    a2.set_ylabel("v/U on y = L/2")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"Lid-driven cavity, Re = {reynolds:g}: rms difference {100 * errors['rms']:.2f} % of U "
                 f"(u {100 * errors['u_rms']:.2f} %, v {100 * errors['v_rms']:.2f} %)", fontsize=10)
    save_figure(fig, path)
