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

__all__ = ["KLEEFSMAN", "SENSORS", "COLUMN_HEIGHT", "RHO_G_H", "ARRIVAL", "MEAN_WINDOW", "running_mean",
           "pressure_figures", "height_rms", "EXPERIMENT"]

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
    """The mean of ``values`` over ``width`` seconds centred on each sample (fewer samples at the ends): a series
    sampled every Δt averages round(width/Δt) samples."""
    t, values = np.asarray(t, dtype=np.float64), np.asarray(values, dtype=np.float64)
    n = max(1, int(round(width / float(np.median(np.diff(t))))))
    kernel = np.ones(n)
    return np.convolve(values, kernel, mode="same") / np.convolve(np.ones_like(values), kernel, mode="same")


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
    (m), ``range`` (m, the record's max - min there) and ``rms_of_range`` (their ratio)."""
    t, h = np.asarray(t, dtype=np.float64), np.asarray(h, dtype=np.float64)
    te, he = KLEEFSMAN["t"], KLEEFSMAN[gauge]
    inside = (te >= t[0]) & (te <= t[-1])
    diff = np.interp(te[inside], t, h) - he[inside]
    rms = float(np.sqrt(np.mean(diff ** 2)))
    span = float(he[inside].max() - he[inside].min())
    return {"rms": rms, "range": span, "rms_of_range": rms / span}


#: the experiment's own figures: P1-P4 by :func:`pressure_figures`
EXPERIMENT = {name: pressure_figures(KLEEFSMAN["t"], KLEEFSMAN[name]) for name in ("P1", "P2", "P3", "P4")}
