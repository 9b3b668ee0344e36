"""The per-step diagnostics of a PIC run: kinetic, field and total energy, momentum, deposited charge, the field
energy and potential of chosen Fourier modes and, with open boundaries, the particle count and the charge injected
and absorbed by each wall. Reduced on the device and read once per step (the step report). One row per step in the state's ``history`` (:class:`~warpfree.solver.HostTable`), so
a resumed run's record covers the whole run. Normalised units (:mod:`.species`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import warp as wp
import warp.sparse as wsp

from warpfree.kernels import pic_field as K
from warpfree.reduce import Reduction
from warpfree.solver import PhaseTimes

from .coupling import NodeCoupling
from .device_solve import bsr_matrix
from .field import PlasmaPoisson
from .particles import WALLS, Particles

__all__ = ["Diagnostics", "history_columns", "report_slots", "REPORT", "FIELD_TERMS"]

#: the columns every PIC history has, in order around the field terms
FIRST = ("time",)
LAST = ("kinetic_energy", "total_energy", "momentum_x", "momentum_y")
FIELD = ("field_energy", "deposited_charge", "net_charge_density")
OPEN = ("particles", "injected_charge", "wall_charge_lower", "wall_charge_upper")
#: the step report's first slots (then the field terms of the row's time: FIELD_TERMS and the modes' coefficients)
REPORT = ("kinetic_energy", "momentum_x", "momentum_y", "bad_particle")
#: the field terms reduced on the device after each solve
FIELD_TERMS = FIELD


def report_slots(modes) -> int:
    """The step report's length: :data:`REPORT`, the field terms and each mode's coefficient (real, imaginary)."""
    return len(REPORT) + len(FIELD_TERMS) + 2 * len(modes)


def history_columns(modes: list[tuple[int, int]], open_boundaries: bool, region: list[str] = ()) -> list[str]:
    """The history's columns: time, the field terms (:meth:`Diagnostics.field_terms`), then the particles' energy and
    momentum. ``region``: a region's columns instead of the box's walls' (its boundary groups' absorbed charges, its
    electrodes' charges and floating potentials)."""
    field = list(FIELD) + ((list(OPEN[:2]) + list(region) if region else list(OPEN)) if open_boundaries else [])
    field += [f"mode_{mx}_{my}_energy" for mx, my in modes] + [f"mode_{mx}_{my}_potential_re" for mx, my in modes]
    return [*FIRST, *field, *LAST]


class Diagnostics:
    """The field terms at x^n (computed on the device after each solve) and the push's time-centred kinetic energy and
    momentum, as one history row per step: the step report.

    The terms are reduced on the device into :attr:`report` (:data:`REPORT` slots, then each mode's coefficient, real
    and imaginary: the clock's report slots, ``warpfree.clock``), which :meth:`read` brings to the host once per step
    with the clock's time, with the largest bad-particle flag of the
    step's fits; the host adds the mode energies A |k|² |u_k|² and, with open boundaries, its own tallies. With the
    field solved on the host (SuperLU: u and Q are there already) the field terms are NumPy's, not the device's
    (a dozen small launches a step cost the CPU more than the products).
    """

    def __init__(self, field: PlasmaPoisson, coupling: NodeCoupling, particles: Particles, modes,
                 phases: PhaseTimes, report: wp.array, read_report: Callable[[], np.ndarray]):
        self.field = field
        self.coupling = coupling
        self.particles = particles
        self.phases = phases
        self.launcher = L = coupling.launcher
        dev = L.device
        self.modes = [tuple(int(v) for v in m) for m in modes]
        node_count = field.model.node_count
        self.mode_matrix = mode_matrix = (field.mode_coefficients(self.modes) if self.modes
                                          else np.zeros((0, node_count)))
        #: the field terms from the host's u and Q when the field is solved there (the CPU's default), else reduced
        #: on the device into the report
        self.host_terms = coupling.device_solve is None
        self.pending_host: dict = {}
        self.mode_k2 = np.sum(field.wavevectors(self.modes) ** 2, axis=1) if self.modes else np.zeros(0)
        self.mode_rows = [wp.array(np.ascontiguousarray(part), dtype=wp.float64, device=dev)
                          for row in mode_matrix for part in (row.real, row.imag)]
        self.stiffness = bsr_matrix(field.stiffness, dev)
        self._stiffness_u = wp.zeros(node_count, dtype=wp.float64, device=dev)
        self._products = wp.zeros(node_count, dtype=wp.float64, device=dev)
        self._sum = Reduction(L, wp.float64, "sum")
        self._vector_sum = Reduction(L, wp.vec2d, "sum")
        self._flag_max = Reduction(L, wp.int32, "max")
        self.field_slots = len(FIELD_TERMS) + len(self.mode_rows)
        self.pending = wp.zeros(self.field_slots, dtype=wp.float64, device=dev)  # the field terms of the last solve
        if report.shape[0] != len(REPORT) + self.field_slots:
            raise ValueError(f"the step report needs {len(REPORT) + self.field_slots} slots (report_slots(modes)), "
                             f"got {report.shape[0]}")
        #: the step's report on the device (the clock's report slots) and its one read (the clock's)
        self.report, self._read_report = report, read_report
        self.pending_tallies: dict[str, float] = {}
        self.row: dict[str, float] | None = None   # the row of the last record, until read
        self.bad_flag = 0
        #: the combination of the ranks' reports (their particle sums added in rank order; one process's own), or None
        self.combine = None
        #: a region's boundary groups (their absorbed charges are history columns), or None in a box
        self.region_groups: list[str] | None = None

    def _sum_into(self, values: wp.array, n: int, slot: int, out: wp.array, scale: float = 1.0) -> None:
        self._sum.launch(values, n)
        self.launcher.launch(K.put, 1, [self._sum.result, wp.float64(scale), slot, out])

    def after_solve(self) -> None:
        """:meth:`launch_field_terms`, then the host's tallies (:meth:`keep_tallies`)."""
        self.launch_field_terms()
        self.keep_tallies()

    def launch_field_terms(self) -> None:
        """The field terms of the solve just done, on the device (the row of the time they belong to is completed by
        the next push, which gives its time-centred kinetic energy): ½ uᵀ K u, Σ Q, the net charge density and each
        mode's coefficient C u."""
        L, c, n = self.launcher, self.coupling, self.field.model.node_count
        if self.host_terms:
            return
        u = c.potential_wp
        with self.phases("diagnostics"):
            wsp.bsr_mv(self.stiffness, u, self._stiffness_u)
            L.launch(K.product, n, [u, self._stiffness_u, self._products])
            self._sum_into(self._products, n, FIELD_TERMS.index("field_energy"), self.pending, 0.5)
            self._sum_into(c.charge, n, FIELD_TERMS.index("deposited_charge"), self.pending)
            net = FIELD_TERMS.index("net_charge_density")
            if c.device_solve is not None and not self.field.walled:
                L.launch(K.put, 1, [c.device_solve.net, wp.float64(1.0), net, self.pending])
            for k, row in enumerate(self.mode_rows):
                L.launch(K.product, n, [row, u, self._products])
                self._sum_into(self._products, n, len(FIELD_TERMS) + k, self.pending)

    def keep_tallies(self) -> None:
        """The host's terms of the solve just done: the net charge density of its SuperLU solve and, with open
        boundaries, the particle count and charge tallies."""
        c = self.coupling
        self.pending_net = None if c.device_solve is not None else (self.field.net_charge_density
                                                                     if not self.field.walled else 0.0)
        if self.host_terms:  # the host's solve left u and Q on the host: NumPy's terms cost no launch
            u = c.potential
            coeff = self.mode_matrix @ u
            self.pending_host = {"field_energy": self.field.field_energy(u),
                                 "deposited_charge": float(c.charge_host.sum()),
                                 "coefficients": np.column_stack([coeff.real, coeff.imag]).ravel()}
        pa = self.particles
        if pa.open_boundaries:
            wall = pa.wall_charge
            self.pending_tallies = dict(particles=float(pa.live_total), injected_charge=float(pa.state.injected_charge))
            names = self.region_groups
            if names is None:
                self.pending_tallies.update(wall_charge_lower=float(wall[2]), wall_charge_upper=float(wall[3]))
            else:
                field = self.field
                self.pending_tallies.update({f"absorbed_charge_{n}": float(wall[WALLS + g]) for g, n in enumerate(names)})
                self.pending_tallies.update({f"charge_{e.name}": float(q) for e, q in zip(field.electrodes, field.charges)})
                self.pending_tallies.update({f"potential_{e.name}": float(v) for e, v in
                                             zip(field.electrodes, field.potentials) if e.floating})

    def record(self, time: float) -> None:
        """Time n's row: :meth:`launch_record`, then the host's part (:meth:`begin_row`)."""
        self.launch_record()
        self.begin_row(time)

    def launch_record(self) -> None:
        """Time n's row on the device: the field terms at x^n and the time-centred kinetic energy and momentum the push
        just wrote (read with the step's report, :meth:`read`)."""
        with self.phases("diagnostics"):
            L, pa, n = self.launcher, self.particles, self.particles.count
            L.launch(K.copy_values, 1, [self.pending, self.field_slots, len(REPORT), self.report])
            self._sum_into(pa.kinetic, n, REPORT.index("kinetic_energy"), self.report)
            self._vector_sum.launch(pa.momentum, n)
            L.launch(K.put_vector, 1, [self._vector_sum.result, REPORT.index("momentum_x"), self.report])

    def begin_row(self, time: float) -> None:
        """The host's part of time n's row: the time and the tallies it keeps itself."""
        self.row = {"time": time, "net_charge_density": self.pending_net, **self.pending_tallies}
        if self.host_terms:
            self.row["host"] = self.pending_host

    def flag(self, flags: wp.array, n: int) -> None:
        """The largest of the step's bad-particle flags into the report (``NodeCoupling.bad_particle``)."""
        self._flag_max.launch(flags, n)
        self.launcher.launch(K.put_flag, 1, [self._flag_max.result, REPORT.index("bad_particle"), self.report])

    def read(self) -> None:
        """The step's one read: the report; appends the recorded row (if any) to the history, keeps the flag."""
        values = self._read_report()
        if self.combine is not None:
            values = self.combine(values)
        self.bad_flag = int(values[REPORT.index("bad_particle")])
        if self.row is None:
            return
        row, self.row = self.row, None
        host = row.pop("host", None)
        if host is not None:
            row["field_energy"], row["deposited_charge"] = host["field_energy"], host["deposited_charge"]
            coefficients = host["coefficients"]
        else:
            field = values[len(REPORT):]
            row["field_energy"] = float(field[FIELD_TERMS.index("field_energy")])
            row["deposited_charge"] = float(field[FIELD_TERMS.index("deposited_charge")])
            if row["net_charge_density"] is None:
                row["net_charge_density"] = float(field[FIELD_TERMS.index("net_charge_density")])
            coefficients = field[len(FIELD_TERMS):]
        coeff = coefficients[0::2] + 1j * coefficients[1::2]
        energy = self.field.area * self.mode_k2 * np.abs(coeff) ** 2   # A |k|² |u_k|² (modes ±k together)
        for (mx, my), e, c in zip(self.modes, energy, coeff):
            row[f"mode_{mx}_{my}_energy"] = float(e)
            row[f"mode_{mx}_{my}_potential_re"] = float(c.real)
        kinetic = float(values[REPORT.index("kinetic_energy")])
        row.update(kinetic_energy=kinetic, total_energy=kinetic + row["field_energy"],
                   momentum_x=float(values[REPORT.index("momentum_x")]),
                   momentum_y=float(values[REPORT.index("momentum_y")]))
        self.particles.state.history.append(row)
