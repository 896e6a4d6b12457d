"""docs/reproductions.md shows what the stored notebooks printed, and nothing else.

Independent truth: the outputs stored in notebooks/*.ipynb by scripts/regenerate_notebooks.py; the table on the
page must be exactly what scripts/reproductions_table.py reads from them, so a number typed by hand, or left behind
by an earlier run, fails here.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
sys.path.insert(0, str(SCRIPTS))

import reproductions_table as table  # noqa: E402
from reproductions_rows import ROWS  # noqa: E402


def test_the_page_is_what_the_stored_notebooks_printed() -> None:
    page = table.PAGE.read_text(encoding="utf-8")
    assert table.page_with_table(page, table.render(ROWS)) == page, (
        "docs/reproductions.md differs from the stored outputs: run python scripts/reproductions_table.py"
    )


def test_a_notebook_without_a_full_run_gives_no_number() -> None:
    quote = table.Quote("any", r"error (\S+)")
    assert quote.render(lambda stem: None).startswith(table.NOT_RUN)
    assert quote.number(lambda stem: None) is None


def test_a_changed_printout_is_an_error_not_a_blank() -> None:
    quote = table.Quote("any", r"error (\S+) °C")
    with pytest.raises(table.PatternMissing, match="any"):
        quote.render(lambda stem: "the error was 0.1 K")


def test_the_last_match_and_the_template_are_used() -> None:
    quote = table.Quote("nb", r"^(\d+)³: error (\S+)", "{1} at {0}³", number_group=1)
    text = "16³: error 3e-3\n24³: error 1.4e-3"
    assert quote.render(lambda stem: text) == "1.4e-3 at 24³"
    assert quote.number(lambda stem: text) == pytest.approx(1.4e-3)


def test_every_row_has_the_papers_value_and_a_source() -> None:
    for row in ROWS:
        assert row.paper and row.source and row.item.startswith("["), row
        if row.difference != "none":
            assert row.paper_number is not None, row
