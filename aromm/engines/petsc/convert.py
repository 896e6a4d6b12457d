"""Between numpy/scipy blocks of this rank's rows and PETSc objects (MPIAIJ, MPIDENSE, MPI vectors).

A rank's block of a matrix is its owned rows with *global* column indices (scipy CSR); of a vector or a
tall matrix (a basis), its owned rows.  PETSc copies what it is given (no shared buffers).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.engines.petsc import runtime
from aromm.engines.petsc.layout import RowLayout


def matrix(block: sp.csr_array, rows: RowLayout, comm: Any) -> Any:
    """Square MPIAIJ matrix from this rank's rows (``rows.local`` × n, global columns)."""
    PETSc = runtime.petsc()
    csr = sp.csr_array(block)
    csr.sum_duplicates()
    csr.sort_indices()
    index = PETSc.IntType
    mat = PETSc.Mat().createAIJ(size=((rows.local, rows.n), (rows.local, rows.n)),
                                csr=(csr.indptr.astype(index), csr.indices.astype(index),
                                     np.asarray(csr.data, dtype=float)), comm=comm)
    mat.assemble()
    return mat


def vector(local: npt.ArrayLike, rows: RowLayout, comm: Any) -> Any:
    """MPI vector holding a copy of this rank's entries."""
    PETSc = runtime.petsc()
    vec = PETSc.Vec().createMPI((rows.local, rows.n), comm=comm)
    vec.getArray()[:] = np.asarray(local, dtype=float)
    return vec


def dense(local: FloatArray, rows: RowLayout, comm: Any) -> Any:
    """MPIDENSE matrix (n × m) from this rank's rows (``rows.local`` × m)."""
    PETSc = runtime.petsc()
    block = np.asfortranarray(np.asarray(local, dtype=float))
    mat = PETSc.Mat().createDense(size=((rows.local, rows.n), (PETSc.DECIDE, block.shape[1])), array=block,
                                  comm=comm)
    mat.assemble()
    return mat


def array(vec: Any) -> FloatArray:
    """A copy of this rank's entries of a PETSc vector."""
    return np.array(vec.getArray(readonly=True), dtype=float)


def apply(mat: Any, local: FloatArray, rows: RowLayout, comm: Any) -> FloatArray:
    """This rank's rows of ``mat @ X`` for a tall X given by its rows (n_local × m), by one MatMatMult."""
    if local.ndim == 1:
        out = mat.createVecLeft()
        mat.mult(vector(local, rows, comm), out)
        return array(out)
    if local.shape[1] == 0:
        return np.zeros_like(local)
    product = mat.matMult(dense(local, rows, comm))
    return np.array(product.getDenseArray(), dtype=float)


def gram(a: FloatArray, b: FloatArray, comm: Any) -> FloatArray:
    """``Aᵀ B`` for tall A, B given by this rank's rows (summed over the ranks)."""
    return runtime.allsum(a.T @ b, comm)
