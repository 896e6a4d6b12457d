"""Between numpy/scipy blocks of this rank's rows and PETSc objects (MPIAIJ, MPI vectors), and the products of
PETSc matrices with tall numpy blocks (bases) that never copy the block.

A rank's block of a matrix is its owned rows with *global* column indices (scipy CSR); of a vector or a
tall matrix (a basis), its owned rows.  PETSc copies what it is given (no shared buffers).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.engines.petsc import runtime
from aromm.engines.petsc.layout import RowLayout

#: Columns multiplied at a time by :func:`blocks` (its work arrays are rows × BLOCK per matrix).
BLOCK = 8
#: Rows combined at a time by :func:`combine_rows`.
ROWS = 4096


def matrix(block: sp.csr_array, rows: RowLayout, comm: Any, fields: int = 1) -> Any:
    """Square MPIAIJ matrix from this rank's rows (``rows.local`` × n, global columns); ``fields`` > 1: interlaced
    unknowns per node, the matrix's block size (GAMG then coarsens nodes, not single unknowns)."""
    PETSc = runtime.petsc()
    csr = sp.csr_array(block)
    csr.sum_duplicates()
    csr.sort_indices()
    index = PETSc.IntType
    mat = PETSc.Mat().createAIJ(size=((rows.local, rows.n), (rows.local, rows.n)), bsize=fields,
                                csr=(csr.indptr.astype(index, copy=False), csr.indices.astype(index, copy=False),
                                     np.asarray(csr.data, dtype=float)), comm=comm)
    mat.assemble()
    return mat


def vector(local: npt.ArrayLike, rows: RowLayout, comm: Any) -> Any:
    """MPI vector holding a copy of this rank's entries."""
    PETSc = runtime.petsc()
    vec = PETSc.Vec().createMPI((rows.local, rows.n), comm=comm)
    vec.getArray()[:] = np.asarray(local, dtype=float)
    return vec


def array(vec: Any) -> FloatArray:
    """A copy of this rank's entries of a PETSc vector."""
    return np.array(vec.getArray(readonly=True), dtype=float)


def apply(mat: Any, local: FloatArray, rows: RowLayout, comm: Any) -> FloatArray:
    """This rank's entries of ``mat @ x`` for a vector x given by its entries."""
    out = mat.createVecLeft()
    mat.mult(vector(local, rows, comm), out)
    return array(out)


def blocks(mats: tuple[Any, ...], x: FloatArray, block: int = BLOCK) -> Iterator[tuple[slice, list[FloatArray]]]:
    """``(cols, [M @ X[:, cols] for M in mats])`` for the column blocks of a tall X given by this rank's rows
    (collective).  One matrix–vector product per column into one work array per matrix (rows × ``block``),
    reused from block to block: no copy of X and no temporary of its size."""
    if not mats:
        return
    src, dst = mats[0].createVecRight(), mats[0].createVecLeft()
    work = [np.empty((x.shape[0], min(block, x.shape[1]))) for _ in mats]
    for j0 in range(0, x.shape[1], block):
        cols = slice(j0, min(j0 + block, x.shape[1]))
        for j in range(cols.start, cols.stop):
            src.getArray()[:] = x[:, j]
            for mat, out in zip(mats, work, strict=True):
                mat.mult(src, dst)
                out[:, j - j0] = dst.getArray(readonly=True)
        yield cols, [w[:, : cols.stop - cols.start] for w in work]
    src.destroy()
    dst.destroy()


def quadratic(mat: Any, a: FloatArray, b: FloatArray, comm: Any) -> FloatArray:
    """``Aᵀ M B`` for tall A, B given by this rank's rows, summed over the ranks (M applied by :func:`blocks`)."""
    out = np.empty((a.shape[1], b.shape[1]))
    for cols, (mb,) in blocks((mat,), b):
        out[:, cols] = a.T @ mb
    return runtime.allsum(out, comm)


def diagonal(mat: Any, x: FloatArray, comm: Any) -> FloatArray:
    """``diag(Xᵀ M X)`` (each column's energy), summed over the ranks."""
    out = np.empty(x.shape[1])
    for cols, (mx,) in blocks((mat,), x):
        out[cols] = np.einsum("ij,ij->j", x[:, cols], mx)
    return runtime.allsum(out, comm)


def combine_rows(x: FloatArray, q: FloatArray, out: FloatArray | None = None, rows: int = ROWS) -> FloatArray:
    """``X @ Q`` computed block of rows by block of rows (no temporary of X's size); ``out`` may be X itself
    when Q is square, or a view of the final basis."""
    out = np.empty((x.shape[0], q.shape[1])) if out is None else out
    for i in range(0, x.shape[0], rows):
        out[i:i + rows] = x[i:i + rows] @ q
    return out


def gram(a: FloatArray, b: FloatArray, comm: Any) -> FloatArray:
    """``Aᵀ B`` for tall A, B given by this rank's rows (summed over the ranks)."""
    return runtime.allsum(a.T @ b, comm)
