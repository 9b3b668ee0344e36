"""The README's scene example runs as written and every file it names exists (so the README cannot drift from the
API or the tree)."""

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


#: a file or folder of the tree named in backticks: `warpfree/...`, `kernels/...`, `scenes/...`, `tests/...`, `bench/...`
TREE_PATH = re.compile(r"`((?:warpfree|kernels|scenes|tests|bench)/[^`\s<>*]*)`")


def test_every_path_the_docs_name_exists():
    """The README and the validation READMEs name files by their path from the repository root; each must exist."""
    docs = [ROOT / "README.md", *sorted((ROOT / "warpfree" / "validation").glob("*/README.md"))]
    missing = []
    for doc in docs:
        for path in sorted(set(TREE_PATH.findall(doc.read_text(encoding="utf-8")))):
            if not os.path.exists(os.path.join(ROOT, path.split("::")[0].rstrip("/"))):
                missing.append(f"{os.path.relpath(doc, ROOT)}: {path}")
    assert not missing, missing
