"""Scenes: find them (shipped with the package, or any file), load them, and type their parameters.

A scene is a Python module with ``build(**params)`` returning a run, every parameter defaulted, its docstring's first
line saying what it does, and ``SMALLEST``, the parameters of its smallest meaningful run. The shipped scenes are the
modules of :mod:`warpfree.scenes` (the top-level ``scenes/`` folder, installed with the package); ``warpfree run
NAME`` runs one by name, ``warpfree run path/to/scene.py`` any file.

Parameters are typed from ``build()``'s signature (:class:`SceneParameter`): its annotation (``bool``, ``int``,
``float``, ``str``, ``tuple[...]``, any of them ``| None``), else the type of its default. A ``--set`` value is parsed
to that type or refused naming the parameter; it never reaches the scene as a raw string.
"""

from __future__ import annotations

import ast
import importlib.resources
import importlib.util
import inspect
import math
import os
import types
import typing
from dataclasses import dataclass

from .errors import ParameterError, closest_names

__all__ = ["SceneParameter", "shipped_scenes", "scene_path", "load_scene", "scene_parameters", "parse_overrides",
           "summary_line", "value_text"]

TRUE_WORDS = ("true", "1", "yes")
FALSE_WORDS = ("false", "0", "no")
NONE_WORD = "none"


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


# -- typed parameters ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SceneParameter:
    """One parameter of a scene's ``build()``: its name, default and type.

    ``kind`` is bool, int, float, str or tuple; ``items`` the item types of a tuple (``None`` with ``variadic``: any
    length); ``optional``: ``None`` is a value (``--set name=none``).
    """

    name: str
    default: object
    kind: type | None
    items: tuple = ()
    variadic: bool = False
    optional: bool = False

    @property
    def type_text(self) -> str:
        """The parameter's type as ``warpfree run --list`` prints it (``float``, ``tuple[float, ...]``, ``untyped``)."""
        if self.kind is None:
            text = "untyped"
        elif self.kind is tuple:
            inner = ", ".join(t.__name__ for t in self.items) + (", ..." if self.variadic else "")
            text = f"tuple[{inner}]"
        else:
            text = self.kind.__name__
        return text + (" | None" if self.optional else "")

    def parse(self, text: str):
        """The value ``text`` (from ``--set``) stands for, of this parameter's type; else ParameterError naming it."""
        text = text.strip()
        if self.optional and text.lower() == NONE_WORD:
            return None
        if self.kind is None:
            raise ParameterError(self.name, "has no type the command line can read (the scene's build() gives it no "
                                            "annotation and a default of None); set it from Python")
        if self.kind is tuple:
            parts = [p for p in text.strip("()[] ").replace(",", " ").split() if p]
            if not self.variadic and len(parts) != len(self.items):
                raise ParameterError(self.name, f"must be {len(self.items)} values ({self.type_text}), got {text!r}")
            kinds = [self.items[0]] * len(parts) if self.variadic else list(self.items)
            return tuple(_parse_scalar(self.name, p, k, self.type_text) for p, k in zip(parts, kinds))
        return _parse_scalar(self.name, text, self.kind, self.type_text)


def _parse_scalar(name: str, text: str, kind: type, type_text: str):
    low = text.lower()
    if kind is bool:
        if low in TRUE_WORDS:
            return True
        if low in FALSE_WORDS:
            return False
        raise ParameterError(name, f"must be true or false (or {'/'.join(TRUE_WORDS[1:])}, "
                                   f"{'/'.join(FALSE_WORDS[1:])}), got {text!r}")
    if kind is str:
        return text
    try:
        number = float(text)
    except ValueError:
        raise ParameterError(name, f"must be {_article(type_text)}, got {text!r}") from None
    if not math.isfinite(number):
        raise ParameterError(name, f"must be a finite number, got {text!r}")
    if kind is int:
        try:
            return int(text)
        except ValueError:  # 1e6: an integer written with an exponent
            if number.is_integer() and abs(number) < 2 ** 53:
                return int(number)
            raise ParameterError(name, f"must be an integer, got {text!r}") from None
    return number


def _article(type_text: str) -> str:
    return ("an " if type_text[0] in "aeiou" else "a ") + type_text


def _typed(name: str, annotation, default) -> SceneParameter:
    """The parameter's type from its annotation, else from its default."""
    optional = False
    if annotation is not inspect.Parameter.empty:
        members = typing.get_args(annotation) if _is_union(annotation) else (annotation,)
        optional = type(None) in members
        members = tuple(m for m in members if m is not type(None))
        annotation = members[0] if len(members) == 1 else inspect.Parameter.empty
    if annotation is inspect.Parameter.empty:
        if default is None:
            return SceneParameter(name, default, None, optional=True)
        annotation = type(default)
    origin = typing.get_origin(annotation) or annotation
    if origin is tuple or origin is list:
        args = typing.get_args(annotation)
        if args and args[-1] is Ellipsis:
            return SceneParameter(name, default, tuple, (args[0],), variadic=True, optional=optional)
        if not args:  # a bare tuple: its items typed like the default's
            if not isinstance(default, (tuple, list)) or not default:
                return SceneParameter(name, default, tuple, (float,), variadic=True, optional=optional)
            args = tuple(bool if isinstance(v, bool) else int if isinstance(v, int) else
                         float if isinstance(v, float) else str for v in default)
        return SceneParameter(name, default, tuple, tuple(args), optional=optional)
    if origin in (bool, int, float, str):
        return SceneParameter(name, default, origin, optional=optional)
    return SceneParameter(name, default, None, optional=optional)


def _is_union(annotation) -> bool:
    return typing.get_origin(annotation) is typing.Union or isinstance(annotation, types.UnionType)


def scene_parameters(module) -> dict[str, SceneParameter]:
    """Name -> :class:`SceneParameter` of every defaulted parameter of the scene's ``build()``."""
    hints = typing.get_type_hints(module.build)
    out = {}
    for name, p in inspect.signature(module.build).parameters.items():
        if p.default is inspect.Parameter.empty:
            continue
        out[name] = _typed(name, hints.get(name, inspect.Parameter.empty), p.default)
    return out


def value_text(value) -> str:
    """A value as ``--set`` reads it back (:meth:`SceneParameter.parse`): ``true``, ``8.0,16.0``, ``none``."""
    if value is None:
        return NONE_WORD
    if isinstance(value, bool):
        return TRUE_WORDS[0] if value else FALSE_WORDS[0]
    if isinstance(value, (tuple, list)):
        return ",".join(value_text(v) for v in value)
    return repr(value) if isinstance(value, float) else str(value)


def parse_overrides(pairs: list[str], parameters: dict[str, SceneParameter]) -> dict:
    """``name=value`` strings -> typed values; an unknown name is refused with the closest names."""
    out = {}
    for pair in pairs:
        if "=" not in pair:
            raise ParameterError("--set", f"expected name=value, got {pair!r}")
        name, text = pair.split("=", 1)
        name = name.strip()
        if name not in parameters:
            raise ParameterError(name, f"is not a parameter of this scene: {closest_names(name, parameters)}")
        out[name] = parameters[name].parse(text)
    return out
