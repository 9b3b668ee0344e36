"""The benchmarks find every method family by themselves (no benchmark is run): the scenes that bench/core/gpu_check.py
times, the n and 2n runs of bench/core/scaling.py and the hot kernels bench/core/register_report.py holds to its
register budget come from what the scenes and kernel modules declare (``BENCHMARK``, ``KERNEL_VARIANTS``,
``HOT_KERNELS``), so a family a declaration forgets fails here instead of being left out of a benchmark."""

from __future__ import annotations

import ast
import contextlib
import importlib
import importlib.util
import pkgutil
import sys

import pytest

from helpers import ROOT

import warpfree.solvers
from warpfree.scene_loader import shipped_scenes
from warpfree.solver import Solver

BENCH = ROOT / "bench"


@contextlib.contextmanager
def _bench_on_path():
    saved = list(sys.path)
    sys.path[:0] = [str(BENCH), str(BENCH / "core")]
    try:
        yield
    finally:
        sys.path[:] = saved


def _load(path):
    spec = importlib.util.spec_from_file_location(f"bench_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    with _bench_on_path():
        spec.loader.exec_module(module)
    return module


common = _load(BENCH / "common.py")
gpu_check = _load(BENCH / "core" / "gpu_check.py")
scaling = _load(BENCH / "core" / "scaling.py")
register_report = _load(BENCH / "core" / "register_report.py")


def _solver_classes() -> list[type]:
    """Every solver class the wings under warpfree/solvers/ define (each of their modules imported)."""
    for info in pkgutil.walk_packages(warpfree.solvers.__path__, "warpfree.solvers."):
        importlib.import_module(info.name)

    def below(cls):
        for sub in cls.__subclasses__():
            yield sub
            yield from below(sub)

    return [c for c in below(Solver) if c.__module__.startswith("warpfree.solvers.")]


SOLVERS = _solver_classes()
#: family -> whether its solvers split their work over ranks
DISTRIBUTES = {}
for _cls in SOLVERS:
    _family = _cls.__module__.split(".")[2]
    DISTRIBUTES[_family] = DISTRIBUTES.get(_family, False) or _cls.distributes
#: the families that have a shipped scene
WITH_SCENES = {common.scene_family(path) for path in common.scene_files().values()}


def build_parameters(scene: str) -> set[str]:
    """The parameters a scene's ``build()`` declares (read from its source)."""
    tree = ast.parse(common.scene_files()[scene].read_text(encoding="utf-8"))
    build = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "build")
    return {a.arg for a in build.args.args + build.args.kwonlyargs}


def test_the_families_read_from_the_source_are_the_wings_with_a_solver():
    assert set(common.solver_families()) == set(DISTRIBUTES)
    assert {"wcsph", "spem", "efg", "pic", "heat"} <= set(DISTRIBUTES)


def test_the_benchmarks_see_every_shipped_scene():
    assert set(common.scene_files()) == set(shipped_scenes())
    assert set(gpu_check.scene_order(None)) == set(shipped_scenes())
    reference = {"efg_cook": {"wall_s": 9.0}, "em_line_1d": {"wall_s": 1.0}, "machine": {"cpu": "x"}}
    order = gpu_check.scene_order(reference)
    assert order[:2] == ["em_line_1d", "efg_cook"] and set(order) == set(shipped_scenes())


@pytest.mark.parametrize("scene", sorted(shipped_scenes()))
def test_every_scene_runs_one_family(scene):
    assert common.scene_family(common.scene_files()[scene]) in DISTRIBUTES


def test_every_family_with_a_scene_is_timed_by_the_gpu_check():
    assert WITH_SCENES == set(DISTRIBUTES), "a family without a shipped scene"
    assert set(gpu_check.SIZES) == WITH_SCENES, "declare BENCHMARK in one scene of each family"
    for family, (scene, parameter, values, steps) in gpu_check.SIZES.items():
        assert common.scene_family(common.scene_files()[scene]) == family
        assert parameter in build_parameters(scene), (scene, parameter)
        assert len(values) == 3 and isinstance(steps, int) and steps >= 1, scene


def test_the_gpu_check_s_diode_at_scale_sets_parameters_of_its_scene_and_the_parts_share_the_budget():
    """Its settings (and the dry run's) are the cylindrical diode's parameters, the finest last; the parts' shares
    sum to the whole budget."""
    parameters = build_parameters("pic_cylindrical_diode")
    for settings in gpu_check.DIODE_SCALE + gpu_check.DIODE_DRY_RUN:
        assert set(settings) <= parameters, settings
    spacings = [s["cathode_spacing"] for s in gpu_check.DIODE_SCALE]
    assert spacings == sorted(spacings, reverse=True) and spacings[-1] < 0.0125   # finer than the CPU's finest run
    assert sum(gpu_check.SHARES.values()) == pytest.approx(1.0)
    whole = gpu_check.part_budgets(480.0, set())
    assert whole == pytest.approx({part: 480.0 * s for part, s in gpu_check.SHARES.items()})
    alone = gpu_check.part_budgets(480.0, set(gpu_check.SHARES) - {"diode"})
    assert alone == pytest.approx({"diode": 480.0})     # a part run on its own has the whole budget


def test_every_family_that_distributes_is_in_the_scaling_sweep():
    distributed = {family for family, flag in DISTRIBUTES.items() if flag and family in WITH_SCENES}
    for size, cases in scaling.SIZES.items():
        assert set(cases) == distributed, (size, "declare BENCHMARK['scaling'] where the solver distributes")
        for family, (scene, n, two_n) in cases.items():
            assert set(n) == set(two_n) and set(n) <= build_parameters(scene) and n != two_n, (size, scene)
    assert set(scaling.CASES) == distributed


def test_the_kernel_variants_are_settings_of_their_scenes():
    for scene, settings in register_report.EXTRA:
        assert settings and set(settings) <= build_parameters(scene), (scene, settings)


def _kernels_defined(path) -> set[str]:
    """The ``@wp.kernel`` functions a kernel module defines, at its top level or inside a factory."""
    return {n.name for n in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(n, ast.FunctionDef) and any(ast.unparse(d).startswith("wp.kernel") for d in n.decorator_list)}


def test_every_hot_kernel_is_a_kernel_of_its_module():
    assert register_report.HOT == common.hot_kernels()
    for module, names in register_report.HOT.items():
        missing = set(names) - _kernels_defined(ROOT / "kernels" / f"{module}.py")
        assert not missing, f"kernels/{module}.py names hot kernels it does not define: {sorted(missing)}"


def _kernel_modules_reached(wing: str) -> set[str]:
    """The modules of kernels/ that a wing's code imports, directly or through the core (``warpfree.*``)."""
    seen = set()
    path = ROOT / "warpfree" / "solvers" / wing
    todo = [f"warpfree.solvers.{wing}.{p.stem}" for p in path.glob("*.py")] if path.is_dir() \
        else [f"warpfree.solvers.{wing}"]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            spec = importlib.util.find_spec(name) if name.startswith("warpfree.") else None
        except ModuleNotFoundError:  # a name imported from a module, not a module
            spec = None
        if spec is None or not spec.origin or not spec.origin.endswith(".py"):
            continue
        package = name if spec.origin.endswith("__init__.py") else name.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(open(spec.origin, encoding="utf-8").read())):
            if isinstance(node, ast.Import):
                todo += [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]) if node.level else ""
                module = ".".join(filter(None, [base, node.module]))
                todo += [module] + [f"{module}.{a.name}" for a in node.names]
    return {n.split(".")[2] for n in seen if n.startswith("warpfree.kernels.") and n.count(".") == 2}


@pytest.mark.parametrize("wing", sorted(common.wings()))
def test_every_wing_reaches_a_hot_kernel(wing):
    """A wing's step or solve runs through kernels a module marks hot: its own (``kernels/<family>.py``) or the core's
    it stands on (the Galerkin floor's for EFG)."""
    reached = _kernel_modules_reached(wing)
    assert reached & set(register_report.HOT), f"{wing} reaches {sorted(reached)}, none with HOT_KERNELS"

