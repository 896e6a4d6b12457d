"""Every reference key cited in the code, help texts and notebooks is defined on docs/references.md,
and nothing cites the papers by the internal names of their files ("seed 00x") or by paths outside
the repository."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("aromm", "inverse", "tests", "benchmarks", "scripts", "notebooks", "data", "docs")
SOURCES = [p for folder in FOLDERS
           for p in sorted((ROOT / folder).rglob("*")) if p.suffix in (".py", ".ipynb", ".md", ".toml")]
SOURCES = [p for p in SOURCES if p != Path(__file__).resolve()] + [ROOT / "README.md"]  # not this checker
# a citation opens with a key: [Chavez2020, eq. 13], [Quemener2012; Chavez2020, eq. 9], [GarnierDanes]
CITATION = re.compile(r"(?<![\w\]\[])\[((?:[A-Z][A-Za-z]+(?:\d{4})?)(?:[,;][^\]]*)?)\]")
UNDATED = {"GarnierDanes"}  # works without a year on the copy we have
KEY = re.compile(r"^\| \*\*([A-Za-z0-9]+)\*\* \|", re.MULTILINE)


def defined_keys() -> set[str]:
    return set(KEY.findall((ROOT / "docs" / "references.md").read_text(encoding="utf-8")))


def cited_keys(text: str) -> set[str]:
    keys = set()
    for body in CITATION.findall(text):
        for part in body.split(";"):
            head = part.strip().split(",")[0].strip()
            if head in UNDATED or re.fullmatch(r"[A-Z][A-Za-z]+\d{4}", head):
                keys.add(head)
    return keys


def test_the_references_page_defines_the_source_papers() -> None:
    assert {"Chavez2020", "Hassan2019", "GarnierDanes", "Quemener2012"} <= defined_keys()


@pytest.mark.parametrize("path", SOURCES, ids=[str(p.relative_to(ROOT)) for p in SOURCES])
def test_citations_resolve_and_name_no_internal_file(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    undefined = cited_keys(text) - defined_keys()
    assert not undefined, f"cited but not defined on docs/references.md: {sorted(undefined)}"
    assert not re.search(r"\bseed (00[0-2]\b|eq\.|table|fig|§)", text, re.IGNORECASE), "a paper cited as a seed"
    assert not re.search(r"\.\./shared|shared/method|/work/", text), "a path outside the repository"
