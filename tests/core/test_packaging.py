"""The package as a user gets it: shipped scenes listed and run by name, --version, python -m warpfree, a run
directory that already holds files refused unless --overwrite, and a non-editable install from the wheel in a fresh
virtual environment holding every package file and running every shipped scene by name."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import warpfree
from warpfree.cli import main
from warpfree.scene_loader import load_scene, shipped_scenes, summary_line

from helpers import ROOT


def run_cli(*args):
    return main(["run", *args, "--no-progress"])


def test_every_scene_of_the_scenes_folder_ships_with_one_line_and_its_smallest_run():
    shipped = shipped_scenes()
    assert set(shipped) == {p.stem for p in (ROOT / "scenes").glob("*.py") if not p.stem.startswith("_")}
    for name, path in shipped.items():
        line = summary_line(path)
        assert line and line != "(no description)" and len(line) <= 130, name
        module = load_scene(path)
        assert isinstance(module.SMALLEST, dict) and module.SMALLEST, name


def test_list_version_and_python_m_warpfree(capsys):
    assert main(["list"]) == 0
    listing = capsys.readouterr().out
    for name in shipped_scenes():
        assert f"\n{name} " in "\n" + listing
    res = subprocess.run([sys.executable, "-m", "warpfree", "--version"], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.strip() == f"warpfree {warpfree.__version__}"
    res = subprocess.run([sys.executable, "-m", "warpfree", "run", "nope_scene"], capture_output=True, text=True)
    assert res.returncode == 2 and "no scene named 'nope_scene'" in res.stderr and "Traceback" not in res.stderr


def test_a_scene_runs_by_name_and_a_misspelt_name_gets_the_closest(tmp_path, capsys):
    out = tmp_path / "hc"
    assert run_cli("heat_conduction_2d", "--set", "n=16", "--set", "t_end=0.2", "--no-frames", "--out", str(out)) == 0
    assert json.loads((out / "summary.json").read_text())["status"] == "ok"
    assert run_cli("heat_conduction", "--out", str(tmp_path / "other")) == 2
    assert "did you mean heat_conduction_2d" in capsys.readouterr().err


def _listing(path: Path):
    return sorted((p.relative_to(path).as_posix(), p.stat().st_mtime_ns) for p in path.rglob("*"))


def test_a_run_directory_with_files_is_refused_unless_overwrite(tmp_path, capsys):
    """Re-running into an existing --out once mixed the old frames and VTU files with the new ones."""
    out = tmp_path / "db"
    args = ["heat_conduction_2d", "--set", "n=16", "--set", "t_end=0.2", "--out", str(out)]
    assert run_cli(*args, "--set", "output_interval=0.02") == 0  # 11 outputs
    before = _listing(out)
    assert run_cli(*args) == 2
    assert capsys.readouterr().err.startswith("warpfree: error: --out:") and _listing(out) == before
    # a bad value with --overwrite leaves the earlier run as it was: it is cleared only once the scene has built
    assert run_cli(*args, "--overwrite", "--set", "mode=0") == 2
    assert _listing(out) == before
    assert run_cli(*args, "--overwrite") == 0
    assert len(list((out / "vtk").glob("*.vtu"))) == 5  # t = 0, 0.05, ..., 0.2: none of the earlier run's 11
    stranger = tmp_path / "mine"
    stranger.mkdir()
    (stranger / "notes.txt").write_text("keep me")
    assert run_cli("heat_conduction_2d", "--out", str(stranger), "--overwrite") == 2
    assert "not a warpfree run directory" in capsys.readouterr().err and (stranger / "notes.txt").is_file()


def _source_copy(into: Path) -> Path:
    """The tree as git has it (a clean checkout), without the venv and run outputs of this one."""
    ignore = shutil.ignore_patterns(".venv", ".git", "runs", "build", "dist", "__pycache__", "*.egg-info",
                                    ".pytest_cache")
    src = into / "src"
    shutil.copytree(ROOT, src, ignore=ignore)
    return src


#: what runs every shipped scene at its smallest size in one process of the fresh environment, without frames (the
#: scene tests draw them with the same code; they took half the time)
RUN_EVERY_SCENE = """
import sys
from warpfree.cli import main
from warpfree.scene_loader import load_scene, shipped_scenes, value_text

for name, path in shipped_scenes().items():
    sets = [a for k, v in load_scene(path).SMALLEST.items() for a in ("--set", f"{k}={value_text(v)}")]
    print(name, main(["run", name, *sets, "--no-progress", "--no-frames", "--out", name]), flush=True)
"""


def _wheel_name(source: str) -> str:
    """Where a file of the source tree lies in the wheel: kernels/ and scenes/ install as warpfree.kernels and
    warpfree.scenes."""
    top, _, rest = source.partition("/")
    return source if top == "warpfree" else f"warpfree/{top}/{rest}"


@pytest.mark.slow
def test_a_wheel_installed_in_a_fresh_venv_holds_every_package_file_and_runs_every_shipped_scene(tmp_path):
    """Build the wheel: it holds every file of the package's folders (warpfree/, kernels/, scenes/: code, reference
    data, meshes); install it (not editable, without its dependencies, which the fresh venv borrows from this
    interpreter's site-packages through a .pth file) and, from a folder outside the tree, list the scenes and run
    every one by name at its smallest size: a package or data file the package list forgets, or a scene reading a
    file outside the package, fails here."""
    import zipfile

    src = _source_copy(tmp_path)
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist), str(src)], check=True,
                   capture_output=True)
    wheel = next(dist.glob("warpfree-*.whl"))
    shipped = set(zipfile.ZipFile(wheel).namelist())
    sources = [p.relative_to(src).as_posix() for top in ("warpfree", "kernels", "scenes")
               for p in (src / top).rglob("*") if p.is_file()]
    assert len(sources) > 100
    assert sorted(s for s in sources if _wheel_name(s) not in shipped) == []
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    fresh_python, warpfree_command = venv / "bin" / "python", str(venv / "bin" / "warpfree")
    subprocess.run([str(fresh_python), "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheel)], check=True,
                   capture_output=True)
    fresh_site = Path(subprocess.run([str(fresh_python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                     check=True, capture_output=True, text=True).stdout.strip())
    (fresh_site / "borrowed_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = subprocess.run([str(fresh_python), "-c", "import warpfree, warpfree.kernels, warpfree.scenes; "
                            "print(warpfree.__file__)"], cwd=work, env=env, check=True, capture_output=True, text=True)
    assert where.stdout.startswith(str(fresh_site)), where.stdout
    version = subprocess.run([warpfree_command, "--version"], cwd=work, env=env, capture_output=True, text=True)
    assert version.stdout.strip() == f"warpfree {warpfree.__version__}"
    listing = subprocess.run([warpfree_command, "list"], cwd=work, env=env, capture_output=True,
                             text=True)
    assert listing.returncode == 0, listing.stderr
    runs = subprocess.run([str(fresh_python), "-c", RUN_EVERY_SCENE], cwd=work, env=env, capture_output=True,
                          text=True)
    codes = dict(line.split() for line in runs.stdout.splitlines() if line.count(" ") == 1)
    failed = []
    for name in shipped_scenes():
        if codes.get(name) != "0" or not (work / name / "summary.json").is_file():
            failed.append(f"{name}: exit {codes.get(name)}")
        elif name not in listing.stdout:
            failed.append(f"{name}: not listed")
    assert not failed, "\n".join(failed) + "\n" + runs.stderr[-2000:]
