"""The normalised plasma scenes' units in SI, for a plasma of electron density n0 (m⁻³) and temperature T_e (eV).

The scenes compute with n0 = T_e = e = m_e = ε0 = 1, so every result holds for any plasma; a user's own density and
temperature give the scales that turn them into SI:

- length: the Debye length λ_D = sqrt(ε0 k T_e / (n0 e²)) (m);
- time: 1/ω_pe, ω_pe = sqrt(n0 e² / (ε0 m_e)) (rad/s) the electron plasma frequency; a rate (1/s) and an
  angular frequency (rad/s) are in ω_pe;
- speed: v_te = λ_D ω_pe = sqrt(k T_e / m_e) (m/s), the electron thermal speed;
- potential: k T_e / e (V), numerically T_e in eV;
- flux: n0 v_te (particles per m² per s); current density: e n0 v_te (A/m²); density: n0 (m⁻³).

Constants: CODATA 2018 (``scipy.constants``). Checked against the NRL Plasma Formulary (``tests/pic/test_units.py``):
λ_D = 7.43e2 sqrt(T_e/n) cm and f_pe = 8.98e3 sqrt(n) Hz, n in cm⁻³, T_e in eV. float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from scipy import constants

from warpfree.errors import ParameterError

__all__ = ["PlasmaUnits", "plasma_units", "DIMENSIONS"]

#: a result's dimension -> its SI unit
DIMENSIONS = {"length": "m", "time": "s", "rate": "1/s", "angular_frequency": "rad/s", "speed": "m/s",
              "potential": "V", "flux": "1/(m² s)", "current_density": "A/m²", "density": "1/m³"}

@dataclass(frozen=True)
class PlasmaUnits:
    """The SI scales of a plasma of electron ``density`` n0 (m⁻³) and ``electron_temperature`` T_e (eV)."""

    density: float
    electron_temperature: float

    @property
    def debye_length(self) -> float:
        """λ_D = sqrt(ε0 k T_e / (n0 e²)) (m)."""
        return math.sqrt(constants.epsilon_0 * self.electron_temperature / (self.density * constants.e))

    @property
    def plasma_frequency(self) -> float:
        """ω_pe = sqrt(n0 e² / (ε0 m_e)) (rad/s)."""
        return math.sqrt(self.density * constants.e ** 2 / (constants.epsilon_0 * constants.m_e))

    @property
    def thermal_speed(self) -> float:
        """v_te = λ_D ω_pe = sqrt(k T_e / m_e) (m/s)."""
        return self.debye_length * self.plasma_frequency

    def scale(self, dimension: str) -> float:
        """The SI value of one normalised unit of ``dimension`` (a key of :data:`DIMENSIONS`)."""
        scales = {"length": self.debye_length, "time": 1.0 / self.plasma_frequency, "rate": self.plasma_frequency,
                  "angular_frequency": self.plasma_frequency,
                  "speed": self.thermal_speed, "potential": self.electron_temperature,
                  "flux": self.density * self.thermal_speed,
                  "current_density": constants.e * self.density * self.thermal_speed, "density": self.density}
        return scales[dimension]

    def describe(self, results: dict[str, tuple[float, str]]) -> dict:
        """The plasma, its scales and ``results`` ({name: (normalised value, dimension)}) in SI, for a summary:
        {"plasma": ..., "scales": ..., "results": {name: {"value", "unit"}}}."""
        scales = {"debye_length": (self.debye_length, "m"), "plasma_frequency": (self.plasma_frequency, "rad/s"),
                  "plasma_period": (2.0 * math.pi / self.plasma_frequency, "s"),
                  "thermal_speed": (self.thermal_speed, "m/s")}
        return {"plasma": {"density": {"value": self.density, "unit": "1/m³"},
                           "electron_temperature": {"value": self.electron_temperature, "unit": "eV"}},
                "scales": {name: {"value": value, "unit": unit} for name, (value, unit) in scales.items()},
                "results": {name: {"value": float(value) * self.scale(dimension), "unit": DIMENSIONS[dimension]}
                            for name, (value, dimension) in results.items()}}


def plasma_units(density: float | None, electron_temperature: float | None) -> PlasmaUnits | None:
    """The scene's SI scales: both given, their :class:`PlasmaUnits`; neither, None (normalised units only); one
    alone: ParameterError naming the other."""
    if density is None and electron_temperature is None:
        return None
    if electron_temperature is None:
        raise ParameterError("electron_temperature", "must be given with density (the two set the SI units)")
    if density is None:
        raise ParameterError("density", "must be given with electron_temperature (the two set the SI units)")
    return PlasmaUnits(float(density), float(electron_temperature))
