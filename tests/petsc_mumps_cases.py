"""One MUMPS solve set up by the petsc engine, in the pytest process or under ``mpiexec -n 2 python
tests/petsc_worker.py OUT petsc_mumps_cases`` (tests/test_petsc_eigensolvers.py)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

#: PETSc options prefix of the probe solve.
PROBE_PREFIX = "aromm_probe_"


def mumps_probe(comm: Any, prefix: str = PROBE_PREFIX) -> dict[str, np.ndarray]:
    """A MUMPS Cholesky solve of a 1-D Laplacian + identity (400 rows, a known solution) set up by the engine's
    :func:`aromm.engines.petsc.linear.krylov` with options ``prefix``: the ICNTL(28)/(29) its factor holds, and
    the largest error of the solution."""
    from aromm.engines.petsc import convert, linear
    from aromm.engines.petsc.layout import RowLayout

    n = 400
    a = sp.diags([-1.0, 3.0, -1.0], [-1, 0, 1], shape=(n, n), format="csr")
    size, rank = comm.getSize(), comm.getRank()
    rows = RowLayout(tuple(r * n // size for r in range(size + 1)), rank)
    mat = convert.matrix(sp.csr_array(a[rows.lo:rows.hi]), rows, comm)
    ksp = linear.krylov(mat, "mumps", 1e-12, prefix)
    x_true = np.linspace(0.0, 1.0, n)
    b = convert.vector((a @ x_true)[rows.lo:rows.hi], rows, comm)
    x = mat.createVecRight()
    linear.solve(ksp, b, x, "MUMPS probe", 1e-12)
    factor = ksp.getPC().getFactorMatrix()
    error = float(np.abs(convert.array(x) - x_true[rows.lo:rows.hi]).max())
    return {"icntl_28": np.array(factor.getMumpsIcntl(28)), "icntl_29": np.array(factor.getMumpsIcntl(29)),
            "probe_error": np.array(error)}


def results(comm: Any) -> dict[str, np.ndarray]:
    return mumps_probe(comm)
