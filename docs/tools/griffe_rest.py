"""A griffe extension for the API reference: warpfree's docstrings are written in reST (Sphinx roles such as
``:class:`~warpfree.run.Run```, double-backtick literals, "Parameters" blocks of ``name: text`` lines under a dashed
underline); mkdocstrings shows docstrings as Markdown. This rewrites that markup into Markdown before rendering: a
role becomes inline code (the last name with ``~``, the whole path without), a dashed title a bold label, and the
lines of a Parameters block a bullet list. The docstrings themselves are not changed."""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|exc|obj):`(~?)([^`]+)`")
UNDERLINE = re.compile(r"^\s*-{3,}\s*$")
ENTRY = re.compile(r"^(\w[\w, *]*?): (.*)$")


def _role(match: re.Match) -> str:
    short, target = match.groups()
    return f"`{target.rsplit('.', 1)[-1] if short else target}`"


def markdown_from_rest(text: str) -> str:
    """The docstring ``text`` with its reST roles, section titles and parameter blocks as Markdown."""
    lines = ROLE.sub(_role, text).splitlines()
    out: list[str] = []
    in_block = False
    for line in lines:
        if UNDERLINE.match(line) and out and out[-1].strip():
            out[-1] = f"**{out[-1].strip()}**"
            out.append("")
            in_block = True
            continue
        if not line.strip():
            in_block = False
        elif in_block:
            entry = None if line[:1].isspace() else ENTRY.match(line)
            line = f"- `{entry.group(1)}`: {entry.group(2)}" if entry else f"    {line.strip()}"
        out.append(line)
    return "\n".join(out)


class RestToMarkdown(griffe.Extension):
    """Rewrites every object's docstring with :func:`markdown_from_rest` as griffe loads it."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown_from_rest(obj.docstring.value)
