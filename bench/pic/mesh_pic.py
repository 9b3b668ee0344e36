"""A conventional 2D electrostatic mesh particle-in-cell code as Warp kernels: the baseline that warpfree's meshfree
PIC is compared with (plasma oscillation frequency and two-stream growth rate, error against wall time).

Equations (normalised units: ε0 = 1, electron charge -1 and mass 1, ω_p = 1 for the total electron density n0 = 1,
lengths in units of v/ω_p for cold plasmas, in Debye lengths where a temperature exists)::

    dx_p/dt = v_p,   dv_p/dt = (q/m)_s E(x_p),   -∇²φ = ρ,   E = -∇φ

on the periodic box [0, Lx) x [0, Ly) with nodes at (iΔx, jΔy), i < nx, j < ny. Macro-particles of species s carry
charge Q_s = q_s n_s Lx Ly / N_s and mass M_s = m_s n_s Lx Ly / N_s; an immobile ion background (optional) makes the
box neutral. One step of the standard momentum-conserving scheme (Birdsall & Langdon, *Plasma Physics via Computer
Simulation*, ch. 2-4, 14; Hockney & Eastwood, ch. 5):

1. Cloud-in-cell (bilinear) deposit ρ_g = Σ_p Q_p W(x_g - x_p) / (ΔxΔy) + ρ_ion, written as a gather: the particles are
   counting-sorted by cell (Warp's radix sort of cell keys, then one kernel marking each cell's range in the sorted
   order), and every node sums the particles of its 4 adjacent cells. Race-free and deterministic (no atomics:
   Warp's CPU atomics are not thread-safe under warpfree's threaded launches), so bitwise the same for any thread
   count.
2. Poisson by NumPy FFT, the exact inverse of the periodic 5-point Laplacian:
   φ̂(k) = ρ̂(k) / [(2 sin(kxΔx/2)/Δx)² + (2 sin(kyΔy/2)/Δy)²], φ̂(0) = 0.
3. E on the nodes by central differences, E_x = -(φ_{i+1,j} - φ_{i-1,j}) / (2Δx) (likewise E_y).
4. CIC gather of E at each particle (same weights as the deposit: no self-force, momentum conserved to round-off),
   leapfrog v^{n+1/2} = v^{n-1/2} + (q/m) E^n Δt, x^{n+1} = x^n + v^{n+1/2} Δt, wrapped into the box. The run starts
   with v^{-1/2} = v^0 - (q/m) E^0 Δt/2.

Diagnostics at every step n: kinetic energy Σ M (|v^{n-1/2}|² + |v^{n+1/2}|²)/4 (time-centred), field energy
½ Σ_g |E_g|² ΔxΔy, total momentum Σ M (v^{n-1/2} + v^{n+1/2})/2, and the complex amplitude c of one Fourier mode
(kx index m, ky = 0) of φ (φ ≈ Re(c e^{i k x}), k = 2πm/Lx) with that mode's field energy ¼ κ² |c|² LxLy,
κ = sin(kΔx)/Δx (the central difference's wavenumber).

Cases (functions returning dicts, including ``wall_s``: the time loop only, by ``time.perf_counter``; the kernels
are loaded by the set-up's first field solve, so compilation is never timed):

* :func:`plasma_oscillation`: cold electrons on a quiet lattice displaced by A sin(kx), k = 2π/Lx. The frequency
  from the zero crossings of the mode's φ (linearly interpolated, averaged over the run) against the leapfrog value
  (2/Δt) asin(Δt/2) of ω_p = 1; also reported: the grid's cold-plasma dispersion for CIC + 5-point Poisson + central
  E, ω_g² = sinc²(kΔx/2) sinc(kΔx) (aliases neglected), under leapfrog, (2/Δt) asin(ω_g Δt/2), which is what the
  code should (and does) reproduce: its error against ω_p falls as (kΔx)².
* :func:`two_stream`: two cold beams ±v0 of density ½ each (ω_p = 1 in total, ω_b = 1/√2 per beam), Lx = 2π v0/0.612
  so that the fundamental k has k v0 = 0.612 = (√3/2) ω_b, the fastest-growing wavenumber of the cold symmetric
  two-stream instability, γ_max = ω_b/2 = 1/(2√2). Only the fundamental is unstable (k v0 < ω_p), seeded by a
  position perturbation A sin(kx) of both beams. Growth rate: half the slope of a least-squares line through
  log(mode field energy) over the linear phase, from the first step where the mode energy exceeds ``fit_low`` x the
  beams' initial kinetic energy K0 up to the step before it first exceeds ``fit_high`` x K0 (defaults 1e-7 and 1e-3:
  with the default A = 1e-5 the seed is at 5e-11 K0, so the window starts ~2000x above the seed, where the
  non-growing roots of the dispersion relation excited by the seed have fallen to a few % of the growing mode, and
  ends well before saturation by trapping, which sets in at ~1e-2 K0). With 2 x 2 particles per cell and beam the
  mode energy carries a ripple of up to ±8 % about the exponential (the quiet beam lattices crossing the grid,
  aliased by the step); the fit averages it out (±2 % at nx = 64 with 4 x 4).

Precision: float64 throughout (positions, velocities, ρ, φ, E): the two-stream fit spans eight decades of field
energy and a float32 lattice would seed the instability at its round-off.

Usage::

    python bench/pic/mesh_pic.py                     # both cases at nx = 16, 32, 64; 1 thread
    python bench/pic/mesh_pic.py --threads 2 --nx 32 64 --json out.json

Not a timed benchmark by itself: it prints the errors and the wall time of each run (one run each).
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
import warp as wp

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = []
RUN_ALL_SKIPPED = "the mesh PIC module of pic_vs_mesh.py, which runs it (its own command line is a standalone check)"

# -- kernels -----------------------------------------------------------------------------------------------------

ZERO = wp.constant(wp.float64(0.0))
ONE = wp.constant(wp.float64(1.0))
HALF = wp.constant(wp.float64(0.5))
QUARTER = wp.constant(wp.float64(0.25))


@wp.func
def locate(s: wp.float64, n: int):
    """Cell index and fraction of a coordinate ``s`` in cell units (0 <= s <= n): (c, s - floor(s)), c in [0, n)."""
    f = wp.floor(s)
    c = int(f)
    if c >= n:  # s rounded up to n: the cell 0 with fraction 0
        c = c - n
    if c < 0:
        c = c + n
    return c, s - f


@wp.func
def wrap(s: wp.float64, length: wp.float64):
    """``s`` brought into [0, length)."""
    r = s - length * wp.floor(s / length)
    if r >= length:  # s = -tiny rounds to length
        r = r - length
    return r


@wp.kernel
def cell_keys(first: int, nx: int, ny: int, inv_dx: wp.float64, inv_dy: wp.float64, x: wp.array(dtype=wp.vec2d),
              keys: wp.array(dtype=wp.int32), values: wp.array(dtype=wp.int32)):
    """keys[p] = the cell of particle p (ci ny + cj), values[p] = p: the input of the radix sort."""
    p = first + wp.tid()
    xp = x[p]
    ci, fx = locate(xp[0] * inv_dx, nx)
    cj, fy = locate(xp[1] * inv_dy, ny)
    keys[p] = ci * ny + cj
    values[p] = p


@wp.kernel
def cell_ranges(first: int, n: int, keys: wp.array(dtype=wp.int32), start: wp.array(dtype=wp.int32),
                end: wp.array(dtype=wp.int32)):
    """Sorted position s: the first (last) of its cell's run writes that cell's start (end). Each cell is written by
    one thread only; empty cells keep start = end = 0 (zeroed before)."""
    s = first + wp.tid()
    c = keys[s]
    if s == 0:
        start[c] = s
    elif keys[s - 1] != c:
        start[c] = s
    if s == n - 1:
        end[c] = s + 1
    elif keys[s + 1] != c:
        end[c] = s + 1


@wp.kernel
def deposit(first: int, nx: int, ny: int, inv_dx: wp.float64, inv_dy: wp.float64, inv_cell_area: wp.float64,
            background: wp.float64, x: wp.array(dtype=wp.vec2d), species: wp.array(dtype=wp.int32),
            charge: wp.array(dtype=wp.float64), order: wp.array(dtype=wp.int32), start: wp.array(dtype=wp.int32),
            end: wp.array(dtype=wp.int32), rho: wp.array(dtype=wp.float64)):
    """ρ at node k = (i, j): the CIC weights of the particles of the 4 cells around the node (gather)."""
    k = first + wp.tid()
    i = k // ny
    j = k - i * ny
    total = ZERO
    for a in range(2):  # a = 0: the cell to the left (the node is its right corner), a = 1: the node's own cell
        ci = (i - 1 + a + nx) % nx
        for b in range(2):
            cj = (j - 1 + b + ny) % ny
            c = ci * ny + cj
            for s in range(start[c], end[c]):
                p = order[s]
                xp = x[p]
                ii, fx = locate(xp[0] * inv_dx, nx)
                jj, fy = locate(xp[1] * inv_dy, ny)
                wx = fx
                if a == 1:
                    wx = ONE - fx
                wy = fy
                if b == 1:
                    wy = ONE - fy
                total = total + charge[species[p]] * wx * wy
    rho[k] = total * inv_cell_area + background


@wp.kernel
def node_field(first: int, nx: int, ny: int, half_inv_dx: wp.float64, half_inv_dy: wp.float64,
               phi: wp.array(dtype=wp.float64), e: wp.array(dtype=wp.vec2d)):
    """E = -∇φ at node k by central differences (periodic)."""
    k = first + wp.tid()
    i = k // ny
    j = k - i * ny
    ip = (i + 1) % nx
    im = (i - 1 + nx) % nx
    jp = (j + 1) % ny
    jm = (j - 1 + ny) % ny
    ex = -(phi[ip * ny + j] - phi[im * ny + j]) * half_inv_dx
    ey = -(phi[i * ny + jp] - phi[i * ny + jm]) * half_inv_dy
    e[k] = wp.vec2d(ex, ey)


@wp.kernel
def push(first: int, nx: int, ny: int, inv_dx: wp.float64, inv_dy: wp.float64, lx: wp.float64, ly: wp.float64,
         dt_kick: wp.float64, dt_drift: wp.float64, order: wp.array(dtype=wp.int32), species: wp.array(dtype=wp.int32),
         q_over_m: wp.array(dtype=wp.float64), mass: wp.array(dtype=wp.float64), e: wp.array(dtype=wp.vec2d),
         x: wp.array(dtype=wp.vec2d), v: wp.array(dtype=wp.vec2d), ke: wp.array(dtype=wp.float64),
         momentum: wp.array(dtype=wp.vec2d)):
    """Particle order[first + tid] (cell order, for locality): CIC gather of E, v += (q/m) E dt_kick,
    x += v dt_drift wrapped; its time-centred kinetic energy and momentum. Writes only its own particle."""
    p = order[first + wp.tid()]
    xp = x[p]
    ci, fx = locate(xp[0] * inv_dx, nx)
    cj, fy = locate(xp[1] * inv_dy, ny)
    ci1 = (ci + 1) % nx
    cj1 = (cj + 1) % ny
    gx = ONE - fx
    gy = ONE - fy
    ep = (e[ci * ny + cj] * (gx * gy) + e[ci1 * ny + cj] * (fx * gy) + e[ci * ny + cj1] * (gx * fy)
          + e[ci1 * ny + cj1] * (fx * fy))
    s = species[p]
    v_old = v[p]
    v_new = v_old + ep * (q_over_m[s] * dt_kick)
    v[p] = v_new
    xn = xp + v_new * dt_drift
    x[p] = wp.vec2d(wrap(xn[0], lx), wrap(xn[1], ly))
    m = mass[s]
    ke[p] = QUARTER * m * (wp.dot(v_old, v_old) + wp.dot(v_new, v_new))
    momentum[p] = (v_old + v_new) * (HALF * m)


# -- the code ----------------------------------------------------------------------------------------------------

def _launcher(launcher):
    if launcher is not None:
        return launcher
    import warpfree.device

    return warpfree.device.current_launcher()


class MeshPIC:
    """Electrostatic CIC PIC on an nx x ny periodic grid of [0, lx) x [0, ly).

    ``x``, ``v``: (N, 2) initial positions (inside the box) and velocities; ``species``: (N,) index into the
    per-species macro ``charge``, ``mass`` (their ratio is q/m). ``neutralise``: add the uniform immobile background
    that cancels the particles' total charge. ``mode``: the kx index of the φ mode recorded each step.
    """

    def __init__(self, nx: int, ny: int, lx: float, ly: float, x, v, species, charge, mass, neutralise: bool = True,
                 mode: int = 1, launcher=None):
        for name, n in (("nx", nx), ("ny", ny)):
            if int(n) != n or n < 4:
                raise ValueError(f"{name} must be an integer >= 4, got {n!r}")
        for name, length in (("lx", lx), ("ly", ly)):
            if not (math.isfinite(length) and length > 0):
                raise ValueError(f"{name} must be finite and > 0, got {length!r}")
        x = np.ascontiguousarray(x, dtype=np.float64)
        v = np.ascontiguousarray(v, dtype=np.float64)
        species = np.ascontiguousarray(species, dtype=np.int32)
        charge = np.ascontiguousarray(charge, dtype=np.float64)
        mass = np.ascontiguousarray(mass, dtype=np.float64)
        n = x.shape[0]
        if x.shape != (n, 2) or v.shape != (n, 2) or species.shape != (n,) or n < 1:
            raise ValueError(f"x and v must be (N, 2) and species (N,) with N >= 1, got {x.shape}, {v.shape}, "
                             f"{species.shape}")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
            raise ValueError("x and v must be finite")
        if np.any(x < 0) or np.any(x[:, 0] >= lx) or np.any(x[:, 1] >= ly):
            raise ValueError(f"x must lie in [0, {lx}) x [0, {ly})")
        if charge.shape != mass.shape or charge.ndim != 1 or np.any(mass <= 0) or not np.all(np.isfinite(charge)):
            raise ValueError("charge and mass must be 1D of equal length, finite, mass > 0")
        if species.min() < 0 or species.max() >= charge.shape[0]:
            raise ValueError(f"species must index the {charge.shape[0]} species, got {species.min()}..{species.max()}")
        if not (0 <= mode < nx // 2):
            raise ValueError(f"mode must be in [0, nx/2) = [0, {nx // 2}), got {mode!r}")
        self.launcher = _launcher(launcher)
        dev = self.launcher.device
        self.nx, self.ny, self.lx, self.ly, self.n, self.mode = int(nx), int(ny), float(lx), float(ly), n, int(mode)
        self.dx, self.dy = self.lx / self.nx, self.ly / self.ny
        self.x = wp.array(x, dtype=wp.vec2d, device=dev)
        self.v = wp.array(v, dtype=wp.vec2d, device=dev)
        self.species = wp.array(species, dtype=wp.int32, device=dev)
        self.charge = wp.array(charge, dtype=wp.float64, device=dev)
        self.mass = wp.array(mass, dtype=wp.float64, device=dev)
        self.q_over_m = wp.array(charge / mass, dtype=wp.float64, device=dev)
        total = float(np.sum(charge[species]))
        self.background = -total / (self.lx * self.ly) if neutralise else 0.0
        cells = self.nx * self.ny
        self.keys = wp.zeros(2 * n, dtype=wp.int32, device=dev)  # the radix sort needs 2n
        self.order = wp.array(np.arange(2 * n, dtype=np.int32), dtype=wp.int32, device=dev)
        self.start = wp.zeros(cells, dtype=wp.int32, device=dev)
        self.end = wp.zeros(cells, dtype=wp.int32, device=dev)
        self.rho = wp.zeros(cells, dtype=wp.float64, device=dev)
        self.phi = wp.zeros(cells, dtype=wp.float64, device=dev)
        self.e = wp.zeros(cells, dtype=wp.vec2d, device=dev)
        self.ke = wp.zeros(n, dtype=wp.float64, device=dev)
        self.momentum = wp.zeros(n, dtype=wp.vec2d, device=dev)
        kx = 2.0 * np.pi * np.fft.fftfreq(self.nx, d=self.dx)
        ky = 2.0 * np.pi * np.fft.rfftfreq(self.ny, d=self.dy)
        k2 = ((2.0 * np.sin(0.5 * kx * self.dx) / self.dx) ** 2)[:, None] + \
             ((2.0 * np.sin(0.5 * ky * self.dy) / self.dy) ** 2)[None, :]
        k2[0, 0] = 1.0
        self.inv_k2 = 1.0 / k2
        self.inv_k2[0, 0] = 0.0
        self.mode_kappa = math.sin(2.0 * math.pi * self.mode / self.lx * self.dx) / self.dx
        self.mode_amplitude = 0j
        self.solve_field()  # loads the kernels (the first launch JIT-compiles the module)

    # -- one step's parts
    def sort(self) -> None:
        """Counting sort of the particles by cell: ``order`` lists them cell by cell, cell c in [start, end)."""
        L, n = self.launcher, self.n
        L.launch(cell_keys, n, [self.nx, self.ny, 1.0 / self.dx, 1.0 / self.dy, self.x, self.keys, self.order])
        wp.utils.radix_sort_pairs(self.keys, self.order, n)
        self.start.zero_()
        self.end.zero_()
        L.launch(cell_ranges, n, [n, self.keys, self.start, self.end])

    def solve_field(self) -> None:
        """Sort, deposit ρ, solve for φ (FFT), E on the nodes; records the φ mode."""
        self.sort()
        L, nx, ny = self.launcher, self.nx, self.ny
        L.launch(deposit, nx * ny, [nx, ny, 1.0 / self.dx, 1.0 / self.dy, 1.0 / (self.dx * self.dy), self.background,
                                    self.x, self.species, self.charge, self.order, self.start, self.end, self.rho])
        rho_hat = np.fft.rfft2(self.rho.numpy().reshape(nx, ny))
        phi_hat = rho_hat * self.inv_k2
        self.phi.assign(np.fft.irfft2(phi_hat, s=(nx, ny)).reshape(-1))
        self.mode_amplitude = complex(2.0 * phi_hat[self.mode, 0] / (nx * ny))
        L.launch(node_field, nx * ny, [nx, ny, 0.5 / self.dx, 0.5 / self.dy, self.phi, self.e])

    def _push(self, dt_kick: float, dt_drift: float) -> None:
        self.launcher.launch(push, self.n, [self.nx, self.ny, 1.0 / self.dx, 1.0 / self.dy, self.lx, self.ly,
                                            float(dt_kick), float(dt_drift), self.order, self.species, self.q_over_m,
                                            self.mass, self.e, self.x, self.v, self.ke, self.momentum])

    def field_energy(self) -> float:
        e = self.e.numpy()
        return 0.5 * float(np.sum(e * e)) * self.dx * self.dy

    def mode_field_energy(self) -> float:
        """Field energy of the recorded mode (±k together): ¼ κ² |c|² LxLy."""
        return 0.25 * self.mode_kappa ** 2 * abs(self.mode_amplitude) ** 2 * self.lx * self.ly

    def run(self, dt: float, steps: int) -> dict:
        """Half-kick v(0) back to v(-dt/2), then ``steps`` leapfrog steps. Returns the diagnostics at t_n = n dt,
        n = 0 .. steps-1 (arrays) and ``wall_s`` of the loop (the half kick and the steps, diagnostics included)."""
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be finite and > 0, got {dt!r}")
        if int(steps) != steps or steps < 1:
            raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
        steps = int(steps)
        t = np.arange(steps) * dt
        ke, fe, mode_fe = np.zeros(steps), np.zeros(steps), np.zeros(steps)
        momentum, mode = np.zeros((steps, 2)), np.zeros(steps, dtype=complex)
        t0 = time.perf_counter()
        self._push(-0.5 * dt, 0.0)  # v(-dt/2) = v(0) - (q/m) E(0) dt/2
        for n in range(steps):
            fe[n] = self.field_energy()
            mode[n] = self.mode_amplitude
            mode_fe[n] = self.mode_field_energy()
            self._push(dt, dt)
            ke[n] = float(np.sum(self.ke.numpy()))
            momentum[n] = np.sum(self.momentum.numpy(), axis=0)
            if not (math.isfinite(ke[n]) and math.isfinite(fe[n])):
                raise FloatingPointError(f"non-finite energy at step {n} (t = {t[n]:.4g}); dt = {dt} too large?")
            self.solve_field()
        self.launcher.synchronize()
        wall = time.perf_counter() - t0
        return dict(t=t, kinetic_energy=ke, field_energy=fe, momentum=momentum, mode=mode, mode_field_energy=mode_fe,
                    wall_s=wall, steps=steps)


def lattice(nx: int, ny: int, lx: float, ly: float, px: int, py: int) -> np.ndarray:
    """A quiet start: (nx px) x (ny py) particles at the centres of a regular sub-lattice of the box."""
    gx = (np.arange(nx * px) + 0.5) * (lx / (nx * px))
    gy = (np.arange(ny * py) + 0.5) * (ly / (ny * py))
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    return np.stack([X.ravel(), Y.ravel()], axis=1)


def _per_direction(particles_per_cell: int) -> tuple[int, int]:
    """(px, py): √ppc each way for a square number, else ppc along x and 1 along y."""
    if int(particles_per_cell) != particles_per_cell or particles_per_cell < 1:
        raise ValueError(f"particles_per_cell must be an integer >= 1, got {particles_per_cell!r}")
    r = math.isqrt(int(particles_per_cell))
    return (r, r) if r * r == particles_per_cell else (int(particles_per_cell), 1)


def _check_dt(dt: float) -> None:
    if not (math.isfinite(dt) and 0 < dt < 2.0):
        raise ValueError(f"dt must be in (0, 2) (leapfrog limit ω_p dt < 2, ω_p = 1), got {dt!r}")


def zero_crossing_frequency(t: np.ndarray, s: np.ndarray) -> tuple[float, int]:
    """Angular frequency from the zero crossings of ``s`` (linearly interpolated): π (crossings - 1) / (last - first);
    and the number of crossings."""
    i = np.flatnonzero(np.sign(s[:-1]) * np.sign(s[1:]) < 0)
    if i.size < 2:
        return float("nan"), int(i.size)
    tc = t[i] + (t[i + 1] - t[i]) * s[i] / (s[i] - s[i + 1])
    return float(math.pi * (tc.size - 1) / (tc[-1] - tc[0])), int(tc.size)


def plasma_oscillation(nx: int = 32, particles_per_cell: int = 4, dt: float = 0.1, periods: float = 10.0,
                       amplitude: float = 0.01, ny: int = 8, lx: float = 2.0 * math.pi, launcher=None,
                       series: bool = False) -> dict:
    """Cold plasma oscillation of the fundamental mode k = 2π/lx (Δy = Δx, so ly = lx ny/nx).

    Electrons (n0 = 1, q/m = -1) on a quiet lattice of ``particles_per_cell`` per cell, displaced by
    ``amplitude`` sin(kx), at rest, over a neutralising background; run for ``periods`` plasma periods. Returns the
    measured ω (zero crossings of the φ mode), the leapfrog reference (2/dt) asin(dt/2) and the relative error against
    it, the grid-dispersion prediction, the relative spread of total energy, the largest |total momentum|, wall time.
    """
    _check_dt(dt)
    px, py = _per_direction(particles_per_cell)
    k = 2.0 * math.pi / lx
    if not (math.isfinite(amplitude) and 0 < amplitude * k < 0.5):
        raise ValueError(f"amplitude must satisfy 0 < amplitude k < 0.5 (k = {k:.4g}), got {amplitude!r}")
    if not (math.isfinite(periods) and periods >= 1):
        raise ValueError(f"periods must be >= 1, got {periods!r}")
    ly = lx * ny / nx
    x0 = lattice(nx, ny, lx, ly, px, py)
    n = x0.shape[0]
    x = x0.copy()
    x[:, 0] = np.mod(x0[:, 0] + amplitude * np.sin(k * x0[:, 0]), lx)
    weight = lx * ly / n  # n0 = 1
    pic = MeshPIC(nx, ny, lx, ly, x, np.zeros_like(x), np.zeros(n, dtype=np.int32), [-weight], [weight],
                  neutralise=True, mode=1, launcher=launcher)
    steps = int(math.ceil(periods * 2.0 * math.pi / dt))
    r = pic.run(dt, steps)
    c = r["mode"]
    ref = c[np.argmax(np.abs(c))]
    signed = np.real(c * np.conj(ref)) / abs(ref)
    omega, crossings = zero_crossing_frequency(r["t"], signed)
    omega_leapfrog = 2.0 / dt * math.asin(0.5 * dt)
    theta = k * pic.dx
    omega_grid = math.sqrt(np.sinc(theta / (2 * math.pi)) ** 2 * np.sinc(theta / math.pi))
    omega_grid_leapfrog = 2.0 / dt * math.asin(0.5 * omega_grid * dt)
    total = r["kinetic_energy"] + r["field_energy"]
    out = dict(case="plasma_oscillation", nx=nx, ny=ny, lx=lx, ly=ly, particles=n, particles_per_cell=px * py,
               dt=dt, steps=steps, amplitude=amplitude, frequency=omega, crossings=crossings,
               frequency_theory=omega_leapfrog, frequency_error=(omega - omega_leapfrog) / omega_leapfrog,
               frequency_grid_theory=omega_grid_leapfrog,
               frequency_error_vs_grid_theory=(omega - omega_grid_leapfrog) / omega_grid_leapfrog,
               energy_spread=float((total.max() - total.min()) / np.mean(total)),
               max_abs_momentum=float(np.max(np.abs(r["momentum"]))), wall_s=r["wall_s"],
               threads=pic.launcher.threads)
    if series:
        out["series"] = r
    return out


def two_stream(nx: int = 32, particles_per_cell: int = 4, dt: float = 0.1, t_end: float = 45.0,
               amplitude: float = 1e-5, v0: float = 1.0, ny: int = 8, fit_low: float = 1e-7, fit_high: float = 1e-3,
               launcher=None, series: bool = False) -> dict:
    """Cold symmetric two-stream instability of the fundamental mode, k v0 = 0.612 (lx = 2π v0 / 0.612, Δy = Δx).

    Two beams ±v0 (x direction) of density ½ each, q/m = -1, ``particles_per_cell`` per beam and cell on the same
    quiet lattice, both displaced by ``amplitude`` sin(kx) (a length), over a neutralising background.
    The growth rate γ is half the slope of log(mode field energy) fitted where it lies between ``fit_low`` K0 and
    ``fit_high`` K0 (K0 = the beams' initial kinetic energy); error against γ_max = 1/(2√2).
    """
    _check_dt(dt)
    px, py = _per_direction(particles_per_cell)
    if not (math.isfinite(v0) and v0 > 0):
        raise ValueError(f"v0 must be finite and > 0, got {v0!r}")
    if not (0 < fit_low < fit_high < 1):
        raise ValueError(f"need 0 < fit_low < fit_high < 1, got {fit_low!r}, {fit_high!r}")
    kv0 = 0.612
    lx = 2.0 * math.pi * v0 / kv0
    k = 2.0 * math.pi / lx
    if not (math.isfinite(amplitude) and 0 < amplitude * k < 0.1):
        raise ValueError(f"amplitude must satisfy 0 < amplitude k < 0.1 (k = {k:.4g}), got {amplitude!r}")
    ly = lx * ny / nx
    x0 = lattice(nx, ny, lx, ly, px, py)
    nb = x0.shape[0]
    x1 = x0.copy()
    x1[:, 0] = np.mod(x0[:, 0] + amplitude * np.sin(k * x0[:, 0]), lx)
    x = np.concatenate([x1, x1])
    v = np.zeros_like(x)
    v[:nb, 0], v[nb:, 0] = v0, -v0
    species = np.repeat(np.array([0, 1], dtype=np.int32), nb)
    weight = 0.5 * lx * ly / nb  # density ½ per beam
    pic = MeshPIC(nx, ny, lx, ly, x, v, species, [-weight, -weight], [weight, weight], neutralise=True, mode=1,
                  launcher=launcher)
    steps = int(math.ceil(t_end / dt))
    r = pic.run(dt, steps)
    k0 = 0.5 * v0 ** 2 * lx * ly  # 2 beams x ½ density x ½ v0²
    w = r["mode_field_energy"] / k0
    t = r["t"]
    above = np.flatnonzero(w >= fit_low)
    gamma, window = float("nan"), (float("nan"), float("nan"))
    if above.size:
        i0 = int(above[0])
        past = np.flatnonzero(w[i0:] >= fit_high)
        i1 = i0 + int(past[0]) if past.size else steps
        if i1 - i0 >= 5:
            slope = np.polyfit(t[i0:i1], np.log(w[i0:i1]), 1)[0]
            gamma, window = 0.5 * float(slope), (float(t[i0]), float(t[i1 - 1]))
    gamma_theory = 1.0 / (2.0 * math.sqrt(2.0))
    total = r["kinetic_energy"] + r["field_energy"]
    out = dict(case="two_stream", nx=nx, ny=ny, lx=lx, ly=ly, particles=2 * nb, particles_per_cell=2 * px * py,
               dt=dt, steps=steps, amplitude=amplitude, v0=v0, growth_rate=gamma, growth_rate_theory=gamma_theory,
               growth_rate_error=(gamma - gamma_theory) / gamma_theory, fit_window=window,
               fit_thresholds=(fit_low, fit_high), seed_energy=float(w[0]), peak_mode_energy=float(w.max()),
               energy_spread=float((total.max() - total.min()) / np.mean(total)),
               max_abs_momentum=float(np.max(np.abs(r["momentum"]))), wall_s=r["wall_s"],
               threads=pic.launcher.threads)
    if series:
        out["series"] = r
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nx", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--ny", type=int, default=8)
    ap.add_argument("--ppc", type=int, default=4, help="particles per cell (per beam for the two-stream case)")
    ap.add_argument("--dt", type=float, default=0.1)
    ap.add_argument("--periods", type=float, default=10.0, help="plasma oscillation: plasma periods")
    ap.add_argument("--t-end", type=float, default=45.0, help="two-stream: end time (1/ω_p)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--case", choices=("both", "oscillation", "two_stream"), default="both")
    ap.add_argument("--json", default=None, help="write the results (without time series) to this file")
    args = ap.parse_args()
    import warpfree.device

    launcher = warpfree.device.use("cpu", args.threads)
    rows = []
    if args.case in ("both", "oscillation"):
        print(f"plasma oscillation (dt = {args.dt}, {args.periods:g} periods, reference (2/dt) asin(dt/2), "
              f"{launcher.threads} thread(s))")
        print("|  nx | particles | steps | ω measured | error vs leapfrog ω_p | error vs grid theory | wall s |")
        print("| --: | --: | --: | --: | --: | --: | --: |")
        for nx in args.nx:
            r = plasma_oscillation(nx, args.ppc, args.dt, args.periods, ny=args.ny, launcher=launcher)
            rows.append(r)
            print(f"| {nx} | {r['particles']} | {r['steps']} | {r['frequency']:.6f} | {r['frequency_error']:+.3e} | "
                  f"{r['frequency_error_vs_grid_theory']:+.1e} | {r['wall_s']:.3f} |", flush=True)
    if args.case in ("both", "two_stream"):
        print(f"\ntwo-stream (k v0 = 0.612, dt = {args.dt}, to t = {args.t_end:g}, reference γ = 1/(2√2), fit "
              "of the mode energy between 1e-7 and 1e-3 of K0)")
        print("|  nx | particles | steps | γ measured | error | fit window t | wall s |")
        print("| --: | --: | --: | --: | --: | :-: | --: |")
        for nx in args.nx:
            r = two_stream(nx, args.ppc, args.dt, args.t_end, ny=args.ny, launcher=launcher)
            rows.append(r)
            print(f"| {nx} | {r['particles']} | {r['steps']} | {r['growth_rate']:.5f} | "
                  f"{r['growth_rate_error']:+.3e} | {r['fit_window'][0]:.1f}-{r['fit_window'][1]:.1f} | "
                  f"{r['wall_s']:.3f} |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
