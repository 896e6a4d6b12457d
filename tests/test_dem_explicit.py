"""Explicit integration [Hassan2019, eq. 5]: exact stability limit, refusal above it, accuracy."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.dem.explicit import simulate_explicit, stability_bound, stability_limit
from aromm.dem.neighbours import build_bonds
from aromm.dem.network import Network
from aromm.dem.packing import cubic_lattice, pack_spheres
from aromm.full.analytic import slab_dirichlet_series

VALUES = {"matrix.k": 33.0, "matrix.c": 7800 * 0.9, "initial.T": 25.0}
FIXED = (FaceSpec("y0", T=25.0), FaceSpec("y1", T=100.0))


@pytest.fixture(scope="module")
def system() -> ThermalSystem:
    p = pack_spheres(600, np.random.default_rng(2), box=0.1)
    cut = p.cut(p.lower, p.lower + p.box)
    net = Network(cut, build_bonds(cut, gap=build_bonds(p, 7.5).gap_threshold), 0.8,
                  np.zeros(cut.n, dtype=np.int64))
    return net.system(VALUES, boundary=FIXED, outputs=("x0",), time=TimeGrid(0.2, 0.01))


def test_limit_is_two_over_largest_eigenvalue(system: ThermalSystem) -> None:
    free = np.setdiff1d(np.arange(system.n), np.concatenate([d.dofs for d in system.dirichlet]))
    k = sp.csr_array(system.conductance.evaluate(VALUES))[free][:, free].toarray()
    c = sp.csr_array(system.capacity.evaluate(VALUES)).diagonal()[free]
    lam = sla.eigh(k, np.diag(c), eigvals_only=True).max()
    assert stability_limit(system) == pytest.approx(2.0 / lam, rel=1e-5)
    bound = stability_bound(system)
    assert bound < stability_limit(system)
    assert bound > 0.25 * stability_limit(system)  # dem.md: about half the exact limit


def test_refuses_step_above_limit(system: ThermalSystem) -> None:
    limit = stability_limit(system)
    with pytest.raises(InputError, match="stability limit"):
        simulate_explicit(system, times=[0.01], dt=1.01 * limit)
    out = simulate_explicit(system, times=[0.2], dt=0.99 * limit)
    assert np.all(np.isfinite(out.as_array()))


def test_lattice_chain_matches_analytic_series() -> None:
    """A cut cubic lattice with fixed end layers is a 1-D finite-difference chain: O(a^2) from eq. 12."""
    cells, a = 20, 5e-3
    lat = cubic_lattice(cells, a)
    lat = lat.cut(lat.lower, lat.lower + np.array([cells * a, cells * a, 2 * a]))
    net = Network(lat, build_bonds(lat, gap=0.1), 4 / np.pi, np.zeros(lat.n, dtype=np.int64))
    system = net.system(VALUES, boundary=FIXED, time=TimeGrid(0.2, 0.01))
    times = [0.05, 0.1, 0.2]
    out = simulate_explicit(system, times=times, fields=True)
    assert out.fields is not None
    y = lat.centers[:, 1] - 0.5 * a  # fixed layers sit at the first and last centres
    alpha = 33.0 / (7800 * 0.9)
    ref = slab_dirichlet_series(y[None, :], np.array(times)[:, None], (cells - 1) * a, alpha, 25.0, 25.0, 100.0)
    err = np.abs(out.fields - ref).max()
    assert err < 0.01 * 75.0  # 1 % of the imposed difference at 19 layers (second-order chain)
