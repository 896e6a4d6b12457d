"""Packings [Hassan2019, § 2.1]: reproducible, dense, non-overlapping, Gaussian radii; cut, tile, save/load."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aromm.core.errors import InputError
from aromm.dem.packing import Packing, cubic_lattice, gaussian_radii, load_packing, pack_spheres


@pytest.fixture(scope="module")
def packing() -> Packing:
    return pack_spheres(1500, np.random.default_rng(11), box=0.02)


def _min_image_overlap(p: Packing) -> float:
    """Largest relative overlap 1 - d/(r_i + r_j) by brute force (independent of the KD-tree)."""
    d = p.centers[:, None, :] - p.centers[None, :, :]
    d -= p.box * np.round(d / p.box)
    dist = np.sqrt((d**2).sum(-1))
    sigma = p.radii[:, None] + p.radii[None, :]
    np.fill_diagonal(dist, np.inf)
    return float(np.max(1.0 - dist / sigma))


def test_volume_fraction_radii_and_no_overlap(packing: Packing) -> None:
    assert packing.n == 1500 and packing.periodic
    assert packing.volume_fraction == pytest.approx(0.64, rel=1e-9)
    r = packing.radii / packing.mean_radius
    # CV 0.3 truncated at +-2.5 sd: sd of the truncated normal is 0.3 * 0.9586
    assert np.std(r) == pytest.approx(0.3 * 0.9586, abs=0.02)
    assert r.min() >= 1 - 2.5 * 0.3 - 1e-12 and r.max() <= 1 + 2.5 * 0.3 + 1e-12
    assert _min_image_overlap(packing) < 1e-3
    assert np.all((packing.centers >= 0) & (packing.centers < 0.02))


def test_reproducible_from_rng() -> None:
    a = pack_spheres(300, np.random.default_rng(5))
    b = pack_spheres(300, np.random.default_rng(5))
    c = pack_spheres(300, np.random.default_rng(6))
    np.testing.assert_array_equal(a.centers, b.centers)
    assert not np.allclose(a.centers, c.centers)


def test_gaussian_radii_rejects_bad_cv() -> None:
    with pytest.raises(InputError, match="coefficient of variation"):
        gaussian_radii(10, 0.5, np.random.default_rng(0))


def test_save_load_roundtrip(tmp_path: Path, packing: Packing) -> None:
    path = tmp_path / "pack.npz"
    packing.save(path)
    back = load_packing(path)
    np.testing.assert_array_equal(back.centers, packing.centers)
    np.testing.assert_array_equal(back.radii, packing.radii)
    assert back.periodic and back.volume_fraction == pytest.approx(packing.volume_fraction)


def test_load_refuses_foreign_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.npz"
    np.savez(path, x=np.zeros(3))
    with pytest.raises(InputError, match="not a packing"):
        load_packing(path)


def test_tile_is_exact_copy(packing: Packing) -> None:
    big = packing.tile(2)
    assert big.n == 8 * packing.n
    assert big.volume_fraction == pytest.approx(packing.volume_fraction)
    np.testing.assert_allclose(big.box, 2 * packing.box)


def test_cut_keeps_centres_inside_and_density(packing: Packing) -> None:
    lo, hi = np.full(3, 0.005), np.full(3, 0.025)  # reaches past the periodic box: images are used
    cut = packing.cut(lo, hi)
    assert not cut.periodic
    assert np.all((cut.centers >= lo) & (cut.centers < hi))
    # whole spheres counted inside the sub-box: phi within a few % of 0.64 (boundary fluctuation)
    assert cut.volume_fraction == pytest.approx(0.64, rel=0.06)
    with pytest.raises(InputError, match="upper corner"):
        packing.cut(hi, lo)


def test_cubic_lattice_contacts() -> None:
    lat = cubic_lattice(4, 1e-3)
    assert lat.volume_fraction == pytest.approx(np.pi / 6)
    assert _min_image_overlap(lat) == pytest.approx(0.0, abs=1e-12)
