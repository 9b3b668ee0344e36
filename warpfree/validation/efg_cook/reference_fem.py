"""Fine-mesh finite-element reference for Cook's membrane (Rocha 2012, §5.2): the script that wrote ``reference.csv``.

Nine-node Lagrange quadrilaterals (Q9, 3 x 3 Gauss) on a structured n x n mesh of the quadrilateral
(0, 0), (48, 44), (48, 60), (0, 44) (Cook 1974), unit thickness, clamped on x = 0, a uniform shear
traction t_y = F/16 on x = 48 (total F) lumped consistently (∫ N_a t_y ds on each edge), plane strain by
default. Assembly is vectorised over elements (NumPy einsum), the solve is a sparse direct one
(scipy.sparse.linalg.splu, SuperLU with a symmetric minimum-degree ordering). The displacements at
(48, 60) and (48, 52) and the strain energy ½ fᵀu are Richardson-extrapolated from the three finest meshes
with the observed order.

Rerun (the shipped file: about 5 minutes and 11 GB of memory, of which 512² takes 4 minutes; up to 256² it
is 45 s and 2.5 GB; the last row is the h -> 0 extrapolation):

    python -m warpfree.validation.efg_cook.reference_fem --meshes 16 32 64 128 256 512 \
        --csv warpfree/validation/efg_cook/reference.csv

The cross-check of the README (plane strain, E = 70, ν = 1/3, F = 100; the solids4foam tutorial):

    python -m warpfree.validation.efg_cook.reference_fem --E 70 --nu 0.333333333333333333 --F 100
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from warpfree.validation.efg_cook import CORNERS, DEFAULTS
# σ = D ε for engineering strains: Rocha (2012), eq. 3.38 (plane strain) or 3.37 (plane stress)
from warpfree.validation.efg_timoshenko import elasticity_matrix


def lagrange_quadratic(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """1D quadratic Lagrange functions on [-1, 1] with nodes -1, 0, 1 and their derivatives: (q, 3) each."""
    t = np.asarray(t, dtype=np.float64)
    values = np.stack([0.5 * t * (t - 1), 1 - t ** 2, 0.5 * t * (t + 1)], axis=-1)
    derivs = np.stack([t - 0.5, -2 * t, t + 0.5], axis=-1)
    return values, derivs


def q9_reference_gradients(order: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Gauss points of the order x order rule on [-1, 1]² for the tensor Q9: (dN/dξ, dN/dη) as (g, 9, 2) and
    weights (g,). Local node (a, b) -> index 3 a + b, a along ξ, b along η."""
    t, w = np.polynomial.legendre.leggauss(order)
    val, der = lagrange_quadratic(t)
    # gauss point (i, j) at (t_i, t_j); N_(a,b) = l_a(ξ) l_b(η)
    dxi = np.einsum("ia,jb->ijab", der, val).reshape(order * order, 9)
    deta = np.einsum("ia,jb->ijab", val, der).reshape(order * order, 9)
    return np.stack([dxi, deta], axis=-1), np.outer(w, w).ravel()


def structured_q9_mesh(n: int, corners: np.ndarray = CORNERS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n x n Q9 mesh of the quadrilateral ``corners`` by the bilinear map of the unit square.

    Node (i, j), 0 <= i, j <= 2n at (ξ, η) = (i, j)/(2n) has index i (2n + 1) + j and position
    X = (1-ξ)(1-η) P0 + ξ(1-η) P1 + ξη P2 + (1-ξ)η P3. Returns (nodes (N, 2), elements (n², 9) with local
    node (a, b) at 3 a + b, grid index (N, 2) of (i, j)).
    """
    m = 2 * n + 1
    s = np.linspace(0.0, 1.0, m)
    xi, eta = (g.ravel() for g in np.meshgrid(s, s, indexing="ij"))
    weights = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta], axis=1)
    nodes = weights @ corners
    ei, ej = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    a, b = (g.ravel() for g in np.meshgrid(np.arange(3), np.arange(3), indexing="ij"))
    elements = (2 * ei[:, None] + a[None, :]) * m + (2 * ej[:, None] + b[None, :])
    grid = np.column_stack([np.repeat(np.arange(m), m), np.tile(np.arange(m), m)])
    return nodes, elements, grid


def element_stiffness(nodes: np.ndarray, elements: np.ndarray, D: np.ndarray) -> np.ndarray:
    """K_e = Σ_g w_g det J_g B_gᵀ D B_g, 3 x 3 Gauss, dofs [u_x0, u_y0, u_x1, ...] of the element. -> (ne, 18, 18)."""
    dN_ref, w = q9_reference_gradients(3)
    X = nodes[elements]                                        # (e, 9, 2)
    J = np.einsum("gak,eai->egik", dN_ref, X)                  # J_ik = ∂x_i/∂ξ_k
    detJ = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    if np.any(detJ <= 0):
        raise ValueError("inverted element")
    inv = np.empty_like(J)
    inv[..., 0, 0], inv[..., 1, 1] = J[..., 1, 1] / detJ, J[..., 0, 0] / detJ
    inv[..., 0, 1], inv[..., 1, 0] = -J[..., 0, 1] / detJ, -J[..., 1, 0] / detJ
    dN = np.einsum("gak,egkj->egaj", dN_ref, inv)              # ∂N_a/∂x_j
    B = np.zeros(dN.shape[:2] + (3, 18))
    B[:, :, 0, 0::2] = dN[..., 0]
    B[:, :, 1, 1::2] = dN[..., 1]
    B[:, :, 2, 0::2] = dN[..., 1]
    B[:, :, 2, 1::2] = dN[..., 0]
    return np.einsum("eg,egpi,pq,egqj->eij", detJ * w, B, D, B, optimize=True)


def assemble_stiffness(nodes: np.ndarray, elements: np.ndarray, D: np.ndarray):
    """Global K (CSR, 2N x 2N) from :func:`element_stiffness`; node a has dofs 2a (x) and 2a + 1 (y)."""
    from scipy.sparse import coo_matrix

    Ke = element_stiffness(nodes, elements, D)
    dofs = np.stack([2 * elements, 2 * elements + 1], axis=-1).reshape(len(elements), 18)
    rows = np.broadcast_to(dofs[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], Ke.shape).ravel()
    n_dof = 2 * len(nodes)
    return coo_matrix((Ke.ravel(), (rows, cols)), shape=(n_dof, n_dof)).tocsr()


def edge_load(nodes: np.ndarray, edge_nodes: np.ndarray, traction: np.ndarray) -> np.ndarray:
    """Consistent nodal forces f_a = ∫ N_a t ds of a constant traction on a chain of quadratic edges.

    ``edge_nodes`` (k, 3) are the end, middle and end nodes of each edge; 3-point Gauss is exact for the
    straight, uniformly parametrised edges of the mesh (f = t ℓ (1/6, 2/3, 1/6)). -> (2N,).
    """
    t, w = np.polynomial.legendre.leggauss(3)
    val, der = lagrange_quadratic(t)                                    # (g, 3)
    X = nodes[edge_nodes]                                               # (k, 3, 2)
    jac = np.linalg.norm(np.einsum("ga,kai->kgi", der, X), axis=-1)     # ds/dt (k, g)
    share = np.einsum("g,kg,ga->ka", w, jac, val)                       # ∫ N_a ds (k, 3)
    f = np.zeros(2 * len(nodes))
    for comp in range(2):
        np.add.at(f, 2 * edge_nodes.ravel() + comp, (share * traction[comp]).ravel())
    return f


def solve_cook(n: int, E: float = DEFAULTS["E"], nu: float = DEFAULTS["nu"], F: float = DEFAULTS["F"],
               plane: str = "strain", corners: np.ndarray = CORNERS) -> dict:
    """Solve the membrane on an n x n Q9 mesh; returns a dict with n, the number of dofs, u_y(48, 60),
    u_y(48, 52), u_x(48, 60), the strain energy ½ fᵀu (= ½ work of the load, per unit thickness) and
    the solve time (s)."""
    from scipy.sparse.linalg import splu

    start = time.perf_counter()
    nodes, elements, grid = structured_q9_mesh(n, corners)
    m = 2 * n + 1
    K = assemble_stiffness(nodes, elements, elasticity_matrix(E, nu, plane))
    right = np.flatnonzero(grid[:, 0] == m - 1)                          # ξ = 1, ordered by η
    right = right[np.argsort(grid[right, 1])]
    edges = np.stack([right[0:-1:2], right[1::2], right[2::2]], axis=1)
    height = np.linalg.norm(corners[2] - corners[1])
    f = edge_load(nodes, edges, np.array([0.0, F / height]))
    clamped = np.flatnonzero(grid[:, 0] == 0)
    fixed = np.zeros(2 * len(nodes), dtype=bool)
    fixed[2 * clamped], fixed[2 * clamped + 1] = True, True
    free = np.flatnonzero(~fixed)
    u = np.zeros(2 * len(nodes))
    # K is symmetric positive definite: a symmetric fill-reducing ordering halves SuperLU's fill against COLAMD
    factor = splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    u[free] = factor.solve(f[free])
    corner = right[-1]
    middle = right[n]
    assert np.allclose(nodes[corner], corners[2]) and np.allclose(nodes[middle], 0.5 * (corners[1] + corners[2]))
    return {"n": n, "dofs": free.size, "uy_corner": u[2 * corner + 1], "uy_middle": u[2 * middle + 1],
            "ux_corner": u[2 * corner], "energy": 0.5 * f @ u, "seconds": time.perf_counter() - start}


def richardson(coarse: float, medium: float, fine: float, ratio: float = 2.0) -> tuple[float, float]:
    """Richardson extrapolation from three meshes refined by ``ratio``: observed order
    p = log((q_c - q_m)/(q_m - q_f)) / log(ratio) and limit q_f + (q_f - q_m)/(ratio^p - 1). -> (limit, p)."""
    order = np.log((coarse - medium) / (medium - fine)) / np.log(ratio)
    return fine + (fine - medium) / (ratio ** order - 1.0), float(order)


QUANTITIES = ("uy_corner", "uy_middle", "ux_corner", "energy")
CSV_HEADER = ("elements_per_side (0 = Richardson limit h->0 of the three finest), "
              "uy_48_60 (per F=1: length), uy_48_52 (per F=1: length), ux_48_60 (per F=1: length), "
              "strain_energy (per F=1: half f.u per unit thickness)")


def write_csv(path: str, rows: list[dict], limits: dict) -> None:
    """One line per mesh, then the extrapolated line with elements_per_side = 0 (format of :func:`read_csv`)."""
    lines = [CSV_HEADER]
    for row in rows:
        lines.append(", ".join([str(row["n"])] + [f"{row[q]:.10e}" for q in QUANTITIES]))
    lines.append(", ".join(["0"] + [f"{limits[q][0]:.10e}" for q in QUANTITIES]))
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", type=int, nargs="+", default=[16, 32, 64, 128],
                        help="elements per side, each twice the previous")
    parser.add_argument("--E", type=float, default=DEFAULTS["E"])
    parser.add_argument("--nu", type=float, default=DEFAULTS["nu"])
    parser.add_argument("--F", type=float, default=DEFAULTS["F"], help="total vertical shear on x = 48")
    parser.add_argument("--plane", choices=("strain", "stress"), default="strain")
    parser.add_argument("--csv", help="write the results (per F = 1 requires --F 1) to this file")
    args = parser.parse_args(argv)
    rows = []
    for n in args.meshes:
        row = solve_cook(n, args.E, args.nu, args.F, args.plane)
        rows.append(row)
        print(f"n={n:4d} dofs={row['dofs']:8d} uy(48,60)={row['uy_corner']:.9f} uy(48,52)={row['uy_middle']:.9f} "
              f"ux(48,60)={row['ux_corner']:.9f} U={row['energy']:.9f} ({row['seconds']:.1f} s)", flush=True)
    limits = {}
    if len(rows) >= 3:
        for q in QUANTITIES:
            limits[q] = richardson(*(r[q] for r in rows[-3:]))
            change = abs(rows[-1][q] - rows[-2][q])
            previous = f", from the previous three {richardson(*(r[q] for r in rows[-4:-1]))[0]:.9f}" \
                if len(rows) >= 4 else ""
            print(f"{q}: extrapolated {limits[q][0]:.9f}, observed order {limits[q][1]:.3f}, "
                  f"finest change {change:.3e}, correction {abs(limits[q][0] - rows[-1][q]):.3e}{previous}")
    if args.csv:
        if (args.E, args.nu, args.F, args.plane) != (DEFAULTS["E"], DEFAULTS["nu"], 1.0, "strain") or len(rows) < 3:
            parser.error("--csv stores the Table 5.2 problem per F = 1 (default --E, --nu, --F, --plane) "
                         "and needs three meshes or more")
        write_csv(args.csv, rows, limits)
    return {"rows": rows, "limits": limits}


if __name__ == "__main__":
    main()
