"""The halo exchange's device packing (``kernels/halo.py``, ``warpfree.parallel.halo``): the pack and unpack kernels
against NumPy fancy indexing for every value type a refresh takes; a refresh plan's layout (fields of every type side
by side, several neighbours) through a loopback in one process; and a refresh over real MPI ranks, with work between
its start and its finish. Every comparison is exact: a refresh copies bits."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
import warp as wp

from warpfree.kernels import halo as H
from warpfree.parallel import Decomposition, Partition, World
from warpfree.parallel.launch import find_mpiexec, run_ranks


def _layout(dtype) -> tuple[int, type]:
    """(components, NumPy scalar type) of a Warp value type."""
    return getattr(dtype, "_length_", 1), wp.dtype_to_numpy(getattr(dtype, "_wp_scalar_type_", dtype))


def _values(dtype, n: int, rng) -> np.ndarray:
    """n rows of ``dtype``'s NumPy form, every row distinct (random bits where a float can hold them)."""
    width, scalar = _layout(dtype)
    if np.issubdtype(scalar, np.integer):
        values = rng.integers(-2**31, 2**31 - 1, size=(n, width), dtype=np.int64).astype(scalar)
    else:
        values = rng.standard_normal((n, width)).astype(scalar)
    return values.reshape(n) if width == 1 else values


@pytest.mark.parametrize("dtype", H.TYPES, ids=lambda t: t.__name__)
def test_pack_and_unpack_are_numpy_fancy_indexing(dtype):
    rng = np.random.default_rng(1)
    n, m, room = 50, 17, 40
    values = _values(dtype, n, rng)
    rows = rng.choice(n, m, replace=False).astype(np.int32)
    slots = rng.choice(room, m, replace=False).astype(np.int32)
    a = wp.array(values, dtype=dtype, device="cpu")
    block = wp.zeros(room, dtype=dtype, device="cpu")
    args = [wp.array(rows, dtype=wp.int32), wp.array(slots, dtype=wp.int32)]
    wp.launch(H.pack_rows, dim=m, inputs=[0, a, args[0], args[1], block], device="cpu")
    expected = np.zeros_like(block.numpy())
    expected[slots] = values[rows]
    assert np.array_equal(block.numpy(), expected)
    # unpack into other rows of a fresh array: exactly those rows change, to the block's values
    target_rows = rng.choice(n, m, replace=False).astype(np.int32)
    before = _values(dtype, n, rng)
    b = wp.array(before, dtype=dtype, device="cpu")
    wp.launch(H.unpack_rows, dim=m, inputs=[0, block, args[1], wp.array(target_rows, dtype=wp.int32), b],
              device="cpu")
    expected = before.copy()
    expected[target_rows] = block.numpy()[slots]
    assert np.array_equal(b.numpy(), expected)


class Loopback(World):
    """A rank that is its own neighbours: the message "to" rank r arrives as the message "from" rank r (their sizes
    agree when send[r] and receive[r] have one length), copied at start; nothing leaves the process."""

    def __init__(self):
        super().__init__()
        self.size = 2   # not a one-process part: refresh runs its plan

    def persistent_exchange(self, sends, receives):
        return _LoopbackMessages(sends, receives)


class _LoopbackMessages:
    def __init__(self, sends, receives):
        assert sends.keys() == receives.keys()
        self.pairs = [(sends[r], receives[r]) for r in sends]
        self.started = self.waited = 0

    def start(self):
        self.started += 1
        for out, into in self.pairs:
            assert out.size == into.size
            into[:] = out

    def wait(self):
        self.waited += 1

    def free(self):
        self.pairs = []


def test_a_plan_packs_every_type_side_by_side_and_unpacks_each_into_its_ghost_rows():
    """Five fields of five types (item sizes 4, 8, 4, 12, 16: blocks aligned to 48 bytes) to three "neighbours" of
    different lengths: after a refresh every received row holds the value of its sent row, and no other row changed."""
    rng = np.random.default_rng(2)
    n = 200
    order = rng.permutation(n)
    send = {1: order[:7], 4: order[7:26], 6: order[26:27]}
    receive = {1: order[100:107], 4: order[107:126], 6: order[126:127]}
    part = Partition(Loopback(), None, 1.0, np.arange(n), np.ones(n, bool), send, receive, n)
    values = [_values(t, n, rng) for t in H.TYPES]
    arrays = [wp.array(v, dtype=t, device="cpu") for v, t in zip(values, H.TYPES)]
    part.refresh(*arrays)
    for v, a in zip(values, arrays):
        expected = v.copy()
        for r in send:
            expected[receive[r]] = v[send[r]]
        assert np.array_equal(a.numpy(), expected)
    plan = next(iter(part._plans.values()))
    assert plan.align == 48 and plan.messages.started == 1
    part.refresh(*arrays)                      # the same arrays: the same plan, its messages started again
    assert len(part._plans) == 1 and plan.messages.started == 2


def test_a_refresh_under_way_refuses_another_and_refuses_numpy():
    n = 10
    part = Partition(Loopback(), None, 1.0, np.arange(n), np.ones(n, bool), {1: np.arange(3)},
                     {1: np.arange(5, 8)}, n)
    a = wp.array(np.arange(n, dtype=np.float32), dtype=float, device="cpu")
    part.start_refresh(a)
    with pytest.raises(RuntimeError, match="under way"):
        part.start_refresh(a)
    assert np.array_equal(a.numpy(), np.arange(n))     # the ghosts change only at the finish
    part.finish_refresh()
    assert np.array_equal(a.numpy()[5:8], [0, 1, 2])
    with pytest.raises(TypeError, match="Warp arrays"):
        part.refresh(np.zeros(n, np.float32))


def test_set_ghosts_writes_the_ghost_rows_alone():
    n = 12
    owned = np.arange(n) % 3 != 0
    part = Partition(Loopback(), None, 1.0, np.arange(n), owned, {}, {}, n)
    a = wp.array(np.ones((n, 4), np.float32), dtype=wp.vec4, device="cpu")
    part.set_ghosts(a, wp.vec4(0.0, 2.0, 0.0, 0.0))
    expected = np.ones((n, 4), np.float32)
    expected[~owned] = [0.0, 2.0, 0.0, 0.0]
    assert np.array_equal(a.numpy(), expected)


def test_the_variable_says_whether_mpi_is_cuda_aware(monkeypatch):
    from warpfree.errors import ParameterError

    W = importlib.import_module("warpfree.parallel.world")   # the module (the package's ``world`` is its function)

    for setting, aware in (("1", True), ("0", False)):
        monkeypatch.setattr(W, "_cuda_aware", None)
        monkeypatch.setenv(W.CUDA_AWARE_VARIABLE, setting)
        assert W.cuda_aware_mpi() is aware
    monkeypatch.setattr(W, "_cuda_aware", None)
    monkeypatch.setenv(W.CUDA_AWARE_VARIABLE, "yes")
    with pytest.raises(ParameterError, match=W.CUDA_AWARE_VARIABLE):
        W.cuda_aware_mpi()


def test_one_process_refreshes_nothing():
    x = np.random.default_rng(0).uniform(0, 1, (50, 3))
    dec = Decomposition.build(1, x, None, 0.1, 3, "rcb", domain_lower=(0.0, 0.0, 0.0))
    part = Partition.of_all(World(), dec, 0.2, x)
    a = wp.array(np.arange(50, dtype=np.float32), dtype=float, device="cpu")
    part.refresh(a)
    assert part.whole and not part._plans


def test_whole_from_pieces_joins_owned_rows_by_id_and_refuses_a_missing_or_twice_owned_item():
    """Two pieces of a 5-item set, each holding its own items and a ghost: row i of the whole is item i, from its
    owner's piece; an item no piece owns, or two pieces own, is refused."""
    from warpfree.errors import ParameterError
    from warpfree.parallel.halo import whole_from_pieces

    a = {"id": np.array([0, 2, 3]), "own": np.array([1, 1, 0]), "v": np.array([10.0, 12.0, -1.0])}
    b = {"id": np.array([1, 3, 4, 2]), "own": np.array([1, 1, 1, 0]), "v": np.array([11.0, 13.0, 14.0, -2.0])}
    whole = whole_from_pieces([a, b], ["v"], "id", 5, owned="own")
    assert np.array_equal(whole["v"], [10.0, 11.0, 12.0, 13.0, 14.0])
    with pytest.raises(ParameterError, match="4 of the 5"):
        whole_from_pieces([a, dict(b, own=np.array([1, 1, 0, 0]))], ["v"], "id", 5, owned="own")
    with pytest.raises(ParameterError, match="twice"):
        whole_from_pieces([a, dict(b, own=np.array([1, 1, 1, 1]))], ["v"], "id", 5, owned="own")


def test_whole_from_pieces_of_sparse_ids_gives_the_items_present_in_id_order():
    """Ids a set issued and partly retired (items that joined and left): with no ``count``, the rows of the ids present,
    ascending, the first copy of each (ghosts are their owners' copies), each piece's first ``rows`` rows only."""
    from warpfree.parallel.halo import whole_from_pieces

    a = {"id": np.array([17, 3, 40, 99], np.int32), "n": 3, "v": np.array([1.7, 0.3, 4.0, -9.0])}
    b = {"id": np.array([40, 8], np.int32), "n": 2, "v": np.array([4.0, 0.8])}
    whole = whole_from_pieces([a, b], ["v"], "id", None, rows="n")
    assert np.array_equal(whole["id"], [3, 8, 17, 40]) and np.array_equal(whole["v"], [0.3, 0.8, 1.7, 4.0])
    with_ids = whole_from_pieces([a, b], ["v", "id"], "id", None, rows="n")
    assert with_ids["id"].dtype == np.int32 and np.array_equal(with_ids["id"], [3, 8, 17, 40])


def test_a_part_of_sparse_ids_gathers_its_rows_in_id_order():
    """A part of a set whose ids are sparse (count: the ids issued, 50; 4 items, held out of id order): its owned rows
    in id order, and no row for an id no item has."""
    ids = np.array([9, 2, 41, 30])
    values = ids[:, None] * np.array([1.0, 0.5])
    part = Partition(Loopback(), None, 1.0, ids, np.ones(4, bool), {}, {}, 50)
    assert np.array_equal(part.gather(values), [[2.0, 1.0], [9.0, 4.5], [30.0, 15.0], [41.0, 20.5]])


RANKS_SCRIPT = r"""
import numpy as np, warp as wp
from warpfree.device import init_warp
from warpfree.kernels.halo import TYPES
from warpfree.parallel import Decomposition, Partition, world
init_warp()
w = world()
n = 3000
rng = np.random.default_rng(0)
x = np.c_[rng.uniform(0, 2, n), rng.uniform(0, 1, n), np.zeros(n)]
dec = Decomposition.build(w.size, x, None, 0.1, 2, "rcb", domain_lower=(0.0, 0.0, 0.0))
part = Partition.of_all(w, dec, 0.25, x)
assert part.n_ghosts > 0


def truth(t, step):  # every item's value at a step, the same on every rank
    width = getattr(t, "_length_", 1)
    v = np.arange(n)[:, None] * 7 + step + np.arange(width)[None, :]
    v = (v * 0.37).astype(wp.dtype_to_numpy(getattr(t, "_wp_scalar_type_", t)))
    return v.reshape(n) if width == 1 else v


arrays = [wp.zeros(part.n, dtype=t, device="cpu") for t in TYPES]
other = wp.zeros(part.n, dtype=float, device="cpu")
for step in range(3):
    for a, t in zip(arrays, TYPES):   # owned rows current, ghost rows stale
        a.numpy()[part.owned_index] = truth(t, step)[part.ids[part.owned_index]]
    part.start_refresh(*arrays)
    other.fill_(float(step))          # work between the start and the finish
    part.finish_refresh()
    for a, t in zip(arrays, TYPES):
        assert np.array_equal(a.numpy(), truth(t, step)[part.ids]), (w.rank, t, step)
    assert np.all(other.numpy() == step)
    part.refresh(other)               # a second list of arrays: a second plan
print("ok", w.rank, part.n_ghosts, len(part._plans))
"""


needs_mpi = pytest.mark.skipif(find_mpiexec() is None, reason="no MPI here")


@needs_mpi
@pytest.mark.parametrize("ranks", [2, 3])
def test_ranks_refresh_every_type_exactly_with_work_between_start_and_finish(ranks):
    """Items scattered over a 2 x 1 box cut by RCB; for three steps every rank sets its owned rows, starts a refresh,
    does other work, finishes: every held row (owned and ghost) then holds the item's value of that step."""
    done = run_ranks(ranks, ["-c", RANKS_SCRIPT], timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.count("ok") == ranks and done.stdout.count(" 2\n") == ranks   # two plans on every rank
