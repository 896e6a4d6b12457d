"""ASCII fallbacks for a console that cannot print the toolkit's symbols (k̄, ñ, °C, m³, ...).

The commands print symbols such as ``k̄`` (k + combining macron), ``ñ``, ``°C``, ``m³``, ``×``.  On a
console whose encoding lacks them (``PYTHONIOENCODING=ascii``, a latin-1 terminal) printing would raise
``UnicodeEncodeError``, and click re-encodes an ASCII stream as UTF-8 (mojibake).  :func:`fallback_streams`
puts a thin stream in front of stdout and stderr that replaces what the real stream cannot encode:
``k̄`` → ``kbar``, ``ñ`` → ``n~``, ``°C`` → ``degC``, ``³`` → ``3``, anything else unknown → ``?``.
"""

from __future__ import annotations

import io
import sys
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

#: Replacements tried before the compatibility decomposition (NFKD) of a character.
ASCII = {"°": "deg", "×": "x", "−": "-", "–": "-", "—": "-", "‖": "||", "≤": "<=", "≥": ">=", "±": "+/-",
         "µ": "u", "μ": "u", "·": "*", "→": "->", "≈": "~", "…": "...", "’": "'", "‘": "'", "“": '"', "”": '"',
         "φ": "phi", "β": "beta", "δ": "delta", "λ": "lambda", "σ": "sigma", "τ": "tau", "ρ": "rho", "π": "pi",
         "ξ": "xi", "Σ": "Sum", "§": "Sec.", "↔": "<->", "\u0304": "bar", "\u0303": "~", "\u0302": "^"}
PROBE = "k̄ñÑ°C³²×−"  # what the commands print; a stream that encodes these needs no fallback


def encodable(text: str, encoding: str) -> bool:
    try:
        text.encode(encoding)
    except (UnicodeEncodeError, LookupError):
        return False
    return True


def to_ascii(char: str) -> str:
    """An ASCII spelling of one character (table above, else its decomposition without accents, else ``?``)."""
    if char in ASCII:
        return ASCII[char]
    parts = unicodedata.normalize("NFKD", char)
    spelled = "".join(ASCII.get(c, c) for c in parts if c.isascii() or c in ASCII)
    return spelled or "?"


def transliterate(text: str, encoding: str) -> str:
    """``text`` with every character ``encoding`` cannot encode replaced by :func:`to_ascii`.

    >>> transliterate("k̄ = 0.2 W/(m K), ñ = 8, T̄ (°C), c̄ (J/(m³ K)), Ñ", "ascii")
    'kbar = 0.2 W/(m K), n~ = 8, Tbar (degC), cbar (J/(m3 K)), N~'
    """
    if encodable(text, encoding):
        return text
    return "".join(c if encodable(c, encoding) else to_ascii(c) for c in text)


class Fallback(io.TextIOBase):
    """A text stream writing to ``target`` through :func:`transliterate` (announces UTF-8 so that click passes
    text through unchanged)."""

    def __init__(self, target: TextIO) -> None:
        super().__init__()
        self.target = target
        self.target_encoding = getattr(target, "encoding", None) or "ascii"

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return "utf-8"

    def write(self, text: str) -> int:
        self.target.write(transliterate(text, self.target_encoding))
        return len(text)

    def flush(self) -> None:
        self.target.flush()

    def isatty(self) -> bool:
        return self.target.isatty()

    def fileno(self) -> int:
        return self.target.fileno()

    def writable(self) -> bool:
        return True


@contextmanager
def fallback_streams() -> Iterator[None]:
    """Within the block, ``sys.stdout`` and ``sys.stderr`` print ASCII fallbacks when they cannot encode
    :data:`PROBE`; streams that can are left alone."""
    saved = sys.stdout, sys.stderr
    if not encodable(PROBE, getattr(sys.stdout, "encoding", None) or "ascii"):
        sys.stdout = Fallback(saved[0])  # type: ignore[assignment]
    if not encodable(PROBE, getattr(sys.stderr, "encoding", None) or "ascii"):
        sys.stderr = Fallback(saved[1])  # type: ignore[assignment]
    try:
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        sys.stdout, sys.stderr = saved
