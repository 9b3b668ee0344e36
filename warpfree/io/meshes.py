"""Triangle meshes written as PLY, OBJ or STL (free surfaces, iso-surfaces of any field)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ["write_mesh"]


def write_mesh(path: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray) -> Path:
    """Save a triangle mesh (``vertices`` (V, 3), ``faces`` (F, 3) vertex indices) by the file extension
    (.ply, .obj or .stl; binary PLY/STL), atomically. Duplicate vertices are merged (trimesh's processing)."""
    import trimesh

    path = Path(path)
    ext = path.suffix.lower().lstrip(".")
    if ext not in ("ply", "obj", "stl"):
        raise ParameterError("path", f"extension must be .ply, .obj or .stl, got {path.suffix!r}")
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=len(f) > 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    mesh.export(str(tmp), file_type=ext)
    os.replace(tmp, path)
    return path
