"""Every ``warpfree`` command the documentation prints is one the command line takes as printed: its subcommand and
options parse, its scene exists and each ``--set`` names a declared parameter with a value it accepts. (Running them
is the gallery's and the validation table's job: ``docs/tools/make_gallery.py`` runs every gallery command,
``warpfree validate`` the cases; the Python examples run in ``test_docs_examples.py``.)"""

from __future__ import annotations

import re
import shlex

import pytest

from warpfree.cli import build_parser
from warpfree.parameters import parse_overrides, scene_parameters
from warpfree.scene_loader import load_scene

from helpers import ROOT

#: a fenced block of commands or of what a terminal shows
BLOCK = re.compile(r"^```(?:bash|sh|text)\n(.*?)^```", re.S | re.M)


def documented_commands() -> list[tuple[str, str]]:
    """(page, command) of every ``warpfree ...`` line in a fenced block of the docs and the README (a leading
    ``.venv/bin/`` or ``mpiexec -n N`` dropped, lines continued with a backslash joined; a trailing comment stays for
    :func:`shlex.split` to drop)."""
    out = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for block in BLOCK.findall(page.read_text(encoding="utf-8")):
            for line in block.replace("\\\n", " ").splitlines():
                match = re.search(r"(?:^|&& |\s)(?:\.venv/bin/)?(warpfree (?:run|validate|list|bundle)(?:\s.*)?)$",
                                  line.strip())
                if match and "[" not in match.group(1) and "..." not in match.group(1):  # not a synopsis
                    out.append((str(page.relative_to(ROOT)), match.group(1)))
    return out


COMMANDS = documented_commands()


def test_the_docs_print_commands_of_every_kind():
    kinds = {command.split()[1] for _, command in COMMANDS}
    assert {"run", "validate"} <= kinds and len(COMMANDS) >= 40


@pytest.mark.parametrize("page,command", COMMANDS, ids=[f"{p}:{c[:60]}" for p, c in COMMANDS])
def test_a_documented_command_is_taken_as_printed(page, command):
    args = build_parser().parse_args(shlex.split(command, comments=True)[1:])
    if args.command == "run" and args.scene:
        module = load_scene(str(ROOT / args.scene) if args.scene.endswith(".py") else args.scene)
        parse_overrides(args.overrides, scene_parameters(module))
