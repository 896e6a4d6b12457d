"""The bond network as a ThermalSystem [Hassan2019, eq. 1-6, 14]; the shared solvers work on it unchanged."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.dem.neighbours import build_bonds
from aromm.dem.network import Network, face_particles, laplacian, sphere_inclusion, transmission_factor
from aromm.dem.packing import Packing, cubic_lattice, pack_spheres
from aromm.full.solve import simulate, steady_field


@pytest.fixture(scope="module")
def packing() -> Packing:
    return pack_spheres(2000, np.random.default_rng(7), box=0.05)


@pytest.fixture(scope="module")
def inclusion_net(packing: Packing) -> Network:
    cut = packing.cut(packing.lower, packing.lower + packing.box)
    bonds = build_bonds(cut, gap=build_bonds(packing, 7.5).gap_threshold)
    return Network(cut, bonds, 0.8, sphere_inclusion(cut), ("matrix", "inclusion"))


def test_terms_and_harmonic_interface(inclusion_net: Network) -> None:
    values = {"matrix.k": 33.0, "inclusion.k": 165.0, "matrix.c": 7.0e6, "inclusion.c": 3.0e6}
    system = inclusion_net.system(values, time=TimeGrid(1.0, 0.1))
    assert system.conductance.names == ("K_matrix", "K_matrix|inclusion", "K_inclusion")
    assert system.conductance["K_matrix|inclusion"].coefficient.kind == "harmonic"
    k = sp.csr_array(system.conductance.evaluate(values))
    # independent: per-bond lambda from the phases, then the Laplacian
    ph = inclusion_net.phases[inclusion_net.bonds.pairs]
    lam = np.array([33.0, 165.0])
    la, lb = lam[ph[:, 0]], lam[ph[:, 1]]
    direct = laplacian(inclusion_net.n, inclusion_net.bonds.pairs, inclusion_net.factor * 2 * la * lb / (la + lb))
    assert abs(k - direct).max() < 1e-12 * abs(direct).max()
    assert abs(k - k.T).max() == 0.0
    np.testing.assert_allclose(k @ np.ones(inclusion_net.n), 0.0, atol=1e-12 * abs(k).max())


def test_capacity_conserves_mass(inclusion_net: Network) -> None:
    """[Hassan2019, eq. 1]: rho_d = rho_c/phi, so the particles' heat capacities sum to rho_c c V."""
    values = {"matrix.k": 1.0, "inclusion.k": 1.0, "matrix.c": 7.02e6, "inclusion.c": 7.02e6}
    system = inclusion_net.system(values, time=TimeGrid(1.0, 0.1))
    c = sp.csr_array(system.capacity.evaluate(values))
    assert c.diagonal().sum() == pytest.approx(7.02e6 * inclusion_net.packing.domain_volume, rel=1e-12)
    assert c.nnz == inclusion_net.n


def test_radius_conventions(packing: Packing) -> None:
    b = build_bonds(packing, 7.5)
    pair = transmission_factor(packing, b, 1.0, "pair")
    glob = transmission_factor(packing, b, 1.0, "global")
    r = 0.5 * (packing.radii[b.pairs[:, 0]] + packing.radii[b.pairs[:, 1]])
    np.testing.assert_allclose(pair / glob, (r / packing.mean_radius) ** 2)
    np.testing.assert_allclose(pair, np.pi * r**2 / b.lengths)
    with pytest.raises(InputError, match="R_moy"):
        transmission_factor(packing, b, 1.0, "mean")  # type: ignore[arg-type]


def test_faces_are_particles_cutting_the_plane(inclusion_net: Network) -> None:
    p = inclusion_net.packing
    y0 = face_particles(p, "y0")
    assert np.all(p.centers[y0, 1] - p.radii[y0] <= 0.0)
    others = np.setdiff1d(np.arange(p.n), y0)
    assert np.all(p.centers[others, 1] - p.radii[others] > 0.0)
    with pytest.raises(InputError, match="unknown face"):
        face_particles(p, "w0")


def test_shared_steady_solver_on_lattice_gives_linear_profile() -> None:
    """aromm.full.solve.steady_field unchanged on a DEM network: a cut cubic lattice is a 1-D chain per row."""
    lat = cubic_lattice(6, 1e-3)
    cut = lat.cut(lat.lower, lat.lower + lat.box)
    net = Network(cut, build_bonds(cut, gap=0.1), 4 / np.pi, np.zeros(cut.n, dtype=np.int64))
    system = net.system({"matrix.k": 2.0}, boundary=(FaceSpec("x0", T=10.0), FaceSpec("x1", T=60.0)), outputs=("y0",))
    field = steady_field(system)
    x = cut.centers[:, 0]
    expected = 10.0 + 50.0 * (x - 0.5e-3) / 5e-3  # fixed layers at the first and last centres
    np.testing.assert_allclose(field, expected, rtol=1e-10)
    obs = simulate(system)
    assert obs.steady and obs.mean_T["y0"][0] == pytest.approx(35.0)


def test_shared_transient_solver_matches_explicit(inclusion_net: Network) -> None:
    from aromm.dem.explicit import simulate_explicit

    values = {"matrix.k": 33.0, "inclusion.k": 165.0, "matrix.c": 7.0e3, "inclusion.c": 7.0e3,
              "initial.T": 0.0}
    system = inclusion_net.system(values, boundary=(FaceSpec("x0", T=0.0), FaceSpec("x1", T=1.0)), outputs=("y0", "z1"),
                                  time=TimeGrid(0.004, 2e-6))
    implicit = simulate(system, times=[0.002, 0.004])
    explicit = simulate_explicit(system, times=[0.002, 0.004])
    np.testing.assert_allclose(explicit.as_array(), implicit.as_array(), atol=2e-3)
    assert explicit.as_array()[-1, 0] > 0.05  # heat has arrived: the comparison is not trivial


def test_aromm_reducer_on_network() -> None:
    """aromm.reduce works unchanged on a DEM network (flux on z0, convection on z1)."""
    from aromm.reduction.offline import reduce

    p = pack_spheres(600, np.random.default_rng(3), box=0.01)
    cut = p.cut(p.lower, p.lower + p.box)
    net = Network(cut, build_bonds(cut, gap=build_bonds(p, 7.5).gap_threshold), 0.8,
                  np.zeros(cut.n, dtype=np.int64))
    values = {"matrix.k": 1.0, "matrix.c": 1e6}
    system = net.system(values, boundary=(FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)), outputs=("z0", "z1"),
                        time=TimeGrid(100.0, 1.0))
    assert system.conductance.names == ("K_matrix", "H_z1")
    rom = reduce(system, order=20, cache=False)
    other = {"matrix.k": 1.5, "matrix.c": 2e6}  # away from the basis parameters
    full = simulate(system, other).as_array()
    assert np.abs(rom.simulate(other).as_array() - full).max() < 0.01 * np.abs(full).max()
    # energy balance of the full model at steady state: the flux in leaves by convection
    steady = steady_field(system)
    area_out = net.face_areas("z1")
    assert float(area_out @ (20.0 * steady)) == pytest.approx(500.0 * 0.01**2, rel=1e-8)
