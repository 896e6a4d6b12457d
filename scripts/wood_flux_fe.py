"""Private check tool (not library code): effective conductivity of a voxel image by the flux method.

Seed 001 eq. 13: uniform flux q on face S1 (x0, y0 or z0), T = 0 on the opposite face S2, other faces
adiabatic; k_ii = q L / (T̄_S1 − T̄_S2).  Discretisation: one trilinear (Q1) hexahedron per voxel,
nodal temperatures, node index i + (nx+1)(j + (ny+1)k), as the lead's aromm/fem.py; element
matrices are one reference voxel matrix scaled by the phase conductivity.  Face means are exact
integrals of the Q1 trace (trapezoid weights).  Used by scripts/make_wood_ver.py until
aromm.homogenize lands; then replaced by it as the confirmation.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from aromm.linalg import factorize


def voxel_stiffness(dx: float, dy: float, dz: float) -> np.ndarray:
    """8×8 Q1 stiffness of one box voxel with unit conductivity, local node a + 2b + 4c."""
    def k1(h: float) -> np.ndarray:
        return np.array([[1.0, -1.0], [-1.0, 1.0]]) / h

    def m1(h: float) -> np.ndarray:
        return np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6.0

    return (
        np.kron(m1(dz), np.kron(m1(dy), k1(dx)))
        + np.kron(m1(dz), np.kron(k1(dy), m1(dx)))
        + np.kron(k1(dz), np.kron(m1(dy), m1(dx)))
    )


def stiffness(labels: np.ndarray, voxel: tuple[float, float, float], k: dict[int, float]) -> sp.csr_array:
    nx, ny, nz = labels.shape
    i, j, kk = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    base = (i + (nx + 1) * (j + (ny + 1) * kk)).ravel()
    offsets = np.array([a + (nx + 1) * (b + (ny + 1) * c) for c in (0, 1) for b in (0, 1) for a in (0, 1)])
    nodes = base[:, None] + offsets[None, :]
    ke = voxel_stiffness(*voxel)
    coef = np.zeros(labels.size)
    for label, value in k.items():
        coef[labels.ravel() == label] = value
    rows = np.repeat(nodes, 8, axis=1).ravel()
    cols = np.tile(nodes, (1, 8)).ravel()
    data = (coef[:, None, None] * ke[None, :, :]).ravel()
    n = (nx + 1) * (ny + 1) * (nz + 1)
    return sp.csr_array(sp.coo_array((data, (rows, cols)), shape=(n, n)))


def flux_conductivity(
    labels: np.ndarray, voxel: tuple[float, float, float], k: dict[int, float], q: float = 500.0,
    method: str = "amg",
) -> np.ndarray:
    """(k_xx, k_yy, k_zz) by seed 001 eq. 13 on faces x0/x1, y0/y1, z0/z1."""
    shape = labels.shape
    npts = tuple(n + 1 for n in shape)
    kmat = stiffness(labels, voxel, k)
    index = np.arange(np.prod(npts)).reshape(npts, order="F")
    out = []
    for axis in range(3):
        others = [d for d in range(3) if d != axis]
        # trapezoid weights of the face grid (exact integral of the bilinear trace)
        w = [np.full(npts[d], voxel[d]) for d in others]
        for ww in w:
            ww[[0, -1]] *= 0.5
        weight = np.outer(w[0], w[1])
        s1 = np.take(index, 0, axis=axis)
        s2 = np.take(index, -1, axis=axis)
        free = np.ones(kmat.shape[0], bool)
        free[s2.ravel()] = False
        load = np.zeros(kmat.shape[0])
        load[s1.ravel()] = q * weight.ravel()
        a = kmat[free][:, free]
        t = np.zeros(kmat.shape[0])
        t[free] = factorize(a, method, rtol=1e-10).solve(load[free])
        mean1 = float((t[s1.ravel()] * weight.ravel()).sum() / weight.sum())
        length = shape[axis] * voxel[axis]
        out.append(q * length / mean1)
    return np.array(out)
