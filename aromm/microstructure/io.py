"""Read and write voxel label images.

A label image is a 3-D integer array indexed ``[x, y, z]``; each integer names a phase
(the scene maps labels to phases, e.g. 1 = fibre, 0 = gas for the wood of [Chavez2020]).
The voxel size is in metres, one float (cubic voxels) or ``(dx, dy, dz)``.

Formats read by :func:`load_image` (chosen by the file name):

* ``.npy``: the array as stored, axes ``[x, y, z]``;
* ``.npz``: key ``labels`` (axes ``[x, y, z]``) and optional key ``voxel_size``;
* ``.tif`` / ``.tiff`` multi-page file, or a directory of single-page ``.tif`` slices
  (sorted by name, numbers compared as numbers): each page is one z slice with rows = y and
  columns = x, i.e. the stack axis is z;
* anything else with ``shape=(nx, ny, nz)`` (and ``dtype``, default ``uint8``): raw bytes with
  x varying fastest, then y, then z (the layout of Fiji/ImageJ and most tomography exports).

Pickled objects are never loaded (``allow_pickle=False``).
"""

from __future__ import annotations

import math
import re
import zipfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.files import output_path

VoxelSize = tuple[float, float, float]
LabelImage = npt.NDArray[np.int32]

TIFF_SUFFIXES = (".tif", ".tiff")
FORMATS = "'.npy', '.npz', '.tif'/'.tiff' (file or directory of slices), or raw bytes with shape=(nx, ny, nz)"
_INT32 = np.iinfo(np.int32)


def as_voxel_size(value: object, source: str = "voxel_size") -> VoxelSize:
    """Return ``(dx, dy, dz)`` in metres from one positive number or three.

    ``source`` names where the value came from, for the error message.

    >>> as_voxel_size(5e-6)
    (5e-06, 5e-06, 5e-06)
    >>> as_voxel_size([1e-6, 2e-6, 3e-6])
    (1e-06, 2e-06, 3e-06)
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, bool):
        items: list[object] = [value]
    elif isinstance(value, int | float):
        items = [value] * 3
    elif isinstance(value, Sequence) and not isinstance(value, str) and len(value) == 3:
        items = list(value)
    else:
        raise InputError(
            f"{source}: voxel size must be a positive number of metres or a list of three, got {value!r}"
        )
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in items):
        raise InputError(f"{source}: voxel size entries must be numbers (metres), got {value!r}")
    sizes = tuple(float(v) for v in items)  # type: ignore[arg-type]
    if not all(math.isfinite(v) and v > 0 for v in sizes):
        raise InputError(f"{source}: voxel size must be positive and finite (metres), got {value!r}")
    return (sizes[0], sizes[1], sizes[2])


def as_labels(array: npt.ArrayLike, source: str = "labels") -> LabelImage:
    """Check that ``array`` is a non-empty 3-D integer label image and return it as ``int32``.

    Booleans become 0/1; floating-point arrays are accepted when every value is a whole number.

    >>> as_labels(np.ones((2, 2, 2), dtype=bool)).dtype
    dtype('int32')
    """
    arr = np.asarray(array)
    if arr.ndim != 3:
        raise InputError(f"{source}: a label image must be 3-D [x, y, z], got shape {arr.shape}")
    if arr.size == 0:
        raise InputError(f"{source}: the label image is empty (shape {arr.shape})")
    if arr.dtype == np.bool_:
        return arr.astype(np.int32)
    if arr.dtype.kind in "iu":
        lo, hi = int(arr.min()), int(arr.max())
        if lo < _INT32.min or hi > _INT32.max:
            raise InputError(f"{source}: labels {lo}..{hi} do not fit in 32-bit integers")
        return arr.astype(np.int32, copy=False)
    if arr.dtype.kind == "f":
        bad = ~np.isfinite(arr)
        bad[~bad] = arr[~bad] != np.round(arr[~bad])
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0])
            raise InputError(
                f"{source}: labels must be integers, found {arr[index]!r} at voxel {index}"
                " (a grey-level image must be segmented into phase labels first)"
            )
        return as_labels(arr.astype(np.int64), source)
    raise InputError(f"{source}: labels must be integers, got dtype {arr.dtype}")


def _as_shape(shape: object, source: str) -> tuple[int, int, int]:
    if (
        not isinstance(shape, Sequence)
        or len(shape) != 3
        or not all(isinstance(n, int | np.integer) and not isinstance(n, bool) and n > 0 for n in shape)
    ):
        raise InputError(f"{source}: shape must be three positive integers (nx, ny, nz), got {shape!r}")
    return (int(shape[0]), int(shape[1]), int(shape[2]))


def _natural_key(name: str) -> list[object]:
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def _check_npy_size(path: Path) -> None:
    """Refuse a ``.npy`` whose header claims more data than the file holds (a truncated or forged file), before
    numpy allocates what the header claims."""
    try:
        with path.open("rb") as fh:
            version = np.lib.format.read_magic(fh)
            shape, _, dtype = (np.lib.format.read_array_header_1_0(fh) if version == (1, 0)
                               else np.lib.format.read_array_header_2_0(fh))
            start = fh.tell()
    except (OSError, ValueError, EOFError):
        return  # not a plain .npy (a .npz under another name...): np.load says what it is
    claimed = int(np.prod(shape, dtype=object)) * np.dtype(dtype).itemsize
    held = path.stat().st_size - start
    if claimed > held:
        raise InputError(f"{path}: the .npy header claims an array of shape {tuple(int(n) for n in shape)} "
                         f"({claimed:,} bytes of {np.dtype(dtype)}) but the file holds {held:,} bytes: truncated or "
                         "damaged; write the image again")


def _read_npy(path: Path) -> np.ndarray:
    _check_npy_size(path)
    try:
        array = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise InputError(f"{path}: not a readable .npy array ({err})") from None
    if not isinstance(array, np.ndarray):
        array.close()
        raise InputError(f"{path}: holds a .npz archive, not one .npy array; rename it to .npz")
    return array


def _read_npz(path: Path) -> tuple[np.ndarray, VoxelSize | None]:
    # InputError is a ValueError: raise it outside the try block so it is not re-wrapped
    try:
        archive = np.load(path, allow_pickle=False)
        if isinstance(archive, np.lib.npyio.NpzFile):
            with archive:
                keys = list(archive.files)
                labels = archive["labels"] if "labels" in keys else None
                voxel = archive["voxel_size"] if "voxel_size" in keys else None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise InputError(f"{path}: not a readable .npz archive ({err})") from None
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise InputError(f"{path}: expected a .npz archive with key 'labels', found a single array")
    if labels is None:
        raise InputError(
            f"{path}: no key 'labels' in the archive (keys: {', '.join(keys) or 'none'});"
            " expected 'labels' and optionally 'voxel_size'"
        )
    voxel_size = None if voxel is None else as_voxel_size(voxel, f"{path}: key 'voxel_size'")
    return labels, voxel_size


def _read_tiff_pages(path: Path) -> list[np.ndarray]:
    """The image series of a TIFF file (one series for stacks written at once or ImageJ stacks;
    one series per page for files written page by page)."""
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            return [np.asarray(series.asarray()) for series in tif.series]
    except (OSError, ValueError, IndexError, tifffile.TiffFileError) as err:  # a ValueError from tifffile 2023.7 on
        raise InputError(f"{path}: not a readable TIFF file ({err})") from None


def _read_tiff_page(path: Path) -> np.ndarray:
    series = _read_tiff_pages(path)
    if len(series) != 1 or series[0].ndim != 2:
        shapes = [s.shape for s in series]
        raise InputError(f"{path}: a slice must be one 2-D single-channel page, got series of shapes {shapes}")
    return series[0]


def _read_tiff(path: Path) -> np.ndarray:
    series = _read_tiff_pages(path)
    if len(series) == 1:
        stack = series[0]
    elif all(s.ndim == 2 and s.shape == series[0].shape for s in series):
        stack = np.stack(series, axis=0)
    else:
        raise InputError(f"{path}: TIFF pages of unequal shapes {[s.shape for s in series][:4]}…; expected z slices")
    if stack.ndim == 2:
        raise InputError(f"{path}: the TIFF holds one 2-D page {stack.shape}; a 3-D stack (z pages) is needed")
    if stack.ndim != 3:
        raise InputError(
            f"{path}: TIFF data of shape {stack.shape} is not a stack of single-channel 2-D pages"
        )
    return stack.transpose(2, 1, 0)


def _read_tiff_directory(path: Path) -> np.ndarray:
    files = sorted(
        (p for p in path.iterdir() if p.is_file() and p.suffix.lower() in TIFF_SUFFIXES),
        key=lambda p: _natural_key(p.name),
    )
    if not files:
        raise InputError(f"{path}: directory holds no .tif/.tiff slices")
    slices: list[np.ndarray] = []
    for file in files:
        page = _read_tiff_page(file)
        if slices and page.shape != slices[0].shape:
            raise InputError(f"{file}: slice shape {page.shape} differs from {files[0].name} {slices[0].shape}")
        slices.append(page)
    return np.stack(slices, axis=0).transpose(2, 1, 0)


def _read_raw(path: Path, shape: tuple[int, int, int], dtype: npt.DTypeLike) -> np.ndarray:
    try:
        kind = np.dtype(dtype)
    except TypeError:
        raise InputError(f"{path}: unknown dtype {dtype!r} for a raw file (e.g. 'uint8', '<u2', 'int32')") from None
    expected = math.prod(shape) * kind.itemsize
    actual = path.stat().st_size
    if actual != expected:
        raise InputError(
            f"{path}: raw file has {actual} bytes but shape {shape} of {kind} needs {expected}"
            f" ({math.prod(shape)} voxels x {kind.itemsize} bytes)"
        )
    return np.fromfile(path, dtype=kind).reshape(shape, order="F")


def read_array(
    path: str | Path,
    shape: Sequence[int] | None = None,
    dtype: npt.DTypeLike | None = None,
) -> tuple[np.ndarray, VoxelSize | None]:
    """The 3-D array ``[x, y, z]`` stored in ``path`` as it is (any dtype: labels, or 8-, 16-bit or float grey
    levels for :mod:`aromm.microstructure.segmentation`) and the voxel size stored with it (or None).

    Formats and refusals as :func:`load_image`, which checks the array as labels.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    suffix = path.suffix.lower()
    voxel_size: VoxelSize | None = None
    raw = not path.is_dir() and suffix not in (".npy", ".npz", *TIFF_SUFFIXES)
    if dtype is not None and not raw:
        raise InputError(f"{path}: dtype applies to raw files only; {suffix or 'a directory'} stores its own")
    if path.is_dir():
        array = _read_tiff_directory(path)
    elif suffix == ".npy":
        array = _read_npy(path)
    elif suffix == ".npz":
        array, voxel_size = _read_npz(path)
    elif suffix in TIFF_SUFFIXES:
        array = _read_tiff(path)
    elif shape is None:
        raise InputError(f"{path}: unknown image format {suffix!r}; allowed: {FORMATS}")
    else:
        array = _read_raw(path, _as_shape(shape, str(path)), "uint8" if dtype is None else dtype)
    if shape is not None and np.shape(array) != _as_shape(shape, str(path)):
        raise InputError(f"{path}: image shape {np.shape(array)} differs from the requested shape {tuple(shape)}")
    return array, voxel_size


def load_image(
    path: str | Path,
    shape: Sequence[int] | None = None,
    dtype: npt.DTypeLike | None = None,
) -> tuple[LabelImage, VoxelSize | None]:
    """Read a 3-D label image; return ``(labels [x, y, z] as int32, voxel_size or None)``.

    The format follows the name (see the module docstring): ``.npy``, ``.npz`` (keys ``labels``,
    optional ``voxel_size``), a ``.tif``/``.tiff`` stack or a directory of slices (stack axis z),
    otherwise raw bytes, which need ``shape=(nx, ny, nz)`` and ``dtype`` (default ``uint8``).
    For the other formats ``shape``, when given, is checked against the file.  Only ``.npz``
    can carry a voxel size; the others return ``None``.

    Raises :class:`~aromm.core.errors.InputError` naming the file and what is wrong.

    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> np.arange(24, dtype=np.uint8).tofile(folder / "block.raw")
    >>> labels, voxel = load_image(folder / "block.raw", shape=(2, 3, 4))
    >>> int(labels[1, 0, 0]), int(labels[0, 1, 0]), int(labels[0, 0, 1]), voxel
    (1, 2, 6, None)
    """
    array, voxel_size = read_array(path, shape, dtype)
    return as_labels(array, str(path)), voxel_size


def save_image(path: str | Path, labels: npt.ArrayLike, voxel_size: object | None = None) -> Path:
    """Write ``labels`` (and ``voxel_size`` when given) to a compressed ``.npz`` that
    :func:`load_image` reads back; return the path.

    >>> import tempfile, pathlib
    >>> file = save_image(pathlib.Path(tempfile.mkdtemp()) / "cube.npz", np.ones((2, 2, 2), int), 1e-6)
    >>> load_image(file)[1]
    (1e-06, 1e-06, 1e-06)
    """
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise InputError(f"{path}: save_image writes .npz files only")
    image = as_labels(labels, str(path))
    path = output_path(path, "label image")
    if voxel_size is None:
        np.savez_compressed(path, labels=image)
    else:
        np.savez_compressed(path, labels=image, voxel_size=np.asarray(as_voxel_size(voxel_size, f"{path}: voxel_size")))
    return path
