"""The solver contract's State: device arrays and host values (numbers, NumPy arrays, per-step tables) saved and
restored together, bitwise, and a checkpoint of another shape refused naming resume."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpfree.errors import ParameterError
from warpfree.solver import HostTable, State


def make_state():
    s = State()
    s.position = wp.array(np.arange(6, dtype=np.float32).reshape(3, 2), dtype=wp.vec2, device="cpu")
    s.steps = 7
    s.charge = 0.1 + 0.2
    s.tally = np.array([1.5, -2.0, 0.0])
    s.history = HostTable(["time", "energy"])
    s.history.append({"time": 0.0, "energy": 1.0})
    s.history.append({"time": 0.5, "energy": 0.75})
    s._cache = 3          # private: not state
    s.flag = True         # a bool is not state either (its meaning would be reinterpreted as an int)
    return s


def test_host_values_are_checkpointed_with_the_arrays_and_restored_with_their_types():
    saved = make_state().numpy()
    assert set(saved) == {"position", "steps", "charge", "tally", "history"}
    assert saved["history"].shape == (2, 2) and saved["steps"].dtype == np.int64
    other = State()
    other.position = wp.zeros(3, dtype=wp.vec2, device="cpu")
    other.steps, other.charge, other.tally = 0, 0.0, np.zeros(3)
    other.history = HostTable(["time", "energy"])
    other.assign(saved)
    assert other.steps == 7 and type(other.steps) is int
    assert other.charge == 0.1 + 0.2 and type(other.charge) is float
    assert np.array_equal(other.tally, [1.5, -2.0, 0.0]) and other.tally is not saved["tally"]
    assert other.history.as_dict() == {"time": [0.0, 0.5], "energy": [1.0, 0.75]} and len(other.history) == 2
    assert np.array_equal(other.position.numpy(), saved["position"])


@pytest.mark.parametrize("key,value", [("tally", np.zeros(4)), ("steps", np.zeros(2, np.int64)),
                                       ("history", np.zeros((2, 3))), ("charge", np.array(1, np.int64))])
def test_a_host_value_of_another_shape_or_type_is_refused(key, value):
    saved = make_state().numpy()
    saved[key] = value
    with pytest.raises(ParameterError, match=f"resume: .*{key}"):
        make_state().assign(saved)


def test_a_table_row_must_have_every_column():
    table = HostTable(["a", "b"])
    with pytest.raises(ValueError, match="columns"):
        table.append({"a": 1.0})
    assert len(table) == 0 and table.to_array().shape == (0, 2)
