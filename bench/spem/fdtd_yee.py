"""Yee FDTD solvers of the waveguide of ``scenes/em_waveguide_2d.py`` and of the line of ``scenes/em_line_1d.py``,
as Warp kernels: the mesh method SPEM is compared with (``bench/spem/spem_vs_fdtd.py``).

TMz on Yee's staggered grid (Yee 1966; Taflove & Hagness, *Computational Electrodynamics*, ch. 3): Ez at (iΔ, jΔ),
Hx at (iΔ, (j+½)Δ), Hy at ((i+½)Δ, jΔ); plates (Ez = 0) at i = 0 and i = nx, the line j = 0 driven with
E0 sin(πx/a) s(t) (hard), a Berenger split-field PML (same grading and exponential update as SPEM's) on the
top rows, backed by Ez = 0 at j = ny. Each update is a gather over a cell's own neighbours (race-free), launched
through warpfree's launcher so that both codes use the same threads. float32, SI units.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpfree.kernels.spem import exponential_step
from warpfree.solvers.spem import C0, EPS0, MU0, PML


@wp.kernel
def update_h(first: int, nx: int, ny: int, dt: float, inv_dx: float, ez: wp.array(dtype=float),
             loss_hx: wp.array(dtype=float), hx: wp.array(dtype=float), hy: wp.array(dtype=float)):
    """Hx(i, j+½) ← a Hx - b ∂Ez/∂y (σy* matched), Hy(i+½, j) ← Hy + (Δt/μ0) ∂Ez/∂x; arrays (nx+1)(ny+1)."""
    k = first + wp.tid()
    i = k // (ny + 1)
    j = k - i * (ny + 1)
    e = ez[k]
    if j < ny:
        p = exponential_step(loss_hx[k], dt, 1.0 / MU0)
        hx[k] = p[0] * hx[k] - p[1] * (ez[k + 1] - e) * inv_dx
    if i < nx:
        hy[k] = hy[k] + dt / MU0 * (ez[k + ny + 1] - e) * inv_dx


@wp.kernel
def update_e(first: int, nx: int, ny: int, dt: float, inv_dx: float, hx: wp.array(dtype=float),
             hy: wp.array(dtype=float), loss_ez: wp.array(dtype=float), ez: wp.array(dtype=float),
             ezy: wp.array(dtype=float)):
    """Interior Ez: Ezx ← Ezx + (Δt/ε0) ∂Hy/∂x, Ezy ← a Ezy - b ∂Hx/∂y, Ez = Ezx + Ezy; the border stays 0."""
    k = first + wp.tid()
    i = k // (ny + 1)
    j = k - i * (ny + 1)
    if i == 0 or i == nx or j == 0 or j == ny:
        return
    p = exponential_step(loss_ez[k], dt, 1.0 / EPS0)
    e_y = ezy[k]
    e_x = ez[k] - e_y + dt / EPS0 * (hy[k] - hy[k - ny - 1]) * inv_dx
    e_y = p[0] * e_y - p[1] * (hx[k] - hx[k - 1]) * inv_dx
    ezy[k] = e_y
    ez[k] = e_x + e_y


@wp.kernel
def drive(first: int, ny: int, profile: wp.array(dtype=float), value: float, ez: wp.array(dtype=float)):
    """Hard source on the line j = 0: Ez(i, 0) = profile_i s(t)."""
    i = first + wp.tid()
    ez[i * (ny + 1)] = profile[i] * value


class YeeWaveguide:
    """The waveguide of width a, interior length L and PML thickness δ on a Yee grid of spacing ≈ Δ."""

    def __init__(self, launcher, width: float, length: float, pml_thickness: float, spacing: float, amplitude: float,
                 pml: PML):
        self.launcher = launcher
        self.nx = int(round(width / spacing))
        self.ny = int(round((length + pml_thickness) / spacing))
        self.dx = width / self.nx
        self.width = width
        n = (self.nx + 1) * (self.ny + 1)
        dev = launcher.device
        i, j = np.divmod(np.arange(n), self.ny + 1)
        x, y = i * self.dx, j * self.dx
        sigma_e = pml.sigma(np.stack([x, y], 1), (0.0, 0.0), (width, length))[:, 1]
        sigma_h = pml.sigma(np.stack([x, y + 0.5 * self.dx], 1), (0.0, 0.0), (width, length))[:, 1]
        self.loss_ez = wp.array((sigma_e / EPS0).astype(np.float32), dtype=float, device=dev)
        self.loss_hx = wp.array((sigma_h / EPS0).astype(np.float32), dtype=float, device=dev)
        self.ez, self.ezy, self.hx, self.hy = (wp.zeros(n, dtype=float, device=dev) for _ in range(4))
        xs = np.arange(self.nx + 1) * self.dx
        self.profile = wp.array((amplitude * np.sin(np.pi * xs / width)).astype(np.float32), dtype=float, device=dev)
        self.t = 0.0

    def reset(self) -> None:
        """Fields to zero and t = 0 (after an untimed step that loads the kernels)."""
        for a in (self.ez, self.ezy, self.hx, self.hy):
            a.zero_()
        self.t = 0.0

    def stable_dt(self) -> float:
        return self.dx / (C0 * math.sqrt(2.0))

    def step(self, dt: float, source) -> None:
        L, nx, ny, inv = self.launcher, self.nx, self.ny, 1.0 / self.dx
        n = (nx + 1) * (ny + 1)
        L.launch(update_e, n, [nx, ny, float(dt), inv, self.hx, self.hy, self.loss_ez, self.ez, self.ezy])
        L.launch(drive, nx + 1, [ny, self.profile, float(source(self.t + 0.5 * dt)), self.ez])
        L.launch(update_h, n, [nx, ny, float(dt), inv, self.ez, self.loss_hx, self.hx, self.hy])
        self.t += dt

    def column(self, x: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(x of the grid column nearest x, y of its nodes, Ez there)."""
        i = int(round(x / self.dx))
        ez = self.ez.numpy().reshape(self.nx + 1, self.ny + 1)[i]
        return i * self.dx, np.arange(self.ny + 1) * self.dx, ez


@wp.kernel
def update_line_e(first: int, n: int, dt: float, inv_dx: float, hy: wp.array(dtype=float), ez: wp.array(dtype=float)):
    """1D: Ez(k) ← Ez + (Δt/ε0) ∂Hy/∂x at the interior nodes (Hy(k+½) stored at k); the ends stay 0 (PEC)."""
    k = first + wp.tid()
    if k == 0 or k == n:
        return
    ez[k] = ez[k] + dt / EPS0 * (hy[k] - hy[k - 1]) * inv_dx


@wp.kernel
def update_line_h(first: int, dt: float, inv_dx: float, ez: wp.array(dtype=float), hy: wp.array(dtype=float)):
    """1D: Hy(k+½) ← Hy + (Δt/μ0) ∂Ez/∂x, k = 0 .. n-1."""
    k = first + wp.tid()
    hy[k] = hy[k] + dt / MU0 * (ez[k + 1] - ez[k]) * inv_dx


@wp.kernel
def drive_node(first: int, node: int, value: float, ez: wp.array(dtype=float)):
    """Hard source at one node: Ez(node) = s(t)."""
    ez[node] = value


class YeeLine:
    """The line of ``scenes/em_line_1d.py`` on a 1D Yee grid: Ez at x_k = kΔ (k = 0..n, PEC ends), Hy at the
    midpoints, Δ = length/n with n = round(length/spacing) (the nodes of ``staggered_line``), a hard sine source
    at the node nearest the centre."""

    def __init__(self, launcher, length: float, spacing: float):
        self.launcher = launcher
        self.n = max(2, int(round(length / spacing)))
        self.dx = length / self.n
        self.x = np.arange(self.n + 1) * self.dx
        self.source = int(np.argmin(np.abs(self.x - 0.5 * length)))
        dev = launcher.device
        self.ez, self.hy = (wp.zeros(self.n + 1, dtype=float, device=dev) for _ in range(2))
        self.t = 0.0

    def reset(self) -> None:
        for a in (self.ez, self.hy):
            a.zero_()
        self.t = 0.0

    def stable_dt(self) -> float:
        return self.dx / C0

    def step(self, dt: float, source) -> None:
        L, inv = self.launcher, 1.0 / self.dx
        L.launch(update_line_e, self.n + 1, [self.n, float(dt), inv, self.hy, self.ez])
        L.launch(drive_node, 1, [self.source, float(source(self.t + 0.5 * dt)), self.ez])
        L.launch(update_line_h, self.n, [float(dt), inv, self.ez, self.hy])
        self.t += dt


@wp.kernel
def update_e_medium(first: int, nx: int, ny: int, inv_dx: float, step_over_eps: wp.array(dtype=float),
                    hx: wp.array(dtype=float), hy: wp.array(dtype=float), ez: wp.array(dtype=float)):
    """Ez += (Δt/ε) (∂Hy/∂x - ∂Hx/∂y) where ``step_over_eps`` is non-zero (Δt/ε per node; 0: a conductor node)."""
    k = first + wp.tid()
    i = k // (ny + 1)
    j = k - i * (ny + 1)
    c = step_over_eps[k]
    if c == 0.0 or i == 0 or i == nx or j == 0 or j == ny:
        return
    ez[k] = ez[k] + c * ((hy[k] - hy[k - ny - 1]) - (hx[k] - hx[k - 1])) * inv_dx


class YeeCavity:
    """The circular cavity of ``scenes/em_cavity_2d.py`` (radius r0, εr inside, perfectly conducting wall) on a Yee
    grid of spacing Δ = r0/``cells_per_radius`` over [0, 2 r0]²: the wall is staircased, every Ez node at r >= r0
    from the centre held at 0 (Taflove & Hagness §3.13: the usual FDTD treatment of a curved conductor without
    conformal cells). Ez(r, 0) = 1 - r²/r0² on the free nodes, H = 0."""

    def __init__(self, launcher, radius: float, eps_r: float, cells_per_radius: int):
        self.launcher = launcher
        self.n = 2 * int(cells_per_radius)
        self.dx = radius / int(cells_per_radius)
        self.eps_r = eps_r
        m = (self.n + 1) ** 2
        i, j = np.divmod(np.arange(m), self.n + 1)
        x, y = i * self.dx, j * self.dx
        self.r = np.hypot(x - radius, y - radius)
        self.free = self.r < radius * (1 - 1e-12)
        self.initial = np.where(self.free, 1.0 - (self.r / radius) ** 2, 0.0).astype(np.float32)
        dev = launcher.device
        self.step_over_eps = wp.zeros(m, dtype=float, device=dev)
        self.ez, self.hx, self.hy = (wp.zeros(m, dtype=float, device=dev) for _ in range(3))
        self.loss_hx = wp.zeros(m, dtype=float, device=dev)
        self.reset()

    def reset(self) -> None:
        self.ez.assign(self.initial)
        self.hx.zero_()
        self.hy.zero_()
        self.t = 0.0

    def stable_dt(self) -> float:
        """Yee's limit in the medium, Δ √εr/(c√2)."""
        return self.dx * math.sqrt(self.eps_r) / (C0 * math.sqrt(2.0))

    def step(self, dt: float) -> None:
        L, n, inv = self.launcher, self.n, 1.0 / self.dx
        m = (n + 1) ** 2
        if self.t == 0.0:
            self.step_over_eps.assign(np.where(self.free, dt / (EPS0 * self.eps_r), 0.0).astype(np.float32))
        L.launch(update_e_medium, m, [n, n, inv, self.step_over_eps, self.hx, self.hy, self.ez])
        L.launch(update_h, m, [n, n, float(dt), inv, self.ez, self.loss_hx, self.hx, self.hy])
        self.t += dt


@wp.kernel
def update_e_pml(first: int, nx: int, ny: int, dt: float, inv_dx: float, hx: wp.array(dtype=float),
                 hy: wp.array(dtype=float), inv_eps: wp.array(dtype=float), loss: wp.array(dtype=wp.vec2),
                 ez: wp.array(dtype=float), ezx: wp.array(dtype=float)):
    """Interior Ez in a medium (1/ε per node) with the split-field PML on every side: Ezx ← a_x Ezx + b_x ∂Hy/∂x,
    Ezy ← a_y Ezy - b_y ∂Hx/∂y, Ez = Ezx + Ezy; the border stays 0."""
    k = first + wp.tid()
    i = k // (ny + 1)
    j = k - i * (ny + 1)
    if i == 0 or i == nx or j == 0 or j == ny:
        return
    c = loss[k]
    px = exponential_step(c[0], dt, inv_eps[k])
    py = exponential_step(c[1], dt, inv_eps[k])
    e_x = ezx[k]
    e_y = ez[k] - e_x
    e_x = px[0] * e_x + px[1] * (hy[k] - hy[k - ny - 1]) * inv_dx
    e_y = py[0] * e_y - py[1] * (hx[k] - hx[k - 1]) * inv_dx
    ezx[k] = e_x
    ez[k] = e_x + e_y


@wp.kernel
def update_h_pml(first: int, nx: int, ny: int, dt: float, inv_dx: float, ez: wp.array(dtype=float),
                 loss_hx: wp.array(dtype=float), loss_hy: wp.array(dtype=float), hx: wp.array(dtype=float),
                 hy: wp.array(dtype=float)):
    """Hx(i, j+½) ← a Hx - b ∂Ez/∂y (σy*), Hy(i+½, j) ← a Hy + b ∂Ez/∂x (σx*), vacuum μ0."""
    k = first + wp.tid()
    i = k // (ny + 1)
    j = k - i * (ny + 1)
    e = ez[k]
    if j < ny:
        p = exponential_step(loss_hx[k], dt, 1.0 / MU0)
        hx[k] = p[0] * hx[k] - p[1] * (ez[k + 1] - e) * inv_dx
    if i < nx:
        q = exponential_step(loss_hy[k], dt, 1.0 / MU0)
        hy[k] = q[0] * hy[k] + q[1] * (ez[k + ny + 1] - e) * inv_dx


@wp.kernel
def tfsf_correct(first: int, targets: wp.array(dtype=wp.int32), x: wp.array(dtype=float),
                 scale: wp.array(dtype=float), t: wp.float64, frequency: wp.float64, ramp: wp.float64,
                 start: wp.float64, field: wp.array(dtype=float)):
    """TF/SF on Yee's grid (Taflove & Hagness §5.9): field[target] += scale × f(t - (x - start)/c), f the sin²-ramped
    sine of the incident wave along +x (scale carries ±Δt/(μΔ) for H targets, ±Δt/(εΔ)/η for E targets)."""
    s = first + wp.tid()
    tau = t - (wp.float64(x[s]) - start) / wp.float64(299792458.0)
    value = wp.float64(0.0)
    if tau > wp.float64(0.0):
        u = wp.min(wp.float64(1.0), tau * frequency / ramp)
        r = wp.sin(wp.float64(1.5707963267948966) * u)
        value = r * r * wp.sin(wp.float64(6.283185307179586) * frequency * tau)
    field[targets[s]] = field[targets[s]] + scale[s] * float(value)


@wp.kernel
def dft_nodes(first: int, nodes: wp.array(dtype=wp.int32), ez: wp.array(dtype=float), t: wp.float64,
              dt: wp.float64, frequency: wp.float64, real: wp.array(dtype=wp.float64),
              imag: wp.array(dtype=wp.float64)):
    """F += Ez(t) e^{-2πift} Δt at the monitored nodes."""
    s = first + wp.tid()
    v = wp.float64(ez[nodes[s]]) * dt
    phase = wp.float64(6.283185307179586) * frequency * t
    real[s] = real[s] + v * wp.cos(phase)
    imag[s] = imag[s] - v * wp.sin(phase)


class YeeScatterer:
    """The plane wave on a cylinder of ``scenes/em_scatterer_2d.py`` on Yee's grid: Ez nodes at the scene's E particles
    (the same lattice), 1/ε per node the scene's (``eps_r``, its averaged interface), the same split-field PML on every
    side, the incident wave along +x by TF/SF at the same box, and a DFT of Ez at ``nodes`` from ``dft_start`` on."""

    def __init__(self, launcher, positions: np.ndarray, eps_r: np.ndarray, spacing: float, pml: PML, interior: float,
                 box: float, frequency: float, ramp: float, nodes: np.ndarray, dft_start: float):
        self.launcher = launcher
        lo = positions[:, :2].min(axis=0)
        self.nx = self.ny = int(round((positions[:, 0].max() - lo[0]) / spacing))
        n = (self.nx + 1) * (self.ny + 1)
        if positions.shape[0] != n:
            raise ValueError("the positions are not the scene's lattice")
        self.dx = spacing
        dev = launcher.device
        i, j = np.divmod(np.arange(n), self.ny + 1)
        x, y = lo[0] + i * spacing, lo[1] + j * spacing
        inner = ((-interior, -interior), (interior, interior))
        sig_e = pml.sigma(np.stack([x, y], 1), *inner)
        self.inv_eps = wp.array((1.0 / (EPS0 * eps_r)).astype(np.float32), dtype=float, device=dev)
        self.loss = wp.array((sig_e / (EPS0 * eps_r[:, None])).astype(np.float32), dtype=wp.vec2, device=dev)
        self.loss_hx = wp.array((pml.sigma(np.stack([x, y + 0.5 * spacing], 1), *inner)[:, 1] / EPS0)
                                .astype(np.float32), dtype=float, device=dev)
        self.loss_hy = wp.array((pml.sigma(np.stack([x + 0.5 * spacing, y], 1), *inner)[:, 0] / EPS0)
                                .astype(np.float32), dtype=float, device=dev)
        self.ez, self.ezx, self.hx, self.hy = (wp.zeros(n, dtype=float, device=dev) for _ in range(4))
        # the TF/SF box: the nodes with |x|, |y| <= box (i0..i1, j0..j1)
        i0, i1 = int(np.ceil((-box - lo[0]) / spacing - 1e-9)), int(np.floor((box - lo[0]) / spacing + 1e-9))
        j0, j1 = int(np.ceil((-box - lo[1]) / spacing - 1e-9)), int(np.floor((box - lo[1]) / spacing + 1e-9))
        k = lambda a, b: a * (self.ny + 1) + b  # noqa: E731
        eta = math.sqrt(MU0 / EPS0)
        js, is_ = np.arange(j0, j1 + 1), np.arange(i0, i1 + 1)
        # H targets: Hy(i0-½, j) -= c Ez_inc(i0, j), Hy(i1+½, j) += c Ez_inc(i1, j); Hx(i, j0-½) += c Ez_inc(i, j0),
        # Hx(i, j1+½) -= c Ez_inc(i, j1), c = Δt/(μ0 Δ) (times the step, given per step as a factor)
        h_hy = [(k(i0 - 1, j), -1.0, x[k(i0, j)]) for j in js] + [(k(i1, j), 1.0, x[k(i1, j)]) for j in js]
        h_hx = [(k(i, j0 - 1), 1.0, x[k(i, j0)]) for i in is_] + [(k(i, j1), -1.0, x[k(i, j1)]) for i in is_]
        # E targets: Ez(i0, j) -= (Δt/(εΔ)) Hy_inc(i0-½, j), Ez(i1, j) += (Δt/(εΔ)) Hy_inc(i1+½, j), Hy_inc = -Ez_inc/η;
        # Hx_inc = 0 for a wave along +x
        e_ez = [(k(i0, j), 1.0 / eta, x[k(i0, j)] - 0.5 * spacing) for j in js] + \
               [(k(i1, j), -1.0 / eta, x[k(i1, j)] + 0.5 * spacing) for j in js]
        self._targets = {}
        for name, rows in (("hy", h_hy), ("hx", h_hx), ("ez", e_ez)):
            idx, sign, px = (np.array(c) for c in zip(*rows))
            self._targets[name] = (wp.array(idx.astype(np.int32), dtype=wp.int32, device=dev), sign, px,
                                   wp.array(px.astype(np.float32), dtype=float, device=dev))
        self.inv_eps_host = 1.0 / (EPS0 * eps_r)
        self.frequency, self.ramp, self.start = frequency, ramp, -box  # the front reaches x = -box at t = 0, as the scene's
        self.nodes = wp.array(nodes.astype(np.int32), dtype=wp.int32, device=dev)
        self.real = wp.zeros(nodes.size, dtype=wp.float64, device=dev)
        self.imag = wp.zeros(nodes.size, dtype=wp.float64, device=dev)
        self.dft_start = dft_start
        self._scale = None
        self.t = 0.0

    def stable_dt(self) -> float:
        return self.dx / (C0 * math.sqrt(2.0))

    def _scales(self, dt: float) -> None:
        dev, c = self.launcher.device, dt / (MU0 * self.dx)
        self._scale = {}
        for name, (idx, sign, px, xs) in self._targets.items():
            factor = sign * c if name != "ez" else sign * dt / self.dx * self.inv_eps_host[idx.numpy()]
            self._scale[name] = wp.array(np.asarray(factor, np.float32), dtype=float, device=dev)

    def step(self, dt: float) -> None:
        if self._scale is None:
            self._scales(dt)
        L, nx, ny, inv = self.launcher, self.nx, self.ny, 1.0 / self.dx
        n = (nx + 1) * (ny + 1)
        t_h, t_e = wp.float64(self.t), wp.float64(self.t + 0.5 * dt)
        f, ramp, s0 = wp.float64(self.frequency), wp.float64(self.ramp), wp.float64(self.start)
        L.launch(update_e_pml, n, [nx, ny, float(dt), inv, self.hx, self.hy, self.inv_eps, self.loss, self.ez, self.ezx])
        idx, _, _, xs = self._targets["ez"]
        L.launch(tfsf_correct, idx.shape[0], [idx, xs, self._scale["ez"], t_h, f, ramp, s0, self.ez])
        L.launch(tfsf_correct, idx.shape[0], [idx, xs, self._scale["ez"], t_h, f, ramp, s0, self.ezx])
        if self.t + 0.5 * dt - 0.5 * dt >= self.dft_start - 1e-6 * dt:
            L.launch(dft_nodes, self.nodes.shape[0], [self.nodes, self.ez, t_e, wp.float64(dt), f, self.real,
                                                     self.imag])
        L.launch(update_h_pml, n, [nx, ny, float(dt), inv, self.ez, self.loss_hx, self.loss_hy, self.hx, self.hy])
        for name, field in (("hy", self.hy), ("hx", self.hx)):
            idx, _, _, xs = self._targets[name]
            L.launch(tfsf_correct, idx.shape[0], [idx, xs, self._scale[name], t_e, f, ramp, s0, field])
        self.t += dt
