"""The per-step diagnostics of a PIC run: kinetic, field and total energy, momentum, deposited charge, the field
energy and potential of chosen Fourier modes and, with open boundaries, the particle count and the charge injected
and absorbed by each wall. One row per step in the state's ``history`` (:class:`~warpfree.solver.HostTable`), so
a resumed run's record covers the whole run. Normalised units (:mod:`.species`).
"""

from __future__ import annotations

import numpy as np

from warpfree.solver import PhaseTimes

from .coupling import NodeCoupling
from .field import PlasmaPoisson
from .particles import Particles

__all__ = ["Diagnostics", "history_columns"]

#: the columns every PIC history has, in order around the field terms
FIRST = ("time",)
LAST = ("kinetic_energy", "total_energy", "momentum_x", "momentum_y")
FIELD = ("field_energy", "deposited_charge", "net_charge_density")
OPEN = ("particles", "injected_charge", "wall_charge_lower", "wall_charge_upper")


def history_columns(modes: list[tuple[int, int]], open_boundaries: bool) -> list[str]:
    """The history's columns: time, the field terms (:meth:`Diagnostics.field_terms`), then the particles' energy and
    momentum."""
    field = list(FIELD) + (list(OPEN) if open_boundaries else [])
    field += [f"mode_{mx}_{my}_energy" for mx, my in modes] + [f"mode_{mx}_{my}_potential_re" for mx, my in modes]
    return [*FIRST, *field, *LAST]


class Diagnostics:
    """The field terms at x^n (computed after each solve, recorded with the next push) and the push's time-centred
    kinetic energy and momentum, as one history row per step."""

    def __init__(self, field: PlasmaPoisson, coupling: NodeCoupling, particles: Particles, modes,
                 phases: PhaseTimes):
        self.field = field
        self.coupling = coupling
        self.particles = particles
        self.phases = phases
        self.modes = [tuple(int(v) for v in m) for m in modes]
        node_count = field.model.node_count
        self.mode_matrix = field.mode_coefficients(self.modes) if self.modes else np.zeros((0, node_count))
        self.mode_k2 = np.sum(field.wavevectors(self.modes) ** 2, axis=1) if self.modes else np.zeros(0)
        self.pending: dict[str, float] = {}

    def field_terms(self) -> dict[str, float]:
        """The field energy ½ uᵀ K u, the deposited and net charge, the walls' tallies and the modes, at x^n."""
        u = self.coupling.potential
        out = {"field_energy": self.field.field_energy(u),
               "deposited_charge": float(self.coupling.charge.numpy().sum()),
               "net_charge_density": self.coupling.net_charge_density}
        pa = self.particles
        if pa.open_boundaries:
            wall = pa.state.wall_charge
            out.update(particles=float(pa.count), injected_charge=float(pa.state.injected_charge),
                       wall_charge_lower=float(wall[2]), wall_charge_upper=float(wall[3]))
        if self.modes:
            coeff = self.mode_matrix @ u
            energy = self.field.area * self.mode_k2 * np.abs(coeff) ** 2   # A |k|² |u_k|² (modes ±k together)
            for (mx, my), e in zip(self.modes, energy):
                out[f"mode_{mx}_{my}_energy"] = float(e)
            for (mx, my), c in zip(self.modes, coeff):
                out[f"mode_{mx}_{my}_potential_re"] = float(c.real)
        return out

    def after_solve(self) -> None:
        """Keep the field terms of the solve just done (the row of the time they belong to is written by the next
        push, which gives its time-centred kinetic energy)."""
        self.pending = self.field_terms()

    def record(self, time: float) -> None:
        """Append time n's row: the field terms at x^n and the time-centred kinetic energy and momentum the push
        just wrote."""
        with self.phases("diagnostics"):
            pa = self.particles
            row = {"time": time, **self.pending}
            n = pa.count
            kin = float(pa.kinetic[:n].numpy().sum()) if n else 0.0
            # column by column: NumPy's sum over axis 0 of an (n, 2) array took 2.4 ms at 131 k particles, 0.13 ms so
            mom = pa.momentum[:n].numpy() if n else np.zeros((1, 2))
            mom = (mom[:, 0].sum(), mom[:, 1].sum())
            row.update(kinetic_energy=kin, total_energy=kin + row["field_energy"], momentum_x=float(mom[0]),
                       momentum_y=float(mom[1]))
            pa.state.history.append(row)
