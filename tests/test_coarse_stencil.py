"""The coarse levels' 27-point coefficient arrays (aromm.linalg.multigrid.coarse_stencil) against CSR and mathematics.

The layout is checked by what a Galerkin level must be: symmetric, with zero row sums on a periodic grid (constants
in the kernel), and equal to the CSR rows assembled from the same element classes; the compiled and numpy products
against the CSR product of the same coefficients, to the rounding of 27-term sums.
"""

from __future__ import annotations

import numpy as np
import pytest

from aromm.linalg.multigrid.coarse_stencil import OFFSETS, StencilMatrix, compiled_product, numpy_product
from aromm.linalg.multigrid.hierarchy import ElementLevel, fixed_mask
from aromm.linalg.multigrid.operator import VoxelOperator

EPS = float(np.finfo(float).eps)


def _operator(shape: tuple[int, int, int], periodic: bool, fixed: tuple[str, ...] = ()) -> VoxelOperator:
    phase = np.random.default_rng(5).integers(0, 3, size=shape)
    conductivity = np.array([[1.0, 1.0, 1.0], [1e3, 1e3, 1e3], [0.5, 2.0, 4.0]])  # contrast 2e3, one orthotropic
    return VoxelOperator(phase, conductivity, (1e-3, 2e-3, 1.5e-3), periodic=periodic, fixed=fixed)


@pytest.mark.parametrize(("periodic", "fixed"), [(True, ()), (False, ()), (False, ("x0", "z1"))])
def test_a_galerkin_level_is_symmetric_and_equals_its_csr_rows(periodic: bool, fixed: tuple[str, ...]) -> None:
    level = ElementLevel.coarse_of(_operator((10, 9, 12), periodic, fixed))
    stencil = level.to_stencil(np.float64)
    csr = level.to_csr()
    a = stencil.toarray()
    scale = float(np.abs(a).max())
    assert np.abs(a - a.T).max() <= 32 * EPS * scale
    assert np.abs(a - csr.toarray()).max() == 0.0  # the same sums, stored two ways
    if periodic:
        assert np.abs(a.sum(axis=1)).max() <= 64 * EPS * scale
    mask = fixed_mask(level.node_shape, fixed)
    if fixed:
        assert np.array_equal(a[mask][:, mask], np.eye(int(mask.sum())))
        assert not a[mask][:, ~mask].any() and not a[~mask][:, mask].any()


@pytest.mark.parametrize("shape", [(4, 5, 6), (1, 3, 2), (2, 2, 1), (5, 1, 7)])
@pytest.mark.parametrize("periodic", [True, False])
def test_the_products_equal_the_csr_product(shape: tuple[int, int, int], periodic: bool) -> None:
    """Random coefficients (zero towards missing neighbours of a box), axes of 1 and 2 nodes where a periodic
    neighbour is the node itself or both neighbours coincide: compiled, numpy and CSR agree to 27-term rounding."""
    rng = np.random.default_rng(sum(shape) + periodic)
    data = rng.standard_normal((27, *shape))
    if not periodic:
        for o, index in enumerate(OFFSETS):
            for axis, (i, n) in enumerate(zip(index, shape, strict=True)):
                if i != 1:
                    data[o][(slice(None),) * axis + (0 if i == 0 else n - 1,)] = 0.0
    m = StencilMatrix(data, periodic)
    x = rng.standard_normal(m.shape[0])
    truth = m.tocsr() @ x
    bound = 27 * EPS * float(np.abs(data).max() * np.abs(x).max()) * 2
    y = np.empty(shape)
    numpy_product(data, x.reshape(shape), y, periodic)
    assert np.abs(y.ravel() - truth).max() <= bound
    kernel = compiled_product()
    if kernel is not None:
        kernel(data, x.reshape(shape), y, periodic)
        assert np.abs(y.ravel() - truth).max() <= bound
    assert np.abs(m @ x - truth).max() <= bound


def test_single_precision_coefficients_keep_float32_rounding() -> None:
    """The V-cycle's float32 level against float64: within the rounding of the coefficients and of the sums."""
    level = ElementLevel.coarse_of(_operator((12, 12, 12), True))
    double, single = level.to_stencil(np.float64), level.to_stencil(np.float32)
    x = np.random.default_rng(8).standard_normal(double.shape[0])
    exact = double @ x
    rounded = single.matvec(x.astype(np.float32))
    assert rounded.dtype == np.float32
    scale = float(np.abs(double.data).max() * np.abs(x).max())
    assert np.abs(rounded - exact).max() <= 2 * 27 * float(np.finfo(np.float32).eps) * scale


def test_held_nodes_act_as_identity_rows_and_zero_columns() -> None:
    """A level constrained afterwards (the fixed-temperature problems share the free coefficients): its product,
    diagonal and Gershgorin row sums are those of the dense matrix with identity rows and zero columns at the held
    nodes; the free level is left as it was."""
    level = ElementLevel.coarse_of(_operator((9, 10, 11), False))
    free = level.to_stencil(np.float64)
    mask = fixed_mask(level.node_shape, ("y0", "y1"))
    a = free.toarray()
    a[mask] = 0.0
    a[:, mask] = 0.0
    a[mask, mask] = 1.0
    held = free.with_fixed(mask)
    assert np.abs(held.toarray() - a).max() == 0.0
    x = np.random.default_rng(4).standard_normal(a.shape[0])
    assert np.abs(held @ x - a @ x).max() <= 27 * EPS * float(np.abs(a).max() * np.abs(x).max()) * 2
    assert np.array_equal(held.diagonal(), np.diag(a))
    assert np.abs(held.abs_row_sums() - np.abs(a).sum(axis=1)).max() <= 27 * EPS * float(np.abs(a).max())
    assert np.abs(free.toarray() - level.to_csr().toarray()).max() == 0.0  # the free level left as it was
