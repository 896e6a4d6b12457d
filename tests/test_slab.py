"""Homogeneous slab between two fixed temperatures against the analytic series [Hassan2019, eq. 12–13]."""

from __future__ import annotations

import numpy as np

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.analytic import slab_dirichlet_series
from aromm.full.solve import transient

L, K, C = 0.1, 33.0, 7800.0 * 900.0  # [Hassan2019]'s steel slab: 0.1 m, 33 W/(m K), rho c = 7.02e6 J/(m3 K)
ALPHA = K / C
TAU = L**2 / ALPHA


def _slab_error(nz: int, dt: float, t_end: float) -> float:
    system = assemble_voxels(np.zeros((1, 1, nz), dtype=int), (L, L, L / nz), [PhaseSpec("steel", 0, K, C)],
                             [FaceSpec("z0", T=25.0), FaceSpec("z1", T=100.0)], time=TimeGrid(t_end, dt),
                             initial_T=25.0)
    obs = transient(system, times=[t_end], fields=True)
    assert obs.fields is not None
    line = obs.fields[0][4 * np.arange(nz + 1)]  # nodes x = y = 0, z = k dz
    z = np.arange(nz + 1) * L / nz
    exact = slab_dirichlet_series(z, t_end, L, ALPHA, 25.0, 25.0, 100.0, n_terms=400)
    return float(np.max(np.abs(line - exact)))


def test_slab_converges_at_second_order_in_space() -> None:
    t_end = 0.05 * TAU
    errors = [_slab_error(nz, t_end / 400, t_end) for nz in (8, 16, 32)]
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > 1.8), (errors, rates)
    assert errors[-1] < 0.1  # K, on a 75 K temperature difference


def test_slab_converges_at_second_order_in_time() -> None:
    t_end = 0.05 * TAU
    errors = [_slab_error(64, t_end / steps, t_end) for steps in (4, 8, 16)]
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > 1.6), (errors, rates)
