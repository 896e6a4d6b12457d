"""A digest of a label image that does not depend on how the image is cut into boxes.

Each voxel contributes a mixing of the 64-bit word ``(global voxel index << 32) | label`` (SplitMix64:
Steele, Lea & Flood 2014) and the digest is the sum of those contributions modulo 2⁶⁴, in two lanes (two different
mixings): a sum does not depend on the order in which boxes are visited, so the whole image read at once
(:func:`label_digest`) and the boxes of any number of ranks summed over the ranks
(:func:`aromm.engines.petsc.assembly.image_digest`) give the same digest.  Global voxel index
``i + nx (j + ny k)`` for voxel (i, j, k).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

_MIX = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB))
LANES = 2


def _splitmix(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective mixing of 64-bit words."""
    z = x + _MIX[0]
    z = (z ^ (z >> np.uint64(30))) * _MIX[1]
    z = (z ^ (z >> np.uint64(27))) * _MIX[2]
    return z ^ (z >> np.uint64(31))


def box_lanes(labels: np.ndarray, box: Sequence[tuple[int, int]], shape: Sequence[int]) -> np.ndarray:
    """The two 64-bit lane sums of the voxels of ``labels``, the box ``((x0, x1), (y0, y1), (z0, z1))`` of an
    image of ``shape`` (layer by layer: one plane of words at a time)."""
    (x0, x1), (y0, y1), (z0, z1) = box
    nx, ny = int(shape[0]), int(shape[1])
    plane = (np.arange(x0, x1, dtype=np.uint64)[:, None]
             + np.uint64(nx) * np.arange(y0, y1, dtype=np.uint64)[None, :])
    lanes = np.zeros(LANES, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(z1 - z0):
            word = ((plane + np.uint64(nx * ny * (z0 + k))) << np.uint64(32)) | labels[:, :, k].astype(
                np.uint32).astype(np.uint64)
            for lane in range(LANES):
                lanes[lane] += _splitmix(word ^ _MIX[lane + 1]).sum(dtype=np.uint64)
    return lanes


def lanes_hex(lanes: np.ndarray) -> str:
    """The digest's text: the lanes as 16 hexadecimal digits each."""
    return "".join(f"{int(v):016x}" for v in lanes)


def label_digest(labels: np.ndarray) -> str:
    """The digest of a whole label image (nx, ny, nz)."""
    shape = labels.shape
    return lanes_hex(box_lanes(labels, tuple((0, int(n)) for n in shape), shape))
