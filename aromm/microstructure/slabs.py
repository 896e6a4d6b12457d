"""Read a voxel label image one z-slab at a time, without holding the whole image.

A distributed engine gives each process the voxel layers ``k0 <= k < k1`` of the image (a z-slab, as a
tomography stack is read page by page).  :class:`ImageSlabs` knows the image's shape from the file header
and reads a slab on demand:

* ``.npy``: memory-mapped (``np.load(mmap_mode="r")``); only the slab's bytes are copied into memory
  (a C-ordered ``[x, y, z]`` array stores z fastest, so the operating system pages in the whole file once,
  but the process keeps only its slab);
* ``.tif`` / ``.tiff`` multi-page file or directory of single-page slices: one page (one z slice, rows = y,
  columns = x) per layer (a TIFF not stored page by page is read whole);
* raw bytes with ``shape`` and ``dtype`` (x fastest, z slowest): memory-mapped, the slab is contiguous;
* ``.npz`` (compressed, not seekable) and in-memory arrays: read whole once, then sliced.

Every slab is checked and returned as ``int32`` by :func:`aromm.microstructure.io.as_labels`, indexed
``[x, y, z - k0]``.  The whole-image reader is :func:`aromm.microstructure.io.load_image`; both read
the same voxels (tests/test_slabs.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.microstructure.io import (
    TIFF_SUFFIXES,
    LabelImage,
    VoxelSize,
    _natural_key,
    as_labels,
    load_image,
)


@dataclass(frozen=True)
class ImageSlabs:
    """A label image of ``shape`` (nx, ny, nz) read by z-slabs; ``voxel_size`` when the file stores one."""

    shape: tuple[int, int, int]
    source: str
    _read: Callable[[int, int], np.ndarray]
    voxel_size: VoxelSize | None = None

    def read(self, k0: int, k1: int) -> LabelImage:
        """Voxel layers ``k0 <= k < k1`` as an int32 array ``[x, y, k - k0]``."""
        nz = self.shape[2]
        if not 0 <= k0 < k1 <= nz:
            raise InputError(f"{self.source}: z-slab [{k0}, {k1}) outside the image's {nz} layers")
        return as_labels(np.ascontiguousarray(self._read(k0, k1)), f"{self.source} (layers {k0}..{k1 - 1})")

    def labels_present(self, k0: int, k1: int) -> set[int]:
        """The labels found in layers ``k0 <= k < k1``."""
        return {int(v) for v in np.unique(self.read(k0, k1))}

    @classmethod
    def from_array(cls, labels: npt.ArrayLike, source: str = "labels") -> ImageSlabs:
        image = as_labels(labels, source)
        shape = (int(image.shape[0]), int(image.shape[1]), int(image.shape[2]))
        return cls(shape, source, lambda k0, k1: image[:, :, k0:k1])

    @classmethod
    def open(cls, path: str | Path, shape: Sequence[int] | None = None,
             dtype: npt.DTypeLike | None = None) -> ImageSlabs:
        """Open ``path`` (formats of :func:`aromm.microstructure.io.load_image`) reading the header only."""
        path = Path(path)
        if not path.exists():
            raise InputError(f"{path}: no such file or directory")
        suffix = path.suffix.lower()
        if path.is_dir():
            return _tiff_directory(path)
        if suffix == ".npy":
            return _npy(path)
        if suffix in TIFF_SUFFIXES:
            return _tiff_file(path)
        if suffix == ".npz" or shape is None:
            labels, voxel = load_image(path, shape=shape, dtype=dtype)
            whole = cls.from_array(labels, str(path))
            return cls(whole.shape, str(path), whole._read, voxel)
        return _raw(path, shape, "uint8" if dtype is None else dtype)


def _checked_shape(path: Path, shape: tuple[int, ...]) -> tuple[int, int, int]:
    if len(shape) != 3 or min(shape) < 1:
        raise InputError(f"{path}: a label image must be 3-D [x, y, z] and non-empty, got shape {shape}")
    return (int(shape[0]), int(shape[1]), int(shape[2]))


def _npy(path: Path) -> ImageSlabs:
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise InputError(f"{path}: not a readable .npy array ({err})") from None
    return ImageSlabs(_checked_shape(path, array.shape), str(path), lambda k0, k1: np.array(array[:, :, k0:k1]))


def _raw(path: Path, shape: Sequence[int], dtype: npt.DTypeLike) -> ImageSlabs:
    kind = np.dtype(dtype)
    dims = _checked_shape(path, tuple(int(n) for n in shape))
    expected = math.prod(dims) * kind.itemsize
    if path.stat().st_size != expected:
        raise InputError(f"{path}: raw file has {path.stat().st_size} bytes but shape {dims} of {kind} "
                         f"needs {expected}")
    array = np.memmap(path, dtype=kind, mode="r", shape=dims, order="F")
    return ImageSlabs(dims, str(path), lambda k0, k1: np.array(array[:, :, k0:k1]))


def _page_reader(pages: Callable[[int], np.ndarray]) -> Callable[[int, int], np.ndarray]:
    def read(k0: int, k1: int) -> np.ndarray:
        return np.stack([pages(k).T for k in range(k0, k1)], axis=2)  # page rows = y, columns = x

    return read


def _tiff_file(path: Path) -> ImageSlabs:
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            count = len(tif.pages)
            first = tif.pages[0].shape
    except (OSError, ValueError, IndexError) as err:
        raise InputError(f"{path}: not a readable TIFF file ({err})") from None
    if len(first) != 2 or count < 2:  # not one page per z slice: read whole, as load_image does
        labels, _ = load_image(path)
        return ImageSlabs.from_array(labels, str(path))

    def page(k: int) -> np.ndarray:
        with tifffile.TiffFile(path) as tif:
            return np.asarray(tif.pages[k].asarray())

    return ImageSlabs((int(first[1]), int(first[0]), count), str(path), _page_reader(page))


def _tiff_directory(path: Path) -> ImageSlabs:
    import tifffile

    files = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in TIFF_SUFFIXES),
                   key=lambda p: _natural_key(p.name))
    if not files:
        raise InputError(f"{path}: directory holds no .tif/.tiff slices")
    first = tifffile.imread(files[0]).shape
    if len(first) != 2:
        raise InputError(f"{files[0]}: a slice must be one 2-D single-channel page, got shape {first}")

    def page(k: int) -> np.ndarray:
        data = np.asarray(tifffile.imread(files[k]))
        if data.shape != first:
            raise InputError(f"{files[k]}: slice shape {data.shape} differs from {files[0].name} {first}")
        return data

    return ImageSlabs((int(first[1]), int(first[0]), len(files)), str(path), _page_reader(page))
