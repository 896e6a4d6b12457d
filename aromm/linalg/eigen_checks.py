"""Checks of computed eigenpairs by chunks of columns (bounded memory): residuals, norms and Gram matrices.

Each function touches at most :data:`CHECK_COLUMNS` columns of the basis at a time, so checking Ñ modes of an
n-unknown problem costs O(n × CHECK_COLUMNS) temporary memory whatever Ñ.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from aromm.core.system import FloatArray

CHECK_COLUMNS = 32


def relative_residuals(k: sp.csr_array, n_mat: sp.csr_array, lam: FloatArray, v: FloatArray) -> FloatArray:
    """``||K v − λ N v|| / (||K v|| + |λ| ||N v||)`` per column (temporaries of CHECK_COLUMNS columns)."""
    out = np.empty(v.shape[1])
    for lo in range(0, v.shape[1], CHECK_COLUMNS):
        cols = slice(lo, lo + CHECK_COLUMNS)
        kv = k @ v[:, cols]
        nv = n_mat @ v[:, cols]
        num = np.linalg.norm(kv - nv * lam[cols], axis=0)
        den = np.linalg.norm(kv, axis=0) + np.abs(lam[cols]) * np.linalg.norm(nv, axis=0)
        out[cols] = num / np.maximum(den, 1e-300)
    return out


def column_norms(m: sp.csr_array, v: FloatArray) -> FloatArray:
    """``sqrt(diag(vᵀ M v))`` (temporaries of CHECK_COLUMNS columns)."""
    return np.sqrt(np.concatenate([np.einsum("ij,ij->j", v[:, lo:lo + CHECK_COLUMNS], m @ v[:, lo:lo + CHECK_COLUMNS])
                                   for lo in range(0, v.shape[1], CHECK_COLUMNS)]))


def chunked_gram(m: sp.csr_array, v: FloatArray) -> FloatArray:
    """``vᵀ M v`` (temporaries of CHECK_COLUMNS columns)."""
    out = np.empty((v.shape[1], v.shape[1]))
    for lo in range(0, v.shape[1], CHECK_COLUMNS):
        out[:, lo:lo + CHECK_COLUMNS] = v.T @ (m @ v[:, lo:lo + CHECK_COLUMNS])
    return out
