"""SPHERIC benchmark test 2 (Kleefsman et al. 2005): the experiment's pressures and water heights, the sensors'
positions, and the figures a run is compared on.

The record (``spheric2_kleefsman_2005.csv``, README.md for its source) holds the pressures P1-P8 (Pa) on the obstacle
and the water heights H1-H4 (m) at about 1 kHz from the release to t = 2.5 s. The figures of a pressure series
(:func:`pressure_figures`) are those a transducer's record is read by: the first impact (the first 5 ms mean above
0.05 ρ g H), the peak of the 5 ms running mean (a transducer averages over its face; the record itself averages about
0.4 ms), and the mean over the quasi-steady 1.2-2.0 s. A height series is compared by its rms difference from the
record, in units of the record's range (:func:`height_rms`).
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import read_csv
from warpfree.validation import running_mean as shared_running_mean

__all__ = ["KLEEFSMAN", "SENSORS", "COLUMN_HEIGHT", "RHO_G_H", "ARRIVAL", "MEAN_WINDOW", "running_mean",
           "pressure_figures", "height_rms", "EXPERIMENT", "PRESSURE_SENSORS", "HEIGHT_SENSORS", "HEIGHT_TOLERANCE",
           "HEIGHT_CHECKED_FROM",
           "compare", "height_checks", "plot_sensors"]

CASE = "dam_break_3d"

_COLUMNS = ["t_s"] + [f"P{k}_Pa" for k in range(1, 9)] + [f"H{k}_m" for k in range(1, 5)]

_header, _data = read_csv(CASE, "spheric2_kleefsman_2005.csv")
if _header != _COLUMNS:
    raise ValueError(f"validation data {CASE}/spheric2_kleefsman_2005.csv: header {_header}, expected {_COLUMNS}")

#: the experiment's record: "t" (s), "P1".."P8" (Pa), "H1".."H4" (m), each an array over the same times
KLEEFSMAN = {name.split("_")[0]: _data[:, k] for k, name in enumerate(_COLUMNS)}

#: the sensors' positions (m; z up, the tank from (0, 0, 0) to (3.22, 1, 1), the obstacle's front face at x = 0.8245):
#: pressures on the obstacle's front face (P1-P4) and top (P5-P8), water-height gauges (H1-H4: x, y)
SENSORS = {"P1": (0.8245, 0.471, 0.021), "P2": (0.8245, 0.471, 0.061), "P3": (0.8245, 0.471, 0.101),
           "P4": (0.8245, 0.471, 0.141), "P5": (0.8035, 0.471, 0.161), "P6": (0.7635, 0.471, 0.161),
           "P7": (0.7235, 0.471, 0.161), "P8": (0.6835, 0.471, 0.161),
           "H1": (0.496, 0.5), "H2": (0.992, 0.5), "H3": (1.488, 0.5), "H4": (2.638, 0.5)}

#: the water column's height H (m) and ρ g H (Pa, ρ = 1000 kg/m³, g = 9.81 m/s²): the pressure scale
COLUMN_HEIGHT = 0.55
RHO_G_H = 1000.0 * 9.81 * COLUMN_HEIGHT

#: a pressure series' first impact: its first 5 ms mean above this fraction of ρ g H
ARRIVAL = 0.05
#: the quasi-steady stretch whose mean is compared (s)
MEAN_WINDOW = (1.2, 2.0)


def running_mean(t: np.ndarray, values: np.ndarray, width: float = 0.005) -> np.ndarray:
    """The mean of ``values`` over ``width`` seconds (5 ms) centred on each sample
    (:func:`warpfree.validation.running_mean`)."""
    return shared_running_mean(t, values, width)


def pressure_figures(t, p) -> dict:
    """The figures of a pressure series (t in s, p in Pa): ``arrival`` (s, the first 5 ms mean above ARRIVAL ρ g H;
    None if never), ``peak`` (Pa, the largest 5 ms mean) and ``peak_time`` (s), ``mean`` (Pa, over MEAN_WINDOW, None
    if the series does not cover it)."""
    t, p = np.asarray(t, dtype=np.float64), np.asarray(p, dtype=np.float64)
    mean5 = running_mean(t, p)
    above = np.flatnonzero(mean5 > ARRIVAL * RHO_G_H)
    window = (t >= MEAN_WINDOW[0]) & (t <= MEAN_WINDOW[1])
    covered = t[-1] >= MEAN_WINDOW[1] - 0.01
    k = int(np.argmax(mean5))
    return {"arrival": float(t[above[0]]) if above.size else None, "peak": float(mean5[k]),
            "peak_time": float(t[k]), "mean": float(p[window].mean()) if covered and window.any() else None}


def height_rms(t, h, gauge: str) -> dict:
    """A water-height series (t in s, h in m) against the record of ``gauge`` over the times both cover: ``rms``
    (m), ``range`` (m, the record's max - min there) and ``rms_of_range`` (their ratio; None where the record is
    flat, before the water comes)."""
    t, h = np.asarray(t, dtype=np.float64), np.asarray(h, dtype=np.float64)
    te, he = KLEEFSMAN["t"], KLEEFSMAN[gauge]
    inside = (te >= t[0]) & (te <= t[-1])
    diff = np.interp(te[inside], t, h) - he[inside]
    rms = float(np.sqrt(np.mean(diff ** 2)))
    span = float(he[inside].max() - he[inside].min())
    return {"rms": rms, "range": span, "rms_of_range": rms / span if span > 0 else None}


#: the experiment's own figures: P1-P4 by :func:`pressure_figures`
EXPERIMENT = {name: pressure_figures(KLEEFSMAN["t"], KLEEFSMAN[name]) for name in ("P1", "P2", "P3", "P4")}

#: the sensors a run of the scene records (every 1 ms; the gauges every 5 ms) and the checks' tolerance on the gauges:
#: their rms difference from the record within 10 % of its range
PRESSURE_SENSORS, HEIGHT_SENSORS = ("P1", "P3"), ("H2", "H4")
HEIGHT_TOLERANCE = 0.10
#: the shortest run whose gauges are checked (s): past the water's arrival at H2 and its first rise there
HEIGHT_CHECKED_FROM = 1.0
SOURCE = ("Kleefsman et al. 2005, J. Comput. Phys. 206:363, the SPHERIC test 2 record "
          "(warpfree/validation/dam_break_3d/README.md)")


def compare(series: dict) -> dict:
    """A run's sensors against the record: ``series`` maps P1, P3, H2, H4 to (t, value) rows. Per pressure sensor
    its :func:`pressure_figures` with ``arrival_error`` and ``mean_error`` (fractions) and ``peak_ratio``; per gauge
    its :func:`height_rms`."""
    out = {}
    for name in PRESSURE_SENSORS:
        rows = np.asarray(series[name], dtype=np.float64)
        f = pressure_figures(rows[:, 0], rows[:, 1])
        e = EXPERIMENT[name]
        f["arrival_error"] = None if f["arrival"] is None else f["arrival"] / e["arrival"] - 1.0
        f["peak_ratio"] = f["peak"] / e["peak"]
        f["mean_error"] = None if f["mean"] is None else f["mean"] / e["mean"] - 1.0
        out[name] = f
    for name in HEIGHT_SENSORS:
        rows = np.asarray(series[name], dtype=np.float64)
        out[name] = height_rms(rows[:, 0], rows[:, 1], name)
    return out


def height_checks(figures: dict, t_end: float) -> dict:
    """The gauges' checks (:func:`warpfree.validation.tolerance_check`), for a run to HEIGHT_CHECKED_FROM s or
    longer (the water reaches H2 at 0.4 s): each rms within HEIGHT_TOLERANCE of the record's range over the run. The
    pressures are compared, not checked (README.md: their first impact is 3-11 % late and their peaks 3-6 times
    the record's at the spacings two cores allow)."""
    from warpfree.validation import tolerance_check

    if t_end < HEIGHT_CHECKED_FROM - 1e-9:
        return {}
    return {f"{name}_rms_of_range": tolerance_check(
        figures[name]["rms_of_range"], HEIGHT_TOLERANCE, SOURCE + f": the water height {name} at "
        f"x = {SENSORS[name][0]} m, over the run's times", basis="the water's arrival and depth where it runs: the "
        "scene reaches 5.7-7.3 % (H2) and 1.6-3.1 % (H4) of the range from dx = 0.05 m down, 1 or 2 s")
        for name in HEIGHT_SENSORS}


def plot_sensors(path: str, series: dict, figures: dict, dx: float) -> None:
    """P1 and P3 (5 ms means, kPa) and H2 and H4 (m) against the record, over the run's times."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(7.5, 6.0)
    top, bottom = fig.subplots(2, 1, sharex=True)
    t_end = max(float(np.asarray(series[n])[-1, 0]) for n in series)
    te = KLEEFSMAN["t"]
    shown = te <= t_end
    for name, colour in zip(PRESSURE_SENSORS, ("C0", "C1")):
        rows = np.asarray(series[name])
        top.plot(rows[:, 0], running_mean(rows[:, 0], rows[:, 1]) / 1e3, colour, lw=0.8, label=f"warpfree {name}")
        top.plot(te[shown], running_mean(te, KLEEFSMAN[name])[shown] / 1e3, colour, lw=0.8, ls=":",
                 label=f"experiment {name}")
    for name, colour in zip(HEIGHT_SENSORS, ("C2", "C3")):
        rows = np.asarray(series[name])
        share = figures[name]["rms_of_range"]
        bottom.plot(rows[:, 0], rows[:, 1], colour, lw=1.0, label=f"warpfree {name}" + (
            f" (rms {100 * share:.1f} % of range)" if share is not None else ""))
        bottom.plot(te[shown], KLEEFSMAN[name][shown], colour, lw=0.8, ls=":", label=f"experiment {name}")
    p1 = figures["P1"]
    top.set_title(f"SPHERIC test 2, dx = {dx:g} m: pressures on the obstacle (5 ms means) and water heights\n"
                  f"P1 first impact {p1['arrival'] or float('nan'):.3f} s ({EXPERIMENT['P1']['arrival']:.3f}), peak "
                  f"{p1['peak'] / 1e3:.1f} kPa ({EXPERIMENT['P1']['peak'] / 1e3:.1f})", fontsize=9)
    top.set_ylabel("p (kPa)")
    bottom.set_ylabel("h (m)")
    bottom.set_xlabel("t (s)")
    for ax in (top, bottom):
        ax.legend(fontsize=7, ncol=2)
        ax.grid(alpha=0.3)
    save_figure(fig, path)
