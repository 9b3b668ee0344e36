"""Two-material resistor (Marques 2008, §6.2): a fine-mesh FEM reference; see ``README.md``.

∇·(σ ∇V) = 0 on an inverted T (SI units, lengths in metres; the sketch in mm): aluminium (material 1,
σ1 = 3.57e7 S/m) in the lower bar [0, 3] x [0, 1] mm, copper (material 2, σ2 = 5.88e7 S/m) in the upper bar
[1, 2] x [1, 2] mm; V = 1 V on the top y = 2 mm, V = 0 on the bottom y = 0, every other side insulated. The
interface y = 1 mm, 1 <= x <= 2 mm, is horizontal; the re-entrant corners (1, 1) and (2, 1) mm, where the
sides of the upper bar meet it, are the "critical regions" (singular field). The geometry is ours: the
thesis's figure (Fig. 6.2, from Marques et al. 2007a) is lost.

The data (Q9 finite elements, n = 16 ... 256 elements per mm, written by ``reference_fem.py``):
``reference_scalars.csv`` (electrode currents and probe values per mesh and their Richardson limit),
``reference_lines.csv`` (V and E on the evaluation lines, finest mesh) and ``reference_grid.csv`` (the finest
solution's V at the nodes of coarser Q9 meshes, finer near the corners, for :func:`potential_at`). The conductance per unit
thickness is scale free in 2D (S/m = A/m per volt); the fields scale as 1/length.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from warpfree.validation import read_csv

__all__ = ["MM", "GEOMETRY", "CONDUCTIVITY", "ELECTRODES", "INTERFACE", "CORNERS", "LINE_NAMES", "PROBES",
           "singular_exponent", "convergence_table", "conductance", "lines", "field_on_lines", "potential_at",
           "probe_values"]

#: One millimetre in metres: the length unit of the sketch (the API is in metres).
MM = 1e-3
#: The conductor as rectangles (x0, x1, y0, y1 in m, material): the lower bar in three pieces (so that its
#: mesh conforms to the upper bar's) and the upper bar.
GEOMETRY = ((0.0, 1 * MM, 0.0, 1 * MM, 1), (1 * MM, 2 * MM, 0.0, 1 * MM, 1), (2 * MM, 3 * MM, 0.0, 1 * MM, 1),
            (1 * MM, 2 * MM, 1 * MM, 2 * MM, 2))
#: σ per material (S/m): 1 aluminium, 2 copper (Marques 2008, §6.2.1-6.2.2).
CONDUCTIVITY = {1: 3.57e7, 2: 5.88e7}
#: Dirichlet electrodes: segment ((x0, y0), (x1, y1)) in m and potential (V). The rest of the boundary is
#: insulated (zero normal current).
ELECTRODES = {"top": {"segment": ((1 * MM, 2 * MM), (2 * MM, 2 * MM)), "potential": 1.0},
              "bottom": {"segment": ((0.0, 0.0), (3 * MM, 0.0)), "potential": 0.0}}
#: The material interface (m): y = 1 mm, 1 <= x <= 2 mm (material 1 below, 2 above).
INTERFACE = ((1 * MM, 1 * MM), (2 * MM, 1 * MM))
#: The re-entrant corners where the upper bar's sides meet the interface (m): the critical regions.
CORNERS = np.array([[1 * MM, 1 * MM], [2 * MM, 1 * MM]])
CORNERS.setflags(write=False)
#: Line ids of ``reference_lines.csv``.
LINE_NAMES = {0: "crossing", 1: "crossing_offset", 2: "upper", 3: "lower", 4: "interface_below",
              5: "interface_above"}
#: Probes of ``reference_scalars.csv``: name -> ((x, y) in m, material whose side is evaluated).
PROBES = {
    "x1.5_y1.5": ((1.5 * MM, 1.5 * MM), 2),
    "x1.25_y1.25": ((1.25 * MM, 1.25 * MM), 2),
    "x1.05_y1.05": ((1.05 * MM, 1.05 * MM), 2),
    "x1.5_y1_Cu": ((1.5 * MM, 1.0 * MM), 2),
    "x1.5_y1_Al": ((1.5 * MM, 1.0 * MM), 1),
    "x1.5_y0.5": ((1.5 * MM, 0.5 * MM), 1),
    "x0.5_y0.5": ((0.5 * MM, 0.5 * MM), 1),
    "x2.5_y0.75": ((2.5 * MM, 0.75 * MM), 1),
}


def singular_exponent(sigma_lower: float = CONDUCTIVITY[1], sigma_upper: float = CONDUCTIVITY[2]) -> float:
    """Leading exponent λ of V - V(corner) ~ r^λ f(θ) at a re-entrant corner: the lower material fills a
    half plane (180°), the upper one a quadrant (90°), both outer sides insulated. Continuity of V and of
    σ ∂V/∂θ across the interface give σ_l tan(λπ) + σ_u tan(λπ/2) = 0, i.e. tan²(λπ/2) = 1 + 2 σ_l/σ_u
    (2/3 for one material). For Al below and Cu above λ = 0.6233: |E| ~ r^(λ-1) = r^-0.377."""
    return float(2.0 / np.pi * np.arctan(np.sqrt(1.0 + 2.0 * sigma_lower / sigma_upper)))


def convergence_table() -> tuple[list[str], np.ndarray]:
    """``reference_scalars.csv`` as (header, data): per mesh n (elements per mm), free dofs, the consistent
    electrode currents (A/m for 1 V, i.e. the conductance per unit thickness in S/m), the gradient-integral
    electrode fluxes, V, E_y and |E| at ``PROBES``; the last row (n = 0) is the Richardson limit."""
    return read_csv("efg_resistor", "reference_scalars.csv")


def conductance() -> float:
    """Extrapolated conductance per unit thickness G = I / 1 V (S/m, i.e. A/m of thickness per volt)."""
    header, data = convergence_table()
    if data[-1, 0] != 0:
        raise ValueError("efg_resistor/reference_scalars.csv: the last row must be the extrapolation (n = 0)")
    return float(data[-1, 2])


def probe_values(extrapolated: bool = True) -> dict[str, dict[str, float]]:
    """V (V), E_y and |E| (V/m) at ``PROBES``: the Richardson limit or (extrapolated=False) the finest mesh."""
    header, data = convergence_table()
    row = data[-1] if extrapolated else data[-2]
    col = {h.split(" ")[0]: i for i, h in enumerate(header)}
    return {name: {"V": float(row[col[f"V_{name}"]]), "Ey": float(row[col[f"Ey_{name}"]]),
                   "E": float(row[col[f"E_{name}"]])} for name in PROBES}


@lru_cache(maxsize=1)
def _lines() -> np.ndarray:
    _, data = read_csv("efg_resistor", "reference_lines.csv")
    data.setflags(write=False)
    return data


def lines() -> dict[str, dict[str, np.ndarray]]:
    """The finest-mesh samples on the evaluation lines, by name (``LINE_NAMES``): arrays "x", "y" (m),
    "material" (1 below the interface, 2 above), "V" (V), "Ex", "Ey", "E" (V/m; E = -∇V, "E" = |E|).

    crossing: x = 1.5 mm, 0 <= y <= 2 mm (E_x = 0 there by symmetry); crossing_offset: x = 1.25 mm; upper:
    y = 1.05 mm, 1 <= x <= 2 mm; lower: y = 0.95 mm, 0 <= x <= 3 mm; interface_below / interface_above: y = 1 mm,
    1.05 <= x <= 1.95 mm, the one-sided limits from material 1 / 2. The crossing lines hold y = 1 mm twice,
    once per side. Step 0.005 mm.
    """
    data = _lines()
    out = {}
    for i, name in LINE_NAMES.items():
        d = data[data[:, 0] == i]
        out[name] = {"x": d[:, 1] * MM, "y": d[:, 2] * MM, "material": d[:, 3].astype(int), "V": d[:, 4],
                     "Ex": d[:, 5], "Ey": d[:, 6], "E": d[:, 7]}
    return out


def field_on_lines() -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """By line name: (points (k, 2) in m, E = -∇V (k, 2) in V/m, material (k,) of the side evaluated)."""
    return {name: (np.column_stack([d["x"], d["y"]]), np.column_stack([d["Ex"], d["Ey"]]), d["material"])
            for name, d in lines().items()}


@lru_cache(maxsize=1)
def _grid() -> tuple[tuple[int, np.ndarray], ...]:
    """The levels of ``reference_grid.csv``, finest first: (elements per mm L, V on the (6L + 1, 4L + 1) node
    grid, NaN where not stored)."""
    _, data = read_csv("efg_resistor", "reference_grid.csv")
    levels = []
    for level in sorted({int(v) for v in data[:, 0]}, reverse=True):
        d = data[data[:, 0] == level]
        values = np.full((6 * level + 1, 4 * level + 1), np.nan)
        values[d[:, 1].astype(int), d[:, 2].astype(int)] = d[:, 3]
        values.setflags(write=False)
        levels.append((level, values))
    return tuple(levels)


def potential_at(points) -> np.ndarray:
    """V (V) at points (k, 2) in m, interpolated from the finest-mesh solution (NaN outside the conductor).

    ``reference_grid.csv`` holds the fine solution's nodal values on Q9 meshes of 32 elements per mm
    everywhere and 64, 128 and 256 (the fine mesh itself) in nested windows around the two corners; a point
    takes the Q9 interpolant of the finest level whose element holds it. Within about 1e-5 V of the finest
    solution everywhere (README).
    """
    from warpfree.validation.efg_cook.reference_fem import lagrange_quadratic

    pts = np.atleast_2d(np.asarray(points, dtype=np.float64)) / MM
    out = np.full(len(pts), np.nan)
    todo = np.ones(len(pts), dtype=bool)
    for n, values in _grid():
        p = pts * n                                                         # in element units of this level
        for di in (-1e-9, 1e-9):
            for dj in (-1e-9, 1e-9):
                ei = np.floor(p[:, 0] + di).astype(int)
                ej = np.floor(p[:, 1] + dj).astype(int)
                k = np.flatnonzero(todo & (ei >= 0) & (ei < 3 * n) & (ej >= 0) & (ej < 2 * n)
                                   & (np.abs(p[:, 0] - ei - 0.5) <= 0.5 + 1e-9)
                                   & (np.abs(p[:, 1] - ej - 0.5) <= 0.5 + 1e-9))
                if k.size == 0:
                    continue
                Ve = values[2 * ei[k, None, None] + np.arange(3)[None, :, None],
                            2 * ej[k, None, None] + np.arange(3)[None, None, :]]          # (k, 3, 3)
                inside = np.all(np.isfinite(Ve), axis=(1, 2))
                k, Ve = k[inside], Ve[inside]
                lx, _ = lagrange_quadratic(np.clip(2 * (p[k, 0] - ei[k]) - 1, -1, 1))
                ly, _ = lagrange_quadratic(np.clip(2 * (p[k, 1] - ej[k]) - 1, -1, 1))
                out[k] = np.einsum("pa,pab,pb->p", lx, Ve, ly)
                todo[k] = False
    return out
