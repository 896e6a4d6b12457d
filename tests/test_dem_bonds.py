"""Bond networks [Hassan2019, § 2.1]: coordination target, minimum degree, connectivity, periodic images."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from aromm.dem.neighbours import build_bonds, coordination_table, gap_for_coordination
from aromm.dem.packing import Packing, cubic_lattice, pack_spheres


@pytest.fixture(scope="module")
def packing() -> Packing:
    return pack_spheres(2000, np.random.default_rng(3))


@pytest.mark.parametrize("z", [6.0, 7.5])
def test_coordination_degree_connectivity(packing: Packing, z: float) -> None:
    b = build_bonds(packing, z, min_degree=3)
    assert b.coordination(packing.n) == pytest.approx(z, abs=0.05)
    assert b.degree(packing.n).min() >= 3
    g = sp.coo_array((np.ones(b.m), (b.pairs[:, 0], b.pairs[:, 1])), shape=(packing.n,) * 2)
    assert connected_components(g, directed=False)[0] == 1
    assert len({tuple(p) for p in b.pairs}) == b.m  # no duplicate bond
    assert np.all(b.pairs[:, 0] < b.pairs[:, 1])


def test_vectors_are_nearest_images(packing: Packing) -> None:
    b = build_bonds(packing, 7.5)
    assert np.all(np.abs(b.vectors) <= 0.5 * packing.box + 1e-12)
    raw = packing.centers[b.pairs[:, 1]] - packing.centers[b.pairs[:, 0]]
    np.testing.assert_allclose(np.mod(raw - b.vectors + 0.5 * packing.box, packing.box) - 0.5 * packing.box,
                               0.0, atol=1e-12)
    gaps = b.lengths / (packing.radii[b.pairs[:, 0]] + packing.radii[b.pairs[:, 1]]) - 1
    assert np.sum(gaps > b.gap_threshold) == b.added  # only repair bonds exceed the threshold


def test_gap_table_matches_dem_notes(packing: Packing) -> None:
    """docs/notes/dem.md: true contacts Z ~ 4.8, gap < 0.9 % -> Z ~ 6, gap < 6 % -> Z ~ 7.5."""
    z = coordination_table(packing, [0.0, 0.009, 0.06])
    assert np.all(np.diff(z) > 0)
    assert z[1] == pytest.approx(6.0, abs=0.4)
    assert z[2] == pytest.approx(7.5, abs=0.4)
    assert gap_for_coordination(packing, 6.0) < gap_for_coordination(packing, 7.5)


def test_cubic_lattice_has_six_neighbours() -> None:
    lat = cubic_lattice(5, 1.0)
    b = build_bonds(lat, 6.0)
    assert b.coordination(lat.n) == pytest.approx(6.0)
    assert np.all(b.degree(lat.n) == 6)
    np.testing.assert_allclose(b.lengths, 1.0)


def test_cut_network_uses_periodic_threshold(packing: Packing) -> None:
    b = build_bonds(packing, 7.5)
    cut = packing.cut(packing.lower, packing.lower + packing.box)
    cb = build_bonds(cut, gap=b.gap_threshold)
    assert cb.degree(cut.n).min() >= 3
    # bonds crossing the periodic boundary are lost: the cut network is less coordinated
    assert cb.coordination(cut.n) < b.coordination(packing.n)
