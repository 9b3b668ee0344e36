"""The device memory a solver holds: its Warp arrays and hash grids, per work item (a particle, a Gauss point).

The objects the solver reaches (attributes, lists, tuples, dicts, Warp structs; not third-party objects nor host NumPy
or SciPy arrays) are walked once. Each Warp array on the solver's device counts its bytes once: a view counts inside
the array it views (byte ranges are merged). A ``wp.HashGrid`` counts what Warp allocates for it
(``warp/native/hashgrid.cpp``): two int32 per cell (cell starts and ends) and, for each point of its room (1.5 times
the points of a build that outgrew it), point cells and point ids, each two int32 (the radix sort's double buffer):
8 bytes a cell, 16 a point of room (24 a point built).

Parts: ``state`` (the arrays of ``solver.state``: what a checkpoint holds), ``neighbours`` (hash grids and neighbour
rows: :mod:`warpfree.neighbours`), ``other`` (operators, coefficients, sources, monitors, scratch). Checked against
Warp's own allocation tracker (``wp.ScopedMemoryTracker``) in the tests.
"""

from __future__ import annotations

import types

import numpy as np
import warp as wp

__all__ = ["HASH_GRID_BYTES_PER_CELL", "HASH_GRID_BYTES_PER_POINT", "solver_memory", "work_item_name"]

#: Warp's hash grid: cell starts and ends, int32 each
HASH_GRID_BYTES_PER_CELL = 8
#: Warp's hash grid: point cells and point ids, int32, twice (the radix sort's buffers), per point of its room
HASH_GRID_BYTES_PER_POINT = 16

#: packages whose objects are not walked into (their arrays are not the solver's, or are host arrays)
_FOREIGN = {"warp", "numpy", "scipy", "mpi4py", "petsc4py", "trimesh", "meshio", "matplotlib", "PIL", "rtree",
            "builtins", "threading", "concurrent", "subprocess", "io", "logging", "weakref", "collections", "ctypes"}

_PARTS = ("state", "neighbours", "other")


def work_item_name(solver) -> str:
    """The item ``work_items`` counts, singular: "particle" for particle-steps and pushes, "Gauss point" for a static
    solve's Gauss points."""
    unit = solver.work_unit
    for suffix, name in (("particle-steps", "particle"), ("particle pushes", "particle"),
                         ("Gauss points", "Gauss point")):
        if unit == suffix:
            return name
    return unit


def _is_struct(obj) -> bool:
    return hasattr(obj, "_ctype") and type(obj).__module__.startswith("warp")


def _children(obj):
    if isinstance(obj, dict):
        return list(obj.values())
    if isinstance(obj, (list, tuple, set, frozenset)):
        return list(obj)
    if _is_struct(obj):
        return [v for k, v in vars(obj).items() if k != "_ctype"]
    from .device import Launcher

    if isinstance(obj, Launcher):  # the process's, shared by every solver (its CPU replay cache is not the solver's)
        return []
    module = type(obj).__module__.split(".")[0]
    if module in _FOREIGN or isinstance(obj, (type, types.ModuleType, types.FunctionType, types.MethodType,
                                              types.BuiltinFunctionType, np.ndarray, np.generic)):
        return []
    values = list(vars(obj).values()) if hasattr(obj, "__dict__") else []
    for cls in type(obj).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if hasattr(obj, name):
                values.append(getattr(obj, name))
    return values


def _neighbour_kind(obj) -> bool:
    from warpfree.kernels import neighbours as nk

    from . import neighbours

    kinds = (neighbours.NeighbourGrid, neighbours.GatherGrid, neighbours.NeighbourList, neighbours.NeighbourTable,
             neighbours.MovingNeighbours, wp.HashGrid, nk.NeighbourRows.instance_type)
    return isinstance(obj, kinds)


def _reachable(solver, device) -> tuple[list, list]:
    """(arrays, grids) reachable from ``solver``: (ptr, bytes, part) of each array on ``device`` and (grid, part)."""
    from .neighbours import grid_points_reserved

    arrays, grids, seen = [], [], set()
    state = getattr(solver, "state", None)
    stack = [(solver, "other")]
    if state is not None:
        stack.append((state, "state"))  # popped first: the state's arrays are claimed as state
    while stack:
        obj, part = stack.pop()
        if obj is None or isinstance(obj, (str, bytes, int, float, bool, complex)) or id(obj) in seen:
            continue
        seen.add(id(obj))
        if part == "other" and _neighbour_kind(obj):
            part = "neighbours"
        if isinstance(obj, wp.array):
            if obj.ptr and str(obj.device) == device:
                arrays.append((int(obj.ptr), int(obj.capacity), part))
            continue
        if isinstance(obj, wp.HashGrid):
            if str(obj.device) == device:
                dims = int(obj._dim_x) * int(obj._dim_y) * int(obj._dim_z)
                grids.append((dims * HASH_GRID_BYTES_PER_CELL
                              + grid_points_reserved(obj) * HASH_GRID_BYTES_PER_POINT, part))
            continue
        stack.extend((child, part) for child in reversed(_children(obj)))
    return arrays, grids


def solver_memory(solver) -> dict:
    """The device bytes ``solver`` holds (module docstring): ``bytes`` in all, ``per_item`` over its work items,
    ``item`` (what an item is), ``parts`` (bytes of ``state``, ``neighbours``, ``other``) and ``device``."""
    device = str(solver.launcher.device)
    arrays, grids = _reachable(solver, device)
    parts, before = dict.fromkeys(_PARTS, 0), 0
    for k, part in enumerate(_PARTS):  # a range counts for the first part that holds it: state, neighbours, other
        upto = _union_bytes([(ptr, ptr + size) for ptr, size, p in arrays if p in _PARTS[:k + 1]])
        parts[part], before = upto - before, upto
    for size, part in grids:
        parts[part] += size
    total = sum(parts.values())
    items = int(solver.work_items)
    return {"device": device, "bytes": total, "per_item": total / items if items else None,
            "item": work_item_name(solver), "parts": parts}


def _union_bytes(ranges: list[tuple[int, int]]) -> int:
    """The bytes the union of the [low, high) ``ranges`` covers."""
    total, reach = 0, None
    for low, high in sorted(ranges):
        if reach is None or low >= reach:
            total += high - low
            reach = high
        elif high > reach:
            total += high - reach
            reach = high
    return total
