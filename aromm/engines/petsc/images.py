"""The image of a scene file, opened on every rank for reading by boxes; converted once where it cannot be.

``.npy``, raw bytes and TIFF stacks stored one page per slice are read by parts
(:class:`aromm.microstructure.boxes.ImageBoxes`): every rank opens the header and reads its box.  A ``.npz``
(compressed: not seekable), a TIFF file not stored page by page, and a generated image (``geometry.generator``)
cannot be: rank 0 alone reads or generates the whole image once, writes it as a ``.npy`` under the cache
directory (``$AROMM_CACHE_DIR/images/<hash>.npy``, named by a hash of the source file's path, size and
modification time, or of the generator's table), logs a line saying so, and every rank then reads its box of
that ``.npy``.  A later run on the same source finds the ``.npy`` and skips the conversion.  Input files are
never written.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.cache import content_key, default_cache_dir
from aromm.core.errors import InputError
from aromm.core.files import atomic_write
from aromm.engines.petsc import runtime
from aromm.microstructure.boxes import ImageBoxes, readable_by_parts
from aromm.microstructure.io import VoxelSize, as_voxel_size, load_image

log = logging.getLogger(__name__)


def converted_path(key: str) -> Path:
    """Where the ``.npy`` copy of a source that cannot be read by parts is kept."""
    return default_cache_dir() / "images" / f"{key}.npy"


def _npz_voxel_size(path: Path) -> VoxelSize | None:
    """The ``voxel_size`` entry of a ``.npz`` (read alone: the labels stay compressed on disk)."""
    with np.load(path, allow_pickle=False) as archive:
        if "voxel_size" not in archive.files:
            return None
        return as_voxel_size(archive["voxel_size"], f"{path}: key 'voxel_size'")


def convert_once(key: str, make: Callable[[], np.ndarray], why: str, comm: Any) -> Path:
    """The ``.npy`` of ``key``, made by rank 0 with ``make()`` when absent (collective; an InputError on rank 0
    is raised on every rank)."""
    target = converted_path(key)
    message = None
    if runtime.is_root(comm):
        try:
            if not target.exists():
                labels = make()
                with atomic_write(target, "converted image", binary=True) as fh:
                    np.save(fh, np.asarray(labels))
                log.info("%s: converted once by rank 0 to %s (%d bytes) so that every rank reads only its box",
                         why, target, target.stat().st_size)
        except InputError as err:
            message = str(err)
    message = runtime.mpi(comm).bcast(message, root=0)
    if message is not None:
        raise InputError(message)
    return target


def open_image(file: Path, shape: tuple[int, ...] | None, dtype: str | None, comm: Any) -> ImageBoxes:
    """``file`` opened for reading by boxes (collective), converted once when it cannot be read by parts."""
    if readable_by_parts(file, shape):
        return ImageBoxes.open(file, shape=shape, dtype=dtype)
    stat = file.stat()
    key = content_key("image file", str(file.resolve()), stat.st_size, stat.st_mtime_ns, shape, dtype)
    why = f"{file} ({'.npz is compressed' if file.suffix.lower() == '.npz' else 'not one TIFF page per z slice'})"
    target = convert_once(key, lambda: load_image(file, shape=shape, dtype=dtype)[0], why, comm)
    voxel = _npz_voxel_size(file) if file.suffix.lower() == ".npz" else None
    return replace(ImageBoxes.open(target), source=str(file), voxel_size=voxel)


def generated_image(scene_file: Path, geometry: Mapping[str, Any], make: Callable[[], np.ndarray],
                    comm: Any) -> ImageBoxes:
    """A generated image (``make()``, called by rank 0 only) opened for reading by boxes (collective)."""
    key = content_key("generated image", json.dumps(dict(geometry), sort_keys=True, default=str))
    why = f"{scene_file}: geometry.generator = {geometry.get('generator')!r} (a generated image)"
    target = convert_once(key, make, why, comm)
    return replace(ImageBoxes.open(target), source=f"{scene_file}: generated image")
