"""Grey-level images (micro-CT) into phase labels: crop, down-sample, denoise, threshold — through scikit-image.

A scene's ``[geometry]`` may name a grey image (8-, 16-bit or float; any format of
:func:`~aromm.microstructure.io.read_array`) with a ``segment`` table (docs/guide/scene.md):

* ``{ thresholds = [t1, t2, …] }`` — grey < t1 → label 0, t1 ≤ grey < t2 → label 1, …: N + 1 phases;
* ``{ method = "otsu" }`` — one threshold maximising the between-class variance of the histogram [Otsu1979]
  (:func:`skimage.filters.threshold_otsu`); ``{ method = "multiotsu", classes = 3 }`` its N-class extension
  (:func:`skimage.filters.threshold_multiotsu`, [Liao2001]).  As in scikit-image, a grey level equal to an automatic
  threshold goes to the lower class (label i + 1 for grey > t_i).
* optional denoising before the threshold: ``denoise = "median"`` (a cube of edge ``size`` voxels,
  :func:`skimage.filters.median`) or ``denoise = "gaussian"`` (standard deviation ``sigma`` voxels,
  :func:`skimage.filters.gaussian`).

With one threshold, the report also gives another standard method's threshold on the same (denoised) image: Li's
minimum cross-entropy [Li1993] for Otsu's, Otsu's for a threshold given by hand (:data:`OTHER_METHOD`).  The
difference is no bound of the threshold's error, but a measure of how much the choice of a standard method moves it;
``aromm identify --segmentation-check`` re-fits on the image thresholded there (the "segmentation" row of the error
budget, docs/method/uncertainty.md).

Before the segmentation, ``crop = [[x0, x1], [y0, y1], [z0, z1]]`` keeps the voxels x0 ≤ i < x1 (indices of the
stored image) and ``downsample = f`` averages f³ blocks (:func:`skimage.transform.downscale_local_mean`; a label
image takes the most frequent label of each block); the voxel edge becomes f times the scan's.  What was done is
returned as a :class:`SegmentationReport` (threshold(s) used, labelled volume fractions, the histogram);
:func:`histogram_figure` draws the histogram with the thresholds.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.files import save_figure
from aromm.microstructure.io import LabelImage, VoxelSize, as_labels, read_array

if TYPE_CHECKING:
    from matplotlib.figure import Figure

METHODS = ("thresholds", "otsu", "multiotsu")
DENOISERS = ("median", "gaussian")
SEGMENT_KEYS = ("thresholds", "method", "classes", "denoise", "size", "sigma")
HISTOGRAM_BINS = 256
#: For one threshold, the standard method whose threshold the report gives beside it (module docstring).
OTHER_METHOD = {"otsu": "li", "thresholds": "otsu"}
#: A refusal naming a key: ``fail("geometry.crop", "what is allowed")`` (aromm.scene.toml.TableReader.fail).
Fail = Callable[[str, str], InputError]


def _fail(key: str, message: str) -> InputError:
    return InputError(f"{key}: {message}")


@dataclass(frozen=True)
class Segmentation:
    """How a grey image becomes labels: ``method`` among METHODS, the user's ``thresholds`` (method
    ``"thresholds"``), the number of ``classes`` (``"multiotsu"``), and the denoising (``None``, ``"median"`` with
    a cube of edge ``size`` voxels, ``"gaussian"`` with standard deviation ``sigma`` voxels)."""

    method: str
    thresholds: tuple[float, ...] = ()
    classes: int = 2
    denoise: str | None = None
    size: int = 3
    sigma: float = 1.0


@dataclass(frozen=True, eq=False)
class SegmentationReport:
    """What the segmentation did: thresholds used (grey levels), volume fraction of each label 0, 1, …, the
    histogram of the (denoised) grey levels (``counts`` over ``edges``), and the image it ran on."""

    method: str
    thresholds: tuple[float, ...]
    fractions: tuple[float, ...]
    counts: npt.NDArray[np.int64]
    edges: npt.NDArray[np.float64]
    dtype: str
    shape: tuple[int, int, int]
    denoise: str | None = None
    other: tuple[str, float] | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (without the histogram); ``other``: another standard method's threshold, for one
        threshold (module docstring)."""
        other = None if self.other is None else {"method": self.other[0], "threshold": self.other[1]}
        return {"method": self.method, "thresholds": list(self.thresholds), "fractions": list(self.fractions),
                "dtype": self.dtype, "shape": list(self.shape), "denoise": self.denoise, "other": other}

    def __str__(self) -> str:
        shape = "×".join(map(str, self.shape))
        lines = [f"segmentation: {self.method} on a {shape} {self.dtype} image"
                 + (f", {self.denoise} denoising first" if self.denoise else ""),
                 "thresholds (grey levels): " + ", ".join(f"{t:.6g}" for t in self.thresholds),
                 "label  volume fraction"]
        lines += [f"{i:5d}  {f:.4f}" for i, f in enumerate(self.fractions)]
        if self.other is not None:
            lines.append(f"{self.other[0]}'s threshold on the same image: {self.other[1]:.6g}")
        return "\n".join(lines)


def parse_segmentation(table: Any, key: str = "geometry.segment", fail: Fail = _fail) -> Segmentation:
    """Check the ``segment`` table of a scene; refusals name ``key`` and the bad entry.

    >>> parse_segmentation({"method": "multiotsu", "classes": 3}).classes
    3
    >>> parse_segmentation({"thresholds": [100, 50]})
    Traceback (most recent call last):
    ...
    aromm.core.errors.InputError: geometry.segment.thresholds: must be increasing finite numbers, got [100, 50]
    """
    if not isinstance(table, Mapping):
        raise fail(key, f"must be a table such as {{ method = \"otsu\" }}, got {table!r}")
    unknown = sorted(set(table) - set(SEGMENT_KEYS))
    if unknown:
        raise fail(f"{key}.{unknown[0]}", f"unknown key; allowed: {', '.join(SEGMENT_KEYS)}")
    method = table.get("method", "thresholds" if "thresholds" in table else None)
    if method not in METHODS:
        raise fail(f"{key}.method", f"must be one of {', '.join(METHODS)} (or give thresholds), got {method!r}")
    thresholds: tuple[float, ...] = ()
    if method == "thresholds":
        raw = table.get("thresholds")
        if (not isinstance(raw, list) or not raw or any(isinstance(t, bool) or not isinstance(t, int | float)
                                                         for t in raw)
                or not np.all(np.isfinite(raw)) or np.any(np.diff(raw) <= 0)):
            raise fail(f"{key}.thresholds", f"must be increasing finite numbers, got {raw!r}")
        thresholds = tuple(float(t) for t in raw)
    elif "thresholds" in table:
        raise fail(f"{key}.thresholds", f"goes with method = \"thresholds\", not {method!r}")
    classes = table.get("classes", 2)
    if isinstance(classes, bool) or not isinstance(classes, int) or classes < 2 or (
            method == "otsu" and classes != 2):
        raise fail(f"{key}.classes", f"must be an integer ≥ 2 (2 for otsu; with multiotsu), got {classes!r}")
    denoise = table.get("denoise")
    if denoise is not None and denoise not in DENOISERS:
        raise fail(f"{key}.denoise", f"must be one of {', '.join(DENOISERS)}, got {denoise!r}")
    size = table.get("size", 3)
    if isinstance(size, bool) or not isinstance(size, int) or size < 1 or ("size" in table and denoise != "median"):
        raise fail(f"{key}.size", f"the median cube edge: a positive integer with denoise = \"median\", got {size!r}")
    sigma = table.get("sigma", 1.0)
    if (isinstance(sigma, bool) or not isinstance(sigma, int | float) or not np.isfinite(sigma) or sigma <= 0
            or ("sigma" in table and denoise != "gaussian")):
        raise fail(f"{key}.sigma", f"the Gaussian width in voxels: > 0 with denoise = \"gaussian\", got {sigma!r}")
    return Segmentation(method, thresholds, int(classes), denoise, int(size), float(sigma))


def denoised(grey: npt.NDArray[Any], spec: Segmentation) -> npt.NDArray[Any]:
    """The grey image after the denoising of ``spec`` (the image itself without one)."""
    from skimage import filters

    if spec.denoise == "median":
        return np.asarray(filters.median(grey, footprint=np.ones((spec.size,) * 3, dtype=bool)))
    if spec.denoise == "gaussian":
        return np.asarray(filters.gaussian(grey.astype(np.float64), sigma=spec.sigma, preserve_range=True))
    return grey


def segment(grey: npt.ArrayLike, spec: Segmentation, bins: int = HISTOGRAM_BINS) -> tuple[LabelImage,
                                                                                         SegmentationReport]:
    """Labels 0…N of a 3-D grey image and the report of how they were obtained (module docstring).

    >>> grey = np.array([10, 10, 200, 200, 200, 120], dtype=np.uint8).reshape(1, 1, 6)
    >>> labels, report = segment(grey, Segmentation("thresholds", (50.0, 150.0)))
    >>> labels.ravel().tolist(), report.fractions
    ([0, 0, 2, 2, 2, 1], (0.3333333333333333, 0.16666666666666666, 0.5))
    """
    from skimage import filters

    image = np.asarray(grey)
    if image.ndim != 3 or image.size == 0:
        raise InputError(f"a grey image must be 3-D [x, y, z] and non-empty, got shape {image.shape}")
    if image.dtype.kind not in "uif" or (image.dtype.kind == "f" and not np.all(np.isfinite(image))):
        raise InputError(f"a grey image holds finite numbers (8-, 16-bit or float), got dtype {image.dtype}"
                         + (" with NaN or infinite values" if image.dtype.kind == "f" else ""))
    smooth = denoised(image, spec)
    if spec.method == "thresholds":
        thresholds = np.asarray(spec.thresholds, dtype=float)
        labels = np.digitize(smooth, thresholds, right=False)
    else:
        if np.ptp(smooth) == 0:
            raise InputError(f"{spec.method}: the grey image is uniform ({smooth.flat[0]!r}): nothing to segment")
        if spec.method == "otsu":
            thresholds = np.atleast_1d(np.asarray(filters.threshold_otsu(smooth), dtype=float))
        else:
            thresholds = np.asarray(filters.threshold_multiotsu(smooth, classes=spec.classes), dtype=float)
        labels = np.digitize(smooth, thresholds, right=True)  # grey > t_i → class i + 1 (scikit-image's rule)
    counts, edges = np.histogram(smooth, bins=bins)
    fractions = np.bincount(labels.ravel(), minlength=thresholds.size + 1) / labels.size
    nx, ny, nz = image.shape
    report = SegmentationReport(spec.method, tuple(float(t) for t in thresholds),
                                tuple(float(f) for f in fractions), counts.astype(np.int64), edges.astype(np.float64),
                                str(image.dtype), (int(nx), int(ny), int(nz)), spec.denoise,
                                _other(smooth, spec.method, thresholds.size))
    return as_labels(labels), report


def _other(smooth: npt.NDArray[Any], method: str, count: int) -> tuple[str, float] | None:
    """(method, threshold) of :data:`OTHER_METHOD` on the denoised image, for one threshold of a non-uniform image."""
    from skimage import filters

    other = OTHER_METHOD.get(method)
    if other is None or count != 1 or np.ptp(smooth) == 0:
        return None
    found = filters.threshold_li(smooth) if other == "li" else filters.threshold_otsu(smooth)
    return other, float(found)


def crop(image: npt.NDArray[Any], box: Any, key: str = "geometry.crop", fail: Fail = _fail) -> npt.NDArray[Any]:
    """The voxels ``x0 ≤ i < x1``, ``y0 ≤ j < y1``, ``z0 ≤ k < z1`` of ``box = [[x0, x1], [y0, y1], [z0, z1]]``.

    >>> crop(np.zeros((4, 5, 6)), [[1, 3], [0, 5], [2, 6]]).shape
    (2, 5, 4)
    """
    ok = isinstance(box, Sequence) and len(box) == 3 and all(
        isinstance(b, Sequence) and len(b) == 2 and all(isinstance(v, int) and not isinstance(v, bool) for v in b)
        for b in box)
    if not ok:
        raise fail(key, f"must be [[x0, x1], [y0, y1], [z0, z1]] (voxel indices), got {box!r}")
    for axis, ((lo, hi), n) in enumerate(zip(box, image.shape, strict=True)):
        if not 0 <= lo < hi <= n:
            raise fail(key, f"axis {'xyz'[axis]}: need 0 ≤ {lo} < {hi} ≤ {n} (the image has {n} voxels)")
    return image[tuple(slice(lo, hi) for lo, hi in box)]


def downsample(image: npt.NDArray[Any], factor: Any, labels: bool, key: str = "geometry.downsample",
               fail: Fail = _fail) -> npt.NDArray[Any]:
    """Blocks of ``factor³`` voxels into one: the mean grey level, or for ``labels`` the most frequent label (the
    smallest on a tie).  Voxels beyond the last whole block are dropped.

    >>> downsample(np.arange(8.0).reshape(2, 2, 2), 2, labels=False).ravel().tolist()
    [3.5]
    >>> downsample(np.array([0, 1, 1, 1, 0, 0]).reshape(6, 1, 1), 3, labels=True).shape
    Traceback (most recent call last):
    ...
    aromm.core.errors.InputError: geometry.downsample: factor 3 leaves no voxel along y (1 voxels)
    """
    if isinstance(factor, bool) or not isinstance(factor, int) or factor < 1:
        raise fail(key, f"must be a positive integer (voxels per block edge), got {factor!r}")
    if factor == 1:
        return image
    for axis, n in enumerate(image.shape):
        if n < factor:
            raise fail(key, f"factor {factor} leaves no voxel along {'xyz'[axis]} ({n} voxels)")
    whole = image[tuple(slice(0, (n // factor) * factor) for n in image.shape)]
    if not labels:
        from skimage.transform import downscale_local_mean

        return np.asarray(downscale_local_mean(whole.astype(np.float64), (factor,) * 3))
    nx, ny, nz = (n // factor for n in whole.shape)
    blocks = whole.reshape(nx, factor, ny, factor, nz, factor)
    present = np.unique(whole)
    votes = np.stack([(blocks == value).sum(axis=(1, 3, 5)) for value in present])
    return present[np.argmax(votes, axis=0)]


def prepare_image(file: Path, geo: Mapping[str, Any], fail: Fail = _fail,
                  ) -> tuple[LabelImage, VoxelSize | None, int, SegmentationReport | None]:
    """Read ``geo["image"]`` (already resolved to ``file``) and apply ``crop``, ``downsample`` and ``segment``.

    Returns the labels, the voxel size stored in the file (or None), the down-sampling factor (the voxel edge of
    the labels is that factor times the scan's) and the segmentation report (None for a label image).
    """
    spec = parse_segmentation(geo["segment"], fail=fail) if "segment" in geo else None
    shape = geo.get("shape")
    array, voxel = read_array(file, shape=tuple(shape) if shape else None, dtype=geo.get("dtype"))
    stored = str(array.dtype)
    if array.ndim != 3:
        raise fail("geometry.image", f"{file}: the image must be 3-D, got shape {array.shape}")
    if spec is None:
        try:
            array = as_labels(array, str(file))
        except InputError as err:
            raise fail("geometry.image", f"{err}; for a grey image add segment = {{ method = \"otsu\" }} or "
                                         "{ thresholds = [...] } (docs/guide/scene.md)") from None
    if "crop" in geo:
        array = crop(array, geo["crop"], fail=fail)
    factor = geo.get("downsample", 1)
    array = downsample(array, factor, labels=spec is None, fail=fail)
    if spec is None:
        return as_labels(array, str(file)), voxel, int(factor), None
    try:
        labels, report = segment(array, spec)
    except InputError as err:
        raise fail("geometry.segment", f"{file}: {err}") from None
    if factor != 1:  # the block means are floats: name the scan's own type
        report = replace(report, dtype=f"{stored}, {factor}× down-sampled")
    return labels, voxel, int(factor), report


def histogram_figure(report: SegmentationReport) -> Figure:
    """The grey-level histogram (log counts) with the thresholds as vertical lines and the labels' volume
    fractions in the title."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 3.5), layout="constrained")
    ax = fig.add_subplot()
    centres = 0.5 * (report.edges[1:] + report.edges[:-1])
    ax.fill_between(centres, report.counts, step="mid", color="0.6")
    ax.set_yscale("log")
    for i, t in enumerate(report.thresholds):
        ax.axvline(t, color=f"C{i + 1}", label=f"t{i + 1} = {t:.4g}")
    ax.set_xlabel(f"grey level ({report.dtype})")
    ax.set_ylabel("voxels")
    fractions = ", ".join(f"{i}: {f:.3f}" for i, f in enumerate(report.fractions))
    ax.set_title(f"{report.method}; volume fractions {fractions}", fontsize=9)
    ax.legend(fontsize=8)
    return fig


def save_histogram(report: SegmentationReport, path: str | Path, dpi: int = 120) -> Path:
    """Write :func:`histogram_figure` to ``path`` atomically (format from the suffix, e.g. ``.png``)."""
    return save_figure(histogram_figure(report), path, "histogram plot", dpi)
