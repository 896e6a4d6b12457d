"""The compiled Q1 slab product (aromm.linalg.multigrid.q1_kernel) equals the numpy passes of VoxelOperator to
rounding, on every kind of operator the multigrid and the reductor build: a box, a periodic cell, fixed faces with a
capacity and an exchange face, and blocks of float32 columns.  (The operator's own tests, which compare it with the
assembled Q1 matrix of aromm.fem, run through this kernel whenever numba is installed.)"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.q1_kernel import slab_product

pytestmark = pytest.mark.skipif(slab_product() is None, reason="numba not installed")
K = np.array([[1.0, 2.0, 3.0], [10.0, 10.0, 20.0], [0.3, 0.3, 0.3]])
CASES = {
    "box": {},
    "periodic": {"periodic": True},
    "fixed, capacity, exchange": {"fixed": ("x0", "z1"), "capacity": np.array([1e6, 2e6, 5e5]),
                                  "exchange": (("y1", 5.0),)},
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_compiled_product_equals_the_numpy_passes(case: str, dtype: type) -> None:
    rng = np.random.default_rng(7)
    phase = rng.integers(0, 3, size=(7, 9, 11))  # (z, y, x): odd, unequal sides
    # the compiled product runs where the per-voxel weights are not kept (large grids; here asked for)
    op = VoxelOperator(phase, K, (1e-3, 2e-3, 1.5e-3), keep_weights=False, **CASES[case])  # type: ignore[arg-type]
    reference = replace(op, compiled=False, keep_weights=True, _cache={})
    x = rng.standard_normal((op.n, 3)).astype(dtype)
    got, want = op.matvec(x), reference.matvec(x)
    eps = float(np.finfo(dtype).eps)
    # 27 terms per row, each a sum of at most 8 products: a few dozen roundings of the row's magnitude
    magnitude = np.abs(replace(op, conductivity=np.abs(K)).matvec(np.abs(x).astype(dtype))).max()
    assert np.abs(got - want).max() <= 64 * eps * max(float(magnitude), float(np.abs(want).max()))
    assert np.array_equal(op.matvec(x[:, 0]), got[:, 0])  # one column or a block: the same numbers
