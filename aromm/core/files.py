"""Output files: checked before the work, written atomically, never over a file aromm did not write.

The rules every command follows (issue 10, docs/design.md "Exit codes"):

* **Never an input.** An output that is the same file as one of the command's inputs (the scene, its image,
  mesh or histories, a measurement CSV, a packing) is refused, even with ``--force``.  Paths are compared by
  identity (:func:`same_file`: ``os.path.samefile`` through symlinks and hard links, ``./x`` and ``x``).
* **Only our own files are replaced.** An existing output is replaced when it is recognisably one of ours
  (:class:`OutputKind`: each writer knows how to recognise what it wrote, e.g. a checkpoint's ``problem``
  entry) or with ``--force``; otherwise the command stops (exit 2) naming the path and the option.
* **Checked before the work** (:func:`check_output`, :func:`check_folder`): not a folder, its folder writable
  or creatable, nothing created by the check itself.
* **Atomic** (:func:`atomic_path`, :func:`atomic_write`, the one writer): a temporary file beside the target,
  renamed over it (``os.replace`` is atomic on one file system), so an interrupted run never leaves a
  truncated file; the file gets the usual permissions ``0666 & ~umask`` (``tempfile.mkstemp`` makes 0600).
"""

from __future__ import annotations

import os
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from aromm.core.errors import InputError

PathLike = str | os.PathLike[str]
#: An input of a command and its role in messages, e.g. ``(Path("s.toml"), "the scene file")``.
Input = tuple[PathLike, str]
SIGNATURE_BYTES = 65536  # head and tail of a file searched for a writer's signature


@dataclass(frozen=True)
class OutputKind:
    """What an output file is (``what``, for messages) and how to recognise one aromm wrote (``ours``)."""

    what: str
    ours: Callable[[Path], bool]


def npz_with(*entries: str) -> Callable[[Path], bool]:
    """Recogniser of an ``.npz`` archive holding (at least) the arrays ``entries``."""
    def ours(path: Path) -> bool:
        try:
            with zipfile.ZipFile(path) as archive:
                names = set(archive.namelist())
        except (OSError, zipfile.BadZipFile, ValueError):
            return False
        return all(f"{e}.npy" in names for e in entries)
    return ours


def signed(signature: bytes) -> Callable[[Path], bool]:
    """Recogniser of a file whose first or last 64 KiB contain ``signature`` (case-insensitive), e.g. the
    ``Software: Matplotlib`` chunk of a PNG or the ``created by meshio`` comment of a VTU file."""
    low = signature.lower()

    def ours(path: Path) -> bool:
        try:
            with path.open("rb") as fh:
                head = fh.read(SIGNATURE_BYTES)
                fh.seek(max(0, path.stat().st_size - SIGNATURE_BYTES))
                tail = fh.read()
        except OSError:
            return False
        return low in head.lower() or low in tail.lower()
    return ours


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` name one existing file (symlinks, hard links, relative spellings).

    >>> import tempfile, pathlib, os
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "x").write_text("1"); os.link(d / "x", d / "y")
    >>> same_file(d / "x", d / "." / "y"), same_file(d / "x", d / "z")
    (True, False)
    """
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (or cannot be examined): not one existing file
        return False


def _writable_folder(folder: Path, what: str, option: str) -> None:
    """The nearest existing ancestor of ``folder`` (which may not exist yet) is a writable folder."""
    existing = folder
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"{option}: cannot write the {what} under {folder}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"{option}: cannot write the {what} under {folder}: folder {existing} is not writable")


def check_output(path: PathLike, kind: OutputKind, *, inputs: Iterable[Input] = (), force: bool = False,
                 option: str = "--out") -> Path:
    """``path`` if a command may write ``kind`` there; InputError naming ``option`` and the path otherwise.

    Refused: one of ``inputs`` (always), a folder, a place whose folder cannot be written, and an existing
    file that ``kind`` does not recognise as ours unless ``force``.  Nothing is created.
    """
    p = Path(path)
    for source, role in inputs:
        if same_file(p, source):
            raise InputError(f"{option}: {p} is {role}, an input of this command; write the {kind.what} "
                             "elsewhere (inputs are never overwritten, not even with --force)")
    if p.is_dir():
        raise InputError(f"{option}: {p} is a folder; give a file name for the {kind.what}")
    _writable_folder(p.parent, kind.what, option)
    if p.exists() and not force and not kind.ours(p):
        article = "an" if kind.what[0] in "aeiou" else "a"
        raise InputError(f"{option}: {p} exists and is not {article} {kind.what} written by aromm; choose another "
                         "path or pass --force to replace it")
    return p


def check_folder(path: PathLike, what: str, option: str) -> Path:
    """``path`` if it is a folder, or can be created, and can be written; InputError naming ``option`` otherwise."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{option}: {p} is a file, not a folder; give a folder for the {what}")
    _writable_folder(p, what, option)
    return p


def distinct(outputs: Sequence[tuple[PathLike | None, str]]) -> None:
    """Refuse two options naming one output file (``(path or None, option)`` pairs)."""
    given = [(Path(p), o) for p, o in outputs if p is not None]
    for i, (p, o) in enumerate(given):
        for q, other in given[i + 1:]:
            if same_file(p, q) or p.resolve() == q.resolve():
                raise InputError(f"{o} and {other} name the same file {p}; give each output its own path")


def output_path(path: PathLike, what: str) -> Path:
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


def _umask() -> int:
    """The process umask, read without changing it where the system tells it (Linux), else set and restored."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: PathLike, what: str) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix, for writers that pick a format from it); on success it is
    renamed to ``path`` with permissions ``0666 & ~umask``, else deleted.  OSError becomes InputError naming it."""
    p = output_path(path, what)
    try:
        fd, name = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=f".tmp{p.suffix}", dir=p.parent)
    except OSError as err:
        raise InputError(f"{p}: cannot write the {what} ({err.strerror or err})") from None
    tmp = Path(name)
    try:
        try:
            os.fchmod(fd, 0o666 & ~_umask())
        finally:
            os.close(fd)
        yield tmp
        os.replace(tmp, p)
    except OSError as err:
        raise InputError(f"{p}: cannot write the {what} ({err.strerror or err})") from None
    finally:
        if tmp.exists():
            tmp.unlink()


def save_figure(figure: Any, path: PathLike, what: str, dpi: int = 120) -> Path:
    """Write a matplotlib figure to ``path`` atomically (:func:`atomic_path`), the format from the suffix."""
    p = Path(path)
    with atomic_path(p, what) as tmp:
        figure.savefig(tmp, dpi=dpi, format=p.suffix.lstrip(".").lower() or None)
    return p


@contextmanager
def atomic_write(path: PathLike, what: str, binary: bool = False) -> Iterator[IO]:  # type: ignore[type-arg]
    """Open a temporary file beside ``path`` for writing (:func:`atomic_path`); on success it replaces ``path``."""
    with atomic_path(path, what) as tmp, tmp.open("wb") if binary else tmp.open("w", encoding="utf-8",
                                                                               newline="") as fh:
        yield fh


def read_npz(path: PathLike, what: str, required: Sequence[str]) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` file read without pickle; InputError naming the file when it is missing,
    empty, truncated, not an archive, or lacks one of the ``required`` arrays."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: {what} not found" if not p.exists() else f"{p}: is a folder, not a {what}")
    try:
        data = np.load(p, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise ValueError("a single array, not an .npz archive")
        with data:
            arrays = {k: np.array(data[k]) for k in data.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as err:
        detail = "empty file" if p.stat().st_size == 0 else str(err) or type(err).__name__
        raise InputError(f"{p}: not a readable {what} ({detail})") from None
    missing = [k for k in required if k not in arrays]
    if missing:
        raise InputError(f"{p}: not a {what} (missing array(s) {', '.join(missing)}; "
                         f"needs {', '.join(required)})")
    return arrays
