"""LICENSE and CITATION.cff say what pyproject.toml says: the MIT license, and a valid Citation File Format 1.2.0
record of this version of warpfree."""

from __future__ import annotations

import re

import pytest

import warpfree

from helpers import ROOT

#: the top-level keys of CFF 1.2.0 (https://github.com/citation-file-format/citation-file-format, schema.json)
CFF_KEYS = {"abstract", "authors", "cff-version", "commit", "contact", "date-released", "doi", "identifiers",
            "keywords", "license", "license-url", "message", "preferred-citation", "references", "repository",
            "repository-artifact", "repository-code", "title", "type", "url", "version"}
CFF_REQUIRED = {"cff-version", "message", "title", "authors"}


def citation() -> dict:
    yaml = pytest.importorskip("yaml", reason="PyYAML reads CITATION.cff (it comes with the docs extra)")
    return yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))


def test_citation_is_a_valid_cff_record_of_this_version():
    record = citation()
    assert CFF_REQUIRED <= set(record) and set(record) <= CFF_KEYS, sorted(set(record) ^ CFF_KEYS)
    assert record["cff-version"] == "1.2.0" and record["type"] == "software"
    assert record["version"] == warpfree.__version__
    assert record["authors"] == [{"name": "the warpfree developers"}]  # an entity, not a person
    assert record["license"] == "MIT"
    assert record["abstract"].strip() and record["title"].strip() and record["message"].strip()
    assert record["keywords"] and all(isinstance(k, str) and k for k in record["keywords"])


def test_license_is_the_mit_license_pyproject_names():
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'^license = "MIT"$', pyproject, re.M) and re.search(r'^license-files = \["LICENSE"\]$', pyproject,
                                                                            re.M)
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "Copyright (c) 2026 the warpfree developers" in text
    assert re.search(r"Permission is hereby granted, free of charge", text)
