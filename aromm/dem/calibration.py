"""Calibration of C_t [Hassan2019, eq. 6-8] and effective conductivities of bond networks.

The conductivity of the equivalent continuum is proportional to C_t, so (eq. 8)

    C_t = C_t^arb * lambda / lambda_e(C_t^arb),

where ``lambda_e`` is the network's effective conductivity computed with an arbitrary
``C_t^arb = 1``.  Two ways to measure ``lambda_e``:

* ``"periodic"`` (default): the periodic network under a macroscopic gradient G.  With
  ``T_p = G . x_p + t_p`` (t periodic) the balance of every particle is the Laplacian
  system ``L t = b``, ``b_p = sum_q H_pq G . (x_q - x_p)`` (nearest image), solved with one
  particle pinned.  The mean heat-flux density is exactly (Love-Weber average)
  ``q = -(1/V) sum_bonds H_pq (T_q - T_p) (x_q - x_p)``, and ``k_e = -q / G`` for
  G = e_x, e_y, e_z gives the full tensor.  No boundary layer: this is the bulk value.
* ``"slab"``: the test of [Hassan2019, Fig. 3, eq. 7]: the periodic packing is cut along its box,
  T = T_0 on the particles of face z0, an entering flux density ``varphi`` on face z1,
  other faces adiabatic; at steady state ``lambda_e = varphi L / (T_z1 - T_0)`` with T_z1
  the cross-section-weighted mean temperature of the z1 particles (those receiving the flux).
  The cut faces' looser layer lowers ``lambda_e``, so C_t comes out larger than the bulk one.

``C_t`` returned uses ``lambda_e`` = the mean of the diagonal of the tensor (periodic), or
the z value (slab).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.core.vocabulary import FaceSpec
from aromm.dem.neighbours import Bonds, build_bonds
from aromm.dem.network import (
    Network,
    Radius,
    face_particles,
    laplacian,
    sphere_inclusion,
    transmission_factor,
)
from aromm.dem.packing import Packing
from aromm.full.solve import reaction_heat_flow, steady_field
from aromm.linalg.direct import factorize

Boundary = Literal["periodic", "slab"]
AMG_ABOVE = 20_000  # particles: above this, "auto" solves with pyamg + CG (CHOLMOD fills to GBs at 1.5e5)


def solver_for(n: int, method: str = "auto") -> str:
    """Linear solver for a network of ``n`` particles: ``"auto"`` picks AMG-CG for large networks."""
    if method != "auto":
        return method
    return "amg" if n > AMG_ABOVE else "auto"


def periodic_field(packing: Packing, bonds: Bonds, conductances: FloatArray, gradients: FloatArray,
                   method: str = "auto") -> FloatArray:
    """Periodic fluctuations t (K) with ``T_p = G·x_p + t_p`` at balance, one column per gradient.

    ``gradients`` is (3,) or (3, k) (K/m).  Solves ``L t = b``, ``b_p = sum_q H_pq G . (x_q - x_p)``
    with particle 0 pinned (the periodic Laplacian has the constants as kernel).  ``method``:
    aromm.linalg.direct solver; ``"auto"`` uses pyamg + CG above 20 000 particles.
    """
    if not packing.periodic:
        raise InputError("periodic_field needs a periodic packing")
    g = np.asarray(gradients, dtype=float)
    single = g.ndim == 1
    g = g.reshape(3, -1)
    n = packing.n
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    hv = conductances[:, None] * (bonds.vectors @ g)  # (m, k)
    rhs = np.column_stack([np.bincount(p, hv[:, j], minlength=n) - np.bincount(q, hv[:, j], minlength=n)
                           for j in range(g.shape[1])])
    lap = laplacian(n, bonds.pairs, conductances)
    t = np.zeros((n, g.shape[1]))
    t[1:] = factorize(lap[1:][:, 1:], solver_for(n, method)).solve(rhs[1:])
    return t[:, 0] if single else t


def periodic_conductivity(packing: Packing, bonds: Bonds, conductances: FloatArray) -> FloatArray:
    """Effective conductivity tensor (W/(m K)) of a periodic network with bond conductances H (W/K)."""
    t = periodic_field(packing, bonds, conductances, np.eye(3))
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    dtemp = t[q] - t[p] + bonds.vectors  # (m, 3): T_q - T_p for G = e_x, e_y, e_z
    flux_sum = np.einsum("b,bi,bj->ij", conductances, bonds.vectors, dtemp)  # sum H dx_i dT_j
    return flux_sum / packing.domain_volume  # k_ij = -q_i / G_j


@dataclass(frozen=True)
class Calibration:
    """Result of :func:`calibrate`: C_t, the coordination Z, lambda_e at C_t = 1 (tensor or scalar)."""

    c_t: float
    z: float
    k_arbitrary: FloatArray
    boundary: str
    radius: str
    gap_threshold: float
    n: int

    def to_json(self) -> dict[str, object]:
        return {"C_t": self.c_t, "Z": self.z, "boundary": self.boundary, "radius": self.radius,
                "gap_threshold": self.gap_threshold, "particles": self.n,
                "k_at_C_t_1": np.asarray(self.k_arbitrary).tolist()}


def slab_conductivity(packing: Packing, bonds: Bonds, c_t: float = 1.0, radius: Radius = "pair",
                      varphi: float = 1.0) -> float:
    """``lambda_e = varphi L / (T_z1 - T_0)`` of a cut packing with lambda = 1 [Hassan2019, eq. 7, Figure 3]."""
    net = Network(packing, bonds, c_t, np.zeros(packing.n, dtype=np.int64), ("matrix",), radius)
    system = net.system({"matrix.k": 1.0}, boundary=(FaceSpec("z0", T=0.0), FaceSpec("z1", flux=varphi)))
    field = steady_field(system, method=solver_for(packing.n))
    top = face_particles(packing, "z1")
    w = packing.radii[top] ** 2
    t_top = float(np.sum(w * field[top]) / w.sum())
    return varphi * float(packing.box[2]) / t_top


def calibrate(packing: Packing, z: float = 7.5, *, radius: Radius = "pair", boundary: Boundary = "periodic",
              min_degree: int = 3, bonds: Bonds | None = None) -> Calibration:
    """C_t such that the network's effective conductivity equals lambda [Hassan2019, eq. 7-8]."""
    if not packing.periodic:
        raise InputError("calibrate needs the periodic packing (the slab test cuts it itself)")
    if bonds is None:
        bonds = build_bonds(packing, z, min_degree=min_degree)
    z_real = bonds.coordination(packing.n)
    if boundary == "periodic":
        k = periodic_conductivity(packing, bonds, transmission_factor(packing, bonds, 1.0, radius))
        k_e = float(np.trace(k) / 3.0)
        return Calibration(1.0 / k_e, z_real, k, boundary, radius, bonds.gap_threshold, packing.n)
    if boundary == "slab":
        cut = packing.cut(packing.lower, packing.lower + packing.box)
        cut_bonds = build_bonds(cut, gap=bonds.gap_threshold, min_degree=min_degree)
        k_e = slab_conductivity(cut, cut_bonds, 1.0, radius)
        return Calibration(1.0 / k_e, cut_bonds.coordination(cut.n), np.asarray(k_e), boundary, radius,
                           bonds.gap_threshold, packing.n)
    raise InputError(f"unknown calibration boundary {boundary!r}; allowed: periodic, slab")


@dataclass(frozen=True)
class InclusionResult:
    """Sphere-inclusion test [Hassan2019, § 3.2]: E = k_eff / k_matrix, per axis and averaged."""

    E: float
    E_axes: FloatArray
    ratio: float
    inclusion_fraction: float
    boundary: str


InclusionBoundary = Literal["periodic", "faces"]


def inclusion_network(packing: Packing, z: float = 7.5, *, radius: Radius = "pair", min_degree: int = 3,
                      radius_fraction: float = 1.0 / 3.0, boundary: InclusionBoundary = "periodic",
                      bonds: Bonds | None = None) -> Network:
    """Bond network of the periodic packing with the central sphere inclusion (radius L/3) tagged.

    ``boundary="periodic"`` keeps the periodic network: the cube is then the cell of a
    simple-cubic array of inclusions, which by mirror symmetry has the same k_eff as the
    cube with two isothermal and four adiabatic faces (the FE set-up).  ``"faces"`` cuts
    the packing along its box (bonds from the periodic packing's gap threshold) for a
    test with fixed temperatures on two faces, as in [Hassan2019], cut layer included.
    C_t is left at 1: E is a ratio of two solves on the same network, so C_t cancels (the
    calibration on the same packing and boundary conditions, [Hassan2019, § 2.3]).  ``bonds``: the periodic
    packing's bonds when already built (:func:`aromm.dem.neighbours.build_bonds` with the same ``z``).
    """
    if not packing.periodic:
        raise InputError("inclusion_network needs the periodic packing (it cuts it itself for 'faces')")
    if bonds is None:
        bonds = build_bonds(packing, z, min_degree=min_degree)
    if boundary == "faces":
        packing = packing.cut(packing.lower, packing.lower + packing.box)
        bonds = build_bonds(packing, gap=bonds.gap_threshold, min_degree=min_degree)
    elif boundary != "periodic":
        raise InputError(f"unknown inclusion boundary {boundary!r}; allowed: periodic, faces")
    return Network(packing, bonds, 1.0, sphere_inclusion(packing, radius_fraction), ("matrix", "inclusion"),
                   radius)


def inclusion_ratio(network: Network, ratio: float, axes: str = "xyz") -> InclusionResult:
    """E = k_eff(k_i = ratio k_m) / k_eff(k_i = k_m) along each of ``axes``, and their mean.

    Periodic network: diagonal of the Love-Weber conductivity tensors.  Cut network: T = 1
    on face ``<axis>1``, 0 on ``<axis>0``, other faces adiabatic, and E the ratio of the heat
    flows through the hot face (aromm.full.solve.steady_field).
    """
    return inclusion_ratios(network, [ratio], axes)[0]


def inclusion_ratios(network: Network, ratios: Sequence[float], axes: str = "xyz") -> list[InclusionResult]:
    """:func:`inclusion_ratio` for several contrasts, with the homogeneous reference solved once."""
    if any(r <= 0 for r in ratios):
        raise InputError(f"conductivity ratios must be positive, got {list(ratios)}")
    if not axes or any(a not in "xyz" for a in axes):
        raise InputError(f"axes must be letters of 'xyz', got {axes!r}")
    idx = ["xyz".index(a) for a in axes]
    cases = [{"matrix.k": 1.0, "inclusion.k": float(r)} for r in (1.0, *ratios)]
    if network.packing.periodic:
        k = np.array([np.diag(periodic_conductivity(network.packing, network.bonds, network.conductances(v)))[idx]
                      for v in cases])  # (1 + len(ratios), len(axes))
    else:
        method = solver_for(network.n)
        columns = []
        for axis in axes:
            system = network.system(cases[0], boundary=(FaceSpec(f"{axis}0", T=0.0), FaceSpec(f"{axis}1", T=1.0)))
            hot = system.dirichlet[1].dofs
            columns.append([reaction_heat_flow(system, steady_field(system, v, method), hot, v) for v in cases])
        k = np.array(columns).T
    vol = network.packing.volumes
    frac = float(vol[network.phases == 1].sum() / vol.sum())
    boundary = "periodic" if network.packing.periodic else "faces"
    return [InclusionResult(float(np.mean(k[i + 1] / k[0])), k[i + 1] / k[0], float(r), frac, boundary)
            for i, r in enumerate(ratios)]
