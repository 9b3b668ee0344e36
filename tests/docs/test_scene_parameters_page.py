"""The documentation's page of scene parameters is what the scenes declare (``docs/tools/scene_parameters.py``), so
it cannot drift from ``warpfree run SCENE --list``."""

import importlib.util

from helpers import ROOT


def test_the_scene_parameters_page_is_made_from_the_declarations():
    spec = importlib.util.spec_from_file_location("scene_parameters_tool", ROOT / "docs" / "tools" /
                                                  "scene_parameters.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    text = tool.page()
    assert "| `kernel` | choice | `wendland_c2` | – | one of cubic_spline, wendland_c2, quintic_spline |" in text
    assert "| `wendland_c2` | Wendland C2 (Wendland 1995), support 2h |" in text
    assert (ROOT / "docs" / "scene-parameters.md").read_text(encoding="utf-8") == text, \
        "docs/scene-parameters.md is out of date: run .venv/bin/python docs/tools/scene_parameters.py"
