"""The README's scene example runs as written (so the README cannot drift from the API)."""

import os
import re

from warpfree import device
from warpfree.scene_loader import load_scene

from helpers import ROOT


def test_writing_a_scene_example_runs(tmp_path):
    text = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()
    section = text[text.index("## Writing a scene"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    path = tmp_path / "my_tank.py"
    path.write_text(code)
    device.use("cpu", 2)
    run = load_scene(str(path)).build(dx=0.05, t_end=0.02)
    summary = run.run(str(tmp_path / "out"), progress=False)
    assert summary["status"] == "ok" and summary["time"] == 0.02 and summary["scene"] == "my_tank"
    assert (tmp_path / "out" / "fluid.pvd").is_file()
