"""The strided-slice grid transfers equal the tensor product of the 1-D interpolation matrices (and its transpose).

Truth: ``P = P_z ⊗ P_y ⊗ P_x`` of :func:`aromm.linalg.multigrid.hierarchy.prolongation_1d`, box and periodic,
even and odd element counts on each axis (an odd box axis keeps its end node; an even periodic axis wraps).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from aromm.linalg.multigrid.hierarchy import prolongation_1d
from aromm.linalg.multigrid.transfer import transfer


def _kron(elements: tuple[int, int, int], periodic: bool) -> sp.csr_array:
    pz, py, px = (prolongation_1d(e, periodic) for e in elements)
    return sp.csr_array(sp.kron(sp.kron(pz, py), px))


def _kept() -> tuple[dict[str, np.ndarray], object]:
    keep: dict[str, np.ndarray] = {}

    def vector(name: str, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
        v = keep.get(name)
        if v is None or v.shape != shape or v.dtype != dtype:
            v = keep[name] = np.full(shape, np.nan, dtype=dtype)  # NaN: a pass must write every entry
        return v

    return keep, vector


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("elements", [(4, 6, 8), (5, 7, 9), (6, 5, 4)])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_transfers_equal_the_kronecker_product(elements: tuple[int, int, int], periodic: bool,
                                               dtype: type) -> None:
    p = _kron(elements, periodic)
    rng = np.random.default_rng(7)
    coarse = rng.standard_normal(p.shape[1]).astype(dtype)
    fine = rng.standard_normal(p.shape[0]).astype(dtype)
    tol = 1e-12 if dtype == np.float64 else 1e-5
    _, vector = _kept()
    for _ in range(2):  # the second pass reuses the kept vectors: stale entries must not leak
        up = transfer(coarse, elements, periodic, False, vector)  # type: ignore[arg-type]
        down = transfer(fine, elements, periodic, True, vector)  # type: ignore[arg-type]
        assert up.dtype == dtype and down.dtype == dtype
        np.testing.assert_allclose(up, p @ coarse.astype(float), rtol=tol, atol=tol)
        np.testing.assert_allclose(down, p.T @ fine.astype(float), rtol=tol, atol=tol)


def test_restriction_is_the_adjoint_of_interpolation() -> None:
    elements = (7, 4, 5)
    rng = np.random.default_rng(3)
    _, vector = _kept()
    c = rng.standard_normal(int(np.prod([(e + 1) // 2 + 1 for e in elements])))
    f = rng.standard_normal(int(np.prod([e + 1 for e in elements])))
    pc = transfer(c, elements, False, False, vector).copy()  # type: ignore[arg-type]
    rf = transfer(f, elements, False, True, vector)  # type: ignore[arg-type]
    assert float(f @ pc) == pytest.approx(float(c @ rf), rel=1e-13)
