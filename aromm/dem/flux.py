"""Heat-flux density of a bond network, per particle and over a neighbourhood (seed 000 eq. 9-10).

Conventions (stated here and tested in tests/test_dem_flux.py):

* **Sign.**  Seed 000 eq. 9 sums ``phi_pq e_pq = lambda S^t (T_q - T_p) e_pq``, which points
  along +grad T.  We return the *heat flux* density ``q = -lambda grad T`` (W/m^2), i.e. the
  negative of the seed's sum, so that a uniform gradient G gives ``q = -lambda G``.
* **Volume.**  The seed divides by the particle volume V_p; summed over the particles that
  overestimates the flux by 1/phi.  We divide by the particle's representative volume
  ``V_p / phi`` (the volumes of seed 000 §2.2, which add up to the domain):

      q_p = -1 / (2 V_p/phi) * sum_q H_pq (T_q - T_p) (x_q - x_p)          (eq. 9)

  (``lambda S^t e_pq = H_pq (x_q - x_p)``; the 1/2 shares each bond between its two ends).
* **Neighbourhood mean** (eq. 10): over the particles r whose centres lie within a distance
  R of p (p included), ``q_p^Omega = sum_r (V_r/phi) q_r / sum_r (V_r/phi)``, i.e. eq. 10 with
  ``Omega_p`` the representative volume of those particles.  Over a whole periodic
  domain this is exactly the Love-Weber mean flux ``-(1/V) sum_bonds H dT dx``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from aromm.dem.bonds import Bonds
from aromm.dem.network import representative_volumes
from aromm.dem.packing import Packing
from aromm.errors import InputError
from aromm.system import FloatArray


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
    """Heat-flux density per particle (W/m^2), shape (n, 3) (seed 000 eq. 9, conventions above)."""
    if conductances.shape != (bonds.m,) or temperatures.shape != (packing.n,):
        raise InputError("particle_flux: one conductance per bond and one temperature per particle")
    moments = bond_flux_moments(bonds, conductances, temperatures, gradient)
    n = packing.n
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    summed = np.column_stack([np.bincount(p, moments[:, k], minlength=n) + np.bincount(q, moments[:, k], minlength=n)
                              for k in range(3)])
    return -0.5 * summed / representative_volumes(packing)[:, None]


def neighbourhood_mean(packing: Packing, flux: FloatArray, radius: float) -> FloatArray:
    """Representative-volume-weighted mean of ``flux`` over the centres within ``radius`` (m) (eq. 10)."""
    if radius < 0:
        raise InputError(f"neighbourhood radius must be non-negative, got {radius}")
    x = packing.centers - packing.lower
    if packing.periodic:
        x = np.mod(x, packing.box)
        x[x >= packing.box] = 0.0
        tree = cKDTree(x, boxsize=packing.box)
    else:
        tree = cKDTree(x)
    member = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    n = packing.n
    rows = np.concatenate([member.row, np.arange(n)])  # each particle is in its own neighbourhood
    cols = np.concatenate([member.col, np.arange(n)])
    m = sp.csr_array(sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(n, n)))  # sums duplicates
    m.data[:] = 1.0  # membership is 0/1
    w = m @ sp.diags_array(representative_volumes(packing))
    return (w @ flux) / (w @ np.ones(n))[:, None]
