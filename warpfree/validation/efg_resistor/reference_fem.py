"""Fine-mesh finite-element reference for the two-material resistor (Marques 2008, §6.2): the script that writes
``reference_scalars.csv``, ``reference_lines.csv`` and ``reference_grid.csv``.

∇·(σ ∇V) = 0 on the inverted T of ``GEOMETRY`` (lengths in mm here, 1 mm = 1e-3 m): aluminium
(σ1 = 3.57e7 S/m) in [0, 3] x [0, 1], copper (σ2 = 5.88e7 S/m) in [1, 2] x [1, 2]; V = 1 on the top
y = 2, V = 0 on the bottom y = 0, the other sides insulated. Nine-node Lagrange quadrilaterals (Q9) on a
uniform grid of square elements of side 1/n mm over the four rectangles of ``GEOMETRY`` (conforming, the
interface y = 1 on element edges); all elements are squares, so K_e = σ_e K_ref with the size-free Q9
Laplace matrix K_ref (3 x 3 Gauss, exact). Sparse direct solve (SuperLU, symmetric minimum-degree order).
The electrode currents are the consistent ones (the residual K V summed over each electrode's nodes) and,
as a check, the integrals of σ ∂V/∂y of the element gradients along the electrodes. Richardson
extrapolation from the two finest meshes with the order 2λ = 1.2466 of the corner singularity (the observed
order of the currents and potentials).

Rerun (about 25 s on two cores and 2.3 GB; the shipped files):

    python -m warpfree.validation.efg_resistor.reference_fem --meshes 16 32 64 128 256 \
        --out warpfree/validation/efg_resistor
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from warpfree.validation.efg_cook.reference_fem import lagrange_quadratic, q9_reference_gradients, richardson
from warpfree.validation.efg_resistor import CONDUCTIVITY, GEOMETRY, MM, LINE_NAMES, PROBES, singular_exponent

#: ``GEOMETRY`` in mm: (x0, x1, y0, y1, material).
RECTANGLES_MM = tuple((x0 / MM, x1 / MM, y0 / MM, y1 / MM, mat) for x0, x1, y0, y1, mat in GEOMETRY)
WIDTH_MM, HEIGHT_MM = 3.0, 2.0
#: Re-entrant corners, where the sides of the upper bar meet the interface (mm).
CORNERS_MM = np.array([[1.0, 1.0], [2.0, 1.0]])


def reference_laplace_matrix() -> np.ndarray:
    """∫ ∇N_a·∇N_b over a square Q9 element (any size: in 2D the Laplace matrix of a square is scale free),
    3 x 3 Gauss (exact for the biquartic integrand). Local node (a, b) -> 3 a + b, a along x, b along y."""
    dN, w = q9_reference_gradients(3)
    return np.einsum("g,gak,gbk->ab", w, dN, dN)


class Mesh:
    """Uniform Q9 mesh, n elements per mm, of the rectangles of ``GEOMETRY``.

    Nodes sit on the grid (i, j)/(2n) mm, 0 <= i <= 6n, 0 <= j <= 4n; element (ei, ej) covers
    [ei, ei + 1] x [ej, ej + 1] / n mm. Attributes: ``nodes`` (N, 2) in mm, ``grid`` (N, 2) integer grid
    indices, ``elements`` (ne, 9), ``cells`` (ne, 2) = (ei, ej), ``material`` (ne,), ``lookup`` (3n, 2n)
    element index or -1 outside the conductor.
    """

    def __init__(self, n: int):
        self.n = n
        ny = int(round(2 * HEIGHT_MM * n)) + 1
        cells, mats = [], []
        for x0, x1, y0, y1, mat in RECTANGLES_MM:
            ei, ej = np.meshgrid(np.arange(round(x0 * n), round(x1 * n)), np.arange(round(y0 * n), round(y1 * n)),
                                 indexing="ij")
            cells.append(np.column_stack([ei.ravel(), ej.ravel()]))
            mats.append(np.full(ei.size, mat))
        self.cells = np.concatenate(cells)
        self.material = np.concatenate(mats)
        a, b = (g.ravel() for g in np.meshgrid(np.arange(3), np.arange(3), indexing="ij"))
        gi = 2 * self.cells[:, :1] + a[None, :]
        gj = 2 * self.cells[:, 1:] + b[None, :]
        used, inverse = np.unique(gi * ny + gj, return_inverse=True)
        self.elements = inverse.reshape(len(self.cells), 9)
        self.grid = np.column_stack([used // ny, used % ny])
        self.nodes = self.grid / (2.0 * n)
        self.lookup = np.full((int(round(WIDTH_MM * n)), int(round(HEIGHT_MM * n))), -1)
        self.lookup[self.cells[:, 0], self.cells[:, 1]] = np.arange(len(self.cells))

    def conductivity(self) -> np.ndarray:
        """σ of each element (S/m)."""
        table = np.zeros(max(CONDUCTIVITY) + 1)
        for m, sigma in CONDUCTIVITY.items():
            table[m] = sigma
        return table[self.material]


def assemble(mesh: Mesh):
    """Global conductance matrix K = Σ_e σ_e K_ref (CSR, N x N, S/m per unit thickness)."""
    from scipy.sparse import coo_matrix

    Kref = reference_laplace_matrix()
    vals = mesh.conductivity()[:, None, None] * Kref[None]
    rows = np.broadcast_to(mesh.elements[:, :, None], vals.shape).ravel()
    cols = np.broadcast_to(mesh.elements[:, None, :], vals.shape).ravel()
    N = len(mesh.nodes)
    return coo_matrix((vals.ravel(), (rows, cols)), shape=(N, N)).tocsr()


def electrode_nodes(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Node indices of the top (y = 2 mm, V = 1) and bottom (y = 0, V = 0) electrodes."""
    top = np.flatnonzero(mesh.grid[:, 1] == int(round(2 * HEIGHT_MM * mesh.n)))
    bottom = np.flatnonzero(mesh.grid[:, 1] == 0)
    return top, bottom


def solve(mesh: Mesh, v_top: float = 1.0, v_bottom: float = 0.0) -> np.ndarray:
    """Nodal potentials (V) with V = v_top on the top electrode, v_bottom on the bottom one."""
    from scipy.sparse.linalg import splu

    K = assemble(mesh)
    top, bottom = electrode_nodes(mesh)
    V = np.zeros(len(mesh.nodes))
    V[top], V[bottom] = v_top, v_bottom
    fixed = np.zeros(len(V), dtype=bool)
    fixed[top], fixed[bottom] = True, True
    free = np.flatnonzero(~fixed)
    rhs = -(K[free][:, fixed] @ V[fixed])
    factor = splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    V[free] = factor.solve(rhs)
    return V


def electrode_currents(mesh: Mesh, V: np.ndarray, K=None) -> dict[str, float]:
    """Currents per unit thickness (A/m) for the solution V: the consistent ones (the residual r = K V summed
    over the electrode nodes; current_top enters at the top, current_bottom leaves at the bottom), the
    dissipation Vᵀ K V (= the conductance times ΔV² when ΔV is the electrode difference), and the integrals of
    σ ∂V/∂y of the element gradients along the electrodes (3-point Gauss per edge)."""
    K = assemble(mesh) if K is None else K
    r = K @ V
    top, bottom = electrode_nodes(mesh)
    t, w = np.polynomial.legendre.leggauss(3)
    val, _ = lagrange_quadratic(t)
    sigma = mesh.conductivity()
    fluxes = {}
    for name, ej, eta in (("top", int(round(HEIGHT_MM * mesh.n)) - 1, 1.0), ("bottom", 0, -1.0)):
        el = np.flatnonzero(mesh.cells[:, 1] == ej)                   # the row of elements on the electrode
        Ve = V[mesh.elements[el]].reshape(-1, 3, 3)                   # (e, a along x, b along y)
        # ∂V/∂y dx = (2n dV/dη)(dξ/(2n)) = dV/dη dξ on the edge η = ±1
        dy = lagrange_quadratic(np.array([eta]))[1][0]                # dl_b/dη on the edge
        dVdeta = np.einsum("ga,eab,b->eg", val, Ve, dy)
        fluxes[name] = float(np.sum(sigma[el][:, None] * w[None, :] * dVdeta))
    return {"current_top": float(r[top].sum()), "current_bottom": float(-r[bottom].sum()),
            "dissipation": float(V @ r), "flux_top": fluxes["top"], "flux_bottom": fluxes["bottom"]}


def evaluate(mesh: Mesh, V: np.ndarray, points_mm: np.ndarray, material: np.ndarray | int | None = None,
             tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Potential (V) and gradient ∇V (V/m) at points (mm) through the element shape functions.

    ``material`` (one per point, or one for all; None = any) picks the side of the interface: only elements
    of that material are used. A point on element edges gets the mean of the (up to 4) elements of that
    material that contain it (the gradient of C0 elements jumps across their edges). Points in no such
    element get NaN.
    """
    p = np.atleast_2d(np.asarray(points_mm, dtype=np.float64))
    mat = np.broadcast_to(np.asarray(-1 if material is None else material), (len(p),))
    n = mesh.n
    s = p * n                                                         # in element units
    total_v = np.zeros(len(p))
    total_g = np.zeros((len(p), 2))
    count = np.zeros(len(p))
    nx, ny = mesh.lookup.shape
    candidates = [np.floor(s - tol).astype(int), np.floor(s + tol).astype(int)]
    for ci in range(2):
        for cj in range(2):
            ei, ej = candidates[ci][:, 0], candidates[cj][:, 1]
            if ci == 1:
                ok = ei != candidates[0][:, 0]
            else:
                ok = np.ones(len(p), dtype=bool)
            if cj == 1:
                ok &= ej != candidates[0][:, 1]
            ok &= (ei >= 0) & (ei < nx) & (ej >= 0) & (ej < ny)
            e = np.full(len(p), -1)
            e[ok] = mesh.lookup[ei[ok], ej[ok]]
            ok &= e >= 0
            ok[ok] &= (mat[ok] < 0) | (mesh.material[e[ok]] == mat[ok])
            if not ok.any():
                continue
            k = np.flatnonzero(ok)
            xi = np.clip(2.0 * (s[k, 0] - ei[k]) - 1.0, -1.0, 1.0)
            eta = np.clip(2.0 * (s[k, 1] - ej[k]) - 1.0, -1.0, 1.0)
            lx, dlx = lagrange_quadratic(xi)
            ly, dly = lagrange_quadratic(eta)
            Ve = V[mesh.elements[e[k]]].reshape(-1, 3, 3)
            total_v[k] += np.einsum("pa,pab,pb->p", lx, Ve, ly)
            # ∂/∂x = 2n ∂/∂ξ per mm = 2n·1000 per m
            total_g[k, 0] += 2 * n / MM * np.einsum("pa,pab,pb->p", dlx, Ve, ly)
            total_g[k, 1] += 2 * n / MM * np.einsum("pa,pab,pb->p", lx, Ve, dly)
            count[k] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return total_v / count, total_g / count[:, None]


def line_points() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The evaluation lines (mm): -> (line id (k,), points (k, 2), material (k,)).

    0 crossing: x = 1.5, 0 <= y <= 2 (step 0.005; y = 1 twice, once per material);
    1 crossing_offset: the same at x = 1.25 (E_x is zero on x = 1.5 by symmetry, not here);
    2 upper: y = 1.05, 1 <= x <= 2 (material 2); 3 lower: y = 0.95, 0 <= x <= 3 (material 1);
    4 interface_below, 5 interface_above: y = 1, 1.05 <= x <= 1.95, the one-sided limits from material 1
    and material 2 (closer to the corners, where the field is singular, the fine mesh's field is not
    converged to 1e-3).
    """
    step = 0.005
    ids, pts, mats = [], [], []

    def add(line, x, y, m):
        ids.append(np.full(len(x), line))
        pts.append(np.column_stack([x, y]))
        mats.append(np.broadcast_to(m, len(x)).copy())

    y_low = np.round(np.arange(0, 200 + 1) * step, 10)
    y_high = np.round(1.0 + np.arange(0, 200 + 1) * step, 10)
    for line, x in ((0, 1.5), (1, 1.25)):
        add(line, np.full(len(y_low), x), y_low, 1)
        add(line, np.full(len(y_high), x), y_high, 2)
    add(2, np.round(1.0 + np.arange(201) * step, 10), np.full(201, 1.05), 2)
    add(3, np.round(np.arange(601) * step, 10), np.full(601, 0.95), 1)
    xi = np.round(1.05 + np.arange(181) * step, 10)
    add(4, xi, np.full(len(xi), 1.0), 1)
    add(5, xi, np.full(len(xi), 1.0), 2)
    assert len(LINE_NAMES) == 6
    return np.concatenate(ids), np.concatenate(pts), np.concatenate(mats)


def probe_points() -> tuple[np.ndarray, np.ndarray]:
    """``PROBES`` (name -> (x, y) in m, material) as points in mm and materials."""
    pts = np.array([xy for xy, _ in PROBES.values()]) / MM
    return pts, np.array([m for _, m in PROBES.values()])


def run_mesh(n: int) -> dict:
    """Solve on the n-per-mm mesh; returns n, dofs, the currents, the probes and the solve time."""
    start = time.perf_counter()
    mesh = Mesh(n)
    V = solve(mesh)
    row = {"n": n, "dofs": len(V) - sum(len(e) for e in electrode_nodes(mesh))}
    row.update(electrode_currents(mesh, V))
    pts, mats = probe_points()
    v, g = evaluate(mesh, V, pts, mats)
    for (name, _), vi, gi in zip(PROBES.items(), v, g):
        row[f"V_{name}"] = float(vi)
        row[f"Ey_{name}"] = float(-gi[1])
        row[f"E_{name}"] = float(np.hypot(*gi))
    row["seconds"] = time.perf_counter() - start
    return {"row": row, "mesh": mesh, "V": V}


def scalar_columns() -> list[tuple[str, str]]:
    """(key, CSV header) of the scalars file after n and dofs."""
    cols = [("current_bottom", "current_bottom (A/m per 1 V: consistent; = conductance S/m)"),
            ("current_top", "current_top (A/m)"),
            ("flux_bottom", "flux_bottom (A/m: integral of sigma dV/dy on y=0)"),
            ("flux_top", "flux_top (A/m: integral of sigma dV/dy on y=2 mm)")]
    for name in PROBES:
        cols.append((f"V_{name}", f"V_{name} (V)"))
    for name in PROBES:
        cols.append((f"Ey_{name}", f"Ey_{name} (V/m)"))
        cols.append((f"E_{name}", f"E_{name} (V/m: |E|)"))
    return cols


def write_scalars(path: str, rows: list[dict], limits: dict) -> None:
    cols = scalar_columns()
    lines = [", ".join(["n (elements per mm; 0 = Richardson limit of the two finest with order 2 lambda)", "dofs"]
                       + [h for _, h in cols])]
    for row in rows:
        lines.append(", ".join([str(row["n"]), str(row["dofs"])] + [f"{row[k]:.12e}" for k, _ in cols]))
    lines.append(", ".join(["0", "0"] + [f"{limits[k][0]:.12e}" for k, _ in cols]))
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


def write_lines(path: str, mesh: Mesh, V: np.ndarray) -> None:
    ids, pts, mats = line_points()
    v, g = evaluate(mesh, V, pts, mats)
    if np.isnan(v).any():
        raise RuntimeError("line sample outside its material")
    lines = ["line (0 crossing x=1.5; 1 crossing x=1.25; 2 upper y=1.05; 3 lower y=0.95; 4 interface from below; "
             "5 interface from above), x (mm), y (mm), material (1 Al below; 2 Cu above), V (V), Ex (V/m), "
             "Ey (V/m), E (V/m: |E|)"]
    for i, (x, y), m, vi, (gx, gy) in zip(ids, pts, mats, v, g):
        # (+ 0.0: no "-0.0")
        lines.append(f"{i}, {x:.4f}, {y:.4f}, {m}, {vi + 0.0:.11e}, {0.0 - gx:.9e}, {0.0 - gy:.9e}, "
                     f"{np.hypot(gx, gy):.9e}")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


#: Levels of ``reference_grid.csv``: (elements per mm, half-width in mm of the square windows around the two
#: corners where the level is stored; None = everywhere). Each window is a union of whole elements of its level.
GRID_LEVELS = ((32, None), (64, 0.25), (128, 0.0625), (256, 0.03125))


def write_grid(path: str, mesh: Mesh, V: np.ndarray, levels=GRID_LEVELS) -> None:
    """The fine solution's nodal V at the Q9 nodes of coarser meshes (subsets of the fine nodes), the finer ones
    only in windows around the corners: interpolated with the Q9 shape functions of the finest level whose
    element holds the point, it reproduces the fine solution to about 1e-5 V everywhere (``potential_at``; the
    finest level is the fine mesh itself)."""
    lines = ["level (elements per mm of its Q9 mesh), i (x = i/(2 level) mm), j (y = j/(2 level) mm), V (V)"]
    for level, half in levels:
        stride = mesh.n // level
        if stride * level != mesh.n:
            raise ValueError(f"grid level {level} must divide the finest n = {mesh.n}")
        keep = (mesh.grid[:, 0] % stride == 0) & (mesh.grid[:, 1] % stride == 0)
        if half is not None:
            near = np.zeros(len(keep), dtype=bool)
            for c in CORNERS_MM:
                near |= np.all(np.abs(mesh.nodes - c) <= half + 1e-12, axis=1)
            keep &= near
        keep = np.flatnonzero(keep)
        for (i, j), v in zip(mesh.grid[keep] // stride, V[keep]):
            lines.append(f"{level},{i},{j},{v:.9f}")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


def interface_check(mesh: Mesh, V: np.ndarray, x_range=(1.1, 1.9), count: int = 161) -> dict[str, float]:
    """σ1 E_y(below) against σ2 E_y(above) and E_x(below) against E_x(above) on y = 1, x in x_range: the
    maximum and mean relative errors (normal: relative to σ2 |E_y above|; tangential: relative to |E| above)."""
    x = np.linspace(*x_range, count)
    pts = np.column_stack([x, np.ones_like(x)])
    _, gb = evaluate(mesh, V, pts, 1)
    _, ga = evaluate(mesh, V, pts, 2)
    jn = np.abs(CONDUCTIVITY[1] * gb[:, 1] - CONDUCTIVITY[2] * ga[:, 1]) / np.abs(CONDUCTIVITY[2] * ga[:, 1])
    jt = np.abs(gb[:, 0] - ga[:, 0]) / np.hypot(*ga.T)
    return {"normal_max": float(jn.max()), "normal_mean": float(jn.mean()),
            "tangential_max": float(jt.max()), "tangential_mean": float(jt.mean())}


def extrapolate(values: list[float], order: float) -> tuple[float, float]:
    """Richardson from the last two values (refinement ratio 2) with a given order: f + (f - m)/(2^p - 1).
    The reference uses p = 2λ, the order of the corner pollution that governs every quantity of the problem
    (observed: 1.25 for the currents and the potentials). -> (limit, order)."""
    m, f = values[-2:]
    return float(f + (f - m) / (2.0 ** order - 1.0)), order


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", type=int, nargs="+", default=[8, 16, 32, 64],
                        help="elements per mm, each twice the previous")
    parser.add_argument("--out", help="folder to write reference_scalars.csv, reference_lines.csv, "
                                      "reference_grid.csv into (needs three meshes or more)")
    args = parser.parse_args(argv)
    lam = singular_exponent()
    print(f"corner exponent lambda = {lam:.6f}: |E| ~ r^{lam - 1:.4f}, energy error ~ h^{2 * lam:.4f}")
    rows, lines_per_mesh, last = [], [], None
    ids, pts, mats = line_points()
    for n in args.meshes:
        out = run_mesh(n)
        row = out["row"]
        rows.append(row)
        v, g = evaluate(out["mesh"], out["V"], pts, mats)
        lines_per_mesh.append((v, np.hypot(*g.T), g))
        chk = interface_check(out["mesh"], out["V"])
        print(f"n={n:4d} dofs={row['dofs']:8d} G={row['current_bottom']:.10e} top={row['current_top']:.10e} "
              f"(rel {abs(row['current_top'] / row['current_bottom'] - 1):.1e}) flux_b={row['flux_bottom']:.8e} "
              f"flux_t={row['flux_top']:.8e} interface normal max/mean {chk['normal_max']:.2e}/"
              f"{chk['normal_mean']:.2e} tangential {chk['tangential_max']:.2e}/{chk['tangential_mean']:.2e} "
              f"({row['seconds']:.1f} s)", flush=True)
        last = out
    limits = {}
    if len(rows) >= 3:
        for key, _ in scalar_columns():
            vals = [r[key] for r in rows]
            limits[key] = extrapolate(vals, 2 * lam)
            orders = [richardson(a, b, c)[1] if (a - b) * (b - c) > 0 else float("nan")
                      for a, b, c in zip(vals, vals[1:], vals[2:])]
            observed = richardson(*vals[-3:])[0] if (vals[-3] - vals[-2]) * (vals[-2] - vals[-1]) > 0 else np.nan
            print(f"{key}: limit {limits[key][0]:.10e} (order {limits[key][1]:.3f}), finest {vals[-1]:.10e}, "
                  f"last step {vals[-1] - vals[-2]:.3e}, observed orders {' '.join(f'{o:.2f}' for o in orders)}, "
                  f"limit with the last observed order {observed:.10e}")
        # line convergence: successive differences of |E| and V, away from the corners (> 0.1 mm) and all
        far = np.min(np.linalg.norm(pts[:, None, :] - CORNERS_MM[None], axis=-1), axis=1) > 0.1
        Eref = np.abs(lines_per_mesh[-1][1]).max()
        for k in range(1, len(rows)):
            dv = np.abs(lines_per_mesh[k][0] - lines_per_mesh[k - 1][0])
            de = np.abs(lines_per_mesh[k][1] - lines_per_mesh[k - 1][1])
            rel = de / np.abs(lines_per_mesh[k][1])
            print(f"lines n={rows[k - 1]['n']}->{rows[k]['n']}: max |dV| {dv.max():.2e} (far {dv[far].max():.2e}); "
                  f"max |d|E|| / max|E| {de.max() / Eref:.2e} (far {de[far].max() / Eref:.2e}); "
                  f"max pointwise rel d|E| far {rel[far].max():.2e}")
    if args.out:
        if len(rows) < 3:
            parser.error("--out needs three meshes or more")
        write_scalars(os.path.join(args.out, "reference_scalars.csv"), rows, limits)
        write_lines(os.path.join(args.out, "reference_lines.csv"), last["mesh"], last["V"])
        write_grid(os.path.join(args.out, "reference_grid.csv"), last["mesh"], last["V"])
    return {"rows": rows, "limits": limits, "last": last}


if __name__ == "__main__":
    main()
