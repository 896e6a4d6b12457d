"""Build the table of docs/reproductions.md from the outputs stored in the notebooks.

    python scripts/reproductions_table.py            # rewrite the table between the page's markers
    python scripts/reproductions_table.py --check    # exit 1 when the page differs from the stored outputs

One row per table and figure of each source paper: the paper's value, ours in the paper's configuration,
ours with our extensions, the difference and the reason.  Every number of ours is a piece of text printed by
a notebook stored from an ``AROMM_FULL=1`` run (``scripts/regenerate_notebooks.py``), found by a regular
expression in its stored outputs and copied as printed; a notebook not (yet) stored at the papers' sizes
gives "not yet run", never a number.  A pattern that does not match the outputs of a notebook stored at the
papers' sizes is an error (the notebook's printing changed): the script says which.  The paper's values are
quotations of the papers, cited by section.  tests/test_reproductions.py checks that the page is what this
script writes.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
PAGE = ROOT / "docs" / "reproductions.md"
BEGIN = "<!-- reproductions-table: begin (written by scripts/reproductions_table.py; do not edit) -->"
END = "<!-- reproductions-table: end -->"
NOT_RUN = "not yet run"


class PatternMissing(RuntimeError):
    """A quoted pattern is not in the outputs of a notebook stored at the papers' sizes."""


def stored_outputs(stem: str) -> str | None:
    """The text outputs (streams, plain text, Markdown) of ``notebooks/<stem>.ipynb``, or None when the notebook
    is missing or not stored from an ``AROMM_FULL=1`` run."""
    path = NOTEBOOKS / f"{stem}.ipynb"
    if not path.is_file():
        return None
    nb = nbformat.read(path, as_version=4)
    if nb.metadata.get("aromm", {}).get("full") is not True:
        return None
    parts = []
    for cell in nb.cells:
        for out in cell.get("outputs", []) if cell.cell_type == "code" else []:
            if out.output_type == "stream":
                parts.append(out.text)
            else:
                data = out.get("data", {})
                parts += [data[k] for k in ("text/markdown", "text/plain") if k in data and "image/png" not in data]
    return "\n".join(parts)


@dataclass(frozen=True)
class Quote:
    """Text printed by a stored notebook: the groups of the last match of ``pattern`` put into ``template``
    (``{0}``, ``{1}`` …; default: the groups joined by " / "); ``number`` is the group compared with the paper."""

    stem: str
    pattern: str
    template: str | None = None
    number_group: int = 0

    def groups(self, outputs: Callable[[str], str | None]) -> tuple[str, ...] | None:
        text = outputs(self.stem)
        if text is None:
            return None
        matches = list(re.finditer(self.pattern, text, re.MULTILINE))
        if not matches:
            raise PatternMissing(f"notebooks/{self.stem}.ipynb: no stored output matches {self.pattern!r}")
        return matches[-1].groups()

    def render(self, outputs: Callable[[str], str | None]) -> str:
        groups = self.groups(outputs)
        if groups is None:
            return f"{NOT_RUN} (`{self.stem}`)"
        return self.template.format(*groups) if self.template else " / ".join(groups)

    def number(self, outputs: Callable[[str], str | None]) -> float | None:
        groups = self.groups(outputs)
        if groups is None:
            return None
        return float(groups[self.number_group].replace("%", "").replace(",", "").replace("−", "-"))


@dataclass(frozen=True)
class Row:
    """One table or figure of a paper (one quantity of it)."""

    item: str
    quantity: str
    paper: str
    paper_config: Quote | str
    ours: Quote | str
    reason: str
    source: str
    difference: str = "none"  # how ours compares with the paper: "relative", "ratio", "points" or "none"
    paper_number: float | None = None


def _cell(value: Quote | str, outputs: Callable[[str], str | None]) -> str:
    return value.render(outputs) if isinstance(value, Quote) else value


def _difference(row: Row, outputs: Callable[[str], str | None]) -> str:
    if row.difference == "none" or row.paper_number is None:
        return "—"
    for label, value in (("paper's config.", row.paper_config), ("extensions", row.ours)):
        if isinstance(value, Quote):
            ours = value.number(outputs)
            if ours is None:
                continue
            p = row.paper_number
            if row.difference == "relative":
                text = f"{100 * (ours / p - 1):+.1f} %"
            elif row.difference == "points":
                text = f"{ours - p:+.3g} pt"
            else:
                text = f"×{ours / p:.2g}"
            return f"{text} ({label})"
    return "—"


def render(rows: Sequence[Row], outputs: Callable[[str], str | None] = stored_outputs) -> str:
    """The Markdown table of ``rows``, numbers read from the stored notebooks through ``outputs``."""
    lines = [
        "| paper, item | quantity | paper | ours, paper's configuration | ours, with our extensions | "
        "difference | why they differ | where |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        cells = [
            r.item,
            r.quantity,
            r.paper,
            _cell(r.paper_config, outputs),
            _cell(r.ours, outputs),
            _difference(r, outputs),
            r.reason,
            r.source,
        ]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines)


def page_with_table(page: str, table: str) -> str:
    """``page`` with the text between its markers replaced by ``table``."""
    start, end = page.find(BEGIN), page.find(END)
    if start < 0 or end < start:
        raise SystemExit(f"{PAGE}: the markers {BEGIN!r} … {END!r} are missing")
    return page[: start + len(BEGIN)] + "\n" + table + "\n" + page[end:]


def main(argv: Sequence[str] | None = None) -> int:
    from reproductions_rows import ROWS

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare the page with the stored outputs, write nothing")
    args = parser.parse_args(argv)
    page = PAGE.read_text(encoding="utf-8")
    try:
        new = page_with_table(page, render(ROWS))
    except PatternMissing as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.check:
        if new != page:
            print(
                f"{PAGE.relative_to(ROOT)} differs from the stored outputs: run python scripts/reproductions_table.py",
                file=sys.stderr,
            )
            return 1
        return 0
    tmp = PAGE.with_suffix(".md.tmp")
    tmp.write_text(new, encoding="utf-8")
    tmp.replace(PAGE)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import reproductions_table  # the rows' Quote and Row are this module's, not __main__'s

    sys.exit(reproductions_table.main())
