"""Write ``docs/scene-parameters.md``: every shipped scene's parameters as its ``build()`` declares them (type, default,
unit, allowed values, meaning; :mod:`warpfree.parameters`), and the meaning of every choice they offer.

    .venv/bin/python docs/tools/scene_parameters.py           # rewrite the page
    .venv/bin/python docs/tools/scene_parameters.py --check   # exit 1 when the page differs from the declarations

The page is made from the declarations alone, so it cannot say something ``warpfree run SCENE --list`` does not
(``tests/docs/test_scene_parameters_page.py`` checks that the committed page is this script's output).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "scene-parameters.md"

INTRO = """# Scene parameters

Every parameter of every shipped scene, as the scene's `build()` declares it: its type, its default, its unit, the
values it may take and what it means. `warpfree run SCENE --list` prints the same for one scene; `--set name=value`
sets one, and a value outside its type or its allowed values is refused in one line naming it, before anything is
built. A scene of your own declares its parameters the same way ([Writing a scene](writing-scenes.md)). This page is
made by `docs/tools/scene_parameters.py` from the declarations.
"""


def cell(text: str) -> str:
    """Text for a Markdown table cell (pipes escaped)."""
    return text.replace("|", "\\|")


def default_text(parameter) -> str:
    """The default as ``--set`` reads it back; a file shipped with warpfree by its path in the repository."""
    from warpfree.parameters import value_text

    value = parameter.default
    if isinstance(value, str) and os.path.isabs(value) and value.startswith(str(ROOT)):
        return os.path.relpath(value, ROOT)
    return value_text(value)


def page() -> str:
    """The page's Markdown."""
    from warpfree.scene_loader import load_scene, scene_parameters, shipped_scenes, summary_line

    lines = [INTRO.rstrip()]
    choices = {}
    for name, path in shipped_scenes().items():
        parameters = scene_parameters(load_scene(path))
        lines += ["", f"## {name}", "", summary_line(path), "",
                  "| parameter | type | default | unit | allowed | meaning |", "|---|---|---|---|---|---|"]
        for p in parameters.values():
            if p.choice is not None:
                choices[p.choice.__name__] = p.choice
            lines.append(f"| `{p.name}` | {cell(p.type_text)} | `{cell(default_text(p))}` | {cell(p.unit) or '–'} "
                         f"| {cell(p.allowed_text) or '–'} | {cell(p.meaning)} |")
    lines += ["", "## Choices", "", "What each choice offered above means.", ""]
    for name in sorted(choices):
        choice = choices[name]
        doc = (choice.__doc__ or "").strip().splitlines()[0]
        lines += [f"### {name}", "", doc, "", "| value | meaning |", "|---|---|"]
        lines += [f"| `{m.value}` | {cell(m.meaning) or '–'} |" for m in choice] + [""]
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with the committed page instead of writing it")
    args = parser.parse_args(argv)
    text = page()
    if args.check:
        same = PAGE.is_file() and PAGE.read_text(encoding="utf-8") == text
        print(f"{PAGE.relative_to(ROOT)}: {'up to date' if same else 'differs from the declarations'}")
        return 0 if same else 1
    PAGE.write_text(text, encoding="utf-8")
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
