"""Dam-break surge-front reference data (Martin & Moyce 1952; Koshizuka & Oka 1996).

Normalisation (Martin & Moyce's): Z = x_front / a, T = t sqrt(n² g / a), with a the initial column width
and n² a the column height. Two aspect ratios have data: n² = 2 (height 2a, T = t sqrt(2g/a): three data
sets, ``DATASETS``) and n² = 1 (a square column, T = t sqrt(g/a): ``DATASETS_SQUARE``).

The data live in this folder as CSV files, one per data set; ``README.md`` next to them gives each
experiment, where the digitisation comes from and how it was transcribed:

- ``surge_front_martin_moyce_1952.csv`` (``T,Z``): PySPH's ``mm_data_1`` (``pysph/examples/db_exp_data.py``),
  Martin & Moyce, a = 1.125 in;
- ``surge_front_koshizuka_oka_1996_pysph.csv`` (``T,Z``): PySPH's ``ko_data``, Koshizuka & Oka's experiment;
- ``surge_front_koshizuka_oka_1996_dualsphysics.csv`` (``t_s,x_front_m``): DualSPHysics' digitisation of
  Koshizuka & Oka in physical units for a = 1 m;
- ``surge_front_martin_moyce_1952_square.csv`` (``T,Z`` with T = t sqrt(g/a)): Martin & Moyce's square
  column, a = 2¼ in, as plotted in Xie (2021), Fig. 7, digitised from that figure.

The data sets disagree with each other by up to ~0.2 in Z at the same T <= 2.5; the tolerance
(±0.15 in Z for T <= 2.5) is of that order.
"""

import numpy as np

from warpfree.validation import read_csv

__all__ = ["MARTIN_MOYCE", "KOSHIZUKA_OKA", "KOSHIZUKA_OKA_DSPH_SI", "KOSHIZUKA_OKA_DSPH", "DATASETS",
           "MARTIN_MOYCE_SQUARE", "DATASETS_SQUARE", "datasets_for", "front_errors", "plot_front"]

CASE = "dam_break_2d"


def _load(filename: str, columns: list[str]) -> np.ndarray:
    header, data = read_csv(CASE, filename)
    if header != columns:
        raise ValueError(f"validation data {CASE}/{filename}: header {header}, expected {columns}")
    return data


#: Martin & Moyce (1952), n² = 2, a = 1.125 in: (T, Z)
MARTIN_MOYCE = _load("surge_front_martin_moyce_1952.csv", ["T", "Z"])

#: Koshizuka & Oka (1996), experiment: (T, Z)
KOSHIZUKA_OKA = _load("surge_front_koshizuka_oka_1996_pysph.csv", ["T", "Z"])

#: Koshizuka & Oka (1996), second digitisation, in physical units for a = 1 m (column 1 m x 2 m),
#: distributed with DualSPHysics (``examples/main/01_DamBreak/EXP_X-DamTipPosition_Koshizula&Oka1996.txt``,
#: transcribed in anchors.md §1.4a): (t [s], x_front [m]). It agrees with Martin & Moyce within 0.07 in Z
#: and differs from PySPH's digitisation of the same experiment by up to 0.2 in Z at T ≈ 2.3 (README.md).
KOSHIZUKA_OKA_DSPH_SI = _load("surge_front_koshizuka_oka_1996_dualsphysics.csv", ["t_s", "x_front_m"])
#: the same in (T, Z) with g = 9.81 m/s²
KOSHIZUKA_OKA_DSPH = np.column_stack([KOSHIZUKA_OKA_DSPH_SI[:, 0] * np.sqrt(2 * 9.81 / 1.0),
                                      KOSHIZUKA_OKA_DSPH_SI[:, 1] / 1.0])

DATASETS = {
    "Martin & Moyce 1952": MARTIN_MOYCE,
    "Koshizuka & Oka 1996": KOSHIZUKA_OKA,
    "Koshizuka & Oka 1996 (DualSPHysics digitisation)": KOSHIZUKA_OKA_DSPH,
}

#: Martin & Moyce (1952), square column (n² = 1), a = 2¼ in, as plotted in Xie (2021) Fig. 7: (T, Z) with
#: T = t sqrt(g/a)
MARTIN_MOYCE_SQUARE = _load("surge_front_martin_moyce_1952_square.csv", ["T", "Z"])

DATASETS_SQUARE = {"Martin & Moyce 1952, square column": MARTIN_MOYCE_SQUARE}


def datasets_for(height_ratio: float) -> dict:
    """The data sets of a column of height ``height_ratio`` × a (n²): 2 or 1; none for other ratios."""
    return {2.0: DATASETS, 1.0: DATASETS_SQUARE}.get(float(height_ratio), {})


def front_errors(t: np.ndarray, x_front: np.ndarray, a: float, g: float, t_max: float | None = 2.5,
                 height_ratio: float = 2.0) -> dict:
    """Z_sim - Z_exp at every experimental point with T <= t_max (None: every point the run covers), per
    data set of the column's aspect ratio n² = ``height_ratio``, with T = t sqrt(n² g / a), Z = x_front / a.

    The simulated front is interpolated linearly in T. Returns {dataset: {"T": [...], "dZ": [...],
    "max_abs": float}} and "max_abs" over all of them.
    """
    T = np.asarray(t) * np.sqrt(height_ratio * g / a)
    Z = np.asarray(x_front) / a
    t_max = np.inf if t_max is None else t_max
    out: dict = {}
    worst = 0.0
    for name, data in datasets_for(height_ratio).items():
        sel = (data[:, 0] <= t_max) & (data[:, 0] <= T.max()) & (data[:, 0] >= T.min())
        dz = np.interp(data[sel, 0], T, Z) - data[sel, 1]
        m = float(np.max(np.abs(dz))) if dz.size else float("nan")
        out[name] = {"T": data[sel, 0].tolist(), "dZ": dz.tolist(), "max_abs": m}
        if dz.size:
            worst = max(worst, m)
    out["max_abs"] = worst
    return out


def plot_front(path: str, t, x_front, a: float, g: float, max_err: float, height_ratio: float = 2.0,
               t_max: float | None = 2.5) -> None:
    """Z against T = t sqrt(n² g/a): simulation line, experiments as markers, the ±0.15 band around the simulation."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    T = np.asarray(t) * np.sqrt(height_ratio * g / a)
    Z = np.asarray(x_front) / a
    fig = Figure(figsize=(6, 4.2), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.fill_between(T, Z - 0.15, Z + 0.15, color="C0", alpha=0.15, label="warpfree ± 0.15")
    ax.plot(T, Z, "C0-", lw=2, label="warpfree WCSPH")
    for (name, data), m in zip(datasets_for(height_ratio).items(), ("o", "s", "^")):
        ax.plot(data[:, 0], data[:, 1], m, mfc="none", label=name)
    if t_max is not None:
        ax.axvline(t_max, color="0.6", ls=":", lw=1)
    ax.set_xlim(0, max(3.0, T.max()))
    ax.set_ylim(1, max(4.0, Z.max() + 0.2))
    ax.set_xlabel(f"T = t √({height_ratio:g} g/a)")
    ax.set_ylabel("Z = x_front / a")
    span = f"T ≤ {t_max:g}" if t_max is not None else "the run"
    ax.set_title(f"Dam break, column {height_ratio:g}a high: max |ΔZ| = {max_err:.3f} over {span}")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
