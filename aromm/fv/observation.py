"""Sensor readings in finite volumes: a thermocouple at a point, the mean over a rectangle of a box face.

The unknowns of :class:`~aromm.fv.grid.VolumeGrid` are the voxel-centre temperatures and, on the faces that carry
a condition or an output, the face temperatures half a cell out.  A reading is a row ``e`` with ``e @ T`` in °C
and ``Σ e = 1``:

* a **point** reads the trilinear interpolant between the eight voxel centres around it (second order, the
  counterpart of Q1's interpolant); within half a cell of a box face it keeps the outer centres' value along that
  axis (first order there).  Voxels without an unknown (an insulating phase, a removed cluster) are left out and
  the others renormalised; a point among none of them is refused;
* a **patch** of a face averages the face temperatures over the rectangle, each voxel face weighted by the area it
  shares with it: the face unknowns where the face has them, else the voxels next to the face (on a face without a
  condition, adiabatic, the face temperature of the two-point scheme is its voxel's).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.fv.grid import AXES, VolumeGrid

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]


def centre_weights(n: int, h: float, x: float) -> tuple[IntArray, FloatArray]:
    """Voxels and weights of the 1-D linear interpolant between voxel centres ``(i + ½) h`` at ``x``, constant
    within half a cell of either end.

    >>> centre_weights(4, 1.0, 1.75)
    (array([1, 2]), array([0.75, 0.25]))
    >>> centre_weights(4, 1.0, 0.2)
    (array([0, 1]), array([1., 0.]))
    """
    if n == 1:
        return np.zeros(1, dtype=np.int64), np.ones(1)
    s = x / h - 0.5
    e = int(min(max(np.floor(s), 0), n - 2))
    f = float(min(max(s - e, 0.0), 1.0))
    return np.array([e, e + 1], dtype=np.int64), np.array([1.0 - f, f])


def overlap_weights(n: int, h: float, lo: float, hi: float) -> tuple[IntArray, FloatArray]:
    """Voxels and the length (m) of ``[lo, hi]`` each voxel ``[i h, (i+1) h]`` shares with it.

    >>> overlap_weights(4, 1.0, 0.5, 2.0)
    (array([0, 1]), array([0.5, 1. ]))
    """
    i = np.arange(n)
    length = np.clip(np.minimum(hi, (i + 1) * h) - np.maximum(lo, i * h), 0.0, None)
    keep = np.flatnonzero(length > 0)
    return keep.astype(np.int64), length[keep]


def _row(columns: IntArray, weights: FloatArray, n: int) -> sp.csr_array:
    row = sp.csr_array((weights / weights.sum(), (np.zeros(columns.size, dtype=np.int64), columns)), shape=(1, n))
    row.sum_duplicates()
    return row


def point_row(grid: VolumeGrid, point: tuple[float, float, float], name: str) -> sp.csr_array:
    """The reading (1, n) of a thermocouple at ``point`` (m) (module docstring)."""
    parts = [centre_weights(grid.phase.shape[a], grid.voxel_size[a], point[a]) for a in range(3)]
    (ix, wx), (iy, wy), (iz, wz) = parts
    cells = grid.index[np.ix_(ix, iy, iz)].ravel()
    weights = (wx[:, None, None] * wy[None, :, None] * wz[None, None, :]).ravel()
    keep = (cells >= 0) & (weights > 0)
    if not keep.any():
        raise InputError(f"outputs.{name}.point: ({', '.join(f'{v:g}' for v in point)}) m lies among voxels "
                         "without a temperature (an insulating phase, or a cluster no fixed face reaches)")
    return _row(cells[keep], weights[keep], grid.n)


def patch_row(grid: VolumeGrid, face: str, window: tuple[tuple[float, float], tuple[float, float]],
              name: str) -> sp.csr_array:
    """The mean temperature (1, n) over the rectangle ``window`` (m, on the face's in-plane axes in xyz order) of
    ``face`` (module docstring)."""
    normal = AXES.index(face[0])
    p, q = (a for a in range(3) if a != normal)
    (iu, lu), (iv, lv) = (overlap_weights(grid.phase.shape[a], grid.voxel_size[a], *w)
                          for a, w in zip((p, q), window, strict=True))
    layer = np.take(grid.index, 0 if face[1] == "0" else -1, axis=normal)  # (shape[p], shape[q])
    cells = layer[np.ix_(iu, iv)].ravel()
    weights = (lu[:, None] * lv[None, :]).ravel()
    keep = cells >= 0
    if not keep.any():
        raise InputError(f"outputs.{name}: its rectangle of face {face} covers no voxel with a temperature")
    cells, weights = cells[keep], weights[keep]
    if face in grid.faces:  # the face unknowns, in the order of the face's conducting cells
        dofs = np.full(grid.n, -1, dtype=np.int64)
        dofs[grid.face_cells(face)] = grid.face_dofs(face)
        cells = dofs[cells]
    return _row(cells, weights, grid.n)
