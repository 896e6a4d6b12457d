"""Content-addressed on-disk cache of expensive arrays (eigenbases, reduced models) as ``.npz``.

* Keys are SHA-256 digests of everything the result depends on (operators, solver options),
  built with :func:`content_key`; the file is ``<cache dir>/<kind>-<key>.npz``.
* Files are written atomically (a temporary file in the same directory, then ``os.replace``),
  so a reader never sees a half-written file, and concurrent writers of the same key are harmless.
* Files are read with ``allow_pickle=False``: only numeric and string arrays are stored.
* The cache directory is ``$AROMM_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/aromm``, else
  ``~/.cache/aromm``; never the package directory.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.files import atomic_write

ENV_VAR = "AROMM_CACHE_DIR"


def default_cache_dir() -> Path:
    """``$AROMM_CACHE_DIR``, else ``$XDG_CACHE_HOME/aromm``, else ``~/.cache/aromm`` (not created here)."""
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "aromm"


def content_key(*parts: object) -> str:
    """SHA-256 (first 24 hex digits) of arrays, sparse matrices, strings and numbers, in order."""
    h = hashlib.sha256()
    for part in parts:
        _feed(h, part)
    return h.hexdigest()[:24]


def _feed(h: hashlib._Hash, part: object) -> None:
    if sp.issparse(part):
        csr = sp.csr_array(part)
        csr.sort_indices()
        h.update(b"csr" + str(csr.shape).encode())
        for arr in (csr.indptr, csr.indices, csr.data):
            h.update(np.ascontiguousarray(arr).tobytes())
    elif isinstance(part, np.ndarray):
        h.update(b"arr" + str(part.shape).encode() + part.dtype.str.encode())
        h.update(np.ascontiguousarray(part).tobytes())
    elif isinstance(part, Mapping):
        for k in sorted(part):
            _feed(h, str(k))
            _feed(h, part[k])
    elif isinstance(part, list | tuple):
        h.update(b"seq%d" % len(part))
        for p in part:
            _feed(h, p)
    else:
        h.update(repr(part).encode())
    h.update(b"|")


class NpzCache:
    """Atomic ``.npz`` store in one directory; ``directory=None`` means :func:`default_cache_dir`."""

    def __init__(self, directory: str | os.PathLike[str] | None = None) -> None:
        self.directory = Path(directory) if directory is not None else default_cache_dir()

    def path(self, kind: str, key: str) -> Path:
        return self.directory / f"{kind}-{key}.npz"

    def load(self, kind: str, key: str) -> dict[str, np.ndarray] | None:
        """The stored arrays, or None when absent or unreadable (a damaged file counts as absent)."""
        p = self.path(kind, key)
        if not p.is_file():
            return None
        try:
            with np.load(p, allow_pickle=False) as data:
                return {name: data[name] for name in data.files}
        except (OSError, ValueError, zipfile.BadZipFile, EOFError):
            return None

    def save(self, kind: str, key: str, arrays: Mapping[str, npt.ArrayLike]) -> Path:
        """Write atomically (:func:`aromm.core.files.atomic_write`: temporary file in the cache folder, then rename)."""
        target = self.path(kind, key)
        with atomic_write(target, f"cache entry ({kind})", binary=True) as fh:
            np.savez(fh, **{k: np.asarray(v) for k, v in arrays.items()})  # type: ignore[arg-type]
        return target
