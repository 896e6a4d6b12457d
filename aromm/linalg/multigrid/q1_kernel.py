"""The compiled Q1 slab product: ``Σ_c T_cᵀ w_c T_c`` of :mod:`aromm.linalg.multigrid.operator` in one pass.

The numpy path of :meth:`VoxelOperator._apply` makes ≈ 55 passes over a slab and gathers 7–8 weights per voxel
(32–64 B/voxel when kept).  Here each row of elements (fixed y and z) is done at once, with the phase's weights read
from the (combinations × phases) table: the four node rows around it are combined along y and z per node
(``q_SS = A + B + C + D``, …), the x pairs of each element give the eight Haar coefficients
``t_{sx sy sz}``, the weights multiply them, and the adjoint runs the same butterflies backwards into the four node
rows of the result.  Inner loops run along x over contiguous memory (vectorised by LLVM); two row buffers hold the
left- and right-node halves of every element's contribution so that no iteration writes what the next reads.

Same arithmetic as the numpy path up to the order of the sums (tests/test_q1_kernel.py: equal to rounding).  Used
where the numpy path would gather the weights again in every product (grids above ``WEIGHT_CACHE_BYTES`` of weights,
or ``keep_weights=False``): measured at 128³ on one thread (benchmarks/kernels.py), 10.7 ns per node in float64
against 15.3 ns for the numpy passes with kept weights, but 12.2 ns in float32 against 9.0 ns: LLVM does not
vectorise the element loop (too many arrays for its alias checks), so with kept weights numpy stays faster and this
kernel reaches ≈ 6 % of the memory-bandwidth bound.  Needs numba (``pip install aromm[fast]``); :func:`slab_product`
returns None without it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray

SlabProduct = Callable[[FloatArray, npt.NDArray[np.integer], FloatArray, FloatArray], None]


def code_table(table: FloatArray) -> FloatArray:
    """(codes, 8) weights of :func:`slab_product` from the operator's (combinations, codes) weight table (its last
    column the zero-weight padding code): a row per code, SSS last (zero without a capacity)."""
    codes = np.zeros((table.shape[1], 8), dtype=table.dtype)
    codes[:, :table.shape[0]] = table.T
    return codes


@cache
def slab_product() -> SlabProduct | None:
    """``product(ext, phase, table, out)``: out ← Σ_e K_e ext over the slab's elements; ``ext`` the node planes
    (planes, rows, cols), ``phase`` the elements' phase codes (planes − 1, rows, cols) (the last row and column:
    the zero-weight code), ``table`` (codes, 8): per code the weights of DSS SDS SSD DDS DSD SDD DDD SSS (letters
    x, y, z; SSS zero without a capacity), contiguous.  None when numba is not installed."""
    try:
        from aromm.linalg.multigrid.q1_compiled import product  # imports numba: only when a product needs it
    except ImportError:
        return None
    return product  # type: ignore[no-any-return]
