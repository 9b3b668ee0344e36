"""The documentation's code runs as written: every ```python block under ``docs/`` is either a script (a tutorial, the
Python API example) that runs to its end and leaves a passing run's ``summary``, or a scene file (a module with
``build(**params)``) that loads; the scene example of "Writing a scene" also runs as a scene into a run directory.
A fragment that is not meant to run alone is fenced as ```py instead (e.g. the solver skeleton of the architecture
page). The scripts are written at small sizes: each runs in seconds on one core once its kernels are compiled."""

from __future__ import annotations

import re
import runpy

import pytest

from warpfree import device
from warpfree.scene_loader import load_scene

from helpers import ROOT

DOCS = ROOT / "docs"
PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks() -> list[tuple[str, int, str]]:
    """(page, index on the page, code) of every ```python block in the documentation."""
    blocks = []
    for page in sorted(DOCS.rglob("*.md")):
        for index, code in enumerate(PYTHON_BLOCK.findall(page.read_text(encoding="utf-8"))):
            blocks.append((str(page.relative_to(DOCS)), index, code))
    return blocks


BLOCKS = python_blocks()


def test_the_tutorials_and_the_api_page_have_scripts():
    """One script per family's tutorial and one on the Python API page (a page that lost its script fails here, not
    silently)."""
    pages = {page for page, _, _ in BLOCKS}
    assert {"tutorials/fluid.md", "tutorials/maxwell.md", "tutorials/galerkin.md", "tutorials/plasma.md",
            "python-api.md", "writing-scenes.md"} <= pages


@pytest.mark.parametrize("page, index, code", BLOCKS, ids=[f"{p}#{i}" for p, i, _ in BLOCKS])
def test_every_python_block_runs(page, index, code, tmp_path, monkeypatch):
    path = tmp_path / f"block_{index}.py"
    path.write_text(code, encoding="utf-8")
    monkeypatch.chdir(tmp_path)  # a script that writes a run directory writes it here
    namespace = runpy.run_path(str(path), run_name="__main__")
    summary = namespace.get("summary")
    if summary is None:
        assert callable(namespace.get("build")), f"{page} block {index}: neither a scene (build) nor a script (summary)"
        return
    assert summary["status"] == "ok", summary.get("error")
    if "validation" in summary:
        failed = [name for name, check in summary["validation"]["checks"].items() if not check["passed"]]
        assert summary["validation"]["passed"] and not failed, failed


@pytest.mark.slow
def test_writing_a_scene_example_stays_at_rest_at_its_defaults(tmp_path):
    """The minimal scene of "Writing a scene" is a scene file: loaded by path and run at its own defaults (dx = 0.02 m
    to t = 1 s) into a directory, it writes its summary and its fluid's VTU series, and the water stays at rest: the
    largest speed stays below 5 % of the shallow-water wave speed sqrt(g H) (a column that collapses reaches about
    sqrt(g H) within a fraction of a second), and the free surface stays within half a spacing of its start."""
    import meshio
    import numpy as np

    text = (DOCS / "writing-scenes.md").read_text(encoding="utf-8")
    code = PYTHON_BLOCK.search(text).group(1)
    path = tmp_path / "my_tank.py"
    path.write_text(code, encoding="utf-8")
    device.use("cpu", 2)
    run = load_scene(str(path)).build()
    summary = run.run(str(tmp_path / "out"), progress=False)
    assert summary["status"] == "ok" and summary["time"] == 1.0 and summary["scene"] == "my_tank"
    assert (tmp_path / "out" / "fluid.pvd").is_file() and (tmp_path / "out" / "summary.json").is_file()
    depth, dx, g = 0.3, 0.02, 9.81
    fluid = run.fields()["fluid"]
    speed = np.linalg.norm(fluid.fields["velocity"], axis=1)
    assert speed.max() < 0.05 * np.sqrt(g * depth), speed.max()
    first = meshio.read(sorted((tmp_path / "out" / "vtk").glob("fluid_*.vtu"))[0]).points
    assert abs(fluid.points[:, 1].max() - first[:, 1].max()) < 0.5 * dx
