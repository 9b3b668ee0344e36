"""Field monitors of SPEM: running discrete Fourier transforms of Ez, Hx and Hy at any points, accumulated on the device
every step.

A :class:`DFTMonitor` records F(f) = Σ_n u(t_n) e^{-2πi f t_n} Δt (V·s/m for Ez, A·s/m for H) at chosen frequencies from
``start`` on, each field at its own staggered time (Ez at t + Δt/2, H at t + Δt: the transform's phase is exact for
both). Meep's DFT monitors do the same; over a window of whole periods of a steady wave of amplitude A and phase φ,
2F/T = A e^{iφ}/i (sin(2πft + φ) = Im e^{i(2πft + φ)}), which the written ``amplitude`` and ``phase`` give.

The transform is linear in the field, so it is accumulated at the particles a point's value is read from and
interpolated at output: a point's value is the quadratic least-squares fit (MLS) of the 12 nearest particles of the
field's set in 2D, weights exp(-(r/Δ)²) (3 in 1D: Lagrange's parabola), exact on a particle; the error is
O((kΔ)³) of the amplitude away from material interfaces and walls (next to them the field's derivative jumps and the
fit is first order there). Each rank accumulates its own particles; a checkpoint holds the sums (restored on resume).

A :class:`FluxMonitor` is a DFT monitor of Ez, Hx and Hy on a path (a polyline, closed or open; a point in 1D) that
integrates the Poynting vector S = E × H = (-Ez Hy, Ez Hx) through it, with n the path's right-hand normal (outward
for a counter-clockwise closed path; +x in 1D):

- ``power``: the time-averaged power of a steady wave, ½ Re ∫ Ẽ (H̃ × ...)·n dl from the window's amplitudes
  (W/m in 2D, W/m² in 1D);
- ``spectrum``: Re ∫ F_E F_H*·n dl of the raw transforms (W s²/m in 2D), Meep's flux spectrum: the ratio of two
  runs' spectra is a transmission or reflection at every frequency a pulse carries.

The path is cut into pieces no longer than half a spacing, each read at its midpoint (the midpoint rule: second
order).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from warpfree.errors import ParameterError, require_finite

from .layouts import HX, HY, StaggeredLayout
from .model import C0

__all__ = ["DFTMonitor", "FluxMonitor", "interpolation_rows", "window_weights", "FIELD_UNITS"]

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")

#: the units of a field and of its transform
FIELD_UNITS = {"ez": ("V/m", "V s/m"), "hx": ("A/m", "A s/m"), "hy": ("A/m", "A s/m")}

#: the fewest particles per wavelength (in the slowest medium) at which a monitor's frequency is resolved: below it
#: the scheme's phase error passes 10 % a wavelength (Yee's dispersion at 4 per wavelength)
RESOLVED_PER_WAVELENGTH = 4.0


@dataclass
class DFTMonitor:
    """Running DFTs named ``name`` of ``fields`` (of "ez", "hx", "hy") at ``points`` (M, dim) (m), at ``frequencies`` (Hz),
    accumulated over the window from ``start`` to ``stop`` (s; its ends anywhere, the steps at them cut)."""

    name: str
    points: np.ndarray
    frequencies: tuple
    fields: tuple = ("ez",)
    start: float = 0.0
    stop: float = math.inf

    def checked(self, layout: StaggeredLayout, slowest: float) -> "DFTMonitor":
        """This monitor checked against ``layout`` (points inside it, ``slowest`` the largest √(εr μr)): refusals name
        ``monitor`` and say why."""
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ParameterError("monitor", f"a monitor's name is letters, digits, '_', '.' or '-' (a file name), got "
                                            f"{self.name!r}")
        dim = layout.dim
        try:
            pts = np.asarray(self.points, dtype=np.float64).reshape(-1, dim) if np.size(self.points) else None
        except (TypeError, ValueError):
            pts = None
        if pts is None or not np.all(np.isfinite(pts)):
            raise ParameterError("monitor", f"{self.name}: points must be finite ({dim} coordinates each)")
        full = np.zeros((pts.shape[0], 3))
        full[:, :dim] = pts
        outside = ~layout.inside(full) if layout.inside is not None else np.zeros(pts.shape[0], bool)
        if np.any(outside):
            k = int(np.flatnonzero(outside)[0])
            raise ParameterError("monitor", f"{self.name}: point {k} at {pts[k].tolist()} lies outside the domain")
        freq = np.atleast_1d(np.asarray(self.frequencies, dtype=np.float64))
        if freq.size == 0 or not np.all(np.isfinite(freq)) or np.any(freq <= 0):
            raise ParameterError("monitor", f"{self.name}: frequencies must be finite and > 0 Hz")
        top = C0 / (slowest * RESOLVED_PER_WAVELENGTH * layout.spacing)
        if freq.max() > top:
            raise ParameterError("monitor", f"{self.name}: {freq.max():.4g} Hz is above the resolved band (at most "
                                            f"{top:.4g} Hz: {RESOLVED_PER_WAVELENGTH:g} particles per wavelength in "
                                            f"the slowest medium)")
        fields = tuple(self.fields)
        for f in fields:
            if f not in FIELD_UNITS or (layout.dim == 1 and f == "hx"):
                raise ParameterError("monitor", f"{self.name}: fields are of {sorted(FIELD_UNITS)} (no hx in 1D), got "
                                                f"{f!r}")
        if len(set(fields)) != len(fields) or not fields:
            raise ParameterError("monitor", f"{self.name}: name each field once")
        require_finite("monitor", self.start)
        if not float(self.stop) > float(self.start):  # NaN included
            raise ParameterError("monitor", f"{self.name}: the window's stop ({self.stop!r} s) must come after its start "
                                            f"({self.start!r} s)")
        return DFTMonitor(self.name, full, tuple(float(f) for f in freq), fields, float(self.start), float(self.stop))


def interpolation_rows(particles: np.ndarray, points: np.ndarray, dim: int, spacing: float) -> sp.csr_matrix:
    """(M, N) weights reading a field at ``points`` from its values at ``particles`` (module docstring): a point on a
    particle (within 1e-9 Δ) reads it alone."""
    from scipy.spatial import cKDTree

    x, p = particles[:, :dim], points[:, :dim]
    k = min(3 if dim == 1 else 12, x.shape[0])
    distance, near = cKDTree(x).query(p, k=k)
    distance, near = distance.reshape(p.shape[0], k), near.reshape(p.shape[0], k)
    rows = np.repeat(np.arange(p.shape[0]), k)
    weights = np.zeros((p.shape[0], k))
    for m in range(p.shape[0]):
        if distance[m, 0] <= 1e-9 * spacing:
            weights[m, 0] = 1.0
            continue
        d = (x[near[m]] - p[m]) / spacing
        if dim == 1:
            basis = np.stack([np.ones(k), d[:, 0], d[:, 0] ** 2], axis=1)
        else:
            basis = np.stack([np.ones(k), d[:, 0], d[:, 1], d[:, 0] ** 2, d[:, 0] * d[:, 1], d[:, 1] ** 2], axis=1)
        w = np.exp(-np.sum(d * d, axis=1))
        moment = basis.T @ (w[:, None] * basis)
        if np.linalg.cond(moment) > 1e10:
            raise ParameterError("monitor", f"the particles around the point {p[m].tolist()} do not fix a quadratic "
                                            f"fit (too few or collinear)")
        weights[m] = np.linalg.solve(moment, basis.T * w)[0]
    out = sp.csr_matrix((weights.ravel(), (rows, near.ravel())), shape=(p.shape[0], x.shape[0]))
    out.eliminate_zeros()
    return out


def field_particles(layout: StaggeredLayout, field: str) -> np.ndarray:
    """The indices, in its set, of the particles that carry ``field`` (every E particle for Ez; under Yee's staggering
    the H particles of that component)."""
    if field == "ez":
        return np.arange(layout.n_e)
    if layout.h_carries is None:
        return np.arange(layout.n_h)
    return np.flatnonzero(layout.h_carries == (HX if field == "hx" else HY))


def window_weights(times: np.ndarray, dt: float, start: float, stop: float) -> np.ndarray:
    """The part (s) of each sample's step [t - Δt/2, t + Δt/2] inside the window [start, stop]: Δt when the step lies
    inside to 1e-6 Δt, else the overlap (``kernels/spem_monitors.py: window_weight``, the same rule)."""
    low, high = times - 0.5 * dt, times + 0.5 * dt
    inside = (low >= start - 1e-6 * dt) & (high <= stop + 1e-6 * dt)
    return np.where(inside, dt, np.maximum(0.0, np.minimum(high, stop) - np.maximum(low, start)))


def window_amplitude(transform: np.ndarray, window: float) -> tuple[np.ndarray, np.ndarray]:
    """(amplitude, phase) of the steady sine a transform over ``window`` seconds of whole periods holds: 2F/T =
    A e^{iφ}/i, so A = 2|F|/T and φ = arg(2iF/T)."""
    if window <= 0:
        return np.zeros(transform.shape), np.zeros(transform.shape)
    value = 2.0j * transform / window
    return np.abs(value), np.angle(value)



class FluxMonitor(DFTMonitor):
    """The Poynting flux through ``path`` ((K, dim) vertices, m; ``closed``: back to the first) at ``frequencies`` (Hz),
    over the window from ``start`` to ``stop`` (s) (module docstring). ``points`` are made from the path when the
    monitor is checked."""

    def __init__(self, name: str, path, frequencies, start: float = 0.0, closed: bool = False,
                 stop: float = math.inf):
        self.name, self.path, self.closed = name, path, bool(closed)
        self.frequencies, self.start, self.stop, self.fields = frequencies, start, stop, ("ez", "hx", "hy")
        self.points, self.weights, self.normals = None, None, None

    def checked(self, layout: StaggeredLayout, slowest: float) -> "FluxMonitor":
        """The monitor checked (:meth:`DFTMonitor.checked`) with its points, weights (m) and normals placed on the
        path; its fields are Ez and the H components of the dimension."""
        dim = layout.dim
        try:
            path = np.asarray(self.path, dtype=np.float64).reshape(-1, dim)
        except (TypeError, ValueError):
            raise ParameterError("monitor", f"{self.name}: a path is (K, {dim}) vertices") from None
        if dim == 1:
            if path.shape[0] != 1:
                raise ParameterError("monitor", f"{self.name}: a 1D flux passes through one point")
            points, weights, normals = path, np.ones(1), np.ones((1, 1))
        else:
            if path.shape[0] < 2 or not np.all(np.isfinite(path)):
                raise ParameterError("monitor", f"{self.name}: a path needs two or more finite vertices")
            ends = np.vstack([path, path[:1]]) if self.closed else path
            points, weights, normals = [], [], []
            for a, b in zip(ends[:-1], ends[1:]):
                length = float(np.linalg.norm(b - a))
                if length == 0.0:
                    continue
                count = int(np.ceil(length / (0.5 * layout.spacing)))
                require_memory_points(count)
                u = (np.arange(count) + 0.5) / count
                points.append(a + u[:, None] * (b - a))
                weights.append(np.full(count, length / count))
                t = (b - a) / length
                normals.append(np.tile([t[1], -t[0]], (count, 1)))
            if not points:
                raise ParameterError("monitor", f"{self.name}: the path has no length")
            points, weights, normals = np.vstack(points), np.concatenate(weights), np.vstack(normals)
        fields = ("ez", "hy") if dim == 1 else ("ez", "hx", "hy")
        base = DFTMonitor(self.name, points, self.frequencies, fields, self.start, self.stop).checked(layout, slowest)
        out = FluxMonitor(self.name, path, base.frequencies, base.start, self.closed, base.stop)
        out.points, out.fields, out.weights, out.normals = base.points, fields, weights, normals
        return out

    def flux(self, transforms: dict[str, np.ndarray], windows: dict[str, float]) -> dict[str, np.ndarray]:
        """(``spectrum``, ``power``) per frequency from the path's transforms (``SPEMSolver.dft``) and the windows
        they summed (s)."""
        ez = transforms["ez"]
        hx = transforms.get("hx", np.zeros_like(ez))
        hy = transforms["hy"]
        nx = self.normals[:, 0:1]
        ny = self.normals[:, 1:2] if self.normals.shape[1] > 1 else np.zeros_like(nx)
        # S·n = Ez (-Hy n_x + Hx n_y)
        spectrum = np.real(ez * np.conj(-hy * nx + hx * ny))
        out = {"spectrum": self.weights @ spectrum}
        scale = {k: (2.0 / w if w > 0 else 0.0) for k, w in windows.items()}
        e = ez * scale["ez"]
        h = (-hy * nx * scale["hy"] + hx * ny * scale.get("hx", 0.0))
        out["power"] = self.weights @ (0.5 * np.real(e * np.conj(h)))
        return out


def require_memory_points(count: int) -> None:
    """Refuse, naming ``monitor``, a path cut into more pieces than memory holds."""
    from warpfree.errors import require_memory

    require_memory("monitor", count, 1024.0, "flux monitor points")
