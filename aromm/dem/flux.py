"""Heat-flux density of a bond network, per particle and over a neighbourhood [Hassan2019, eq. 9-10].

Conventions (stated here and tested in tests/test_dem_flux.py):

* **Sign.**  [Hassan2019, eq. 9] sums ``phi_pq e_pq = lambda S^t (T_q - T_p) e_pq``, which points
  along +grad T.  We return the *heat flux* density ``q = -lambda grad T`` (W/m^2), i.e. the
  negative of that sum, so that a uniform gradient G gives ``q = -lambda G``.
* **Volume.**  [Hassan2019, eq. 10] divides by the particle volume V_p; summed over the particles that
  overestimates the flux by 1/phi.  We divide by the particle's representative volume
  ``V_p / phi`` (the volumes of [Hassan2019, § 2.2], which add up to the domain):

      q_p = -1 / (2 V_p/phi) * sum_q H_pq (T_q - T_p) (x_q - x_p)          (eq. 9)

  (``lambda S^t e_pq = H_pq (x_q - x_p)``; the 1/2 shares each bond between its two ends).
* **Neighbourhood mean** (eq. 10): over the particles r whose centres lie within a distance
  R of p (p included), ``q_p^Omega = sum_r (V_r/phi) q_r / sum_r (V_r/phi)``, i.e. eq. 10 with
  ``Omega_p`` the representative volume of those particles.  Over a whole periodic
  domain this is exactly the Love-Weber mean flux ``-(1/V) sum_bonds H dT dx``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.dem.neighbours import Bonds
from aromm.dem.network import representative_volumes
from aromm.dem.packing import Packing

MEMBERS_PER_CHUNK = 5_000_000


def bond_flux_moments(bonds: Bonds, conductances: FloatArray, temperatures: FloatArray,
                      gradient: FloatArray | None = None) -> FloatArray:
    """``H_pq (T_q - T_p) (x_q - x_p)`` per bond (W m), shape (m, 3).

    For a periodic network solved as ``T = G . x + t`` pass the fluctuation ``t`` as
    ``temperatures`` and ``G`` as ``gradient``: the bond difference is then
    ``t_q - t_p + G . (x_q - x_p)`` (nearest image).
    """
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    dtemp = temperatures[q] - temperatures[p]
    if gradient is not None:
        dtemp = dtemp + bonds.vectors @ np.asarray(gradient, dtype=float)
    return (conductances * dtemp)[:, None] * bonds.vectors


def particle_flux(packing: Packing, bonds: Bonds, conductances: FloatArray, temperatures: FloatArray,
                  gradient: FloatArray | None = None) -> FloatArray:
    """Heat-flux density per particle (W/m^2), shape (n, 3) [Hassan2019, eq. 9, conventions above]."""
    if conductances.shape != (bonds.m,) or temperatures.shape != (packing.n,):
        raise InputError("particle_flux: one conductance per bond and one temperature per particle")
    moments = bond_flux_moments(bonds, conductances, temperatures, gradient)
    n = packing.n
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    summed = np.column_stack([np.bincount(p, moments[:, k], minlength=n) + np.bincount(q, moments[:, k], minlength=n)
                              for k in range(3)])
    return -0.5 * summed / representative_volumes(packing)[:, None]


def neighbourhood_mean(packing: Packing, flux: FloatArray, radius: float) -> FloatArray:
    """Representative-volume-weighted mean of ``flux`` over the centres within ``radius`` (m) (eq. 10).

    Rows are processed in chunks of about ``MEMBERS_PER_CHUNK`` neighbour pairs, so memory stays
    bounded for large neighbourhoods (1.5e5 particles with R = 8 R-bar: ~1e3 neighbours each).
    """
    if radius < 0:
        raise InputError(f"neighbourhood radius must be non-negative, got {radius}")
    x = packing.centers - packing.lower
    if packing.periodic:
        x = np.mod(x, packing.box)
        x[x >= packing.box] = 0.0
    n = packing.n
    vol = representative_volumes(packing)
    weighted = np.column_stack([vol[:, None] * flux, vol])  # sum these over members, then divide
    expected = n * min(1.0, 4.0 / 3.0 * np.pi * radius**3 / packing.domain_volume) + 1.0
    chunk = max(1, int(MEMBERS_PER_CHUNK / expected))
    tree = cKDTree(x, boxsize=packing.box if packing.periodic else None)
    out = np.empty((n, flux.shape[1]))
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        members = tree.query_ball_point(x[start:stop], radius, return_sorted=False)
        rows = np.repeat(np.arange(stop - start), [len(m) for m in members])
        cols = np.concatenate([np.asarray(m, dtype=np.int64) for m in members])
        # each centre is within radius of itself, so every row has at least one member
        sums = np.column_stack([np.bincount(rows, weighted[cols, k], minlength=stop - start)
                                for k in range(weighted.shape[1])])
        out[start:stop] = sums[:, :-1] / sums[:, -1:]
    return out
