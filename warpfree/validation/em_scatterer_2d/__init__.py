"""A TMz plane wave scattered by a circular cylinder, dielectric or perfectly conducting: the exact Bessel series (the
2D Mie solution); no data files, see ``README.md``.

Phasors with time dependence e^{iωt}. The incident wave Ez = E0 e^{-ik0 r cos φ} = E0 Σ_n (-i)^n J_n(k0 r) e^{inφ}, φ
measured from the direction of travel about the cylinder's axis; the scattered field outside the cylinder (r > a) is
E0 Σ_n (-i)^n a_n H_n^(2)(k0 r) e^{inφ}, the field inside a dielectric E0 Σ_n (-i)^n c_n J_n(m k0 r) e^{inφ}, m = √(εr μr)
the refractive index. Ez and H_φ = (1/(iωμ)) ∂Ez/∂r continuous at r = a (x = k0 a, ζ = √(μr/εr) the relative
impedance, η = μr/m):

    a_n = [J_n(x) J_n'(mx) - η J_n'(x) J_n(mx)] / [η J_n(mx) H_n'(x) - J_n'(mx) H_n(x)]  ... for μr = 1 this is
    a_n = [m J_n(x) J_n'(mx) - J_n'(x) J_n(mx)] / [J_n(mx) H_n'(x) - m J_n'(mx) H_n(x)]   (Balanis 2012, §11.5)

and for a perfect conductor a_n = -J_n(x)/H_n^(2)(x). The scattering width (the scattered power per unit length over
the incident intensity) σ = (4/k0) Σ_n |a_n|² (m), and the extinction width -(4/k0) Σ_n Re a_n equals it for a lossless
cylinder (the optical theorem; tested). Terms: |n| <= x + 4 x^(1/3) + 10 (Wiscombe's rule), |a_n| below 1e-12 beyond.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["coefficients", "total_field", "scattering_width", "extinction_width", "terms"]


def terms(k0a: float, eps_r: float = 1.0, mu_r: float = 1.0) -> int:
    """The largest order |n| summed (Wiscombe's rule at the larger of k0 a and m k0 a)."""
    x = k0a * max(1.0, math.sqrt(eps_r * mu_r))
    return int(math.ceil(x + 4.0 * x ** (1.0 / 3.0) + 10.0))


def coefficients(k0a: float, eps_r: float | None, mu_r: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, a_n, c_n) for n = -N..N: the scattered and inside coefficients; ``eps_r`` None: a perfect conductor (c_n =
    0)."""
    from scipy.special import h2vp, hankel2, jv, jvp

    count = terms(k0a, eps_r or 1.0, mu_r)
    n = np.arange(-count, count + 1)
    x = k0a
    if eps_r is None:
        return n, -jv(n, x) / hankel2(n, x), np.zeros(n.size, complex)
    m = math.sqrt(eps_r * mu_r)
    eta = mu_r / m  # ∂Ez/∂r inside is m k0 J_n'(mx) c_n, and H_φ carries 1/μr: the jump condition's factor
    jx, jpx, jmx, jpmx = jv(n, x), jvp(n, x), jv(n, m * x), jvp(n, m * x)
    hx, hpx = hankel2(n, x), h2vp(n, x)
    a = (jx * jpmx - eta * jpx * jmx) / (eta * jmx * hpx - jpmx * hx)
    c = (jx + a * hx) / jmx
    return n, a, c


def total_field(points: np.ndarray, centre, radius: float, k0: float, eps_r: float | None, direction=(1.0, 0.0),
                mu_r: float = 1.0, amplitude: float = 1.0) -> np.ndarray:
    """The total Ez phasor (V/m) at ``points`` (N, >= 2, m) about a cylinder of ``radius`` at ``centre``, the incident
    wave of ``amplitude`` travelling along ``direction`` with phase 0 at the centre."""
    from scipy.special import hankel2, jv

    p = np.asarray(points, float)[:, :2] - np.asarray(centre, float)[:2]
    d = np.asarray(direction, float)[:2]
    d = d / np.linalg.norm(d)
    r = np.hypot(p[:, 0], p[:, 1])
    phi = np.arctan2(p[:, 1], p[:, 0]) - math.atan2(d[1], d[0])
    n, a, c = coefficients(k0 * radius, eps_r, mu_r)
    outside = r > radius
    field = np.zeros(r.size, complex)
    phase = (-1j) ** n[None, :] * np.exp(1j * n[None, :] * phi[:, None])
    ro = r[outside, None]
    field[outside] = np.sum(phase[outside] * (jv(n[None, :], k0 * ro) + a[None, :] * hankel2(n[None, :], k0 * ro)),
                            axis=1)
    if eps_r is not None:
        m = math.sqrt(eps_r * mu_r)
        ri = r[~outside, None]
        field[~outside] = np.sum(phase[~outside] * c[None, :] * jv(n[None, :], m * k0 * ri), axis=1)
    return amplitude * field


def scattering_width(k0: float, radius: float, eps_r: float | None, mu_r: float = 1.0) -> float:
    """σ = (4/k0) Σ |a_n|² (m): the scattered power per unit length over the incident intensity."""
    _, a, _ = coefficients(k0 * radius, eps_r, mu_r)
    return float(4.0 / k0 * np.sum(np.abs(a) ** 2))


def extinction_width(k0: float, radius: float, eps_r: float | None, mu_r: float = 1.0) -> float:
    """-(4/k0) Σ Re a_n (m): the power taken from the incident wave per unit length over its intensity (the optical
    theorem); equal to :func:`scattering_width` for a lossless cylinder."""
    _, a, _ = coefficients(k0 * radius, eps_r, mu_r)
    return float(-4.0 / k0 * np.sum(a.real))
