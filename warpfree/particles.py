"""Particle sets: named Warp arrays sharing one particle count.

Positions are always stored as float32 ``wp.vec3`` (z = 0 for 2D sets) so that one ``wp.HashGrid``
and one set of kernels serve 2D and 3D. Other fields are scalar or vector arrays of any Warp dtype.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .errors import ParameterError


def to_vec3(points: np.ndarray, name: str = "positions") -> np.ndarray:
    """(N, 2) or (N, 3) finite points -> (N, 3) float32 with z = 0 for 2D input."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ParameterError(name, f"must have shape (N, 2) or (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError(name, "contains non-finite values")
    if p.shape[1] == 2:
        p = np.hstack([p, np.zeros((p.shape[0], 1))])
    return p.astype(np.float32)


class ParticleSet:
    """A named set of particles: ``positions`` plus any number of named per-particle arrays."""

    def __init__(self, name: str, positions: np.ndarray, dim: int, device: str = "cpu"):
        if dim not in (1, 2, 3):
            raise ParameterError("dim", f"must be 1, 2 or 3, got {dim!r}")
        p = to_vec3(positions, f"{name}.positions")
        if dim == 3 and np.asarray(positions).shape[1] != 3:
            raise ParameterError(f"{name}.positions", "a 3D set needs (N, 3) positions")
        self.name = name
        self.dim = dim
        self.device = device
        self.n = p.shape[0]
        self.fields: dict[str, wp.array] = {}
        self.fields["x"] = wp.array(p, dtype=wp.vec3, device=device)

    @classmethod
    def view(cls, name: str, dim: int, fields: dict[str, wp.array]) -> "ParticleSet":
        """A set over existing arrays (e.g. slices of a solver's combined arrays); ``fields["x"]`` required."""
        if "x" not in fields:
            raise ParameterError(f"{name}.x", "a particle set needs positions 'x'")
        n = fields["x"].shape[0]
        for k, arr in fields.items():
            if arr.shape[0] != n:
                raise ParameterError(f"{name}.{k}", f"needs {n} rows, got {arr.shape[0]}")
        obj = cls.__new__(cls)
        obj.name, obj.dim, obj.device, obj.n = name, dim, str(fields["x"].device), n
        obj.fields = dict(fields)
        return obj

    @property
    def x(self) -> wp.array:
        return self.fields["x"]

    def add(self, name: str, values=None, dtype=wp.float32) -> wp.array:
        """Add (or replace) a field; ``values`` is a scalar, an array, or None for zeros."""
        if values is None:
            arr = wp.zeros(self.n, dtype=dtype, device=self.device)
        else:
            v = np.asarray(values)
            if v.ndim == 0:
                v = np.full(self.n, v)
            elif dtype == wp.vec3 and v.ndim == 2 and v.shape[1] == 2:
                v = np.hstack([v, np.zeros((v.shape[0], 1))])
            if v.shape[0] != self.n:
                raise ParameterError(f"{self.name}.{name}", f"needs {self.n} rows, got {v.shape[0]}")
            arr = wp.array(v, dtype=dtype, device=self.device)
        self.fields[name] = arr
        return arr

    def __getitem__(self, name: str) -> wp.array:
        return self.fields[name]

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def numpy(self) -> dict[str, np.ndarray]:
        """Copies of every field as NumPy arrays (positions trimmed to ``dim`` columns kept as 3)."""
        return {k: v.numpy().copy() for k, v in self.fields.items()}

    def load(self, data: dict[str, np.ndarray]) -> None:
        """Overwrite fields from NumPy arrays (a checkpoint); shapes must match."""
        for k, v in data.items():
            if k not in self.fields:
                raise ParameterError(f"{self.name}.{k}", "is not a field of this set")
            self.fields[k].assign(v)

    def __repr__(self) -> str:
        return f"ParticleSet({self.name!r}, n={self.n}, dim={self.dim}, fields={list(self.fields)})"
