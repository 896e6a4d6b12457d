"""Nested-dissection ordering: a permutation, separators that decouple, less fill, same solutions."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.linalg.direct import factorize
from aromm.linalg.orderings import nested_dissection


def _voxel_system(n: int):  # type: ignore[no-untyped-def]
    labels = np.random.default_rng(0).integers(0, 2, size=(n, n, n))
    return assemble_voxels(labels, (1e-4,) * 3, [PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 100.0)],
                           [FaceSpec("z0", flux=1.0), FaceSpec("z1", h=10.0)])


def test_ordering_is_a_permutation_whose_top_separator_decouples_the_halves() -> None:
    system = _voxel_system(8)
    a = system.conductance.evaluate(system.values())
    perm = nested_dissection(a, system.geometry.points, leaf_size=16)
    assert np.array_equal(np.sort(perm), np.arange(system.n))
    # the last separator is one node plane; removing it leaves two blocks with no coupling
    plane = system.geometry.points[:, 0] == system.geometry.points[perm[-1], 0]
    left = np.flatnonzero(system.geometry.points[:, 0] < system.geometry.points[perm[-1], 0])
    right = np.flatnonzero(~plane & ~np.isin(np.arange(system.n), left))
    assert left.size and right.size
    assert sp.csr_array(a)[left][:, right].nnz == 0


def test_nested_dissection_reduces_fill_on_a_3d_grid() -> None:
    system = _voxel_system(12)
    a = sp.csc_matrix(system.conductance.evaluate(system.values()))
    perm = nested_dissection(a, system.geometry.points)
    natural = spla.splu(a, permc_spec="NATURAL").nnz
    dissected = spla.splu(a[perm][:, perm], permc_spec="NATURAL").nnz
    assert dissected < 0.6 * natural


@pytest.mark.parametrize("method", ["cholmod", "splu"])
def test_ordered_factorisation_solves_the_same_system(method: str) -> None:
    system = _voxel_system(7)
    a = system.conductance.evaluate(system.values())
    b = system.load.evaluate(system.values())
    plain = factorize(a, method).solve(b)
    ordered = factorize(a, method, points=system.geometry.points).solve(b)
    np.testing.assert_allclose(ordered, plain, rtol=1e-9)


def test_ordering_works_on_scattered_points_and_graphs() -> None:
    """A random geometric graph (like a DEM bond network): valid permutation, exact solve."""
    rng = np.random.default_rng(1)
    pts = rng.random((400, 3))
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    adj = sp.csr_array((d < 0.15) & (d > 0), dtype=float)
    lap = sp.csr_array(sp.diags(adj.sum(axis=1) + 1e-2) - adj)
    perm = nested_dissection(lap, pts, leaf_size=8)
    assert np.array_equal(np.sort(perm), np.arange(400))
    b = rng.standard_normal(400)
    np.testing.assert_allclose(factorize(lap, "cholmod", points=pts).solve(b), spla.spsolve(lap.tocsc(), b),
                               rtol=1e-8)
