"""Inputs that cannot silently go wrong: --set values typed from build()'s signature, unknown names refused with the
closest ones, every error naming the parameter the user set, and the memory guard of every layout builder."""

from __future__ import annotations

import signal
from types import SimpleNamespace

import numpy as np
import pytest

from warpfree import device
from warpfree.cli import main
from warpfree.errors import ParameterError, RunError, parameter_names, reported_as, require_bool, require_integer
from warpfree.scene_loader import load_scene, parse_overrides, scene_parameters, shipped_scenes

SCENES = shipped_scenes()


def run_cli(*args):
    return main(["run", *args, "--no-progress"])


def params_of(build):
    return scene_parameters(SimpleNamespace(build=build))


# -- typed --set values -------------------------------------------------------------------------------------------
def test_bools_are_parsed_never_read_as_truthy_strings():
    def build(flag: bool = True, maybe: bool | None = None):
        return None

    p = params_of(build)
    for text, value in (("false", False), ("FALSE", False), ("0", False), ("no", False), ("true", True), ("1", True),
                        ("yes", True)):
        assert parse_overrides([f"flag={text}"], p) == {"flag": value}
        assert parse_overrides([f"maybe={text}"], p) == {"maybe": value}
    assert parse_overrides(["maybe=none"], p) == {"maybe": None}
    for bad in ("maybe", "on", "2", ""):
        with pytest.raises(ParameterError) as err:
            parse_overrides([f"flag={bad}"], p)
        assert err.value.name == "flag"


def test_numbers_tuples_and_none_are_typed_from_the_annotation():
    def build(n: int = 4, x: float = 1.0, box: tuple = (1.0, 2.0), pair: tuple[int, int] = (1, 2),
              mode: str | None = None, limit: float | None = None):
        return None

    p = params_of(build)
    assert parse_overrides(["n=12", "x=2", "box=3,4", "pair=(5, 6)", "mode=fast", "limit=none"], p) == \
        {"n": 12, "x": 2.0, "box": (3.0, 4.0), "pair": (5, 6), "mode": "fast", "limit": None}
    assert parse_overrides(["n=1e6", "limit=0.5"], p) == {"n": 1_000_000, "limit": 0.5}
    assert isinstance(parse_overrides(["n=1e6"], p)["n"], int)
    for pair, name in (("n=1.5", "n"), ("n=abc", "n"), ("x=nan", "x"), ("x=inf", "x"), ("box=1", "box"),
                       ("pair=1.5,2", "pair"), ("limit=abc", "limit")):
        with pytest.raises(ParameterError) as err:
            parse_overrides([pair], p)
        assert err.value.name == name, pair


def test_an_unknown_name_is_refused_with_the_closest_names(capsys, tmp_path):
    scene = SCENES["dam_break_2d"]
    assert run_cli(scene, "--set", "dxx=0.1", "--out", str(tmp_path / "run")) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpfree: error: dxx: is not a parameter of this scene: did you mean dx")


def test_conservative_false_from_the_command_line_runs_the_plain_scheme(tmp_path, capsys):
    """``--set conservative=false`` once reached the model as the string "false" (true in Python) and ran the
    conservative scheme; ``maybe`` was accepted the same way."""
    module = load_scene(SCENES["em_cavity_2d"])
    assert parse_overrides(["conservative=false"], scene_parameters(module)) == {"conservative": False}
    device.use("cpu", 1)
    small = dict(cells_per_radius=8, t_end=1e-10, frames=False, vtk=False)
    assert module.build(conservative=False, **small).solver.model.conservative is False
    assert module.build(conservative=None, **small).solver.model.conservative is True  # on for FPM
    with pytest.raises(ParameterError) as err:
        module.build(conservative="false", **small)  # a string from Python is refused, not read as truthy
    assert err.value.name == "conservative"
    assert run_cli(SCENES["em_cavity_2d"], "--set", "conservative=maybe", "--out", str(tmp_path / "run")) == 2
    assert capsys.readouterr().err.startswith("warpfree: error: conservative: must be true or false")


def test_the_checks_refuse_what_they_would_otherwise_reinterpret():
    for value in (True, 2.0, "3", None):
        with pytest.raises(ParameterError):
            require_integer("n", value)
    assert require_integer("n", np.int64(3), minimum=1) == 3
    with pytest.raises(ParameterError, match="from 1 to 6"):
        require_integer("order", 7, minimum=1, maximum=6)
    for value in ("false", 0, 1, None):
        with pytest.raises(ParameterError):
            require_bool("flag", value)


def test_reported_as_names_the_scene_parameter():
    with pytest.raises(ParameterError) as err:
        with reported_as(length_x="box"):
            raise ParameterError("length_x", "must be > 0, got 0.0")
    assert err.value.name == "box" and str(err.value) == "box: length_x must be > 0, got 0.0"
    with pytest.raises(ParameterError) as err:
        with reported_as(layers="wall_layers"):
            raise ParameterError("dx, layers", "gives 1e13 boundary particles")
    assert parameter_names(err.value.name) == ["dx", "wall_layers"]
    with pytest.raises(ParameterError) as err:
        with reported_as(layers="wall_layers"):
            raise ParameterError("kernel", "unknown")
    assert err.value.name == "kernel"  # an error about another name passes through


# -- every error names the parameter the user set -----------------------------------------------------------------
@pytest.mark.parametrize("scene,setting,name", [
    ("pic_thermal_plasma", {"box": (0.0, 16.0)}, "box"),
    ("pic_thermal_plasma", {"box": (8.0, -16.0)}, "box"),
    ("pic_thermal_plasma", {"mass_ratio": -1.0}, "mass_ratio"),
    ("pic_thermal_plasma", {"ion_temperature": -1.0}, "ion_temperature"),
    ("pic_thermal_plasma", {"seed": -1}, "seed"),
    ("efg_timoshenko", {"cells_x": 1, "cells_y": 12}, "cells_x"),
    ("pic_diode", {"width": 0.02}, "width"),
    ("pic_diode", {"dt": 0.0}, "dt"),
    ("dam_break_2d", {"wall_safety": -1.0}, "wall_safety"),
    ("dam_break_3d", {"tank_mesh": "nonsense.stl"}, "tank_mesh"),
    ("em_waveguide_2d", {"pml_order": 0}, "pml_order"),
    ("em_waveguide_2d", {"pml_thickness": -1.0}, "pml_thickness"),
    ("em_line_1d", {"output_interval": 0.0}, "output_interval"),
] + [(s, {"output_every": 0}, "output_every") for s in ("pic_diode", "pic_plasma_oscillation", "pic_thermal_plasma",
                                                         "pic_two_stream")])
def test_a_bad_value_is_blamed_on_the_parameter_set(scene, setting, name):
    """Once blamed on internal names (length_y, nodes or support, node_spacing, lj_r0, pml.order, ...) or, for
    output_every = 0, silently run as "every step"."""
    device.use("cpu", 1)
    module = load_scene(SCENES[scene])
    with pytest.raises(ParameterError) as err:
        run = module.build(**{**module.SMALLEST, "frames": False, "vtk": False, **setting})
        run.run(None, progress=False)  # a static solve meets its MLS supports when it evaluates shape functions
    assert name in parameter_names(err.value.name), str(err.value)


class _Slow(Exception):
    pass


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_numeric_parameter_at_zero_negative_or_huge_is_run_or_refused_by_its_name(scene):
    """Every parameter of every shipped scene at 0 and -1 (integers also at 10^12: the memory guard), from its
    smallest run: the build either succeeds, stops as a run that went wrong (RunError), or refuses the value with an
    error naming that parameter; never a traceback of another kind, never another parameter's name."""
    device.use("cpu", 1)
    module = load_scene(SCENES[scene])
    parameters = scene_parameters(module)
    base = {**module.SMALLEST, **{k: False for k in ("frames", "vtk") if k in parameters}}
    previous = signal.signal(signal.SIGALRM, lambda *a: (_ for _ in ()).throw(_Slow()))
    try:
        for name, p in parameters.items():
            values = {float: [0.0, -1.0], int: [0, -1, 10 ** 12],
                      tuple: [tuple(0 * t(1) for t in p.items), tuple(-1 * t(1) for t in p.items)]}.get(p.kind, [])
            for value in values:
                signal.alarm(30)  # an accepted value runs the build (a relaxed, settled tank takes seconds)
                try:
                    module.build(**{**base, name: value})
                except ParameterError as err:
                    assert name in parameter_names(err.name), f"{name}={value!r}: {err}"
                except (RunError, _Slow):
                    pass
                finally:
                    signal.alarm(0)
    finally:
        signal.signal(signal.SIGALRM, previous)


# -- the memory guard ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("scene,setting,name", [
    ("em_line_1d", ["particles_per_wavelength=1e9"], "particles_per_wavelength"),
    ("em_cavity_2d", ["cells_per_radius=1000000"], "cells_per_radius"),
    ("pic_thermal_plasma", ["particles_per_node=1e7"], "particles_per_node"),
    ("pic_diode", ["node_spacing=1e-5"], "node_spacing"),
    ("efg_timoshenko", ["cells_x=40000", "cells_y=10000"], "cells_x"),   # 400 M nodes
    ("efg_timoshenko", ["gauss=100000"], "gauss"),
    ("dam_break_2d", ["dx=1e-6"], "dx"),
    ("poiseuille_2d", ["wall_layers=1000000000"], "wall_layers"),
])
def test_the_memory_guard_refuses_before_allocating(scene, setting, name, tmp_path, capsys):
    """Once tracebacks while allocating 141 GiB (EM) or 1.19 TiB (PIC), or an EFG beam climbing past 15 GB."""
    out = tmp_path / "run"
    assert run_cli(SCENES[scene], *[a for s in setting for a in ("--set", s)], "--out", str(out)) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpfree: error: ") and name in err.split(": ")[2] and "available" in err
    assert "which need" in err and not any(p.name != "run.json" for p in out.glob("*"))
