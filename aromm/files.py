"""Output files: parent folders created, unwritable paths reported by name, atomic replacement.

A result file is either complete or absent: it is written to a temporary file in the same folder
and renamed over the target (``os.replace`` is atomic on one file system), so an interrupted run
never leaves a truncated CSV or checkpoint behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from aromm.errors import InputError


def output_path(path: str | os.PathLike[str], what: str) -> Path:
    """``path`` with its missing parent folders created; InputError naming it (and ``what`` it is) otherwise.

    >>> import tempfile, pathlib
    >>> output_path(pathlib.Path(tempfile.mkdtemp()) / "new" / "fit.png", "plot").parent.is_dir()
    True
    """
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{p}: cannot write the {what} (folder {p.parent}: {err.strerror or err})") from None
    return p


@contextmanager
def atomic_write(path: str | os.PathLike[str], what: str, binary: bool = False) -> Iterator[IO]:  # type: ignore[type-arg]
    """Open a temporary file beside ``path`` for writing; on success rename it to ``path``, else delete it."""
    p = output_path(path, what)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    except OSError as err:
        raise InputError(f"{p}: cannot write the {what} ({err.strerror or err})") from None
    try:
        with os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            yield fh
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
