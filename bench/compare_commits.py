"""Every shipped scene at its smallest size on two versions of warpfree: are the outputs bitwise the same?

What it checks
    Each scene of ``scenes/`` runs from the command line at the parameters its module declares as ``SMALLEST``
    (read from the newer side's scene file, so both sides run the same case), once in each tree, on the same
    thread count. Then every file the two runs wrote is compared:

    * VTU: the points and every point field, array by array, bitwise (dtype and shape included);
    * CSV, PVD, PLY: byte for byte;
    * ``summary.json``: every value but the timings (``wall_s``, ``phases_s``, the throughput's value, any key
      ending in ``_s``) and the paths of the run directory;
    * PNG frames and plots: byte for byte, reported but not counted as a failure (Matplotlib, not the physics).

    A scene only one side has, or a file only one side wrote, is reported.

How
    A side is a git revision (``git archive``) or ``.`` (this working tree, uncommitted changes included). Each is
    assembled into a folder that Python imports ``warpfree`` from, with the mapping of that side's packaging applied
    (``kernels/`` as ``warpfree.kernels``, ``scenes/`` as ``warpfree.scenes``), and run as ``python -S`` with that
    folder and this interpreter's packages on ``PYTHONPATH``: no installed (editable) copy of warpfree can stand in
    for a missing module, so the two sides never mix.

Usage
    python bench/compare_commits.py BASE [NEW]     # NEW defaults to the working tree
    python bench/compare_commits.py 4f67931 --scenes dam_break_2d,pic_diode --keep /tmp/compare
    python bench/compare_commits.py 4f67931 --ignore params/dt --ignore model/dt   # a summary key changed on purpose
Exit code 0 when every scene's outputs are the same, 1 otherwise.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

from warpfree.scene_loader import value_text

ROOT = Path(__file__).resolve().parent.parent
#: summary.json keys whose values are timings or machine facts, not results
VOLATILE_KEYS = {"wall_s", "phases_s", "last_checkpoint", "last_good_checkpoint"}
REPORTED_ONLY = {".png"}


def stage(revision: str, into: Path) -> Path:
    """Copy the tree of ``revision`` (``.``: the working tree) into ``into/src``; assemble ``into/site``."""
    src = into / "src"
    src.mkdir(parents=True)
    if revision == ".":
        files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, check=True,
                               capture_output=True).stdout.decode().split("\0")
        for name in filter(None, files):
            if (ROOT / name).is_file():
                (src / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(ROOT / name, src / name)
    else:
        archive = subprocess.run(["git", "archive", "--format=tar", revision], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    site = into / "site"
    shutil.copytree(src / "warpfree", site / "warpfree")
    for package, folder in package_folders(src).items():
        parts = package.split(".")
        if parts[0] == "warpfree" and len(parts) > 1 and folder != package.replace(".", "/"):
            shutil.copytree(src / folder, site.joinpath(*parts), dirs_exist_ok=True)
    return src


def package_folders(src: Path) -> dict[str, str]:
    """Package -> folder of the tree's mapped packages: ``package-dir`` in pyproject.toml, or ``MAPPED`` in setup.py."""
    config = tomllib.loads((src / "pyproject.toml").read_text())
    mapping = dict(config.get("tool", {}).get("setuptools", {}).get("package-dir", {}))
    if (src / "setup.py").is_file():
        for node in ast.parse((src / "setup.py").read_text()).body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "MAPPED" for t in node.targets):
                mapping.update(ast.literal_eval(node.value))
    return mapping


def side_environment(side: Path) -> dict[str, str]:
    """The environment that imports warpfree from ``side`` only: its assembled folder first, then this interpreter's
    packages, run with ``python -S`` so that no .pth file (an editable install's finder) adds another warpfree."""
    import sysconfig

    paths = [str(side / "site"), sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(dict.fromkeys(paths))}


def smallest(scene_file: Path) -> dict | None:
    """The scene's ``SMALLEST`` parameters (a literal dict at module level), or None."""
    for node in ast.parse(scene_file.read_text()).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "SMALLEST" for t in node.targets):
            return ast.literal_eval(node.value)
    return None


def run_scene(side: Path, scene: str, params: dict, out: Path, threads: int) -> tuple[int, str]:
    cmd = [sys.executable, "-S", "-m", "warpfree.cli", "run", str(side / "src" / "scenes" / f"{scene}.py"),
           "--out", str(out), "--threads", str(threads), "--no-progress"]
    for k, v in params.items():
        cmd += ["--set", f"{k}={value_text(v)}"]
    res = subprocess.run(cmd, cwd=side, env=side_environment(side), capture_output=True, text=True)
    return res.returncode, (res.stdout + res.stderr)[-2000:]


def strip_volatile(value, roots: dict[str, str], ignore: tuple = (), where: str = ""):
    """``value`` without timings and the ``ignore``d key paths (``model/dt``), with each path in ``roots``
    (path -> token) replaced by its token."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if k in VOLATILE_KEYS or k.endswith("_s") or f"{where}{k}" in ignore:
                continue
            if k == "throughput" and isinstance(v, dict):
                v = {kk: vv for kk, vv in v.items() if kk != "value"}
            out[k] = strip_volatile(v, roots, ignore, f"{where}{k}/")
        return out
    if isinstance(value, list):
        return [strip_volatile(v, roots, ignore, where) for v in value]
    if isinstance(value, str):
        for path, token in roots.items():
            value = value.replace(path, token)
    return value


def first_difference(a, b, where: str = "") -> str | None:
    if type(a) is not type(b):
        return f"{where or '/'}: {a!r} != {b!r}"
    if isinstance(a, dict):
        for k in sorted(set(a) | set(b), key=str):
            if k not in a or k not in b:
                return f"{where}/{k}: only on the {'new' if k in b else 'base'} side"
            d = first_difference(a[k], b[k], f"{where}/{k}")
            if d:
                return d
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{where}: {len(a)} items != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{where}[{i}]")
            if d:
                return d
        return None
    same = a == b or (isinstance(a, float) and a != a and b != b)
    return None if same else f"{where}: {a!r} != {b!r}"


def compare_vtu(a: Path, b: Path) -> str | None:
    """None when the two files hold the same points and fields (the same bytes, or the same arrays)."""
    import meshio

    if a.read_bytes() == b.read_bytes():
        return None
    try:
        ma, mb = meshio.read(a), meshio.read(b)
    except ValueError as exc:  # meshio cannot read a file with no points
        return f"bytes differ and a side does not read back ({exc})"
    pairs = {"points": (ma.points, mb.points)}
    if set(ma.point_data) != set(mb.point_data):
        return f"fields {sorted(ma.point_data)} != {sorted(mb.point_data)}"
    pairs.update({k: (ma.point_data[k], mb.point_data[k]) for k in ma.point_data})
    for k, (x, y) in pairs.items():
        if x.dtype != y.dtype or x.shape != y.shape:
            return f"{k}: {x.dtype}{x.shape} != {y.dtype}{y.shape}"
        if not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            bad = np.flatnonzero(~((x == y) | (np.isnan(x) & np.isnan(y)) if x.dtype.kind == "f" else x == y))
            return f"{k}: {bad.size} values differ (max |diff| {np.max(np.abs(x - y)):.3g})"
    return None


def compare_runs(base: Path, new: Path, trees: tuple[Path, Path], ignore: tuple = ()) -> tuple[list[str], list[str], int]:
    """(failures, reported-only differences, files compared) between two run directories; ``trees``: the two
    staged source trees (paths into them, e.g. of a mesh file, are not a difference)."""
    failures, reported, count = [], [], 0
    names_a = {p.relative_to(base).as_posix() for p in base.rglob("*") if p.is_file()}
    names_b = {p.relative_to(new).as_posix() for p in new.rglob("*") if p.is_file()}
    skip = {"run.json"}
    for name in sorted((names_a ^ names_b) - skip):
        (reported if name.endswith(".png") else failures).append(
            f"{name}: only on the {'new' if name in names_b else 'base'} side")
    for name in sorted((names_a & names_b) - skip):
        a, b = base / name, new / name
        count += 1
        if name.endswith(".vtu"):
            d = compare_vtu(a, b)
        elif name.endswith("summary.json"):
            d = first_difference(
                strip_volatile(json.loads(a.read_text()), {str(base): "<out>", str(trees[0]): "<tree>"}, ignore),
                strip_volatile(json.loads(b.read_text()), {str(new): "<out>", str(trees[1]): "<tree>"}, ignore))
        elif name.endswith(".pvd"):
            d = None if a.read_text().replace(str(base), "") == b.read_text().replace(str(new), "") else "differs"
        else:
            d = None if a.read_bytes() == b.read_bytes() else "bytes differ"
        if d:
            (reported if Path(name).suffix in REPORTED_ONLY else failures).append(f"{name}: {d}")
    return failures, reported, count


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("base", help="git revision of the earlier side")
    parser.add_argument("new", nargs="?", default=".", help="git revision of the later side ('.': the working tree)")
    parser.add_argument("--scenes", default=None, help="comma-separated scene names (default: every scene)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--ignore", action="append", default=[], metavar="KEY/PATH",
                        help="a summary.json key path changed on purpose, e.g. model/dt (repeatable)")
    parser.add_argument("--keep", default=None, help="keep the staged trees and runs in this folder")
    args = parser.parse_args(argv)
    work = Path(args.keep or tempfile.mkdtemp(prefix="warpfree_compare_"))
    if work.exists() and any(work.iterdir()):
        shutil.rmtree(work)
    sides = {"base": work / "base", "new": work / "new"}
    stage(args.base, sides["base"])
    stage(args.new, sides["new"])
    scenes = sorted(p.stem for p in (sides["new"] / "src" / "scenes").glob("*.py") if not p.stem.startswith("_"))
    if args.scenes:
        scenes = [s for s in scenes if s in args.scenes.split(",")]
    bad = 0
    for scene in scenes:
        params = smallest(sides["new"] / "src" / "scenes" / f"{scene}.py")
        if params is None:
            print(f"{scene:26s} SKIPPED: the scene declares no SMALLEST parameters")
            bad += 1
            continue
        if not (sides["base"] / "src" / "scenes" / f"{scene}.py").is_file():
            print(f"{scene:26s} new scene (no base side)")
            continue
        outs = {}
        for side, path in sides.items():
            out = work / "runs" / side / scene
            code, log = run_scene(path, scene, params, out, args.threads)
            if code != 0:
                print(f"{scene:26s} FAILED on the {side} side (exit {code}):\n{log}")
                outs = None
                break
            outs[side] = out
        if outs is None:
            bad += 1
            continue
        failures, reported, count = compare_runs(outs["base"], outs["new"], (sides["base"], sides["new"]),
                                                  tuple(args.ignore))
        status = "same" if not failures else "DIFFERENT"
        print(f"{scene:26s} {status}: {count} files compared" + (f", {len(reported)} pictures differ" if reported else ""))
        for line in failures[:10]:
            print(f"    {line}")
        bad += bool(failures)
    print(f"{len(scenes) - bad} of {len(scenes)} scenes give the same outputs ({work})")
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
