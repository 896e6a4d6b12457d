"""Sphinx extension: link the reference keys cited in the text to their row on the references page.

The code, help texts and notes cite works by keys such as ``[Chavez2020, eq. 13]`` or ``[GarnierDanes]``,
defined in the table of docs/references.md (rows ``| **Key** | work |``; tests/test_references.py checks
that every cited key is defined there).  This extension gives each row of that table the id
``ref-<key>`` and turns each cited key elsewhere (plain text only, not code) into a link to that row.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx.application import Sphinx

ROW = re.compile(r"^\| \*\*([A-Za-z0-9]+)\*\* \|", re.MULTILINE)
REFERENCES = "references"


def _keys(app: Sphinx) -> set[str]:
    return set(ROW.findall((Path(app.srcdir) / f"{REFERENCES}.md").read_text(encoding="utf-8")))


def _anchor(key: str) -> str:
    return f"ref-{key.lower()}"


def _label_rows(doctree: nodes.document, keys: set[str]) -> None:
    for row in doctree.findall(nodes.row):
        entries = list(row.findall(nodes.entry))
        if entries and entries[0].astext().strip() in keys:
            row["ids"].append(_anchor(entries[0].astext().strip()))


def _link_citations(app: Sphinx, doctree: nodes.document, docname: str, keys: set[str]) -> None:
    citation = re.compile(r"(?<=\[)(" + "|".join(sorted(map(re.escape, keys), key=len, reverse=True)) + r")(?=[\],;])"
                          r"|(?<=; )(" + "|".join(sorted(map(re.escape, keys), key=len, reverse=True)) + r")(?=[\],;])")
    target = app.builder.get_relative_uri(docname, REFERENCES)
    skip = (nodes.literal, nodes.literal_block, nodes.reference, nodes.raw, nodes.math, nodes.math_block)
    for text in list(doctree.findall(nodes.Text)):
        if isinstance(text.parent, skip) or any(isinstance(a, skip) for a in _ancestors(text)):
            continue
        source = str(text)
        matches = list(citation.finditer(source))
        if not matches:
            continue
        pieces: list[nodes.Node] = []
        last = 0
        for m in matches:
            key = m.group(0)
            pieces.append(nodes.Text(source[last:m.start()]))
            pieces.append(nodes.reference(key, key, refuri=f"{target}#{_anchor(key)}", internal=True))
            last = m.end()
        pieces.append(nodes.Text(source[last:]))
        text.parent.replace(text, pieces)


def _ancestors(node: nodes.Node) -> list[nodes.Node]:
    out = []
    while node.parent is not None:
        node = node.parent
        out.append(node)
    return out


def _resolved(app: Sphinx, doctree: nodes.document, docname: str) -> None:
    if app.builder.format != "html":
        return
    keys = _keys(app)
    if docname == REFERENCES:
        _label_rows(doctree, keys)
    else:
        _link_citations(app, doctree, docname, keys)


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("doctree-resolved", _resolved)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
