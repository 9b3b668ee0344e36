"""The cylindrical diode by a conventional mesh PIC with staircased electrodes: the baseline that warpfree's
``pic_cylindrical_diode`` (exact circles, EFG field) is compared with in ``pic_vs_mesh.py --cases cylindrical_diode``.

Equations (normalised units: ε0 = 1, electron charge -1 and mass 1)::

    dx_p/dt = v_p,   dv_p/dt = -E(x_p),   -∇²φ = ρ,   E = -∇φ

between a cathode r = r_c (φ = 0) and an anode r = r_a (φ = V), on a square grid of spacing Δx with a node at the
axis. The electrodes are staircased, as a Cartesian PIC code holds them: every node with r ≤ r_c is a cathode node
(φ = 0), every node with r ≥ r_a an anode node (φ = V); the conductor surfaces are the faces of those nodes' cells
(the squares of side Δx centred on them). One step (Birdsall & Langdon ch. 2-4, 14):

1. Cloud-in-cell deposit of ρ on the nodes, the counting-sorted gather of ``mesh_pic.py`` (its kernels, unchanged).
2. The 5-point Poisson equation on the free nodes, (4φ_ij - Σ φ_neighbours) / Δx² = ρ_ij, the electrode nodes'
   potentials on the right-hand side: SciPy's SuperLU, factorised once.
3. E on the nodes by central differences, CIC gather, leapfrog (``mesh_pic.py``'s kernels).
4. A particle whose nearest node is an electrode node has crossed that electrode's staircased surface: absorbed,
   its charge counted on that electrode.
5. Gauss's-law emission (as warpfree's, ``warpfree/solvers/pic/emission.py``): the cathode holds on each face it
   shares with a free node the charge (φ_c - φ_f) ε0 per unit depth (the flux through the face, length Δx, of the
   field (φ_c - φ_f)/Δx); every face where that charge is negative (it pulls electrons off) emits it, as whole
   macro-particles stratified over the faces by their charge (the fraction carried to the next step), each
   starting 1e-6 Δx outside the face at a uniformly random point along it, at ``emission_speed`` along its normal.

The anode current is the slope of the anode's absorbed charge over the second half of the run, as the scene's.
Float64 throughout. Wall time: the time loop only (the factorisation and the kernels' compilation excluded).
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import warp as wp

import mesh_pic

FREE, CATHODE, ANODE = 0, 1, 2


class StaircasedDiode:
    """The grid: ``cells_across`` cells over the anode's diameter (Δx = 2 r_a / cells_across), the axis on a node, 4
    cells of margin beyond the anode (a step moves a particle less than one); each node's kind (free, cathode, anode),
    the electrodes' potentials, the 5-point Laplacian of the free nodes factorised, and the cathode's faces (the
    cathode node, the free node beyond it, the outward normal)."""

    def __init__(self, cells_across: int, voltage: float = 1.0, cathode_radius: float = 1.0,
                 anode_radius: float = 2.0):
        if int(cells_across) != cells_across or cells_across < 8:
            raise ValueError(f"cells_across must be an integer >= 8, got {cells_across!r}")
        if not (0 < cathode_radius < anode_radius):
            raise ValueError(f"need 0 < cathode_radius < anode_radius, got {cathode_radius!r}, {anode_radius!r}")
        dx = self.dx = 2.0 * anode_radius / cells_across
        c = self.centre = cells_across // 2 + 4
        nx = self.nx = 2 * c + 1
        coords = (np.arange(nx) - c) * dx
        X, Y = np.meshgrid(coords, coords, indexing="ij")
        self.xy = np.column_stack([X.ravel(), Y.ravel()])
        r = np.hypot(X, Y).ravel()
        kind = self.kind = np.full(nx * nx, FREE, dtype=np.int8)
        kind[r <= cathode_radius] = CATHODE
        kind[r >= anode_radius] = ANODE
        self.fixed = np.where(kind == ANODE, voltage, 0.0)
        free = self.free = np.flatnonzero(kind == FREE)
        index = -np.ones(nx * nx, dtype=np.int64)
        index[free] = np.arange(free.size)
        i, j = np.divmod(free, nx)
        rows, cols, vals = [np.arange(free.size)], [np.arange(free.size)], [np.full(free.size, 4.0)]
        self.boundary = np.zeros(free.size)
        faces = []
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            nb = (i + di) * nx + (j + dj)
            inside = index[nb] >= 0
            rows.append(np.flatnonzero(inside))
            cols.append(index[nb[inside]])
            vals.append(-np.ones(int(inside.sum())))
            self.boundary += np.where(inside, 0.0, self.fixed[nb])
            on_cathode = kind[nb] == CATHODE
            faces += [(int(a), int(b), (-di, -dj)) for a, b in zip(nb[on_cathode], free[on_cathode])]
        laplacian = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                  shape=(free.size, free.size))
        self.lu = spla.splu(laplacian)
        self.face_cathode = np.array([f[0] for f in faces])
        self.face_free = np.array([f[1] for f in faces])
        self.face_normal = np.array([f[2] for f in faces], dtype=np.float64)
        self.face_centre = self.xy[self.face_cathode] + 0.5 * dx * self.face_normal
        self.face_along = np.column_stack([-self.face_normal[:, 1], self.face_normal[:, 0]])

    def potential(self, rho: np.ndarray) -> np.ndarray:
        """φ at every node for the charge density ``rho`` at the nodes (the electrodes' own ignored)."""
        phi = self.fixed.copy()
        phi[self.free] = self.lu.solve(rho[self.free] * self.dx * self.dx + self.boundary)
        return phi


def vacuum_surface_field(cells_across: int, voltage: float = 1.0, cathode_radius: float = 1.0,
                         anode_radius: float = 2.0) -> dict:
    """The field at the staircased cathode with no charge against the exact V / (r ln(r_a/r_c)): on each face,
    (φ_f - φ_c)/Δx (what the emission draws on) against the exact field at the face's centre, and at each free node
    next to the cathode, |E| by central differences against the exact field at its radius; the largest and the rms
    relative errors of each, and the total charge against 2π V / ln(r_a/r_c)."""
    g = StaircasedDiode(cells_across, voltage, cathode_radius, anode_radius)
    phi = g.potential(np.zeros(g.nx * g.nx))
    log_ratio = math.log(anode_radius / cathode_radius)
    exact = lambda r: voltage / (r * log_ratio)  # noqa: E731
    face_field = (phi[g.face_free] - phi[g.face_cathode]) / g.dx
    face_error = face_field / exact(np.linalg.norm(g.face_centre, axis=1)) - 1.0
    nodes = np.unique(g.face_free)
    i, j = np.divmod(nodes, g.nx)
    ex = (phi[(i + 1) * g.nx + j] - phi[(i - 1) * g.nx + j]) / (2 * g.dx)
    ey = (phi[i * g.nx + j + 1] - phi[i * g.nx + j - 1]) / (2 * g.dx)
    node_error = np.hypot(ex, ey) / exact(np.linalg.norm(g.xy[nodes], axis=1)) - 1.0
    charge = float(np.sum(phi[g.face_free] - phi[g.face_cathode]))
    return dict(cells_across=int(cells_across), spacing=g.dx, faces=int(len(face_field)),
                face_field_max_error=float(np.max(np.abs(face_error))),
                face_field_rms_error=float(np.sqrt(np.mean(face_error ** 2))),
                node_field_max_error=float(np.max(np.abs(node_error))),
                node_field_rms_error=float(np.sqrt(np.mean(node_error ** 2))),
                charge_error=charge / (2 * math.pi * voltage / log_ratio) - 1.0)


def cylindrical_diode(cells_across: int, voltage: float = 1.0, cathode_radius: float = 1.0,
                      anode_radius: float = 2.0, expected_current: float = 1.0, particles_per_step: float = 50.0,
                      emission_speed: float = 1e-3, dt: float = 0.02, t_end: float = 20.0, seed: int = 0,
                      launcher=None) -> dict:
    """The diode on a :class:`StaircasedDiode` grid. ``expected_current`` (per unit length) sets the
    macro-particles' charge, I Δt / ``particles_per_step``. Returns the anode current (and over
    ``expected_current``), the free nodes, the particles at the end, the steps and ``wall_s``."""
    g = StaircasedDiode(cells_across, voltage, cathode_radius, anode_radius)
    launcher = mesh_pic._launcher(launcher)
    dev = launcher.device
    dx, c, nx, kind, free = g.dx, g.centre, g.nx, g.kind, g.free
    length = nx * dx  # the kernels' periodic box, never reached: particles are absorbed at the anode first
    face_cathode, face_free, face_normal = g.face_cathode, g.face_free, g.face_normal
    face_centre, face_along, faces = g.face_centre, g.face_along, g.face_cathode
    macro_charge = -abs(expected_current) * dt / particles_per_step
    capacity = 1024
    x_host = np.zeros((0, 2))
    v_host = np.zeros((0, 2))
    rng = np.random.default_rng(seed)
    keys = order = None
    charge = wp.array([macro_charge], dtype=wp.float64, device=dev)
    mass = wp.array([-macro_charge], dtype=wp.float64, device=dev)
    q_over_m = wp.array([-1.0], dtype=wp.float64, device=dev)
    start = wp.zeros(nx * nx, dtype=wp.int32, device=dev)
    end = wp.zeros(nx * nx, dtype=wp.int32, device=dev)
    rho = wp.zeros(nx * nx, dtype=wp.float64, device=dev)
    phi = wp.zeros(nx * nx, dtype=wp.float64, device=dev)
    e = wp.zeros(nx * nx, dtype=wp.vec2d, device=dev)
    inv = 1.0 / dx

    def arrays(n):
        nonlocal capacity, keys, order, x, v, species, ke, momentum
        if keys is None or n > capacity:
            capacity = max(capacity, 2 * n)
            keys = wp.zeros(2 * capacity, dtype=wp.int32, device=dev)
            order = wp.zeros(2 * capacity, dtype=wp.int32, device=dev)
            species = wp.zeros(capacity, dtype=wp.int32, device=dev)
            ke = wp.zeros(capacity, dtype=wp.float64, device=dev)
            momentum = wp.zeros(capacity, dtype=wp.vec2d, device=dev)
            x = wp.zeros(capacity, dtype=wp.vec2d, device=dev)
            v = wp.zeros(capacity, dtype=wp.vec2d, device=dev)

    x = v = species = ke = momentum = None
    arrays(1)

    def solve(n):
        start.zero_()
        end.zero_()
        rho.zero_()
        if n:
            launcher.launch(mesh_pic.cell_keys, n, [nx, nx, inv, inv, x, keys, order])
            wp.utils.radix_sort_pairs(keys, order, n)
            launcher.launch(mesh_pic.cell_ranges, n, [n, keys, start, end])
            launcher.launch(mesh_pic.deposit, nx * nx, [nx, nx, inv, inv, inv * inv, 0.0, x, species, charge, order,
                                                        start, end, rho])
        potential = g.potential(rho.numpy())
        phi.assign(potential)
        launcher.launch(mesh_pic.node_field, nx * nx, [nx, nx, 0.5 * inv, 0.5 * inv, phi, e])
        return potential

    steps = int(math.ceil(t_end / dt))
    anode_charge = np.zeros(steps)
    owed = 0.0
    offset = c * dx  # grid coordinates = position + offset
    potential = solve(0)
    launcher.synchronize()
    t0 = time.perf_counter()
    absorbed_anode = 0.0
    for step in range(steps):
        n = len(x_host)
        if n:
            launcher.launch(mesh_pic.push, n, [nx, nx, inv, inv, length, length, dt, dt, order, species, q_over_m,
                                               mass, e, x, v, ke, momentum])
            x_host = x.numpy()[:n] - offset
            v_host = v.numpy()[:n]
            ci = np.rint(x_host / dx).astype(np.int64) + c
            where = kind[ci[:, 0] * nx + ci[:, 1]]
            absorbed_anode += macro_charge * int(np.count_nonzero(where == ANODE))
            keep = where == FREE
            x_host, v_host = x_host[keep], v_host[keep]
        # Gauss's-law emission from the faces where the cathode's charge pulls electrons off
        face_charge = potential[face_cathode] - potential[face_free]
        share = np.maximum(face_charge / macro_charge, 0.0)
        total = owed + float(share.sum())
        count = int(math.floor(total))
        owed = total - count
        if count:
            cumulative = np.concatenate([[0.0], np.cumsum(share)]) / share.sum()
            u = (np.arange(count) + rng.random(count)) / count
            face = np.clip(np.searchsorted(cumulative, u, side="right") - 1, 0, len(share) - 1)
            pos = (face_centre[face] + 1e-6 * dx * face_normal[face]
                   + (rng.random(count) - 0.5)[:, None] * dx * face_along[face])
            x_host = np.vstack([x_host, pos])
            v_host = np.vstack([v_host, emission_speed * face_normal[face]])
        n = len(x_host)
        arrays(n)
        if n:
            x.assign(np.vstack([x_host + offset, np.zeros((capacity - n, 2))]))
            v.assign(np.vstack([v_host, np.zeros((capacity - n, 2))]))
        potential = solve(n)
        anode_charge[step] = absorbed_anode
    launcher.synchronize()
    wall = time.perf_counter() - t0
    t = (np.arange(steps) + 1) * dt
    late = t >= 0.5 * t[-1]
    current = -np.polyfit(t[late], anode_charge[late], 1)[0]
    return dict(cells_across=int(cells_across), spacing=dx, nodes=int(free.size), faces=len(faces),
                particles=int(len(x_host)), steps=steps, anode_current=float(current),
                over_reference=float(current / expected_current), wall_s=wall, threads=launcher.threads)
