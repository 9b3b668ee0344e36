"""The benchmarks' layout (no benchmark is run): every script under bench/<family>/ declares the runs
bench/run_all.py makes of it, the runner's plan lists them all, and the families are those of the solver wings."""

from __future__ import annotations

import ast
import importlib.util
import subprocess
import sys
import textwrap

import pytest

from helpers import ROOT

BENCH = ROOT / "bench"
#: folders under bench/ that hold no benchmarks
NOT_FAMILIES = {"results", "work", "__pycache__"}
FAMILY_DIRS = sorted(p for p in BENCH.iterdir() if p.is_dir() and p.name not in NOT_FAMILIES
                     and not p.name.startswith("."))


def module_level(path):
    """Whether the module has an ``if __name__ == "__main__":`` block, and its top-level assignment nodes by name."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    has_main = any(isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) and "__name__" in ast.unparse(n.test)
                   for n in tree.body)
    assigned = {t.id: n.value for n in tree.body if isinstance(n, ast.Assign) for t in n.targets
                if isinstance(t, ast.Name)}
    return has_main, assigned


BENCHMARKS = [p for d in FAMILY_DIRS for p in sorted(d.glob("*.py")) if module_level(p)[0]]


def load_run_all():
    spec = importlib.util.spec_from_file_location("bench_run_all", BENCH / "run_all.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_there_are_benchmarks_in_the_families():
    assert {"core", "wcsph", "spem", "efg", "pic"} <= {d.name for d in FAMILY_DIRS}
    assert len(BENCHMARKS) >= 10


def test_benchmarks_are_filed_by_method_family():
    """Each folder under bench/ but core (cross-family) and results is a method family: a wing under warpfree/solvers/
    (a folder, or one module for the example solver)."""
    wings = {p.stem for p in (ROOT / "warpfree" / "solvers").iterdir()
             if not p.name.startswith("_") and p.name != "__pycache__"}
    strays = [d.name for d in FAMILY_DIRS if d.name != "core" and d.name not in wings]
    assert not strays, f"bench/ folders that are no family under warpfree/solvers/: {strays}"


@pytest.mark.parametrize("path", BENCHMARKS, ids=lambda p: str(p.relative_to(BENCH)))
def test_every_benchmark_declares_its_runs(path):
    _, assigned = module_level(path)
    assert "RUN_ALL" in assigned, f"{path.relative_to(ROOT)} has a __main__ block but no RUN_ALL"
    runs = ast.literal_eval(assigned["RUN_ALL"])
    assert isinstance(runs, list) and all(isinstance(r, list) and all(isinstance(a, str) for a in r) for r in runs)
    if not runs:
        reason = ast.literal_eval(assigned["RUN_ALL_SKIPPED"]) if "RUN_ALL_SKIPPED" in assigned else None
        assert isinstance(reason, str) and reason.strip(), f"{path.relative_to(ROOT)}: RUN_ALL = [] without a reason"


def test_run_all_lists_every_benchmark():
    proc = subprocess.run([sys.executable, str(BENCH / "run_all.py"), "--list"], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    assert proc.returncode == 0, proc.stderr
    for path in BENCHMARKS:
        rel = str(path.relative_to(ROOT))
        runs = ast.literal_eval(module_level(path)[1]["RUN_ALL"])
        lines = [line for line in proc.stdout.splitlines() if rel + " " in line + " " or rel + ":" in line]
        assert lines, f"{rel} is not in the plan"
        assert len(lines) == max(1, len(runs)), (rel, lines)  # one line a run, or one 'skip' line


def test_run_all_keeps_the_order_of_the_families():
    proc = subprocess.run([sys.executable, str(BENCH / "run_all.py"), "--list"], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    headers = [line[:-1] for line in proc.stdout.splitlines() if line.endswith("/") and " " not in line]
    assert headers[:5] == ["core", "wcsph", "spem", "efg", "pic"]


def test_a_benchmark_without_run_all_is_an_error(tmp_path):
    run_all = load_run_all()
    (tmp_path / "results").mkdir()
    family = tmp_path / "pic"
    family.mkdir()
    (family / "library.py").write_text("def helper():\n    return 1\n")
    (family / "declared.py").write_text(textwrap.dedent("""\
        RUN_ALL = [[], ["--case", "x"]]
        if __name__ == "__main__":
            pass
    """))
    (family / "skipped.py").write_text('RUN_ALL = []\nRUN_ALL_SKIPPED = "needs a peer"\nif __name__ == "__main__":\n'
                                       '    pass\n')
    scripts, errors = run_all.discover(tmp_path)
    assert not errors
    assert [(s.path.name, s.runs, s.skipped) for s in scripts] == [("declared.py", [[], ["--case", "x"]], None),
                                                                  ("skipped.py", [], "needs a peer")]
    (family / "new_bench.py").write_text('import sys\nif __name__ == "__main__":\n    sys.exit(0)\n')
    (family / "unexplained.py").write_text('RUN_ALL = []\nif __name__ == "__main__":\n    pass\n')
    (family / "computed.py").write_text('RUN_ALL = [["--n", str(3)]]\nif __name__ == "__main__":\n    pass\n')
    _, errors = run_all.discover(tmp_path)
    assert len(errors) == 3
    assert any("new_bench.py" in e and "no RUN_ALL" in e for e in errors)
    assert any("unexplained.py" in e and "RUN_ALL_SKIPPED" in e for e in errors)
    assert any("computed.py" in e and "not a literal" in e for e in errors)
