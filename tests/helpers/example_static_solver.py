"""A small static solver on the core, for the run-shell tests: nodal values from imposed field values.

SPH values are not nodal values (Mendes (2010) §3.1.5): to make the SPH interpolant equal imposed values
f_i at the particles, solve once M u = f with M_ij = W(|x_i - x_j|, h) V_j (eq. 3.31/3.35, diagonal
included). Static neighbour list, race-free triplet assembly, one sparse factorisation: the pattern
of the EFG and SPEM solvers to come.
"""

from __future__ import annotations

import numpy as np

from helpers import kernels_for_tests as kt
from warpfree.device import current_launcher
from warpfree.kernels.smoothing import kernel_id, support_factor
from warpfree.neighbours import NeighbourGrid, NeighbourList
from warpfree.particles import ParticleSet
from warpfree.solver import OutputSet, StaticSolver
from warpfree.space import Space
from warpfree.sparse import FactorisedSystem, PrescribedValues, TripletBuffer, to_csr


class NodalValuesSolver(StaticSolver):
    name = "nodal_values"
    work_unit = "particles"

    def __init__(self, positions, dx: float, imposed, space: Space, h_factor: float = 1.3):
        launcher = current_launcher()
        super().__init__(None, launcher)
        self.space = space
        self.particles = ParticleSet("particles", positions, space.dim, launcher.device)
        self.particles.add("volume", dx ** space.dim)
        self.h = h_factor * dx
        self.imposed = np.asarray(imposed, dtype=np.float64)
        self.nodal = np.zeros_like(self.imposed)
        self.interpolant = np.zeros_like(self.imposed)

    @property
    def dim(self) -> int:
        return self.space.dim

    @property
    def work_items(self) -> int:
        return self.particles.n

    def solve(self) -> None:
        n, x = self.particles.n, self.particles.position
        with self.phases("neighbours"):
            rows = NeighbourList(NeighbourGrid(self.launcher, 2.0 * self.h, self.space, x), x)
        with self.phases("assembly"):
            slots = TripletBuffer(rows.n_pairs, self.launcher.device)
            self.launcher.launch(kt.interpolation_matrix, n, [rows.rows, self.space.box, x, self.particles["volume"],
                                                              kernel_id("wendland_c2"), self.dim, self.h,
                                                              slots.triplets])
            self.matrix = to_csr(slots, (n, n))
        with self.phases("factorisation"):
            system = FactorisedSystem(self.matrix, PrescribedValues([], [], n))
        with self.phases("solve"):
            self.nodal = system.solve(self.imposed)
        self.interpolant = self.matrix @ self.nodal

    def output_sets(self) -> list[OutputSet]:
        return [OutputSet("particles", self.particles.numpy("position"),
                          {"imposed": self.imposed, "nodal": self.nodal, "interpolant": self.interpolant},
                          frame_field="nodal")]

    def diagnostics(self) -> dict[str, float]:
        return {"max_interpolation_error": float(np.max(np.abs(self.interpolant - self.imposed)))}

    def describe(self) -> dict:
        return {"n_particles": self.particles.n, "h": self.h, "support": support_factor("wendland_c2") * self.h}
