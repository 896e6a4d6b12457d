"""The compiled Q1 slab product of :mod:`aromm.linalg.multigrid.q1_kernel`, at module level so that numba caches it
on disk (the first run compiles it; later processes load it).  Imported only when a product uses it.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, fastmath=False)
def product(ext, phase, table, out):  # type: ignore[no-untyped-def]
    planes, rows, cols = ext.shape
    ne = cols - 1
    dt = ext.dtype
    q = np.empty((4, cols), dtype=dt)  # node rows combined along y and z: SS, DS, SD, DD
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    # per element i: its left (x0 → node i) and right (x1 → node i + 1) halves per yz-combination
    halves = np.zeros((8, cols), dtype=dt)  # left[ne] and right[0] stay zero
    l0, l1, l2, l3, r0, r1, r2, r3 = (halves[0], halves[1], halves[2], halves[3], halves[4], halves[5],
                                      halves[6], halves[7])
    w = np.empty((8, cols), dtype=dt)
    out[...] = 0
    for k in range(planes - 1):
        for j in range(rows - 1):
            a, b, c, d = ext[k, j], ext[k, j + 1], ext[k + 1, j], ext[k + 1, j + 1]
            for i in range(cols):
                ab = a[i] + b[i]
                ba = b[i] - a[i]
                cd = c[i] + d[i]
                dc = d[i] - c[i]
                q0[i] = ab + cd
                q1[i] = ba + dc
                q2[i] = cd - ab
                q3[i] = dc - ba
            ph = phase[k, j]
            for m in range(8):  # the elements' weights, gathered by phase code
                wm = w[m]
                for i in range(ne):
                    wm[i] = table[ph[i], m]
            w0, w1, w2, w3, w4, w5, w6, w7 = w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]
            for i in range(ne):
                g_dss = w0[i] * (q0[i + 1] - q0[i])
                g_sss = w7[i] * (q0[i + 1] + q0[i])  # zero weight without a capacity
                g_sds = w1[i] * (q1[i + 1] + q1[i])
                g_dds = w3[i] * (q1[i + 1] - q1[i])
                g_ssd = w2[i] * (q2[i + 1] + q2[i])
                g_dsd = w4[i] * (q2[i + 1] - q2[i])
                g_sdd = w5[i] * (q3[i + 1] + q3[i])
                g_ddd = w6[i] * (q3[i + 1] - q3[i])
                # adjoint of the x pair: left node S − D, right node S + D
                l0[i] = g_sss - g_dss
                r0[i + 1] = g_sss + g_dss
                l1[i] = g_sds - g_dds
                r1[i + 1] = g_sds + g_dds
                l2[i] = g_ssd - g_dsd
                r2[i + 1] = g_ssd + g_dsd
                l3[i] = g_sdd - g_ddd
                r3[i + 1] = g_sdd + g_ddd
            oa, ob, oc, od = out[k, j], out[k, j + 1], out[k + 1, j], out[k + 1, j + 1]
            for i in range(cols):
                s0 = l0[i] + r0[i]
                s1 = l1[i] + r1[i]
                s2 = l2[i] + r2[i]
                s3 = l3[i] + r3[i]
                # adjoint of the yz combination: node (y, z) gets Σ σ_y σ_z s, σ = −1 on a 0 node of a D
                oa[i] += s0 - s1 - s2 + s3
                ob[i] += s0 + s1 - s2 - s3
                oc[i] += s0 - s1 + s2 - s3
                od[i] += s0 + s1 + s2 + s3
