"""A half-immersed horizontal circular cylinder heaving on deep water: Ursell's (1949) linear theory (no data files,
see ``README.md`` in this folder).

A cylinder of radius a floats with its axis in the still water level (density ρ/2: it displaces half its volume). Forced
to heave as y = l cos(σt) it radiates waves of amplitude b on both sides and feels the force of an added mass a33
and a damping b33 (per metre of length), functions of the frequency through K a = σ² a/g. Ursell writes the potential
as a wave source at the centre plus multipoles (a/r)^(2m) [cos 2mθ + K r/(2m - 1) cos (2m - 1)θ], θ from the downward
vertical, whose coefficients p_2m (in phase) and q_2m (in quadrature) make the cylinder's surface a streamline of its
motion; solved here by least squares at points of the quarter circle, as he did. With A, B the stream function's
coefficients on the cylinder and M0, N0 the potential's moments over it:

    b/l = π K a / sqrt(A² + B²)
    μ = a33/(ρ π a²/2) = (4/π) (M0 B + N0 A)/(A² + B²)
    λ = b33 sqrt(a/g)/(ρ π a²/2) = (4 ω̂/π) (M0 A - N0 B)/(A² + B²),   ω̂ = σ sqrt(a/g) = sqrt(K a)

The radiated energy balances the damping: λ = 2 (b/l)²/(π ω̂³) (a check of the two, computed apart). Free, the cylinder
heaves at the frequency where the restoring force 2ρ g a y balances its inertia with the added mass:

    ω̂_n² π (1 + μ(ω̂_n))/4 = 1,   damping ratio ζ = λ(ω̂_n)/(2 ω̂_n (1 + μ(ω̂_n)))

Released from rest at a height y0 above its floating level, it moves as (Maskell & Ursell 1970, the Fourier
integral of the forced motion's response; causal, so its cosine and sine parts agree)

    y(t)/y0 = 1 - (2/π) ∫_0^∞ Re[1/D(ω̂)] sin(ω̂ t̂)/ω̂ dω̂,   D = 1 - (π/4) ω̂² (1 + μ) - i (π/4) ω̂ λ

which :func:`free_decay` integrates over the coefficients tabulated in ``coefficients.csv`` (made by
:func:`coefficients`; ``python -m warpfree.validation.heave_decay_2d`` writes it anew); past the table's last
frequency μ = 1, λ = 0 (the limit, within 3 % there). After its first half period the motion is close to the damped
oscillation above. Dimensionless throughout (lengths in a, times in sqrt(a/g)); float64.
"""

from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources

import numpy as np
from scipy import integrate, optimize

from warpfree.validation import tolerance_check

__all__ = ["coefficients", "natural_frequency", "free_decay", "table", "zero_crossings", "compare", "checks", "plot_heave",
           "MULTIPOLES", "COLLOCATION", "TABLE", "TOLERANCES", "SOURCE", "WINDOW"]

#: multipoles kept and collocation angles on the quarter circle (Ursell: 6 and 10); the results change by < 1e-6 with
#: 10 and 40
MULTIPOLES, COLLOCATION = 8, 24


def _wave_integral(ka: float, r: float, theta: float, kind: str) -> float:
    """The local (non-wave) part of Ursell's source at (r, θ), r in a, K a = ``ka``: with x = r sin θ across and
    y = r cos θ down, ∫_0^∞ e^(-k x)/(K² + k²) [k cos ky - K sin ky] dk for Φ_s ("phi") and
    ∫_0^∞ e^(-k x)/(K² + k²) [k sin ky + K cos ky] dk for Ψ_s ("psi"): it decays across, not down."""
    x, y = r * math.sin(theta), r * math.cos(theta)

    def part(weight: str, power: int):
        """∫ e^(-k x) k^power/(K² + k²) {cos|sin}(k y) dk, a Fourier-weighted integral (y > 0)."""
        f = (lambda k: math.exp(-k * x) * k ** power / (ka * ka + k * k))
        if y < 1e-12:
            return integrate.quad(f, 0.0, math.inf, limit=400)[0] if weight == "cos" else 0.0
        return integrate.quad(f, 0.0, math.inf, weight=weight, wvar=y, limlst=200)[0]

    if kind == "phi":
        return part("cos", 1) - ka * part("sin", 0)
    return part("sin", 1) + ka * part("cos", 0)


def _source(ka: float, r: float, theta: float) -> tuple[float, float, float, float]:
    """Φ_c, Φ_s, Ψ_c, Ψ_s of the wave source at (r, θ)."""
    x, z = r * math.sin(theta), r * math.cos(theta)   # across, and depth below the still water level
    decay = math.pi * math.exp(-ka * z)
    phi_c, psi_c = decay * math.cos(ka * x), decay * math.sin(ka * x)
    phi_s = -_wave_integral(ka, r, theta, "phi") + decay * math.sin(ka * x)
    psi_s = _wave_integral(ka, r, theta, "psi") - decay * math.cos(ka * x)
    return phi_c, phi_s, psi_c, psi_s


def coefficients(omega: float, multipoles: int = MULTIPOLES, collocation: int = COLLOCATION) -> dict:
    """Ursell's heave coefficients at ω̂ = σ sqrt(a/g) > 0: ``added_mass`` μ, ``damping`` λ (module docstring),
    ``wave_ratio`` b/l, and ``damping_from_waves`` 2 (b/l)²/(π ω̂³), which λ equals where the solution holds."""
    ka = omega * omega
    m = np.arange(1, multipoles + 1)
    theta = np.linspace(0.0, 0.5 * math.pi, collocation)
    sources = np.array([_source(ka, 1.0, t) for t in theta])
    top = _source(ka, 1.0, 0.5 * math.pi)
    f = (-np.sin(2 * np.outer(theta, m)) - ka / (2 * m - 1)
         * (np.sin(np.outer(theta, 2 * m - 1)) - np.outer(np.sin(theta), (-1.0) ** (m - 1))))
    p = np.linalg.lstsq(f, sources[:, 2] - top[2] * np.sin(theta), rcond=None)[0]
    q = np.linalg.lstsq(f, sources[:, 3] - top[3] * np.sin(theta), rcond=None)[0]
    sign = (-1.0) ** (m - 1)
    A = top[2] + np.sum(sign * ka / (2 * m - 1) * p)
    B = top[3] + np.sum(sign * ka / (2 * m - 1) * q)
    moment_s = integrate.quad(lambda t: _source(ka, 1.0, t)[1] * math.cos(t), 0.0, 0.5 * math.pi, limit=200)[0]
    moment_c = integrate.quad(lambda t: _source(ka, 1.0, t)[0] * math.cos(t), 0.0, 0.5 * math.pi, limit=200)[0]
    M0 = moment_s + 0.25 * math.pi * ka * q[0] + np.sum(sign * q / (4 * m * m - 1))
    N0 = moment_c + 0.25 * math.pi * ka * p[0] + np.sum(sign * p / (4 * m * m - 1))
    norm = A * A + B * B
    wave_ratio = math.pi * ka / math.sqrt(norm)
    return {"omega": omega, "added_mass": float(4.0 / math.pi * (M0 * B + N0 * A) / norm),
            "damping": float(4.0 * omega / math.pi * (M0 * A - N0 * B) / norm), "wave_ratio": float(wave_ratio),
            "damping_from_waves": float(2.0 * wave_ratio ** 2 / (math.pi * omega ** 3))}


def natural_frequency() -> dict:
    """The half-immersed cylinder's free heave: ω̂_n solving ω̂² π (1 + μ(ω̂))/4 = 1, its added mass, damping ratio ζ
    and damped period T̂_d = 2π/(ω̂_n sqrt(1 - ζ²)) (in sqrt(a/g))."""
    omega = optimize.brentq(lambda w: w * w * math.pi * (1.0 + coefficients(w)["added_mass"]) / 4.0 - 1.0, 0.3, 1.2,
                            xtol=1e-10)
    c = coefficients(omega)
    zeta = c["damping"] / (2.0 * omega * (1.0 + c["added_mass"]))
    return {"omega": omega, "added_mass": c["added_mass"], "damping": c["damping"], "damping_ratio": zeta,
            "period": 2.0 * math.pi / (omega * math.sqrt(1.0 - zeta * zeta))}


#: the tabulated coefficients' file (ω̂, μ, λ, b/l), next to this module
TABLE = "coefficients.csv"


def table_frequencies() -> np.ndarray:
    """ω̂ of the table: finely spaced where μ grows as log(1/ω̂) near 0 (below 0.035 the wave integrals fail; there
    ω̂² μ < 0.007 and D is 1 within that), to 12 where μ is within 3 % of 1."""
    return np.concatenate([np.geomspace(0.035, 0.2, 50, endpoint=False), np.linspace(0.2, 12.0, 473)])


@lru_cache(maxsize=1)
def table() -> np.ndarray:
    """The tabulated (ω̂, μ, λ, b/l) rows, float64."""
    text = resources.files(__package__).joinpath(TABLE).read_text()
    return np.loadtxt(text.splitlines(), delimiter=",", skiprows=1)


def free_decay(times) -> np.ndarray:
    """y(t̂)/y0 of the cylinder released from rest at t̂ = 0 (module docstring), at ``times`` in sqrt(a/g): the
    integral by the trapezoid rule over a grid 20 times finer than the table (μ, λ interpolated linearly in ω̂) to
    ω̂ = 12, then with μ = 1, λ = 0 to ω̂ = 400 (the rest is below 1e-6)."""
    rows = table()
    inner = np.concatenate([np.linspace(rows[k, 0], rows[k + 1, 0], 21)[:-1] for k in range(len(rows) - 1)]
                           + [rows[-1:, 0]])
    outer = np.linspace(rows[-1, 0], 400.0, 400000)[1:]
    mu = np.concatenate([np.interp(inner, rows[:, 0], rows[:, 1]), np.ones_like(outer)])
    lam = np.concatenate([np.interp(inner, rows[:, 0], rows[:, 2]), np.zeros_like(outer)])
    w = np.concatenate([[0.0], inner, outer])
    mu, lam = np.concatenate([[mu[0]], mu]), np.concatenate([[lam[0]], lam])
    d = 1.0 - 0.25 * math.pi * w * w * (1.0 + mu) - 0.25j * math.pi * w * lam
    real = (1.0 / d).real
    real[0] = 1.0   # ω̂ → 0: D → 1 (ω̂² μ → 0)
    out = []
    for t in np.atleast_1d(np.asarray(times, np.float64)):
        kernel = np.where(w > 0, np.sin(w * t) / np.where(w > 0, w, 1.0), t)
        out.append(1.0 - 2.0 / math.pi * np.trapezoid(real * kernel, w))
    return np.array(out)


def write_table(path) -> None:
    """Tabulate :func:`coefficients` at :func:`table_frequencies` into ``path`` (CSV)."""
    rows = [(w, c["added_mass"], c["damping"], c["wave_ratio"])
            for w in table_frequencies() for c in [coefficients(float(w))]]
    header = "omega_hat,added_mass_mu,damping_lambda,wave_ratio"
    np.savetxt(path, np.array(rows), delimiter=",", header=header, comments="", fmt="%.10g")



#: the checks' tolerances: the period between the first and third zero crossings (relative), the first trough and
#: the rms difference over the window (in y0)
TOLERANCES = {"period": 0.02, "first_trough": 0.05, "rms_difference": 0.05}
SOURCE = ("Ursell 1949, Q. J. Mech. Appl. Math. 2:218 (the coefficients; Vugts 1968 measured them), the transient "
          "as Maskell & Ursell 1970, J. Fluid Mech. 44:303; warpfree/validation/heave_decay_2d/README.md")


def zero_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The times where y changes sign, by linear interpolation between samples."""
    t, y = np.asarray(t, np.float64), np.asarray(y, np.float64)
    k = np.flatnonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def _first_period_and_trough(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    crossings = zero_crossings(t, y)
    period = float(crossings[2] - crossings[0]) if crossings.size >= 3 else float("nan")
    first = (t <= crossings[1]) if crossings.size >= 2 else np.ones_like(t, dtype=bool)
    return period, float(np.min(y[first]))


#: the comparison's window, t̂ <= WINDOW: two of the transient's periods (the motion is then below 0.15 y0)
WINDOW = 14.0


def compare(t: np.ndarray, heave: np.ndarray, theory: np.ndarray, window: float = WINDOW) -> dict:
    """The measured heave y/y0 (above the theory's floating level) at times t̂ against the theory's, over t̂ <= ``window``.
    The body's own floating level c (in y0) is fitted, y = c + (1 - c) y_theory (least squares: the discrete body
    floats a little off Archimedes' level, and released y0 above the theory's it is released (1 - c) y0 above its
    own); the motion about it, (y - c)/(1 - c), gives the period between the first and third zero crossings, the
    first trough (the least value before the second crossing) and the rms difference from the theory."""
    t, heave, theory = (np.asarray(v, np.float64) for v in (t, heave, theory))
    inside = t <= window
    rest = 1.0 - theory[inside]
    level = float(np.sum((heave[inside] - theory[inside]) * rest) / np.sum(rest * rest))
    about = (heave - level) / (1.0 - level)
    period, trough = _first_period_and_trough(t[inside], about[inside])
    period_theory, trough_theory = _first_period_and_trough(t[inside], theory[inside])
    return {"floating_level": level, "period": period, "period_theory": period_theory,
            "period_error": period / period_theory - 1.0, "first_trough": trough, "first_trough_theory": trough_theory,
            "rms_difference": float(np.sqrt(np.mean((about[inside] - theory[inside]) ** 2))), "window": window,
            "rms_difference_whole_run": float(np.sqrt(np.mean((about - theory) ** 2))), "samples": int(len(t))}


def checks(res: dict, basis: str) -> dict:
    """The :data:`TOLERANCES` on :func:`compare`'s results."""
    return {"period": tolerance_check(abs(res["period_error"]), TOLERANCES["period"], SOURCE,
                                      basis=f"2 % of the linear transient's, {basis}"),
            "first_trough": tolerance_check(res["first_trough"], TOLERANCES["first_trough"], SOURCE,
                                            reference=res["first_trough_theory"], unit="y0",
                                            basis=f"0.05 y0, {basis}"),
            "rms_difference": tolerance_check(res["rms_difference"], TOLERANCES["rms_difference"], SOURCE, unit="y0",
                                              basis=f"0.05 y0 over t sqrt(g/a) <= {res['window']:g}, {basis}")}


def plot_heave(path: str, t: np.ndarray, heave: np.ndarray, theory: np.ndarray, res: dict, label: str) -> None:
    """The heave y/y0 in time against the linear theory's."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(8.0, 3.8)
    ax = fig.subplots(1, 1)
    ax.plot(t, theory, color="k", lw=1.2, label="linear theory (Ursell 1949; Maskell & Ursell 1970)")
    ax.plot(t, (heave - res["floating_level"]) / (1.0 - res["floating_level"]), lw=1.0,
            label=f"{label}, about its floating level")
    ax.axvline(res["window"], color="k", lw=0.6, ls=":")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("t sqrt(g/a)")
    ax.set_ylabel("heave / release height")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.suptitle(f"Heave decay of a half-immersed cylinder: period {100 * res['period_error']:+.2f} %, "
                 f"rms {res['rms_difference']:.3f} y0", fontsize=10)
    save_figure(fig, path)
