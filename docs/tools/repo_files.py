"""MkDocs hook: the repository's files that the pages link to from outside ``docs/`` (a validation case's README, a
benchmark's results) become part of the site, so that one relative link works on GitHub and in the site.

A page links a file of the repository by its path relative to the page, as GitHub resolves it: from
``docs/validation.md``, ``[the case's README](../warpfree/validation/em_line_1d/README.md)``. MkDocs sees only
``docs/``, so the hook copies each such file into the site under ``repo/`` (``repo/warpfree/validation/em_line_1d/
README.md``: a Markdown file becomes a page outside the navigation, any other file is copied as it is), follows
the relative links of the Markdown files it copies in turn, and rewrites the links of every page to the copies. A
link to a file that does not exist is left alone, so ``mkdocs build --strict`` reports it as before.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files, InclusionLevel

#: where the copies live in the site
PREFIX = "repo/"
#: an inline Markdown link or image: ``[text](target)`` or ``[text](target "title")``
LINK = re.compile(r"(\]\()([^)\s]+)((?:\s+\"[^\"]*\")?\))")
#: the repository's root and its docs folder, set from the configuration
_root: Path | None = None
_docs = "docs"
#: repository paths (relative to the root, POSIX) of the files copied into the site
_copied: set[str] = set()


def _target(path: str) -> tuple[str, str] | None:
    """(path, #anchor) of a relative link ``path``; None for an absolute URL, an anchor alone or a root path."""
    if not path or path.startswith(("#", "/")) or re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", path):
        return None
    base, hashmark, anchor = path.partition("#")
    return base, hashmark + anchor


def _repo_path(page_repo_path: str, link: str) -> str:
    """The repository path a relative ``link`` of the file at ``page_repo_path`` points to (may start with ``..``)."""
    return posixpath.normpath(posixpath.join(posixpath.dirname(page_repo_path), link))


def _outside_docs(repo_path: str) -> bool:
    return not (repo_path == _docs or repo_path.startswith(_docs + "/") or repo_path.startswith(".."))


def _links(text: str):
    for match in LINK.finditer(text):
        target = _target(match.group(2))
        if target is not None:
            yield target[0]


def on_config(config):
    global _root, _docs
    docs_dir = Path(config["docs_dir"]).resolve()
    _root = Path(config["config_file_path"]).resolve().parent
    _docs = docs_dir.relative_to(_root).as_posix()
    return config


def on_files(files: Files, config) -> Files:
    """Copy every repository file the pages link to (and, transitively, those the copied Markdown links to)."""
    _copied.clear()
    pending = [(f"{_docs}/{page.src_uri}", Path(page.abs_src_path).read_text(encoding="utf-8"))
               for page in files.documentation_pages()]
    while pending:
        repo_page, text = pending.pop()
        for link in _links(text):
            path = _repo_path(repo_page, link)
            if not _outside_docs(path) or path in _copied or not (_root / path).is_file():
                continue
            _copied.add(path)
            source = _root / path
            if path.endswith(".md"):
                content = source.read_text(encoding="utf-8")
                pending.append((path, content))
                files.append(File.generated(config, PREFIX + path, content=content,
                                            inclusion=InclusionLevel.NOT_IN_NAV))
            else:
                files.append(File.generated(config, PREFIX + path, abs_src_path=str(source)))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Point the links to copied files at the copies; a copied page's links into ``docs/`` at the pages there."""
    src = page.file.src_uri
    repo_page = src[len(PREFIX):] if src.startswith(PREFIX) else f"{_docs}/{src}"

    def rewrite(match: re.Match) -> str:
        target = _target(match.group(2))
        if target is None:
            return match.group(0)
        path = _repo_path(repo_page, target[0])
        if path in _copied:
            new = PREFIX + path
        elif src.startswith(PREFIX) and path.startswith(_docs + "/"):
            new = path[len(_docs) + 1:]
        else:
            return match.group(0)
        return match.group(1) + posixpath.relpath(new, posixpath.dirname(src) or ".") + target[1] + match.group(3)

    return LINK.sub(rewrite, markdown)
