"""A sine source in the middle of a line (Mendes 2010, §4.2): the exact 1D wave (no data files, see ``README.md``).

A hard source Ez(x_s, t) = sin(ωt) switched on at t = 0 in vacuum radiates both ways at c; before the
fronts reach the ends (|x - x_s| < c t) the exact field is

    Ez(x, t) = sin(ω (t - |x - x_s|/c))  for |x - x_s| < c t,  0 beyond the fronts.        (4.3 with the delay)

The functions take NumPy arrays (float64). Units SI (m, s, Hz, V/m).
"""

from __future__ import annotations

import numpy as np

__all__ = ["line_wave", "mean_error", "wavelength_from_crossings"]

C0 = 299_792_458.0


def line_wave(x, t: float, x_source: float, frequency: float) -> np.ndarray:
    """Exact Ez (V/m) of a unit hard sine source at ``x_source`` switched on at t = 0."""
    x = np.asarray(x, np.float64)
    delay = np.abs(x - x_source) / C0
    return np.where(delay < t, np.sin(2.0 * np.pi * frequency * (t - delay)), 0.0)


def mean_error(x, values, t: float, x_source: float, frequency: float, window=(0.5, 1.5)) -> float:
    """Mean |Ez - exact| (V/m) over the points with x in ``window`` (the thesis's measure, §4.2: z in (0.5, 1.5))."""
    x = np.asarray(x, np.float64)
    sel = (x > window[0]) & (x < window[1])
    return float(np.mean(np.abs(np.asarray(values, np.float64)[sel] - line_wave(x[sel], t, x_source, frequency))))


def wavelength_from_crossings(x, values, window) -> float:
    """Wavelength (m) from the zero crossings of ``values`` along ``x`` inside ``window``: twice the mean
    distance between consecutive crossings, each located by linear interpolation."""
    x = np.asarray(x, np.float64)
    v = np.asarray(values, np.float64)
    order = np.argsort(x)
    x, v = x[order], v[order]
    sel = (x > window[0]) & (x < window[1])
    x, v = x[sel], v[sel]
    k = np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)
    if k.size < 3:
        raise ValueError("fewer than three zero crossings in the window")
    crossings = x[k] - v[k] * (x[k + 1] - x[k]) / (v[k + 1] - v[k])
    return float(2.0 * np.mean(np.diff(crossings)))
