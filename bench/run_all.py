"""Run every benchmark one after the other, as each script declares, and say what is run.

What it runs
    Every script under ``bench/<family>/`` (``bench/*/*.py``; families in the order core, wcsph, spem, efg, pic,
    then any other alphabetically; scripts by name) that has an ``if __name__ == "__main__":`` block declares at
    module level the runs this runner makes of it, a literal read here with ``ast`` (the script is never
    imported)::

        #: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, ...).
        RUN_ALL = [[], ["--case", "heat"]]          # `python bench/f/s.py`, then `python bench/f/s.py --case heat`
        RUN_ALL = []                                # no run; then also:
        RUN_ALL_SKIPPED = "needs --baseline DIR"    # why (printed in the plan)

    A script with a ``__main__`` block and no ``RUN_ALL`` (or one that is not a literal list of argument lists)
    is an error (exit 2, naming the file), so a new benchmark cannot be left out silently. Modules without a
    ``__main__`` block (the libraries a comparison imports) are not listed. ``bench/wcsph/peers/`` is one level
    deeper and not searched.

How
    The whole plan first (every script found, each run's command line, each skipped script with its reason),
    then the runs one at a time from the repository root, never overlapping (each one times the CPU), each
    announced by ``=== bench/<family>/<script> ARGS (date, load)``. Arguments run_all does not know (e.g.
    ``--quick``) go to every run, after the script's own. The first failing run stops everything (exit 1)
    unless ``--keep-going``. Python: ``$PYTHON``, else ``.venv/bin/python`` if it exists, else this interpreter.

Usage
    python bench/run_all.py                # everything declared (see bench/README.md for the times)
    python bench/run_all.py --quick        # every run with --quick (small sizes, results to *_quick.*)
    python bench/run_all.py --list         # the plan only
    python bench/run_all.py --keep-going   # run the rest after a failure, exit 1 at the end
Results: bench/results/*.json, *.md, *.png, written by the scripts themselves.
"""

from __future__ import annotations

import argparse
import ast
import datetime as _dt
import os
import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
#: families run first, in this order; any other family folder follows, alphabetically
FAMILY_ORDER = ("core", "wcsph", "spem", "efg", "pic")
#: folders under bench/ that are not families
NOT_FAMILIES = {"results", "work", "__pycache__"}


@dataclass
class Script:
    path: Path
    family: str
    runs: list[list[str]] = field(default_factory=list)
    skipped: str | None = None


class DeclarationError(Exception):
    pass


def family_dirs(bench: Path = BENCH) -> list[Path]:
    """The family folders under ``bench``, in run order."""
    dirs = [p for p in bench.iterdir() if p.is_dir() and p.name not in NOT_FAMILIES and not p.name.startswith(".")]
    return sorted(dirs, key=lambda p: (FAMILY_ORDER.index(p.name) if p.name in FAMILY_ORDER else len(FAMILY_ORDER),
                                       p.name))


def _is_main_test(test: ast.expr) -> bool:
    """``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(s, ast.Name) and s.id == "__name__" for s in sides)
            and any(isinstance(s, ast.Constant) and s.value == "__main__" for s in sides))


def read_declaration(path: Path) -> tuple[bool, dict]:
    """Whether ``path`` has a module-level ``__main__`` block, and its literal ``RUN_ALL`` / ``RUN_ALL_SKIPPED``."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    except SyntaxError as exc:
        raise DeclarationError(f"does not parse: {exc}") from exc
    has_main = any(isinstance(node, ast.If) and _is_main_test(node.test) for node in tree.body)
    found = {}
    for node in tree.body:
        targets = (node.targets if isinstance(node, ast.Assign)
                   else [node.target] if isinstance(node, ast.AnnAssign) and node.value is not None else [])
        for target in targets:
            if isinstance(target, ast.Name) and target.id in ("RUN_ALL", "RUN_ALL_SKIPPED"):
                try:
                    found[target.id] = ast.literal_eval(node.value)
                except ValueError as exc:
                    raise DeclarationError(f"{target.id} (line {node.lineno}) is not a literal") from exc
    return has_main, found


def check_declaration(found: dict) -> tuple[list[list[str]], str | None]:
    """The runs and the skip reason of a script's declaration, or DeclarationError saying what is wrong."""
    if "RUN_ALL" not in found:
        raise DeclarationError("has a __main__ block but no RUN_ALL: declare the runs bench/run_all.py makes of it "
                               "(RUN_ALL = [[]] for one run without arguments; RUN_ALL = [] with RUN_ALL_SKIPPED = "
                               "'why' for none)")
    runs = found["RUN_ALL"]
    if not (isinstance(runs, list) and all(isinstance(r, list) and all(isinstance(a, str) for a in r) for r in runs)):
        raise DeclarationError(f"RUN_ALL must be a list of argument lists of strings, not {runs!r}")
    skipped = found.get("RUN_ALL_SKIPPED")
    if runs and skipped is not None:
        raise DeclarationError("RUN_ALL_SKIPPED is for RUN_ALL = [] (no run): it says why there is none")
    if not runs and not (isinstance(skipped, str) and skipped.strip()):
        raise DeclarationError("RUN_ALL = [] needs RUN_ALL_SKIPPED = 'why it is not run'")
    return runs, skipped


def discover(bench: Path = BENCH) -> tuple[list[Script], list[str]]:
    """Every benchmark script under ``bench/<family>/``, in run order, and the errors of the declarations
    (``'path: what'``)."""
    scripts, errors = [], []
    for family in family_dirs(bench):
        for path in sorted(family.glob("*.py")):
            try:
                has_main, found = read_declaration(path)
                if not has_main:
                    if found:
                        raise DeclarationError("declares RUN_ALL but has no __main__ block to run")
                    continue  # a library module of its family's scripts
                runs, skipped = check_declaration(found)
            except DeclarationError as exc:
                errors.append(f"{_rel(path)}: {exc}")
                continue
            scripts.append(Script(path, family.name, runs, skipped))
    return scripts, errors


def python_executable() -> str:
    """``$PYTHON``, else the repository's ``.venv/bin/python`` if it exists, else this interpreter."""
    env = os.environ.get("PYTHON")
    if env:  # a relative path is taken from the repository root, where the runs start
        return _rel(ROOT / env) if "/" in env else env
    venv = ROOT / ".venv" / "bin" / "python"
    return _rel(venv) if venv.exists() else sys.executable


def _rel(path: Path | str) -> str:
    try:
        return str(Path(path).relative_to(ROOT))
    except ValueError:
        return str(path)


def command(python: str, script: Script, run: list[str], extra: list[str]) -> list[str]:
    return [python, _rel(script.path), *run, *extra]


def print_plan(scripts: list[Script], python: str, extra: list[str]) -> None:
    n_runs = sum(len(s.runs) for s in scripts)
    families = list(dict.fromkeys(s.family for s in scripts))
    print(f"bench/run_all.py: {len(scripts)} scripts in {len(families)} "
          f"{'family' if len(families) == 1 else 'families'} ({', '.join(families)}), "
          f"{n_runs} runs, one at a time, from {ROOT}"
          + (f"; extra arguments to every run: {shlex.join(extra)}" if extra else ""))
    k = 0
    for family in families:
        print(f"\n{family}/")
        for s in (s for s in scripts if s.family == family):
            if not s.runs:
                print(f"       skip {_rel(s.path)}: {s.skipped}")
            for run in s.runs:
                k += 1
                print(f"  {k:>3}. {shlex.join(command(python, s, run, extra))}")
    print(flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False,
                                 epilog="Any other argument (e.g. --quick) goes to every run.")
    ap.add_argument("--list", action="store_true", help="print the plan and exit")
    ap.add_argument("--keep-going", action="store_true", help="after a failed run go on; exit 1 at the end")
    args, extra = ap.parse_known_args(argv)
    scripts, errors = discover()
    if errors:
        for e in errors:
            print(f"bench/run_all.py: error: {e}", file=sys.stderr)
        return 2
    python = python_executable()
    if not args.list and shutil.which(python if "/" not in python else str(ROOT / python)) is None:
        print(f"bench/run_all.py: error: no Python at {python!r} ($PYTHON or .venv/bin/python)", file=sys.stderr)
        return 2
    print_plan(scripts, python, extra)
    if args.list:
        return 0
    plan = [(s, run) for s in scripts for run in s.runs]
    failed = []
    t_start = time.perf_counter()
    for k, (s, run) in enumerate(plan, 1):
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
        now = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
        print(f"=== {shlex.join([_rel(s.path), *run, *extra])} ({now}, load {load}) [{k}/{len(plan)}]", flush=True)
        t0 = time.perf_counter()
        try:
            rc = subprocess.run(command(python, s, run, extra), cwd=ROOT).returncode
        except KeyboardInterrupt:
            print("\nbench/run_all.py: interrupted", file=sys.stderr)
            return 130
        took = time.perf_counter() - t0
        if rc != 0:
            failed.append(f"{shlex.join([_rel(s.path), *run, *extra])} (exit {rc})")
            print(f"=== FAILED after {took:.0f} s: {failed[-1]}", flush=True)
            if not args.keep_going:
                print(f"bench/run_all.py: stopped at run {k} of {len(plan)} (--keep-going runs the rest)",
                      file=sys.stderr)
                return 1
        else:
            print(f"=== done in {took:.0f} s\n", flush=True)
    total = time.perf_counter() - t_start
    print(f"bench/run_all.py: {len(plan) - len(failed)} of {len(plan)} runs succeeded in {total / 60:.1f} min")
    for f in failed:
        print(f"  failed: {f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
