"""Labels a reader can follow: no text a user reads cites a thesis by an internal name ("seed 000 §4.3", "seed eq.
5-12", "seed-003 note") or calls PIC "PIDC". The theses are cited by author and year (docs/references.md).

Read: the documentation pages, the READMEs (the project's, the validation cases', the benchmarks'), the benchmark
results, CITATION.cff and pyproject.toml; every string literal of the Python sources of ``warpfree/``, ``kernels/``
and ``scenes/`` (read with ``ast``, so comments are left out): the module, class and function docstrings the API
reference renders and ``warpfree list`` shows, the checks' source and basis strings that the CLI prints and the
validation table holds, plot labels and titles, error messages; and the command line's help, every command's.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from helpers import ROOT

#: an internal name of a thesis: "seed 000", "Seed 002's", "seeds 003 and 002", "seed-003", "seed002_pidc";
#: "seed eq. 5-12", "seed eqs 2.30", "seed §3.1.5", "seed thesis 000", "seed note", "seed ch. 5"; "seed 4-39";
#: "The seed (004, §5.5)". Not a random seed: "seed=0", "``seed``", "(seed 1)", "3 seeds", "the seed's transient".
THESIS_NAME = re.compile(r"\bseeds?[\s_-]*0\d\d(?!\d)"
                         r"|\bseeds?\s+(?:eqs?\b|eq\.|§|thesis\b|note\b|notes\b|ch\.|chapter\b)"
                         r"|\bseeds?\s+\d+-\d+"
                         r"|\bseeds?\s*\(\s*0\d\d", re.IGNORECASE)
#: the thesis's name of the method, which warpfree calls PIC
PIDC = re.compile(r"\bpidc\b", re.IGNORECASE)


def offences(text: str) -> list[str]:
    """The internal names in ``text``, each with a little of its context."""
    found = []
    for pattern in (THESIS_NAME, PIDC):
        for m in pattern.finditer(text):
            found.append(text[max(0, m.start() - 30):m.end() + 30].replace("\n", " "))
    return found


def user_documents() -> list[Path]:
    """The Markdown and metadata files a user reads."""
    docs = sorted((ROOT / "docs").rglob("*.md"))
    docs += [ROOT / "README.md", ROOT / "CITATION.cff", ROOT / "pyproject.toml", ROOT / "bench" / "README.md"]
    docs += sorted((ROOT / "warpfree" / "validation").glob("*/README.md"))
    docs += sorted((ROOT / "bench" / "results").glob("*.md"))
    return docs


def string_literals(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every string literal of a Python file (docstrings, messages, labels, f-strings' text)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)]


def python_sources() -> list[Path]:
    return sorted(p for folder in ("warpfree", "kernels", "scenes") for p in (ROOT / folder).rglob("*.py"))


def test_documents_cite_theses_by_author_and_year():
    bad = [f"{doc.relative_to(ROOT)}: {hit}" for doc in user_documents()
           for hit in offences(doc.read_text(encoding="utf-8"))]
    assert not bad, "\n".join(bad)


def test_python_strings_cite_theses_by_author_and_year():
    """Docstrings, the checks' sources and bases, labels and messages of the package, its kernels and its scenes."""
    bad = [f"{path.relative_to(ROOT)}:{line}: {hit}" for path in python_sources()
           for line, text in string_literals(path) for hit in offences(text)]
    assert not bad, "\n".join(bad)


def test_command_line_help():
    import argparse

    from warpfree.cli import build_parser

    parser = build_parser()
    texts = [parser.format_help()]
    for action in parser._actions:  # the sub-commands' own --help
        if isinstance(action, argparse._SubParsersAction):
            texts += [sub.format_help() for sub in action.choices.values()]
    assert len(texts) > 1
    bad = [hit for text in texts for hit in offences(text)]
    assert not bad, bad


def test_the_check_finds_internal_names_and_spares_random_seeds(tmp_path):
    for text in ("seed 000 §4.3", "Seed 002's accuracy", "seeds 003 and 002", "the seed-003 note", "`seed002_pidc.md`",
                 "seed eq. 5-12", "(seed 4-39)", "seed §3.1.5", "seed thesis 000", "The seed (004, §5.5)",
                 "seed eqs 2.30-2.35", "PIDC against mesh PIC", "| pidc | 0.5 |"):
        assert offences(text), text
    for text in ("seed=0", "``seed`` is required", "random nodes (seed 1)", "3 seeds", "seed 1 / 2",
                 "above the seed's transient", "a density bunching seed", "particle-in-diffuse-cell (Marques 2008)",
                 "LayoutSeed", "Mendes (2010), §4.3"):
        assert not offences(text), text
    source = tmp_path / "module.py"
    source.write_text('# seed 000: a comment may keep it\nLABEL = f"t ({1}) seed 002 §6.2"\n', encoding="utf-8")
    assert [hit for _, text in string_literals(source) for hit in offences(text)] == [") seed 002 §6.2"]
