"""Read one box of a voxel label image, without holding the whole image.

A distributed engine gives each process a box of voxels ``lo <= c < hi`` on each axis (aromm.engines.petsc.layout).
:class:`ImageBoxes` knows the image's shape from the file header and reads a box on demand, holding only the
box (as the file's dtype, then as int32) and, for TIFF, one page at a time:

* ``.npy`` (C or Fortran order): memory-mapped (``np.load(mmap_mode="r")``); slicing copies only the box's
  voxels into the process (the operating system may page in more of the file, as shared page cache);
* raw bytes with ``shape`` and ``dtype`` (x fastest, z slowest): memory-mapped at the file's offsets, the same;
* ``.tif`` / ``.tiff`` multi-page file or directory of single-page slices: one page (one z slice, rows = y,
  columns = x) per layer of the box, cropped to the box's x and y ranges before the next page is read;
* ``.npz`` (compressed, not seekable) and TIFF files not stored one page per slice cannot be read by parts:
  :func:`readable_by_parts` says so, and :meth:`ImageBoxes.open` reads them whole (the petsc engine converts
  them once to a ``.npy`` instead, aromm.engines.petsc.images); in-memory arrays are sliced.

Every box is checked and returned as ``int32`` by :func:`aromm.microstructure.io.as_labels`, indexed
``[x - x0, y - y0, z - z0]``.  The whole-image reader is :func:`aromm.microstructure.io.load_image`; both read
the same voxels (tests/test_boxes.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
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

#: Voxels ``lo <= c < hi`` on the x, y and z axes.
Box = tuple[tuple[int, int], tuple[int, int], tuple[int, int]]


def whole_box(shape: Sequence[int]) -> Box:
    return ((0, int(shape[0])), (0, int(shape[1])), (0, int(shape[2])))


@dataclass(frozen=True)
class ImageBoxes:
    """A label image of ``shape`` (nx, ny, nz) read by boxes; ``voxel_size`` when the file stores one."""

    shape: tuple[int, int, int]
    source: str
    _read: Callable[[Box], np.ndarray]
    voxel_size: VoxelSize | None = None

    def read(self, box: Box) -> LabelImage:
        """The voxels of ``box`` as an int32 array ``[x - x0, y - y0, z - z0]``."""
        for (lo, hi), n, axis in zip(box, self.shape, "xyz", strict=True):
            if not 0 <= lo < hi <= n:
                raise InputError(f"{self.source}: box {axis} range [{lo}, {hi}) outside the image's {n} voxels")
        (x0, x1), (y0, y1), (z0, z1) = box
        return as_labels(self._read(box), f"{self.source} (box x {x0}..{x1 - 1}, y {y0}..{y1 - 1}, z {z0}..{z1 - 1})")

    def labels_present(self, box: Box) -> set[int]:
        """The labels found in ``box``."""
        return {int(v) for v in np.unique(self.read(box))}

    @classmethod
    def from_array(cls, labels: npt.ArrayLike, source: str = "labels", voxel_size: VoxelSize | None = None,
                   ) -> ImageBoxes:
        image = as_labels(labels, source)
        shape = (int(image.shape[0]), int(image.shape[1]), int(image.shape[2]))
        return cls(shape, source, lambda box: image[_slices(box)], voxel_size)

    @classmethod
    def open(cls, path: str | Path, shape: Sequence[int] | None = None,
             dtype: npt.DTypeLike | None = None) -> ImageBoxes:
        """Open ``path`` (formats of :func:`aromm.microstructure.io.load_image`) reading the header only (the
        whole image when :func:`readable_by_parts` is False)."""
        path = Path(path)
        if not path.exists():
            raise InputError(f"{path}: no such file or directory")
        suffix = path.suffix.lower()
        if path.is_dir():
            return _tiff_directory(path)
        if not readable_by_parts(path, shape):
            labels, voxel = load_image(path, shape=shape, dtype=dtype)
            return cls.from_array(labels, str(path), voxel)
        if suffix == ".npy":
            return _npy(path)
        if suffix in TIFF_SUFFIXES:
            return _tiff_file(path)
        assert shape is not None  # raw bytes readable by parts need a shape
        return _raw(path, shape, "uint8" if dtype is None else dtype)


def readable_by_parts(path: str | Path, shape: Sequence[int] | None = None) -> bool:
    """False for the files a box cannot be read from without reading the whole: ``.npz``, a TIFF file not stored
    one 2-D page per z slice, raw bytes without a shape (which :func:`load_image` refuses)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if path.is_dir() or suffix == ".npy":
        return True
    if suffix == ".npz":
        return False
    if suffix in TIFF_SUFFIXES:
        return _tiff_pages(path) is not None
    return shape is not None


def _slices(box: Box) -> tuple[slice, slice, slice]:
    return (slice(*box[0]), slice(*box[1]), slice(*box[2]))


def _checked_shape(path: Path, shape: tuple[int, ...]) -> tuple[int, int, int]:
    if len(shape) != 3 or min(shape) < 1:
        raise InputError(f"{path}: a label image must be 3-D [x, y, z] and non-empty, got shape {shape}")
    return (int(shape[0]), int(shape[1]), int(shape[2]))


def _npy(path: Path) -> ImageBoxes:
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise InputError(f"{path}: not a readable .npy array ({err})") from None
    return ImageBoxes(_checked_shape(path, array.shape), str(path), lambda box: np.array(array[_slices(box)]))


def _raw(path: Path, shape: Sequence[int], dtype: npt.DTypeLike) -> ImageBoxes:
    kind = np.dtype(dtype)
    dims = _checked_shape(path, tuple(int(n) for n in shape))
    expected = math.prod(dims) * kind.itemsize
    if path.stat().st_size != expected:
        raise InputError(f"{path}: raw file has {path.stat().st_size} bytes but shape {dims} of {kind} "
                         f"needs {expected}")
    array = np.memmap(path, dtype=kind, mode="r", shape=dims, order="F")
    return ImageBoxes(dims, str(path), lambda box: np.array(array[_slices(box)]))


def _page_reader(pages: Callable[[], AbstractContextManager[Callable[[int], np.ndarray]]],
                 ) -> Callable[[Box], np.ndarray]:
    """A box reader from ``pages()``, a context giving the page of each z index."""
    def read(box: Box) -> np.ndarray:
        (x0, x1), (y0, y1), (z0, z1) = box
        out: np.ndarray | None = None
        with pages() as page:
            for k in range(z0, z1):
                crop = page(k)[y0:y1, x0:x1].T  # page rows = y, columns = x; the rest of the page is dropped here
                if out is None:
                    out = np.empty((x1 - x0, y1 - y0, z1 - z0), dtype=crop.dtype)
                out[:, :, k - z0] = crop
        assert out is not None  # a box has at least one layer
        return out

    return read


def _tiff_pages(path: Path) -> tuple[int, tuple[int, ...]] | None:
    """(page count, first page's shape) of a TIFF file stored one 2-D page per z slice, else None."""
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            count = len(tif.pages)
            first = tif.pages[0].shape
    except (OSError, ValueError, IndexError) as err:
        raise InputError(f"{path}: not a readable TIFF file ({err})") from None
    return (count, first) if len(first) == 2 and count >= 2 else None


def _tiff_file(path: Path) -> ImageBoxes:
    import tifffile

    found = _tiff_pages(path)
    assert found is not None  # checked by readable_by_parts
    count, first = found

    @contextmanager
    def pages() -> Iterator[Callable[[int], np.ndarray]]:
        with tifffile.TiffFile(path) as tif:
            yield lambda k: np.asarray(tif.pages[k].asarray())

    return ImageBoxes((int(first[1]), int(first[0]), count), str(path), _page_reader(pages))


def _tiff_directory(path: Path) -> ImageBoxes:
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

    @contextmanager
    def pages() -> Iterator[Callable[[int], np.ndarray]]:
        yield page

    return ImageBoxes((int(first[1]), int(first[0]), len(files)), str(path), _page_reader(pages))
