"""The fourth-order difference of SPEM (``warpfree.solvers.spem.fourth_order``): the pair exactly skew-adjoint, its
rows exact for cubic fields in the interior and of fourth order up to the walls for fields of the walls' parity, a
box's resonance at fourth order, and the layouts it cannot take refused by name."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warpfree.errors import ParameterError
from warpfree.shapes import Disc
from warpfree.solvers.spem import (C0, PEC, EMObject, SPEMModel, SPEMSolver, staggered_box, staggered_disk,
                                   staggered_line)


@pytest.mark.parametrize("dim", [1, 2])
def test_the_pair_is_skew_adjoint_and_exact_for_cubic_fields_inside(dim):
    layout = staggered_box((0.0, 0.0), (1.0, 0.8), 0.05) if dim == 2 else staggered_line(0.0, 1.0, 0.05)
    model = SPEMModel(layout, order=4)
    assert model.conservation["residual"] < 1e-12
    e, h = layout.e_position, layout.h_position
    for axis, sub in enumerate(layout.h_subsets()):
        field = np.zeros(layout.n_h)
        field[sub] = 1.0 + h[sub, axis] - 2.0 * h[sub, axis] ** 2 + 3.0 * h[sub, axis] ** 3
        got = model._pair.e_operator[axis] @ field
        inside = ~model.held & np.all((e[:, :dim] > 0.1) & (e[:, :dim] < np.array([1.0, 0.8])[:dim] - 0.1), axis=1)
        exact = 1.0 - 4.0 * e[:, axis] + 9.0 * e[:, axis] ** 2
        assert np.abs(got - exact)[inside].max() < 1e-9


def test_the_rows_are_of_fourth_order_up_to_the_walls_for_the_walls_parity():
    """Ez = sin(πx) sin(2πy) (zero on the walls, odd about them) on the unit square: the H rows' derivative, over every
    H particle, converges at order 4 (and the E rows' of its H = cos(πx)-like even field alike)."""
    errors = []
    for cells in (10, 20):
        layout = staggered_box((0.0, 0.0), (1.0, 1.0), 1.0 / cells)
        model = SPEMModel(layout, order=4)
        e, h = layout.e_position, layout.h_position
        ez = np.sin(math.pi * e[:, 0]) * np.sin(2 * math.pi * e[:, 1])
        sub = layout.h_subsets()[0]
        got = (model._pair.h_operator[0] @ ez)[sub]
        exact = math.pi * np.cos(math.pi * h[sub, 0]) * np.sin(2 * math.pi * h[sub, 1])
        errors.append(np.abs(got - exact).max())
    assert math.log2(errors[0] / errors[1]) > 3.7, errors


def test_a_box_resonates_at_fourth_order():
    """The TM11 mode of a square PEC box (ω = cπ√2/a) at a step of 0.05 of the limit (the leapfrog's own error,
    (ωΔt)²/24, then 1e-5 of the frequency at 8 cells): the error at 8 and 16 cells a side falls at order 3.5 or more
    (Yee's difference: order 2), below 1e-3 at 8 cells."""
    from warpfree.validation.pic_plasma_oscillation import frequency_from_crossings

    exact = C0 * math.pi * math.sqrt(2.0)
    errors = {}
    for cells in (8, 16):
        layout = staggered_box((0.0, 0.0), (1.0, 1.0), 1.0 / cells)
        mode = lambda p: np.sin(math.pi * p[:, 0]) * np.sin(math.pi * p[:, 1])  # noqa: E731
        solver = SPEMSolver(SPEMModel(layout, order=4), ez=mode)
        centre = int(np.argmin(np.linalg.norm(layout.e_position[:, :2] - 0.5, axis=1)))
        period = 2 * math.pi / exact
        steps = int(math.ceil(period / (0.05 * solver.stable_dt())))
        dt = period / steps
        times, values = [], []
        for n in range(4 * steps):
            solver.step(dt)
            times.append((n + 0.5) * dt)
            values.append(float(solver.electric.numpy("ez")[centre]))
        errors[cells] = abs(frequency_from_crossings(np.array(times), np.array(values)) / exact - 1.0)
    assert errors[8] < 1e-3
    assert math.log2(errors[8] / errors[16]) > 3.5, errors


@pytest.mark.parametrize("make,setting,reason", [
    (lambda: staggered_box((0, 0), (1, 1), 0.1, jitter=0.2), {}, "uniform lattice"),
    (lambda: staggered_box((0, 0), (1, 1), 0.1, grading=1.5), {}, "uniform lattice"),
    (lambda: staggered_box((0, 0), (1, 1), 0.1, h_staggering="centres"), {}, "uniform lattice"),
    (lambda: staggered_disk((0, 0), 1.0, 0.1), {}, "uniform lattice"),
    (lambda: staggered_box((0, 0), (1, 1), 0.1), {"pec": False}, "pec"),
    (lambda: staggered_box((0, 0), (1, 1), 0.1), {"objects": [EMObject(Disc((0.5, 0.5), 0.2), PEC)]}, "order"),
    (lambda: staggered_box((0, 0), (1, 1), 0.1), {"order": 3}, "order"),
])
def test_layouts_it_cannot_take_are_refused_by_name(make, setting, reason):
    with pytest.raises(ParameterError) as info:
        SPEMModel(make(), **{"order": 4, **setting})
    assert info.value.name in ("order", "pec")
    assert reason in str(info.value)
