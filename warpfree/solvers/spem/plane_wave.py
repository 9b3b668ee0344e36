"""Plane-wave injection by total-field/scattered-field (TF/SF), the remedy Mendes (2010) proposes (§5) for its
failed free-space case (§4.5), on particles.

Inside the total-field box the particles carry the total field, outside it only the scattered field (zero
when nothing scatters). The derivative of a particle is linear in its partners' values, Σ_j g_ij u_j; where
a row crosses the box's boundary the partner holds the other kind of field, so the row adds the incident field
at the partner: +g_ij u_inc(x_j) seen from the total side, -g_ij u_inc(x_j) from the scattered side. Then the
wave enters the box, crosses it and leaves it without touching the scattered region, whatever the operator
(uniform, jittered, conservative): what leaks is only the difference between the discrete wave and the
analytic incident one (the discrete dispersion), measured by the scene. Both E and H are imposed, at their
own staggered times (H^n for the E phase, Ez^{n+1/2} for the H phase), which a hard line source of E
alone does not do (it launches a second wave backwards into the PML next to it).

The incident wave (``kernels/spem.py: IncidentWave``): Ez = A f(τ), H = (A/η) f(τ) (d_y, -d_x),
τ = t - (d·x - s0)/v, v = c/√(εr μr), η = η0 √(μr/εr), s0 the first corner of the box the front reaches.
The boundary must lie in a lossless region of uniform εr, μr (outside any PML).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpfree.errors import ParameterError
from warpfree.kernels import spem as K
from warpfree.neighbours import host_rows

from .model import C0, EPS0, MU0, SPEMModel

__all__ = ["PlaneWave"]


@dataclass
class PlaneWave:
    """A plane wave of ``waveform`` (a :class:`~.solver.Waveform` or :class:`~.solver.GaussianPulse`) and
    ``amplitude`` (V/m) travelling along ``direction``, injected into the total-field box [``lower``,
    ``upper``] (m) in a medium of ``eps_r``, ``mu_r``."""

    waveform: object
    lower: tuple
    upper: tuple
    direction: tuple = (0.0, 1.0)
    amplitude: float = 1.0
    eps_r: float = 1.0
    mu_r: float = 1.0

    def speed(self) -> float:
        """The wave's speed in its medium, c0 / sqrt(ε_r μ_r) (m/s)."""
        return C0 / math.sqrt(self.eps_r * self.mu_r)

    def unit_direction(self, dim: int) -> np.ndarray:
        """The propagation direction as a unit 3-vector (its first ``dim`` components given), or ParameterError."""
        d = np.zeros(3)
        d[:dim] = np.asarray(self.direction, float)[:dim]
        norm = float(np.linalg.norm(d))
        if not np.isfinite(norm) or norm == 0.0:
            raise ParameterError("plane_wave.direction", f"must be a finite non-zero vector, got {self.direction}")
        return d / norm

    def incident(self, dim: int, points: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Ez, Hx, Hy) of the incident wave at ``points`` (N, 3) and time ``t`` (NumPy, for analyses)."""
        d = self.unit_direction(dim)
        tau = t - (points @ d - self.front_start(dim)) / self.speed()
        f = self.waveform(tau) * (tau >= 0)
        ez = self.amplitude * f
        h = ez * math.sqrt(EPS0 * self.eps_r / (MU0 * self.mu_r))
        return ez, h * d[1], -h * d[0]

    def front_start(self, dim: int) -> float:
        """s0 (m): d·x at the corner of the total-field box the wave front reaches first (at t = 0)."""
        d = self.unit_direction(dim)
        lo, hi = np.zeros(3), np.zeros(3)
        lo[:dim], hi[:dim] = np.asarray(self.lower, float)[:dim], np.asarray(self.upper, float)[:dim]
        corners = np.array(np.meshgrid(*[[lo[a], hi[a]] for a in range(3)], indexing="ij")).reshape(3, -1).T
        return float(np.min(corners @ d))

    def inside(self, dim: int, points: np.ndarray) -> np.ndarray:
        """(N,) bool: ``points`` in the total-field box (its boundary included, to 1e-9 of its size)."""
        lo, hi = np.asarray(self.lower, float)[:dim], np.asarray(self.upper, float)[:dim]
        tol = 1e-9 * float(np.max(np.abs(hi - lo)))
        return np.all((points[:, :dim] >= lo - tol) & (points[:, :dim] <= hi + tol), axis=1)


def _crossing_rows(rows, coefficient: np.ndarray, total_self: np.ndarray, total_other: np.ndarray, device: str):
    """The entries of ``rows`` whose two particles lie on different sides, as rows of their own (targets, CSR,
    signed coefficients: + from the total side, - from the scattered side)."""
    ptr, idx = rows.offsets(), rows.indices()
    owner = np.repeat(np.arange(rows.n), np.diff(ptr))
    cross = total_self[owner] != total_other[idx]
    targets, counts = np.unique(owner[cross], return_counts=True)
    sign = np.where(total_self[owner[cross]], 1.0, -1.0)
    out = host_rows(counts, idx[cross], device)
    coef = (coefficient[:rows.n_pairs][cross] * sign[:, None]).astype(np.float32)
    return (wp.array(targets.astype(np.int32) if targets.size else np.zeros(1, np.int32), dtype=wp.int32,
                     device=device), out,
            wp.array(coef if coef.size else np.zeros((1, 3), np.float32), dtype=wp.vec3, device=device),
            int(targets.size))


class DevicePlaneWave:
    """A :class:`PlaneWave` checked against ``model`` with its boundary rows on the device."""

    def __init__(self, wave: PlaneWave, model: SPEMModel, device: str):
        dim, lay = model.dim, model.layout
        for name in ("amplitude", "eps_r", "mu_r"):
            v = getattr(wave, name)
            if not (np.isfinite(v) and (v > 0 or name == "amplitude")):
                raise ParameterError(f"plane_wave.{name}", f"must be finite{'' if name == 'amplitude' else ' and > 0'}, got {v}")
        lo, hi = np.asarray(wave.lower, float)[:dim], np.asarray(wave.upper, float)[:dim]
        if lo.shape != (dim,) or hi.shape != (dim,) or np.any(hi <= lo):
            raise ParameterError("plane_wave.upper", f"the total-field box needs lower < upper per axis, got "
                                                     f"{wave.lower}, {wave.upper}")
        d = wave.unit_direction(dim)
        e, h = model.electric, model.magnetic
        total_e, total_h = wave.inside(dim, lay.e_position), wave.inside(dim, lay.h_position)
        self.e_targets, self.e_rows, self.e_coefficient, self.n_e = _crossing_rows(
            model.e_rows, model.e_coefficient.numpy(), total_e, total_h, device)
        self.h_targets, self.h_rows, self.h_coefficient, self.n_h = _crossing_rows(
            model.h_rows, model.h_coefficient.numpy(), total_h, total_e, device)
        if self.n_e == 0 or self.n_h == 0:
            raise ParameterError("plane_wave.lower", "the total-field box does not cut the particle sets: its boundary "
                                                     "must lie inside the domain")
        for s, targets, n, material, value in ((e, self.e_targets, self.n_e, "inv_permittivity", EPS0 * wave.eps_r),
                                               (h, self.h_targets, self.n_h, "inv_permeability", MU0 * wave.mu_r)):
            at = targets.numpy()[:n]
            if np.any(s.numpy("loss")[at] != 0.0):
                raise ParameterError("plane_wave.lower", "the total-field/scattered-field boundary lies in the PML: "
                                                         "move the box inside the interior")
            if not np.allclose(1.0 / s.numpy(material)[at], value, rtol=1e-5):
                raise ParameterError("plane_wave.eps_r", "the medium at the total-field box's boundary differs from the "
                                                         "wave's eps_r/mu_r")
        self.wave = wave
        w = K.IncidentWave()
        w.direction = wp.vec3(*d)
        w.start = wave.front_start(dim)
        w.speed = wave.speed()
        w.amplitude = float(wave.amplitude)
        w.admittance = math.sqrt(EPS0 * wave.eps_r / (MU0 * wave.mu_r))
        f = wave.waveform
        if hasattr(f, "width"):
            w.kind, w.frequency, w.width, w.delay = 1, f.frequency, f.width, f.delay
        else:
            w.kind, w.frequency, w.phase, w.ramp = 0, f.frequency, f.phase, f.ramp
        self.struct = w
