"""Cook's membrane (Rocha 2012, §5.2, Table 5.2): a fine-mesh FEM reference, ``reference.csv``; see ``README.md``.

The quadrilateral (0, 0), (48, 44), (48, 60), (0, 44) (Cook 1974), unit thickness, clamped on x = 0, a
total vertical shear F uniformly distributed on x = 48 (t_y = F/16), plane strain, E = 240.565 (the thesis's
"240,565" has a Portuguese decimal comma), ν = 0.3. There is no exact solution: ``reference.csv`` holds
Q9 finite-element values per F = 1 on n x n meshes and their Richardson limit (the row with
elements_per_side = 0), written by ``reference_fem.py`` in this folder. At fixed ν the displacements scale
as F/E and the strain energy as F²/E.
"""

from __future__ import annotations

import numpy as np

from warpfree.validation import read_csv

__all__ = ["CORNERS", "DEFAULTS", "TOP_CORNER", "EDGE_MIDPOINT", "PLANE", "edge_traction", "convergence_table",
           "reference"]

#: Vertices of the membrane, counter-clockwise (Cook 1974); the mesh of ``reference_fem`` is their bilinear map.
CORNERS = np.array([[0.0, 0.0], [48.0, 44.0], [48.0, 60.0], [0.0, 44.0]])
CORNERS.setflags(write=False)
#: Table 5.2: E = 240.565 (the thesis prints the Portuguese decimal comma "240,565"), ν = 0.3; F = 1 (not given).
DEFAULTS = {"E": 240.565, "nu": 0.3, "F": 1.0}
#: The monitored points: the top right corner and the middle of the loaded edge.
TOP_CORNER = (48.0, 60.0)
EDGE_MIDPOINT = (48.0, 52.0)
#: The hypothesis of the thesis (§5.2) and of the reference.
PLANE = "strain"
_KEYS = ("uy_48_60", "uy_48_52", "ux_48_60", "strain_energy")


def edge_traction(F: float = DEFAULTS["F"]) -> np.ndarray:
    """The load on the right edge x = 48 (height 16): t = (0, F/16) (force per unit length and thickness)."""
    return np.array([0.0, F / 16.0])


def convergence_table() -> tuple[list[str], np.ndarray]:
    """``reference.csv`` as (header, data): columns elements per side n, u_y(48, 60), u_y(48, 52), u_x(48, 60),
    strain energy ½ fᵀu, all per F = 1 with E = 240.565, ν = 0.3; one row per mesh (n = 16 ... ), then the
    Richardson limit of the three finest meshes with n = 0."""
    return read_csv("efg_cook", "reference.csv")


def reference(F: float = DEFAULTS["F"], E: float = DEFAULTS["E"]) -> dict[str, float]:
    """Extrapolated (h -> 0) reference for total shear F and modulus E (ν = 0.3, plane strain only).

    Returns {"uy_48_60", "uy_48_52", "ux_48_60" (length), "strain_energy" (per unit thickness)}: the CSV's
    last row times F · 240.565/E for displacements (linear elasticity, u ∝ F/E at fixed ν) and times
    F² · 240.565/E for the energy ½ fᵀu. For F = 1 and the defaults u_y(48, 60) = 0.095844.
    """
    _, data = convergence_table()
    if data[-1, 0] != 0:
        raise ValueError("efg_cook/reference.csv: the last row must be the extrapolation (elements_per_side = 0)")
    scale = F * DEFAULTS["E"] / E
    limit = dict(zip(_KEYS, data[-1, 1:].tolist()))
    return {k: v * (scale * F if k == "strain_energy" else scale) for k, v in limit.items()}
