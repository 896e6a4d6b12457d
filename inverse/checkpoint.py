"""Checkpoints of a long identification: ``.npz`` files written atomically, read without pickle.

A checkpoint holds named arrays plus a ``problem`` string identifying what was being solved
(unknowns and bounds, fixed values, seed, swarm size, measurements digest, model types and
outputs); resuming with another problem is refused.  A change inside a model of the same type
(e.g. another reduced order) is not detected.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from aromm.core.errors import InputError
from aromm.core.files import OutputKind, atomic_write, npz_with, read_npz
from inverse.measurements import Measurements

#: What ``--checkpoint`` writes: an ``.npz`` archive with a ``problem`` entry.
CHECKPOINT = OutputKind("identification checkpoint (.npz)", npz_with("problem"))


def measurements_digest(measurements: Sequence[Measurements]) -> str:
    """Content hash of times, face names and values of every scenario."""
    h = hashlib.sha256()
    for m in measurements:
        h.update(np.ascontiguousarray(m.t, dtype=float).tobytes())
        for face in m.faces:
            h.update(face.encode())
            h.update(np.ascontiguousarray(m.values[face], dtype=float).tobytes())
    return h.hexdigest()[:20]


def problem_key(description: Mapping[str, object]) -> str:
    """Canonical JSON of the problem description (sorted keys)."""
    return json.dumps(description, sort_keys=True, default=str)


def save(path: str | os.PathLike[str], problem: str, arrays: Mapping[str, np.ndarray]) -> None:
    """Write ``arrays`` and the ``problem`` key to ``path``, atomically (:func:`aromm.core.files.atomic_write`)."""
    with atomic_write(path, "identification checkpoint", binary=True) as fh:
        payload = {"problem": np.asarray(problem), **{k: np.asarray(v) for k, v in arrays.items()}}
        np.savez(fh, **payload)  # type: ignore[arg-type]  # numpy's stub confuses **arrays with allow_pickle


def read(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The arrays of a checkpoint file (with its ``problem`` entry); InputError naming the file when it is empty,
    truncated or something else."""
    return read_npz(path, "identification checkpoint (.npz written by --checkpoint)", ("problem",))


def load(path: str | os.PathLike[str], problem: str) -> dict[str, np.ndarray]:
    """Arrays of a checkpoint written for the same ``problem``; InputError otherwise."""
    p = Path(path)
    arrays = read(p)
    stored = str(arrays.pop("problem"))
    if stored != problem:
        raise InputError(f"{p}: this checkpoint was written for another identification problem;\n"
                         f"  checkpoint: {stored}\n  now:        {problem}\n"
                         "delete it or run without --resume")
    return arrays
