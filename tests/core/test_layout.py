"""The layout's rules, read from the code's imports: no method family imports another family, the shared core imports
no family, and a kernel module imports no module of the orchestration layer (only Warp, other kernel modules and the
standard library)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from helpers import ROOT

PACKAGE = ROOT / "warpfree"
KERNELS = ROOT / "kernels"
#: the method families: their solver wing under warpfree/solvers/ (a folder, or one module for the example solver)
FAMILIES = sorted(p.stem for p in (PACKAGE / "solvers").iterdir() if not p.name.startswith("_") and p.name != "__pycache__")


def family_of_kernel(path: Path) -> str | None:
    """A kernel module belongs to the family it is named after (``wcsph.py``, ``wcsph_solids.py``), else it is shared."""
    return next((f for f in FAMILIES if path.stem == f or path.stem.startswith(f + "_")), None)


def imported_modules(path: Path) -> set[str]:
    """Absolute names of the modules ``path`` imports (relative imports resolved against its package)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    if path.is_relative_to(KERNELS):
        package = ["warpfree", "kernels"]
    else:
        package = ["warpfree", *path.relative_to(PACKAGE).parent.parts]
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, node.module] if node.module else base)
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)  # from package import module
    return names


def family_imported(name: str) -> str | None:
    parts = name.split(".")
    if parts[:2] == ["warpfree", "solvers"] and len(parts) > 2 and parts[2] in FAMILIES:
        return parts[2]
    if parts[:2] == ["warpfree", "kernels"] and len(parts) > 2:
        return family_of_kernel(Path(parts[2] + ".py"))
    return None


def python_files(folder: Path):
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_families_are_those_of_the_solver_wings():
    assert {"wcsph", "spem", "efg", "nem", "pic", "heat"} <= set(FAMILIES)


@pytest.mark.parametrize("family", FAMILIES)
def test_no_family_imports_another(family):
    wing = PACKAGE / "solvers" / family
    files = python_files(wing) if wing.is_dir() else [PACKAGE / "solvers" / f"{family}.py"]
    files += [p for p in python_files(KERNELS) if family_of_kernel(p) == family]
    crossing = {f"{p.relative_to(ROOT)} imports {name}" for p in files for name in imported_modules(p)
                if family_imported(name) not in (None, family)}
    assert not crossing, sorted(crossing)


def test_the_shared_core_imports_no_family():
    core = [p for p in python_files(PACKAGE) if not p.is_relative_to(PACKAGE / "solvers")]
    core += [p for p in python_files(KERNELS) if family_of_kernel(p) is None]
    upward = {f"{p.relative_to(ROOT)} imports {name}" for p in core for name in imported_modules(p)
              if family_imported(name) is not None}
    assert not upward, sorted(upward)


def test_kernel_modules_never_import_the_orchestration_layer():
    bad = {f"{p.relative_to(ROOT)} imports {name}" for p in python_files(KERNELS) for name in imported_modules(p)
           if name.split(".")[0] == "warpfree" and name.split(".")[:2] != ["warpfree", "kernels"]}
    assert not bad, sorted(bad)
