"""Every parameter of every shipped scene is declared once, in its build() signature, with its type, unit, meaning
and allowed values; closed choices are enumerations; a bad value is refused by name, in one line, before any set-up
(from the command line, exit 2 in under 2 s; from Python, before build() runs); ``--list`` shows the declarations."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from typing import Annotated

import pytest

from warpfree.cli import main
from warpfree.errors import ParameterError
from warpfree.parameters import Choice, Interval, Param, checked_parameters, listing, parse_overrides
from warpfree.scene_loader import load_scene, scene_parameters, shipped_scenes

SCENES = shipped_scenes()


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_parameter_is_declared_with_unit_meaning_and_allowed_values(scene):
    """A meaning for each; an interval for each number (or each number of a tuple); no free text but a file's path
    (a closed choice is a Choice); and each default inside its own declaration."""
    parameters = scene_parameters(load_scene(SCENES[scene]))
    undeclared = [name for name, p in parameters.items() if p.param is None or not p.param.meaning]
    assert not undeclared, undeclared
    numbers = [name for name, p in parameters.items()
               if (p.kind in (int, float) or (p.kind is tuple and set(p.items) <= {int, float}))
               and p.param.interval is None]
    assert not numbers, f"numbers without an allowed interval: {numbers}"
    text = [name for name, p in parameters.items() if p.kind is str and not (p.default and os.path.isfile(p.default))]
    assert not text, f"free-text parameters (a closed choice must be a Choice): {text}"
    for name, p in parameters.items():
        assert p.check(p.default) == p.default, name


CHOICES = sorted((scene, name) for scene, path in SCENES.items()
                 for name, p in scene_parameters(load_scene(path)).items() if p.choice is not None)


def test_the_scenes_have_closed_choices():
    assert len(CHOICES) >= 30 and {"kernel", "frame_field", "method", "scheme", "field_solve"} <= \
        {name for _, name in CHOICES}


@pytest.mark.parametrize("scene,name", CHOICES, ids=[f"{s}-{n}" for s, n in CHOICES])
def test_a_bad_choice_is_refused_by_name_before_anything_is_built(scene, name, tmp_path, capsys):
    """From the command line: one line naming the parameter and its choices, exit 2, nothing written; from Python:
    ParameterError from build() before its body runs (no scene here builds in under a tenth of a second)."""
    module = load_scene(SCENES[scene])
    choice = scene_parameters(module)[name].choice
    out = tmp_path / "run"
    assert main(["run", SCENES[scene], "--set", f"{name}=bogus", "--out", str(out), "--no-progress"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"warpfree: error: {name}: 'bogus' is not a choice: ")
    assert line.endswith(f"choose from {', '.join(sorted(choice.texts()))}")
    assert not out.exists() or not any(out.iterdir())
    started = time.perf_counter()
    with pytest.raises(ParameterError) as err:
        module.build(**{name: "bogus"})
    assert err.value.name == name and time.perf_counter() - started < 0.1
    for member in choice:  # each choice's text reads back as its member
        assert parse_overrides([f"{name}={member.value}"], scene_parameters(module))[name] is member


@pytest.mark.parametrize("scene", sorted({s for s, _ in CHOICES}))
def test_a_bad_choice_is_refused_in_a_fresh_process_in_under_two_seconds(scene, tmp_path):
    """The whole command, from a new interpreter: the scene is loaded (Warp and the solver's modules imported) and
    the value refused, nothing set up."""
    name = next(n for s, n in CHOICES if s == scene)
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "warpfree", "run", scene, "--set", f"{name}=bogus",
                           "--out", str(tmp_path / "run")], capture_output=True, text=True, timeout=60)
    seconds = time.perf_counter() - started
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert done.stderr.startswith(f"warpfree: error: {name}: 'bogus' is not a choice")
    assert seconds < 2.0, seconds


def test_a_number_outside_its_interval_is_refused_by_name_with_the_interval(capsys, tmp_path):
    assert main(["run", "dam_break_2d", "--set", "wall_safety=1", "--out", str(tmp_path / "a")]) == 2
    assert capsys.readouterr().err.strip() == "warpfree: error: wall_safety: must be >= 0 and < 1, got 1.0"
    module = load_scene("dam_break_2d")
    with pytest.raises(ParameterError, match=r"^cfl: must be > 0 and <= 1, got 1.5$"):
        module.build(cfl=1.5)
    with pytest.raises(ParameterError, match=r"^dx: must be > 0, got -0.1$"):
        module.build(dx=-0.1)


def test_a_name_set_twice_is_refused(capsys, tmp_path):
    assert main(["run", "dam_break_2d", "--set", "dx=0.1", "--set", "dx=0.2", "--out", str(tmp_path / "a")]) == 2
    assert capsys.readouterr().err.strip() == "warpfree: error: dx: is set twice (--set dx=...); give it once"


def test_list_shows_every_parameter_with_its_type_default_unit_allowed_values_and_meaning(capsys):
    assert main(["run", "dam_break_2d", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "dx: float = 0.025 m; > 0" in lines
    assert "kernel: choice = wendland_c2; one of cubic_spline, wendland_c2, quintic_spline" in lines
    assert "    smoothing kernel W(r, h)" in lines
    assert "dt: float | None = none; > 0, or none [s]" in lines
    assert len(lines) == 2 * len(scene_parameters(load_scene("dam_break_2d")))


#: every closed choice of the engine with the texts that run.json and summary.json record, in declaration order
ENGINE_CHOICES = {
    "warpfree.smoothing:SmoothingKernel": ["cubic_spline", "wendland_c2", "quintic_spline"],
    "warpfree.solver:StepKind": ["variable", "constant", "fixed"],
    "warpfree.geometry:Side": ["outside", "inside"],
    "warpfree.parallel.decomposition:CutMethod": ["slabs", "rcb"],
    "warpfree.parallel.petsc_system:Preconditioner": ["auto", "superlu", "gamg"],
    "warpfree.distribution:Distribution": ["blocks", "alternating", "random", "neighbours"],
    "warpfree.galerkin.mls:MLSBasis": ["linear", "quadratic"],
    "warpfree.galerkin.mls:MLSWeight": ["cubic_spline", "quartic", "gaussian", "singular"],
    "warpfree.galerkin.mls:SupportShape": ["circular", "rectangular"],
    "warpfree.galerkin.node_layouts:NodePlacement": ["regular", "random"],
    "warpfree.galerkin.shapes:ShapeFunctions": ["efg", "nem"],
    "warpfree.solvers.wcsph.model:BoundaryModel": ["dynamic", "lennard_jones"],
    "warpfree.solvers.wcsph.solver:FluidField": ["speed", "pressure", "density", "velocity_x", "velocity_y",
                                                 "velocity_z"],
    "warpfree.solvers.spem.model:Scheme": ["fpm", "cspm", "sph"],
    "warpfree.solvers.spem.model:PMLSide": ["x-", "x+", "y-", "y+"],
    "warpfree.solvers.spem.layouts:HStaggering": ["edges", "centres"],
    "warpfree.solvers.spem.solver:SourceKind": ["hard", "soft"],
    "warpfree.solvers.efg.boundary:EssentialMethod": ["lagrange", "penalty", "direct"],
    "warpfree.solvers.efg.boundary:InterfaceCondition": ["nitsche", "none"],
    "warpfree.solvers.efg.solver:Integration": ["consistent", "gauss", "scni"],
    "warpfree.solvers.efg.solver:LinearSolver": ["auto", "superlu", "petsc"],
    "warpfree.solvers.efg.solver:Plane": ["stress", "strain"],
    "warpfree.solvers.pic.coupling:Gather": ["momentum", "energy"],
    "warpfree.solvers.pic.device_solve:FieldSolve": ["host", "device", "cg", "dense"],
    "warpfree.solvers.pic.injection:SourceWall": ["lower", "upper"],
    "warpfree.solvers.pic.solver:ParticleWall": ["reflect", "absorb"],
}


@pytest.mark.parametrize("where,texts", sorted(ENGINE_CHOICES.items()))
def test_the_engine_choices_keep_the_texts_runs_record(where, texts):
    """run.json and summary.json record a closed choice by its text, and a resume or a comparison reads it back: each
    enumeration keeps those texts and reads its members back from them (in any case); an unknown text is refused
    naming the parameter, with the choices."""
    import importlib

    module, name = where.split(":")
    choice = getattr(importlib.import_module(module), name)
    assert issubclass(choice, Choice) and choice.texts() == texts
    assert all(choice.of("x", text.upper()) is member for text, member in zip(texts, choice))
    with pytest.raises(ParameterError) as err:
        choice.of("x", "nope")
    assert str(err.value).startswith("x: 'nope' is not a choice: ")
    assert str(err.value).endswith("choose from " + ", ".join(sorted(texts)))


class Colour(Choice):
    """A test choice."""

    RED = "red", "the colour of blood"
    GREEN = "green"


def test_a_choice_reads_its_members_from_their_text_and_compares_as_text():
    assert Colour.of("c", "red") is Colour.RED and Colour.of("c", " Green ") is Colour.GREEN
    assert Colour.of("c", Colour.RED) is Colour.RED and Colour.RED == "red" and f"{Colour.RED}" == "red"
    assert Colour.RED.meaning == "the colour of blood" and Colour.texts() == ["red", "green"]
    with pytest.raises(ParameterError, match=r"^c: 'gren' is not a choice: did you mean green\? choose from green, "
                                             r"red$"):
        Colour.of("c", "gren")
    with pytest.raises(ParameterError, match="^c: must be one of red, green, got 3$"):
        Colour.of("c", 3)


@pytest.mark.parametrize("text,inside,outside,words", [
    ("(0, inf)", [1e-300, 5.0], [0.0, -1.0], "> 0"), ("[0, inf)", [0.0, 2.0], [-1e-9], ">= 0"),
    ("[1, 10]", [1, 10], [0.5, 10.5], "1 to 10"), ("(0, 1]", [1.0, 0.5], [0.0, 1.1], "> 0 and <= 1"),
    ("(-inf, inf)", [-1e300, 0.0], [], "any"), ("[0, 1)", [0.0], [1.0], ">= 0 and < 1")])
def test_intervals_hold_what_they_say_and_say_it_in_words(text, inside, outside, words):
    interval = Interval.parse(text)
    assert all(interval.holds(v) for v in inside) and not any(interval.holds(v) for v in outside)
    assert interval.text == words


def test_a_malformed_declaration_fails_where_it_is_written():
    for bad in ("0, 1", "(1, 0)", "[a, 1]"):
        with pytest.raises(ValueError):
            Param("m", "a length", bad)


def test_a_scene_of_ones_own_is_checked_from_python_and_listed():
    @checked_parameters
    def build(n: Annotated[int, Param("", "points", "[2, inf)")] = 4,
              colour: Annotated[Colour, Param("", "what to paint")] = Colour.RED,
              box: Annotated[tuple[float, float], Param("m", "sides", "(0, inf)")] = (1.0, 2.0),
              scale: Annotated[float | None, Param("m", "a length (none: automatic)", "(0, inf)")] = None):
        return n, colour, box, scale

    assert build(n=3, colour="green", box=[1, 2]) == (3, Colour.GREEN, (1.0, 2.0), None)
    for kwargs, name in (({"n": 1}, "n"), ({"n": 2.5}, "n"), ({"colour": "blue"}, "colour"), ({"box": (1.0, 0.0)},
                         "box"), ({"box": (1.0,)}, "box"), ({"scale": -1.0}, "scale"), ({"size": 1}, "size")):
        with pytest.raises(ParameterError) as err:
            build(**kwargs)
        assert err.value.name == name, kwargs
    from types import SimpleNamespace

    lines = listing(scene_parameters(SimpleNamespace(build=build)))
    assert lines == ["n: int = 4; >= 2", "    points", "colour: choice = red; one of red, green", "    what to paint",
                     "box: tuple[float, float] = 1.0,2.0 m; > 0 (each)", "    sides",
                     "scale: float | None = none; > 0, or none [m]", "    a length (none: automatic)"]
