"""Scenes: find them (shipped with the package, or any file), load them, and type their parameters.

A scene is a Python module with ``build(**params)`` returning a run, every parameter defaulted, its docstring's first
line saying what it does, and ``SMALLEST``, the parameters of its smallest meaningful run. The shipped scenes are the
modules of :mod:`warpfree.scenes` (the top-level ``scenes/`` folder, installed with the package); ``warpfree run
NAME`` runs one by name, ``warpfree run path/to/scene.py`` any file.

Parameters are declared in ``build()``'s signature, typed and with their unit, meaning and allowed values
(:mod:`warpfree.parameters`, whose names this module also offers); a ``--set`` value is parsed to its type and checked
or refused naming the parameter, before anything is built; it never reaches the scene as a raw string.
"""

from __future__ import annotations

import ast
import importlib.resources
import importlib.util
import os

from .errors import ParameterError, closest_names
from .parameters import SceneParameter, parse_overrides, scene_parameters, value_text

__all__ = ["SceneParameter", "shipped_scenes", "scene_path", "load_scene", "scene_parameters", "parse_overrides",
           "summary_line", "value_text"]

# -- finding and loading ---------------------------------------------------------------------------------------------
def shipped_scenes() -> dict[str, str]:
    """Name -> file path of every scene shipped with the package (the modules of ``warpfree.scenes``)."""
    folder = importlib.resources.files("warpfree.scenes")
    return {entry.name[:-3]: str(entry) for entry in sorted(folder.iterdir(), key=lambda e: e.name)
            if entry.name.endswith(".py") and not entry.name.startswith("_")}


def scene_path(scene: str) -> str:
    """The file of ``scene``: a path to a Python file, or the name of a shipped scene (``dam_break_2d``)."""
    if os.path.isfile(scene):
        return scene
    shipped = shipped_scenes()
    if scene in shipped:
        return shipped[scene]
    if scene.endswith(".py") or os.sep in scene:
        raise ParameterError("scene", f"no such scene file: {scene}")
    raise ParameterError("scene", f"no scene named {scene!r}: {closest_names(scene, shipped)} "
                                  "(warpfree list describes them), or give a path to a scene file")


def load_scene(path: str):
    """Import a scene module from a file path (or a shipped scene's name)."""
    path = scene_path(path)
    name = "warpfree_scene_" + os.path.splitext(os.path.basename(path))[0]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # a scene that does not import is bad input, not a crash of warpfree
        where = f" (line {exc.lineno})" if isinstance(exc, SyntaxError) else ""
        raise ParameterError("scene", f"{path} cannot be loaded{where}: {type(exc).__name__}: {exc}") from None
    if not callable(getattr(module, "build", None)):
        raise ParameterError("scene", f"{path} has no build(**params) function")
    return module


def summary_line(path: str) -> str:
    """The first line of a scene file's docstring (what it does), read without importing the scene."""
    try:
        doc = ast.get_docstring(ast.parse(open(path, encoding="utf-8").read())) or ""
    except (OSError, SyntaxError, ValueError) as exc:
        return f"(cannot be read: {type(exc).__name__})"
    return doc.strip().splitlines()[0].strip() if doc.strip() else "(no description)"
