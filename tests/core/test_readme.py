"""The README is the front door and cannot drift from the tree: it starts with the two commands, stays short, shows a
picture committed under ``docs/``, and every file the README, the documentation pages and the validation READMEs name
exists. (The scene example that the README once held lives in ``docs/writing-scenes.md`` now and runs in
``tests/docs/test_docs_examples.py``.)"""

import os
import re

from helpers import ROOT

README = ROOT / "README.md"
#: the two commands a newcomer runs first, as the README's first lines give them
INSTALL_AND_RUN = ("python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/warpfree run "
                   "scenes/dam_break_2d.py --out runs/dam_break_2d")
INSTALL_AND_TEST = "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/python -m pytest -q"
#: the README's budget (bytes)
README_LIMIT = 12_000


def test_readme_starts_with_the_two_commands():
    commands = [line.strip() for line in README.read_text(encoding="utf-8").splitlines()[:12]
                if line.startswith("    ")]
    assert commands == [INSTALL_AND_RUN, INSTALL_AND_TEST]


def test_readme_is_short_and_its_picture_is_committed_under_docs():
    text = README.read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) <= README_LIMIT
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(pictures) == 1 and pictures[0].startswith("docs/") and (ROOT / pictures[0]).is_file(), pictures


#: a file or folder of this tree named in the README or a documentation page: `warpfree/...`, `kernels/...`,
#: `scenes/...`, `tests/...`, `bench/...`, `docs/...`, in prose, code spans or commands (up to the first character a
#: path here never holds)
TREE_PATH = re.compile(r"(?<![\w./-])((?:warpfree|kernels|scenes|tests|bench|docs)/[\w./-]*)")
#: in a validation README, which also quotes other projects' paths in prose: a path of this tree in backticks
QUOTED_TREE_PATH = re.compile(r"`((?:warpfree|kernels|scenes|tests|bench|docs)/[^`\s<>*:]*)")


def named_paths(text: str, pattern: re.Pattern = TREE_PATH) -> set[str]:
    """The tree paths ``text`` names (a sentence's closing full stop or comma left off)."""
    return {path.rstrip(".,") for path in pattern.findall(text)}


def test_every_path_the_docs_name_exists():
    """The README, the documentation pages and the validation READMEs name files by their path from the repository
    root; each must exist."""
    docs = [(doc, TREE_PATH) for doc in (README, *sorted((ROOT / "docs").rglob("*.md")))]
    docs += [(doc, QUOTED_TREE_PATH) for doc in sorted((ROOT / "warpfree" / "validation").glob("*/README.md"))]
    missing = []
    for doc, pattern in docs:
        for path in sorted(named_paths(doc.read_text(encoding="utf-8"), pattern)):
            if not os.path.exists(os.path.join(ROOT, path.rstrip("/"))):
                missing.append(f"{os.path.relpath(doc, ROOT)}: {path}")
    assert not missing, missing


def test_the_path_check_finds_paths_in_prose_and_commands():
    text = "see `warpfree/run.py`, run python bench/core/thread_sweep.py. Or tests/core/test_readme.py::test_x"
    assert named_paths(text) == {"warpfree/run.py", "bench/core/thread_sweep.py", "tests/core/test_readme.py"}
    assert named_paths(text, QUOTED_TREE_PATH) == {"warpfree/run.py"}
    assert "warpfree/no_such_module.py" in named_paths("`warpfree/no_such_module.py`")
