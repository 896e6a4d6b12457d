"""The periodic cell problem in cell-centred finite volumes (:mod:`aromm.fv`): the full conductivity tensor.

``T = G·x + T̃`` with T̃ periodic.  With D the link–cell incidence (the links of the periodic image, wrapped across
the box), W their harmonic-mean conductances (W/K) and s_j the jump of x_j along each link (d_j on links along axis
j, 0 on the others), T̃_j solves ``Dᵀ W D T̃_j = −Dᵀ W s_j`` and ``k_ij |Ω| = (D T̃_i + s_i)ᵀ W (D T̃_j + s_j)``, the
energy form (its error is quadratic in the solve's).  The operator ``Dᵀ W D`` is singular (a constant per connected
cluster); the right-hand side is a divergence, so the system is consistent.  With an insulating phase, an axis
along which no cluster winds around the box (:func:`aromm.fv.volumes.winding_axes`) has k = 0 in its row and column
exactly (a solve would give its rounding), said in the log.

Two ways to solve it:

* ``mg`` — the matrix-free stencil (:func:`aromm.fv.stencil.periodic_stencil`, links in float32) and CG preconditioned
  by its aggregation multigrid (:class:`aromm.fv.multigrid.VolumeMultigrid`), one direction at a time: the diagonal by
  the energy form, the off-diagonal terms by ``k_ij |Ω| = s_iᵀ W (D T̃_j + s_j)`` (equal to the energy form by
  Galerkin orthogonality, ``Dᵀ W (D T̃_j + s_j) = 0``; its error is linear in the solve's, ``|T̃_iᵀ r_j|``),
  symmetrised.  Needs axis-aligned phases; otherwise ``amg``.
* the assembled incidence with the first voxel of every cluster pinned, by a direct method or ``amg`` (pyamg CG).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.core.vocabulary import insulating, phase_index
from aromm.fv.multigrid import VolumeMultigrid, cluster_heads
from aromm.fv.stencil import periodic_stencil
from aromm.fv.volumes import conducting_phase, winding_axes
from aromm.linalg.direct import factorize
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

log = logging.getLogger(__name__)


def axis_k(scene: Scene) -> FloatArray:
    """(phases + 1, 3) conductivities along x, y, z (W/(m K)); the last row zero, for the index −1 (no unknown)."""
    return np.array([p.k if isinstance(p.k, tuple) else (p.k,) * 3 for p in scene.phases] + [(0.0,) * 3], dtype=float)


def periodic_k(scene: Scene, method: str, rtol: float) -> tuple[FloatArray, str]:
    """(k tensor W/(m K), the method that ran) of the periodic cell; ``mg`` falls back to ``amg`` where the
    matrix-free multigrid cannot run (a rotated tensor), saying so in the log."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    winds = (True, True, True)
    if any(insulating(p) for p in scene.phases):
        winds = winding_axes(conducting_phase(np.asarray(image.labels), scene.phases) >= 0)
        for axis in (a for a in range(3) if not winds[a]):
            log.info("homogenisation: no conducting path winds around the periodic cell along %s: k̄_%s = 0, and "
                     "its row and column", "xyz"[axis], "xyz"[axis] * 2)
    if method == "mg":
        shape = np.asarray(image.labels).shape
        if any(p.tensor is not None for p in scene.phases):
            log.info("homogenisation: the periodic cell of %s voxels with a rotated tensor runs on the assembled "
                     "operator (pyamg): the matrix-free multigrid needs axis-aligned phases", "×".join(map(str, shape)))
            method = "amg"
        else:
            return _stencil(scene, rtol, winds), method
    return _assembled(scene, method, rtol, winds), method


def _stencil(scene: Scene, rtol: float, winds: tuple[bool, bool, bool] = (True, True, True)) -> FloatArray:
    """The tensor by the matrix-free multigrid (module docstring); the rows and columns of the axes that do not
    ``wind`` are zero, unsolved."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    phase = phase_index(np.asarray(image.labels), scene.phases)
    k_of = axis_k(scene)
    stencil = periodic_stencil((k_of[phase, 0], k_of[phase, 1], k_of[phase, 2]), image.voxel_size)
    del phase
    solver = VolumeMultigrid(stencil, rtol)
    d = image.voxel_size
    k = np.zeros((3, 3))
    for j in (a for a in range(3) if winds[a]):
        g = stencil.links[j].astype(np.float64)  # a difference of float32 links is exact in float64: b sums to 0
        b = d[j] * (g - np.roll(g, 1, axis=j))  # −Dᵀ W s_j: what leaves each cell along j minus what enters
        del g
        t = solver.solve(b)
        del b
        for i in range(3):
            gi = stencil.links[i]
            grad = np.roll(t, -1, axis=i) - t  # D T̃_j on the links along i (float64)
            if i == j:
                grad += d[j]
            elif winds[i]:
                k[i, j] = d[i] * float(np.sum(gi * grad))  # s_iᵀ W D T̃_j (s_iᵀ W s_j = 0)
            k[j, j] += float(np.sum(gi * grad * grad))  # the energy form, over the links of every axis
        log.debug("finite volumes, periodic cell along %s: %d CG iterations, %d levels", "xyz"[j],
                  solver.iterations[-1], len(solver.levels))
    volume = float(np.prod(image.size))
    return (k + k.T) / (2.0 * volume)


def _assembled(scene: Scene, method: str, rtol: float,
               winds: tuple[bool, bool, bool] = (True, True, True)) -> FloatArray:
    """The full tensor on the assembled incidence ``D`` (module docstring), by ``method``; the rows and columns of
    the axes that do not ``wind`` are zero."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    k_of = axis_k(scene)  # a voxel of no phase (−1) reads the zero row; its links are dropped below anyway
    phase = phase_index(np.asarray(image.labels), scene.phases)
    cells = phase >= 0
    index = np.full(phase.shape, -1, dtype=np.int64)
    index[cells] = np.arange(int(cells.sum()))
    rows, w, jumps = [], [], []
    for axis in range(3):
        a = index.ravel()
        b = np.roll(index, -1, axis=axis).ravel()
        ka = k_of[phase.ravel(), axis]
        kb = k_of[np.roll(phase, -1, axis=axis).ravel(), axis]
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where(ka + kb > 0, 2.0 * ka * kb / (ka + kb), 0.0)
        keep = (a >= 0) & (b >= 0) & (g > 0)
        area = float(np.prod(image.voxel_size)) / image.voxel_size[axis]
        rows.append(np.stack([a[keep], b[keep]]))
        w.append(g[keep] * area / image.voxel_size[axis])
        jump = np.zeros((3, int(keep.sum())))
        jump[axis] = image.voxel_size[axis]
        jumps.append(jump)
    link = np.concatenate(rows, axis=1)
    weights = np.concatenate(w)
    s = np.concatenate(jumps, axis=1)
    m, n = link.shape[1], int(cells.sum())
    d = sp.csr_array(sp.coo_array((np.concatenate([-np.ones(m), np.ones(m)]),
                                   (np.tile(np.arange(m), 2), np.concatenate([link[0], link[1]]))), shape=(m, n)))
    a_full = sp.csr_array(d.T @ sp.diags_array(weights) @ d)
    free = np.setdiff1d(np.arange(n), cluster_heads(a_full))  # one pinned voxel per cluster
    solver = factorize(a_full[free][:, free], method, rtol)
    gradients = {}
    for j in (a for a in range(3) if winds[a]):  # an axis that does not wind has k = 0 in its row and column
        t = np.zeros(n)
        t[free] = solver.solve(-(d.T @ (weights * s[j]))[free])
        gradients[j] = d @ t + s[j]
    volume = float(np.prod(image.size))
    return np.array([[gradients[i] @ (weights * gradients[j]) / volume if i in gradients and j in gradients else 0.0
                      for j in range(3)] for i in range(3)])
