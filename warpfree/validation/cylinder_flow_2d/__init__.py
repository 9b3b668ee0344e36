"""Flow past a circular cylinder: the published drag, wake length and shedding frequency, and the checks of the
scene ``cylinder_flow_2d`` (no data files; see ``README.md`` in this folder).

A cylinder of diameter D in a uniform stream U of a fluid of density ρ and kinematic viscosity ν, Re = U D/ν:

- Re = 20: the flow is steady and symmetric, with two attached eddies behind the cylinder. Drag coefficient
  C_D = F_x/(ρ U² D/2) = 2.045 and wake length (from the cylinder's rear to the end of the eddies, along the
  centreline) L_w/D = 0.94 (Dennis & Chang 1970, finite differences, unbounded); Fornberg (1980): 2.000 and 0.91;
  Tritton (1959, experiment): C_D = 2.09; Coutanceau & Bouard (1977, experiment): L_w/D = 0.93.
- Re = 100: the wake sheds vortices periodically. Strouhal number St = f D/U = 0.164 (Williamson 1996's fit to his
  experiments, St = -3.3265/Re + 0.1816 + 1.6e-4 Re), 0.165 with mean C_D = 1.33 and lift amplitude 0.33 (Park,
  Kwon & Choi 1998, simulation, unbounded).

The published values differ among themselves by 2-3 % (drag) and 3 % (wake length): the tolerances below are those
spreads plus what the scene's stream of finite width adds (a row of cylinders W apart: its blockage D/W raises the
drag and lengthens the wake by a few per cent at W = 12 D). The functions take NumPy arrays (float64).
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import tolerance_check

__all__ = ["REFERENCES", "force_coefficient", "wake_length", "shedding", "cylinder_checks", "plot_cylinder"]

#: the published values the scene checks against, by Reynolds number: (quantity, value, source)
REFERENCES = {
    20: {"drag": (2.045, "Dennis & Chang 1970, J. Fluid Mech. 42, 471-489 (unbounded, finite differences); "
                         "Fornberg 1980: 2.000; Tritton 1959 (experiment): 2.09"),
         "wake_length": (0.94, "Dennis & Chang 1970 (L/a = 1.88); Fornberg 1980: 0.91; Coutanceau & Bouard 1977 "
                               "(experiment): 0.93")},
    100: {"drag": (1.33, "Park, Kwon & Choi 1998, KSME Int. J. 12, 1200-1205 (mean drag, unbounded)"),
          "strouhal": (0.164, "Williamson 1996, Annu. Rev. Fluid Mech. 28, 477-539 (fit to experiments); "
                              "Park et al. 1998: 0.165")},
}

#: the tolerances, as fractions of the published values: the mean drag coefficient, the wake length, the Strouhal
#: number; and the mean lift coefficient's distance from zero (the steady flow is symmetric)
DRAG_TOLERANCE = 0.05
WAKE_TOLERANCE = 0.10
STROUHAL_TOLERANCE = 0.05
LIFT_TOLERANCE = 0.02


def force_coefficient(force, rho: float, speed: float, diameter: float):
    """C = F/(ρ U² D/2): a force per metre of span (N/m) as a coefficient."""
    return np.asarray(force, dtype=np.float64) / (0.5 * rho * speed ** 2 * diameter)


def wake_length(x, u, radius: float) -> float:
    """The length of the recirculating wake (m): from the cylinder's rear (x = ``radius``, its centre at 0) to where
    the velocity ``u`` sampled along the centreline at ``x`` (increasing, starting at the rear) first turns from
    backward to forward, by linear interpolation; 0 when the flow is not backward behind the cylinder; NaN when it
    is backward all along the samples."""
    x, u = np.asarray(x, np.float64), np.asarray(u, np.float64)
    good = np.isfinite(u)
    x, u = x[good], u[good]
    backward = u < 0.0
    if not backward.any():
        return 0.0
    first = int(np.argmax(backward))
    forward = np.flatnonzero(~backward[first:])
    if forward.size == 0:
        return float("nan")
    k = first + int(forward[0])
    x0, x1, u0, u1 = x[k - 1], x[k], u[k - 1], u[k]
    return float(x0 + (x1 - x0) * (-u0) / (u1 - u0) - radius)


def shedding(t, lift, diameter: float, speed: float, band=(0.05, 0.5)) -> tuple[float, float, float]:
    """The vortex shedding in the lift coefficient ``lift`` sampled at ``t`` (s, evenly): the Strouhal number
    St = f D/U of its strongest frequency f within ``band`` (in U/D: the shedding of a laminar wake, 0.12-0.21 up to
    Re = 200, and not the particles' noise above), the amplitude of the lift at that frequency (a least-squares sine)
    and the cycles the record holds (f times its length). The frequency is the peak of the record's spectrum
    (Hann-windowed, zero-padded 64 times), refined to the sine that fits best near it. NaN, NaN, 0 when the record
    holds less than two cycles of the band's lowest frequency."""
    t, lift = np.asarray(t, np.float64), np.asarray(lift, np.float64)
    unit = diameter / speed
    span = (t[-1] - t[0]) / unit if len(t) > 1 else 0.0
    if span * band[0] < 2.0:
        return float("nan"), float("nan"), 0.0
    tau = (t - t[0]) / unit
    signal = (lift - lift.mean()) * np.hanning(len(lift))
    step = span / (len(t) - 1)
    padded = 64 * len(t)
    spectrum = np.abs(np.fft.rfft(signal, padded))
    frequency = np.fft.rfftfreq(padded, step)
    inside = (frequency >= band[0]) & (frequency <= band[1])
    peak = float(frequency[inside][np.argmax(spectrum[inside])])

    def residual(f):
        basis = np.column_stack([np.sin(2 * np.pi * f * tau), np.cos(2 * np.pi * f * tau), np.ones_like(tau)])
        coef, *_ = np.linalg.lstsq(basis, lift, rcond=None)
        return float(np.sum((basis @ coef - lift) ** 2)), float(np.hypot(coef[0], coef[1]))

    near = np.linspace(peak - 0.5 / span, peak + 0.5 / span, 201)
    best = near[int(np.argmin([residual(f)[0] for f in near]))]
    return float(best), residual(best)[1], float(best * span)


def cylinder_checks(reynolds: float, drag: float, lift: float, wake: float, strouhal: float, basis: str) -> dict:
    """The checks at a Reynolds number with published values (20: drag, wake length and a zero mean lift; 100: the
    mean drag and the Strouhal number); none at others."""
    refs = REFERENCES.get(int(round(reynolds))) if abs(reynolds - round(reynolds)) < 1e-9 else None
    if refs is None:
        return {}
    out = {}
    drag_ref, drag_source = refs["drag"]
    out["drag"] = tolerance_check(drag, DRAG_TOLERANCE * drag_ref, drag_source, reference=drag_ref,
                                  basis=f"5 % of the published mean drag coefficient {drag_ref} (their spread 2-3 %, "
                                        f"and the blockage of the stream's finite width), {basis}")
    if "wake_length" in refs:
        wake_ref, wake_source = refs["wake_length"]
        out["wake_length"] = tolerance_check(wake, WAKE_TOLERANCE * wake_ref, wake_source, reference=wake_ref, unit="D",
                                             basis=f"10 % of the published wake length {wake_ref} D (their spread "
                                                   f"3 %, a wake measured on a particle layout), {basis}")
        out["lift"] = tolerance_check(lift, LIFT_TOLERANCE, "a steady flow symmetric about the centreline (exact)",
                                      basis=f"the mean lift coefficient within 0.02 of zero, {basis}")
    if "strouhal" in refs:
        st_ref, st_source = refs["strouhal"]
        out["strouhal"] = tolerance_check(strouhal, STROUHAL_TOLERANCE * st_ref, st_source, reference=st_ref,
                                          basis=f"5 % of the published Strouhal number {st_ref} (experiments and "
                                                f"simulations agree within 1 %), {basis}")
    return out


def plot_cylinder(path: str, t, drag, lift, x, u, radius: float, result: dict, label: str) -> None:
    """The drag and lift coefficients in time (t in D/U) with the published drag, and the centreline velocity behind
    the cylinder (x from the centre in D, u in U) with the published wake's end."""
    from warpfree.io.validation_plots import new_figure, save_figure

    fig = new_figure(10.5, 3.8)
    a1, a2 = fig.subplots(1, 2)
    a1.plot(t, drag, lw=1.0, label="C_D")
    a1.plot(t, lift, lw=1.0, label="C_L")
    refs = REFERENCES.get(int(round(result["reynolds"])), {})
    if "drag" in refs:
        a1.axhline(refs["drag"][0], color="k", lw=0.8, ls="--", label=f"C_D published {refs['drag'][0]}")
    a1.axvspan(result["averaged_from"], t[-1], color="0.9", label="averaged")
    a1.set_xlabel("t U/D")
    a1.set_ylabel("force coefficient")
    a1.set_ylim(min(-0.5, float(np.nanmin(lift)) - 0.1), max(3.0, float(np.nanmax(drag[len(drag) // 3:])) + 0.2))
    a2.plot(x, u, lw=1.0, label=label)
    a2.axhline(0.0, color="0.5", lw=0.6)
    if "wake_length" in refs:
        a2.axvline(0.5 + refs["wake_length"][0], color="k", lw=0.8, ls="--", label="wake's end, published")
    a2.set_xlabel("x/D behind the centre (centreline)")
    a2.set_ylabel("u/U")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    shedding = f", St {result['strouhal']:.3f}" if np.isfinite(result["strouhal"]) else ""
    fig.suptitle(f"Cylinder at Re = {result['reynolds']:g}: C_D {result['drag_mean']:.3f}, wake "
                 f"{result['wake_length']:.3f} D{shedding}", fontsize=10)
    save_figure(fig, path)
