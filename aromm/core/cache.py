"""Content-addressed on-disk cache of expensive arrays (eigenbases, reduced models) as ``.npz``.

* Keys are SHA-256 digests of everything the result depends on (operators, solver options),
  built with :func:`content_key`; the file is ``<cache dir>/<kind>-<key>.npz``.
* Files are written atomically (a temporary file in the same directory, then ``os.replace``),
  so a reader never sees a half-written file, and concurrent writers of the same key are harmless.
* Files are read with ``allow_pickle=False``: only numeric and string arrays are stored.
* The cache directory is ``$AROMM_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/aromm``, else
  ``~/.cache/aromm``; never the package directory.
* It holds the kinds of :data:`KINDS`; every entry records its kind (``cache_kind``), and an entry of another
  kind, lacking an array its kind needs, holding a non-finite number, or unreadable (damaged) is rebuilt with one
  :class:`CacheWarning`.
* One build per entry at a time (:meth:`NpzCache.lock`): an exclusive ``fcntl.flock`` on ``<kind>-<key>.lock``
  beside the entry; a second process waits, then finds the entry built.  The lock file is removed by its holder
  before the release (a waiter re-opens a fresh one), so none is left behind.
"""

from __future__ import annotations

import fcntl
import hashlib
import logging
import os
import warnings
import zipfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.files import atomic_write

ENV_VAR = "AROMM_CACHE_DIR"
KIND_ENTRY = "cache_kind"  # the array naming an entry's kind
#: The kinds of entry: what each holds (docs/guide/cache.md lists them from here) and the arrays it needs.
KINDS: dict[str, tuple[str, tuple[str, ...]]] = {
    "basis": ("the Dirichlet and Steklov modes and eigenvalues (aromm.reduction.modal_bases)",
              ("vectors", "eigenvalues", "kinds", "zeta", "gram", "gram_condition")),
    "corrections": ("the static and first-order correction vectors of the loads (aromm.reduction.corrections)",
                    ("vectors", "coefficients")),
    "rom": ("the reduced model itself (projected operators, initial state, info)",
            ("capacity.names", "conductance.names")),
    "reconstruction": ("the coefficients of the reduced basis Ψ on the detailed basis, for temperature fields "
                       "(aromm.reduction.offline)", ("coefficients",)),
    "krylov-basis": ("the Krylov model's basis Ψ, for temperature fields (aromm.reduction.krylov_offline)", ("psi",)),
    "model-order": ("the order of the model last built for a scene and its settings, whatever the order asked "
                    "(aromm.api.built_order)", ("order",)),
    "referee": ("a certified modal model's worst bound over its Krylov referee's box, under both models' keys "
                "(aromm.api.reduce, aromm.reduction.referee)", ("worst",)),
    "discretisation-gap": ("identify's default discretisation row at estimates rounded to six digits "
                           "(aromm.homogenization.discretisation_gap)", ("k_model", "k_other", "slope")),
}

log = logging.getLogger(__name__)


class CacheWarning(UserWarning):
    """A cache entry could not be used (damaged, another kind at its key, non-finite values): it is rebuilt."""


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
    elif hasattr(part, "content_parts"):  # a matrix-free operator names what identifies it
        _feed(h, part.content_parts())
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
        """The stored arrays, or None when absent, or (with one :class:`CacheWarning`: it is rebuilt) unreadable,
        of another kind, incomplete or holding a non-finite number."""
        p = self.path(kind, key)
        if not p.is_file():
            return None
        try:
            with np.load(p, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
            warnings.warn(f"cache: {p} is damaged ({type(err).__name__}: {err}): rebuilt (and replaced)",
                          CacheWarning, stacklevel=2)
            return None
        found = str(arrays.pop(KIND_ENTRY)) if KIND_ENTRY in arrays else None
        missing = [a for a in KINDS[kind][1] if a not in arrays]
        broken = sorted(k for k, a in arrays.items() if a.dtype.kind in "fc" and not np.all(np.isfinite(a)))
        if (found is not None and found != kind) or missing or broken:
            what = (f"a {found} entry" if found is not None and found != kind else
                    f"an entry without {', '.join(missing)}" if missing else
                    f"an entry with non-finite values in {', '.join(broken[:3])}")
            warnings.warn(f"cache: {p} is {what}, not a {kind} entry: rebuilt (and replaced)", CacheWarning,
                          stacklevel=2)
            return None
        return arrays

    def save(self, kind: str, key: str, arrays: Mapping[str, npt.ArrayLike]) -> Path:
        """Write atomically (:func:`aromm.core.files.atomic_write`: temporary file in the cache folder, then rename)."""
        target = self.path(kind, key)
        with atomic_write(target, f"cache entry ({kind})", binary=True) as fh:
            entries = {**{k: np.asarray(v) for k, v in arrays.items()}, KIND_ENTRY: np.asarray(kind)}
            np.savez(fh, **entries)  # type: ignore[arg-type]
        return target

    @contextmanager
    def lock(self, kind: str, key: str) -> Iterator[None]:
        """Hold the exclusive lock of one entry (module docstring): build and save it within the block."""
        self.directory.mkdir(parents=True, exist_ok=True)
        path = self.directory / f"{kind}-{key}.lock"
        while True:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                log.info("cache: another process is building %s-%s; waiting for it (lock %s)", kind, key, path)
                fcntl.flock(fd, fcntl.LOCK_EX)
            try:
                current = os.stat(path).st_ino == os.fstat(fd).st_ino  # not a file its last holder removed
            except FileNotFoundError:
                current = False
            if current:
                break
            os.close(fd)
        try:
            yield
        finally:
            path.unlink(missing_ok=True)
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
