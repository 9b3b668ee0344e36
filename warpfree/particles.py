"""Particle sets: named Warp arrays sharing one particle count, under the names outputs and checkpoints use.

Positions are stored as float32 ``wp.vec3`` under ``"position"`` (unused axes 0: z in 2D, y and z in
1D) so that one ``wp.HashGrid`` and one set of kernels serve 1D, 2D and 3D. Other fields are scalar or
vector arrays of any Warp dtype.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .errors import ParameterError

POSITION = "position"


def to_points3(points, dim: int | None = None, name: str = "positions") -> np.ndarray:
    """(N, 1), (N, 2) or (N, 3) finite points -> (N, 3) float64, unused axes zero.

    With ``dim`` given, the points must have ``dim`` or 3 columns.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (1, 2, 3):
        raise ParameterError(name, f"must have shape (N, 1), (N, 2) or (N, 3), got {p.shape}")
    if dim is not None and p.shape[1] not in (dim, 3):
        raise ParameterError(name, f"a {dim}D set needs (N, {dim}) or (N, 3) positions, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError(name, "contains non-finite values")
    if p.shape[1] < 3:
        p = np.hstack([p, np.zeros((p.shape[0], 3 - p.shape[1]))])
    return p


def to_vec3(points, name: str = "positions") -> np.ndarray:
    """(N, 1..3) finite points -> (N, 3) float32 with unused axes zero (for ``wp.vec3`` arrays)."""
    return to_points3(points, name=name).astype(np.float32)


class ParticleSet:
    """A named set of particles: ``position`` plus any number of named per-particle arrays.

    Parameters
    ----------
    name: the set's name (file stem of its outputs).
    positions: (N, dim) or (N, 3) points.
    dim: 1, 2 or 3.
    """

    def __init__(self, name: str, positions, dim: int, device: str = "cpu"):
        if dim not in (1, 2, 3):
            raise ParameterError("dim", f"must be 1, 2 or 3, got {dim!r}")
        p = to_points3(positions, dim, f"{name}.positions")
        self.name = name
        self.dim = dim
        self.device = device
        self.n = p.shape[0]
        self.fields: dict[str, wp.array] = {POSITION: wp.array(p.astype(np.float32), dtype=wp.vec3, device=device)}

    #: the set's :class:`~warpfree.parallel.Partition` in a distributed run (its arrays hold this rank's items and
    #: ghosts), None otherwise
    partition = None

    @classmethod
    def view(cls, name: str, dim: int, fields: dict[str, wp.array], partition=None) -> "ParticleSet":
        """A set over existing arrays (e.g. slices of a solver's combined arrays); ``fields["position"]`` required.
        ``partition``: in a distributed run, the items the arrays hold (:meth:`numpy` then gathers every rank's own
        rows, :meth:`load` takes this rank's from a whole set's values)."""
        if POSITION not in fields:
            raise ParameterError(f"{name}.{POSITION}", "a particle set needs positions")
        n = fields[POSITION].shape[0]
        for k, arr in fields.items():
            if arr.shape[0] != n:
                raise ParameterError(f"{name}.{k}", f"needs {n} rows, got {arr.shape[0]}")
        obj = cls.__new__(cls)
        obj.name, obj.dim, obj.device, obj.n = name, dim, str(fields[POSITION].device), n
        obj.fields = dict(fields)
        obj.partition = partition
        return obj

    @property
    def count(self) -> int:
        """Particles in the whole set (every rank's own ones in a distributed run)."""
        return self.n if self.partition is None else self.partition.count

    @property
    def position(self) -> wp.array:
        """The positions (N, vec3, m)."""
        return self.fields[POSITION]

    def add(self, name: str, values=None, dtype=wp.float32) -> wp.array:
        """Add (or replace) a field; ``values`` is a scalar, an array, or None for zeros.
        Vector fields given with fewer columns than the vector (2D or 1D data) are padded with zeros."""
        if values is None:
            arr = wp.zeros(self.n, dtype=dtype, device=self.device)
        else:
            v = np.asarray(values)
            if v.ndim == 0:
                v = np.full(self.n, v)
            width = getattr(dtype, "_length_", None)
            if width and v.ndim == 2 and v.shape[1] < width:
                v = np.hstack([v, np.zeros((v.shape[0], width - v.shape[1]), dtype=v.dtype)])
            if v.shape[0] != self.n:
                raise ParameterError(f"{self.name}.{name}", f"needs {self.n} rows, got {v.shape[0]}")
            arr = wp.array(v, dtype=dtype, device=self.device)
        self.fields[name] = arr
        return arr

    def __getitem__(self, name: str) -> wp.array:
        return self.fields[name]

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def numpy(self, name: str | None = None):
        """A copy of one field as a NumPy array, or of every field (a dict) when ``name`` is None: of the whole set,
        in its order (in a distributed run gathered from every rank, on every rank)."""
        if name is None:
            return {k: self.numpy(k) for k in self.fields}
        if self.partition is not None:
            return self.partition.gather(self.fields[name])
        return self.fields[name].numpy().copy()

    def numpy_held(self, name: str) -> np.ndarray:
        """A copy of one field's rows as this process holds them (in a distributed run: its own and its ghosts)."""
        return self.fields[name].numpy().copy()

    def load(self, data: dict[str, np.ndarray]) -> None:
        """Overwrite fields from NumPy arrays of the whole set; shapes must match."""
        for k, v in data.items():
            if k not in self.fields:
                raise ParameterError(f"{self.name}.{k}", "is not a field of this set")
            shape = (self.count,) + tuple(self.fields[k].numpy().shape[1:])
            if tuple(np.shape(v)) != shape:
                raise ParameterError(f"{self.name}.{k}", f"needs shape {shape}, got {np.shape(v)}")
            self.fields[k].assign(v if self.partition is None else self.partition.take(v))

    def __repr__(self) -> str:
        return f"ParticleSet({self.name!r}, n={self.n}, dim={self.dim}, fields={list(self.fields)})"
