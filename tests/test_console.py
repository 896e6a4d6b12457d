"""ASCII fallbacks of the command line (aromm.cli.console): every symbol the commands print has a spelling."""

from __future__ import annotations

import io
import sys
import tokenize
from pathlib import Path

import pytest

from aromm.cli.console import Fallback, fallback_streams, to_ascii, transliterate

CLI = Path(__file__).resolve().parent.parent / "aromm" / "cli"


def printed_symbols() -> set[str]:
    """Non-ASCII characters in the string literals of the command-line modules (what they can print)."""
    out: set[str] = set()
    for module in (m for m in CLI.glob("*.py") if m.name != "console.py"):
        with module.open("rb") as fh:
            for token in tokenize.tokenize(fh.readline):
                if token.type in (tokenize.STRING, getattr(tokenize, "FSTRING_MIDDLE", -1)):
                    out |= {c for c in token.string if not c.isascii()}
    return out


def test_every_symbol_the_commands_print_has_an_ascii_spelling() -> None:
    symbols = printed_symbols() | set("k̄ñÑ°³²×−")
    unknown = sorted(c for c in symbols if to_ascii(c) == "?")
    assert not unknown, f"no ASCII spelling for {unknown}: add them to aromm.cli.console.ASCII"
    assert all(to_ascii(c).isascii() for c in symbols)


@pytest.mark.parametrize("encoding", ["ascii", "latin-1", "cp1252"])
def test_the_fallback_stream_writes_only_what_the_console_encodes(encoding: str) -> None:
    raw = io.BytesIO()
    target = io.TextIOWrapper(raw, encoding=encoding, errors="strict")
    Fallback(target).write("k̄ (W/(m K)): 0.19, c̄ = 3e6 J/(m³ K), ñ = 200, T̄_z0 (°C), Ñ = 320\n")
    target.flush()
    text = raw.getvalue().decode(encoding)
    assert "kbar" in text and "cbar" in text  # a combining macron is in none of them
    assert ("ñ = 200" if encoding != "ascii" else "n~ = 200") in text  # kept where the console has it
    assert text == transliterate(text, encoding)


def test_utf8_streams_are_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    stream = io.TextIOWrapper(io.BytesIO(), encoding="utf-8")
    monkeypatch.setattr(sys, "stdout", stream)
    with fallback_streams():
        assert sys.stdout is stream


def test_memory_exhausted_is_a_message_and_exit_code_1_not_a_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    """A command that runs out of memory (CHOLMOD on a 128³ probe did) ends with one line saying what to change."""
    import click

    from aromm.cli.common import EXIT_NUMERICAL, run_guarded

    @click.group()
    def cli() -> None:
        pass

    @cli.command("big")
    def big() -> None:
        raise MemoryError

    assert run_guarded(cli, ["big"]) == EXIT_NUMERICAL
    err = capsys.readouterr().err
    assert err.startswith("aromm: out of memory") and "--solver mg" in err and "Traceback" not in err
