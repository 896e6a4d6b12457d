"""A synthetic micro-CT scan of a wood-like sample and the steps from it to k_F and c_F (issue 22, item 7).

The *true* material is a label image of the spruce-like generator (:func:`aromm.microstructure.wood`, walls of
one voxel at 5 µm).  Its scan is made as a tomograph would see it, at half the voxel (2.5 µm):

* each true voxel becomes 2³ scan voxels (:func:`upsample`), with the grey levels ``LEVELS`` of gas and wall;
* the sample does not fill the field of view: a ``margin`` of background (the air around the sample, darker
  than the lumens' gas) precedes it along x;
* the optics blur the image (a Gaussian of ``blur`` scan voxels): every interface, and the sample's edge, gets
  partial-volume voxels of intermediate grey;
* detector noise (Gaussian, ``noise`` grey levels) is added and the result is stored as 16-bit integers.

The notebook ``notebooks/micro_ct.ipynb`` then segments it (crop the margin, down-sample ×2, Otsu), checks the
REV, crops, reduces and identifies against logger data; nothing in ``aromm`` or ``inverse`` imports this module.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

#: 16-bit grey levels of the background outside the sample, the gas of the lumens and the cell wall.
LEVELS = {"background": 6000.0, "gas": 9000.0, "wall": 30000.0}
SCAN_FACTOR = 2  # scan voxels per true voxel along each axis


def upsample(labels: npt.NDArray[np.integer], factor: int = SCAN_FACTOR) -> npt.NDArray[np.integer]:
    """Each voxel repeated ``factor`` times along every axis.

    >>> upsample(np.arange(2).reshape(2, 1, 1), 2)[:, :, 0].tolist()
    [[0, 0], [0, 0], [1, 1], [1, 1]]
    """
    out = labels
    for axis in range(3):
        out = np.repeat(out, factor, axis=axis)
    return out


def synthetic_scan(labels: npt.NDArray[np.integer], rng: np.random.Generator, *, margin: int = 8,
                   blur: float = 1.0, noise: float = 3000.0) -> npt.NDArray[np.uint16]:
    """The 16-bit scan ``[x, y, z]`` of a gas (0) / wall (1) label image (module docstring): ``margin`` scan voxels
    of background before the sample along x, a Gaussian blur of ``blur`` scan voxels, noise of standard deviation
    ``noise`` grey levels drawn from ``rng``."""
    from scipy.ndimage import gaussian_filter

    fine = upsample(labels)
    grey = np.where(fine == 1, LEVELS["wall"], LEVELS["gas"])
    grey = np.concatenate([np.full((margin, *grey.shape[1:]), LEVELS["background"]), grey], axis=0)
    grey = gaussian_filter(grey, blur, mode="nearest") + rng.normal(0.0, noise, grey.shape)
    return np.clip(np.rint(grey), 0, np.iinfo(np.uint16).max).astype(np.uint16)


@dataclass
class Stopwatch:
    """CPU and wall seconds of named steps, in order: ``with watch("segment"): ...``."""

    steps: list[dict[str, object]] = field(default_factory=list)

    @contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        cpu, wall = time.process_time(), time.perf_counter()
        yield
        self.steps.append({"step": name, "CPU s": time.process_time() - cpu, "wall s": time.perf_counter() - wall})
