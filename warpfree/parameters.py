"""Scene parameters, declared once: type, default, unit, meaning and allowed values, in ``build()``'s signature.

A scene declares each parameter where it names it::

    @checked_parameters
    def build(dx: Annotated[float, Param("m", "particle spacing", "(0, inf)")] = 0.025,
              kernel: Annotated[SmoothingKernel, Param("", "smoothing kernel W(r, h)")] = SmoothingKernel.WENDLAND_C2,
              frames: Frames = True) -> TimeLoop:

- the annotation's type says how a ``--set`` value is read (``bool``, ``int``, ``float``, ``str``, ``tuple[...]``, a
  :class:`Choice`, any of them ``| None``), else the default's type does;
- :class:`Param` gives its unit (``""`` for a pure number, a flag or a choice), what it means, and for numbers the
  interval it must lie in (for a tuple: each item);
- a closed choice is a :class:`Choice` (an enumeration whose members are their own names as text), so that the
  command line, ``--list``, the docs and the code share one list of allowed values, and the code compares members,
  never strings.

The command line reads and checks every ``--set`` value against its declaration before anything is built
(:func:`parse_overrides`); :func:`checked_parameters` does the same for a scene built from Python, so a bad value is
refused, naming it, before any set-up. ``warpfree run SCENE --list`` prints the declarations (:func:`listing`).
"""

from __future__ import annotations

import enum
import functools
import inspect
import math
import numbers
import re
import types
import typing
from dataclasses import dataclass
from typing import Annotated

from .errors import ParameterError, closest_names

__all__ = ["Choice", "Param", "Interval", "SceneParameter", "checked_parameters", "scene_parameters",
           "parse_overrides", "value_text", "listing", "Frames", "Vtk", "CheckpointEvery", "Seed"]

TRUE_WORDS = ("true", "1", "yes")
FALSE_WORDS = ("false", "0", "no")
NONE_WORD = "none"


# -- closed choices ------------------------------------------------------------------------------------------------
class Choice(str, enum.Enum):
    """A closed choice: each member is its name as text (``SmoothingKernel.WENDLAND_C2 == "wendland_c2"``, and it is
    written so in ``summary.json`` and ``run.json``) with a short meaning (``member.meaning``)::

        class SmoothingKernel(Choice):
            \"\"\"The SPH smoothing kernel W(r, h).\"\"\"
            WENDLAND_C2 = "wendland_c2", "Wendland C2, support 2h"

    Code compares members (``kernel is SmoothingKernel.WENDLAND_C2``); :meth:`of` reads one from its text."""

    def __new__(cls, value: str, meaning: str = ""):
        member = str.__new__(cls, value)
        member._value_ = value
        member.meaning = meaning
        return member

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    @classmethod
    def of(cls, name: str, value):
        """The member ``value`` stands for (a member, or its text in any case); else ParameterError naming ``name``
        with the closest choices."""
        if isinstance(value, cls):
            return value
        if isinstance(value, str):
            text = value.strip().lower()
            for member in cls:
                if member.value == text:
                    return member
            raise ParameterError(name, f"{value!r} is not a choice: {closest_names(text, cls.texts())}")
        raise ParameterError(name, f"must be one of {', '.join(cls.texts())}, got {value!r}")

    @classmethod
    def texts(cls) -> list[str]:
        """The members' names as text, in declaration order."""
        return [m.value for m in cls]


# -- declarations ----------------------------------------------------------------------------------------------------
_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,]+?)\s*,\s*([^,]+?)\s*([\])])\s*$")


@dataclass(frozen=True)
class Interval:
    """The numbers a parameter may take: ``low``/``high`` (±inf for none) and whether each end is included."""

    low: float
    high: float
    low_closed: bool
    high_closed: bool

    @classmethod
    def parse(cls, text: str) -> "Interval":
        """``"(0, inf)"``, ``"[0, 1]"``, ``"[1, inf)"``, ``"(-inf, inf)"``: mathematical interval notation."""
        match = _INTERVAL.match(text)
        if not match:
            raise ValueError(f"an interval is written like (0, inf) or [0, 1], got {text!r}")
        low, high = float(match.group(2)), float(match.group(3))
        if not low <= high or math.isnan(low) or math.isnan(high):
            raise ValueError(f"an interval's low end must not exceed its high end, got {text!r}")
        return cls(low, high, match.group(1) == "[" and math.isfinite(low), match.group(4) == "]" and
                   math.isfinite(high))

    def holds(self, value: float) -> bool:
        above = value >= self.low if self.low_closed else value > self.low
        below = value <= self.high if self.high_closed else value < self.high
        return above and below

    @property
    def text(self) -> str:
        """In words a reader takes in at once: ``> 0``, ``>= 1``, ``0 to 1``, ``> 0 and <= 1``, ``any``."""
        low = f"{'>=' if self.low_closed else '>'} {_number(self.low)}" if math.isfinite(self.low) else ""
        high = f"{'<=' if self.high_closed else '<'} {_number(self.high)}" if math.isfinite(self.high) else ""
        if low and high:
            if self.low_closed and self.high_closed:
                return f"{_number(self.low)} to {_number(self.high)}"
            return f"{low} and {high}"
        return low or high or "any"


def _number(x: float) -> str:
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


@dataclass(frozen=True)
class Param:
    """What a parameter is: its ``unit`` (SI, or the scene's normalised unit; ``""`` for a pure number, a flag, a
    choice or a name), its ``meaning`` (a short phrase) and, for a number or a tuple of numbers, the ``allowed``
    interval (``"(0, inf)"``; see :class:`Interval`)."""

    unit: str
    meaning: str
    allowed: str | None = None

    def __post_init__(self):
        if self.allowed is not None:
            Interval.parse(self.allowed)  # a malformed declaration fails where it is written

    @property
    def interval(self) -> Interval | None:
        return Interval.parse(self.allowed) if self.allowed is not None else None


#: parameters many scenes share, declared once
Frames = Annotated[bool, Param("", "write PNG frames of the run")]
Vtk = Annotated[bool, Param("", "write VTU snapshots with a PVD index (ParaView)")]
CheckpointEvery = Annotated[int, Param("", "write a checkpoint every this many steps (0: none)", "[0, inf)")]
Seed = Annotated[int, Param("", "seed of the random number generator", "[0, inf)")]


@dataclass(frozen=True)
class SceneParameter:
    """One parameter of a scene's ``build()``: its name, default, type and declaration.

    ``kind`` is bool, int, float, str, tuple or a :class:`Choice` (None: untyped); ``items`` the item types of a tuple
    (with ``variadic``: any length); ``optional``: ``None`` is a value (``--set name=none``); ``param``: its
    :class:`Param` (None where the scene declares none).
    """

    name: str
    default: object
    kind: type | None
    items: tuple = ()
    variadic: bool = False
    optional: bool = False
    param: Param | None = None

    @property
    def choice(self) -> type[Choice] | None:
        """The :class:`Choice` a closed-choice parameter takes its value from (None for any other)."""
        return self.kind if isinstance(self.kind, type) and issubclass(self.kind, Choice) else None

    @property
    def type_text(self) -> str:
        """The parameter's type as ``--list`` prints it (``float``, ``tuple[float, ...]``, ``choice``, ``untyped``)."""
        if self.kind is None:
            text = "untyped"
        elif self.choice is not None:
            text = "choice"
        elif self.kind is tuple:
            inner = ", ".join(t.__name__ for t in self.items) + (", ..." if self.variadic else "")
            text = f"tuple[{inner}]"
        else:
            text = self.kind.__name__
        return text + (" | None" if self.optional else "")

    @property
    def unit(self) -> str:
        return self.param.unit if self.param else ""

    @property
    def meaning(self) -> str:
        if self.param:
            return self.param.meaning
        if self.choice is not None:
            return (inspect.getdoc(self.choice) or "").split("\n")[0].rstrip(".")
        return ""

    @property
    def allowed_text(self) -> str:
        """The values it may take, in words: ``one of a, b, c``, ``> 0``, ``""`` (any value of its type)."""
        if self.choice is not None:
            text = "one of " + ", ".join(self.choice.texts())
        elif self.param is not None and self.param.interval is not None:
            text = self.param.interval.text + (" (each)" if self.kind is tuple else "")
        else:
            text = ""
        return text + (", or none" if self.optional and text else "none or any" if self.optional else "")

    def parse(self, text: str):
        """The value ``text`` (from ``--set``) stands for, of this parameter's type and in its allowed values; else
        ParameterError naming it."""
        text = text.strip()
        if self.optional and text.lower() == NONE_WORD:
            return None
        if self.kind is None:
            raise ParameterError(self.name, "has no type the command line can read (the scene's build() gives it no "
                                            "annotation and a default of None); set it from Python")
        if self.choice is not None:
            return self.choice.of(self.name, text)
        if self.kind is tuple:
            parts = [p for p in text.strip("()[] ").replace(",", " ").split() if p]
            if not self.variadic and len(parts) != len(self.items):
                raise ParameterError(self.name, f"must be {len(self.items)} values ({self.type_text}), got {text!r}")
            kinds = [self.items[0]] * len(parts) if self.variadic else list(self.items)
            value = tuple(_parse_scalar(self.name, p, k, self.type_text) for p, k in zip(parts, kinds))
        else:
            value = _parse_scalar(self.name, text, self.kind, self.type_text)
        return self._within(value)

    def check(self, value):
        """``value`` given from Python, as this parameter's type (a choice's text becomes its member, a list a tuple)
        and in its allowed values; else ParameterError naming it. Nothing is rounded or clamped."""
        if value is None and self.optional:
            return None
        if self.kind is None:
            return value
        if self.choice is not None:
            return self.choice.of(self.name, value)
        if self.kind is tuple:
            if not isinstance(value, (tuple, list)) or (not self.variadic and len(value) != len(self.items)):
                raise ParameterError(self.name, f"must be {self.type_text}, got {value!r}")
            kinds = [self.items[0]] * len(value) if self.variadic else list(self.items)
            return self._within(tuple(_check_scalar(self.name, v, k, self.type_text) for v, k in zip(value, kinds)))
        return self._within(_check_scalar(self.name, value, self.kind, self.type_text))

    def _within(self, value):
        interval = self.param.interval if self.param is not None else None
        if interval is None:
            return value
        for v in (value if isinstance(value, tuple) else (value,)):
            if isinstance(v, numbers.Real) and not isinstance(v, bool) and not interval.holds(v):
                each = "each value " if isinstance(value, tuple) else ""
                raise ParameterError(self.name, f"{each}must be {interval.text}, got {value!r}")
        return value


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


def _check_scalar(name: str, value, kind: type, type_text: str):
    """A value given from Python as ``kind``: a bool must be a bool, an int an integer, a float any finite real
    number (an int is taken as the same float)."""
    if kind is bool:
        if isinstance(value, bool) or type(value).__name__ == "bool_":
            return bool(value)
        raise ParameterError(name, f"must be true or false, got {value!r}")
    if kind is str:
        if not isinstance(value, str):
            raise ParameterError(name, f"must be text, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(name, f"must be {_article(type_text)}, got {value!r}")
    if not math.isfinite(float(value)):
        raise ParameterError(name, f"must be a finite number, got {value!r}")
    if kind is int:
        if not isinstance(value, numbers.Integral):
            raise ParameterError(name, f"must be an integer, got {value!r}")
        return int(value)
    return float(value)


def _article(type_text: str) -> str:
    return ("an " if type_text[0] in "aeiou" else "a ") + type_text


# -- reading a build() signature -------------------------------------------------------------------------------------
def _typed(name: str, annotation, default) -> SceneParameter:
    """The parameter's type and declaration from its annotation, else its type from its default."""
    param = None
    if typing.get_origin(annotation) is Annotated:
        annotation, *extras = typing.get_args(annotation)
        param = next((e for e in extras if isinstance(e, Param)), None)
    optional = False
    if annotation is not inspect.Parameter.empty:
        members = typing.get_args(annotation) if _is_union(annotation) else (annotation,)
        optional = type(None) in members
        members = tuple(m for m in members if m is not type(None))
        annotation = members[0] if len(members) == 1 else inspect.Parameter.empty
    if annotation is inspect.Parameter.empty:
        if default is None:
            return SceneParameter(name, default, None, optional=True, param=param)
        annotation = type(default)
    origin = typing.get_origin(annotation) or annotation
    if origin is tuple or origin is list:
        args = typing.get_args(annotation)
        if args and args[-1] is Ellipsis:
            return SceneParameter(name, default, tuple, (args[0],), variadic=True, optional=optional, param=param)
        if not args:  # a bare tuple: its items typed like the default's
            if not isinstance(default, (tuple, list)) or not default:
                return SceneParameter(name, default, tuple, (float,), variadic=True, optional=optional, param=param)
            args = tuple(bool if isinstance(v, bool) else int if isinstance(v, int) else
                         float if isinstance(v, float) else str for v in default)
        return SceneParameter(name, default, tuple, tuple(args), optional=optional, param=param)
    if origin in (bool, int, float, str) or (isinstance(origin, type) and issubclass(origin, Choice)):
        return SceneParameter(name, default, origin, optional=optional, param=param)
    return SceneParameter(name, default, None, optional=optional, param=param)


def _is_union(annotation) -> bool:
    return typing.get_origin(annotation) is typing.Union or isinstance(annotation, types.UnionType)


def signature_parameters(function) -> dict[str, SceneParameter]:
    """Name -> :class:`SceneParameter` of every defaulted parameter of ``function`` (a scene's ``build()``)."""
    function = inspect.unwrap(function)
    hints = typing.get_type_hints(function, include_extras=True)
    out = {}
    for name, p in inspect.signature(function).parameters.items():
        if p.default is inspect.Parameter.empty:
            continue
        out[name] = _typed(name, hints.get(name, inspect.Parameter.empty), p.default)
    return out


def scene_parameters(module) -> dict[str, SceneParameter]:
    """Name -> :class:`SceneParameter` of every defaulted parameter of a scene module's ``build()``."""
    return signature_parameters(module.build)


def checked_parameters(build):
    """Decorate a scene's ``build()``: every value it is called with is checked against its declaration (type,
    choice, interval) and converted (a choice's text to its member) before the body runs, so that a scene built from
    Python refuses a bad value, naming it, before any set-up, as the command line does."""
    signature = inspect.signature(build)

    @functools.wraps(build)
    def checked(*args, **kwargs):
        parameters = signature_parameters(build)
        unknown = [k for k in kwargs if k not in signature.parameters]
        if unknown:
            raise ParameterError(unknown[0], f"is not a parameter of this scene: "
                                             f"{closest_names(unknown[0], parameters)}")
        try:
            bound = signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise ParameterError("build", str(exc)) from None
        for name, value in bound.arguments.items():
            if name in parameters:
                bound.arguments[name] = parameters[name].check(value)
        return build(*bound.args, **bound.kwargs)

    return checked


# -- the command line's side -----------------------------------------------------------------------------------------
def value_text(value) -> str:
    """A value as ``--set`` reads it back (:meth:`SceneParameter.parse`): ``true``, ``8.0,16.0``, ``none``,
    ``wendland_c2``."""
    if value is None:
        return NONE_WORD
    if isinstance(value, bool):
        return TRUE_WORDS[0] if value else FALSE_WORDS[0]
    if isinstance(value, Choice):
        return value.value
    if isinstance(value, (tuple, list)):
        return ",".join(value_text(v) for v in value)
    return repr(value) if isinstance(value, float) else str(value)


def parse_overrides(pairs: list[str], parameters: dict[str, SceneParameter]) -> dict:
    """``name=value`` strings -> typed, checked values; an unknown name is refused with the closest names, and a name
    given twice is refused (the second would silently win)."""
    out = {}
    for pair in pairs:
        if "=" not in pair:
            raise ParameterError("--set", f"expected name=value, got {pair!r}")
        name, text = pair.split("=", 1)
        name = name.strip()
        if name not in parameters:
            raise ParameterError(name, f"is not a parameter of this scene: {closest_names(name, parameters)}")
        if name in out:
            raise ParameterError(name, f"is set twice (--set {name}=...); give it once")
        out[name] = parameters[name].parse(text)
    return out


def listing(parameters: dict[str, SceneParameter]) -> list[str]:
    """The lines of ``warpfree run SCENE --list``, two a parameter: ``name: type = default unit, allowed values``, then
    its meaning, indented."""
    lines = []
    for p in parameters.values():
        default = value_text(p.default) + (f" {p.unit}" if p.unit and p.default is not None else "")
        lines.append(f"{p.name}: {p.type_text} = {default}" + (f"; {p.allowed_text}" if p.allowed_text else "")
                     + (f" [{p.unit}]" if p.unit and p.default is None else ""))
        if p.meaning:
            lines.append(f"    {p.meaning}")
    return lines
