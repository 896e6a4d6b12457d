"""The DEM bond network as a :class:`~aromm.core.system.ThermalSystem` [Hassan2019, eq. 1-6, 14].

Each bond (p, q) carries the conductance [Hassan2019, eq. 3, 6]

    H_pq = lambda_pq S^t_pq / d_pq,      S^t_pq = C_t pi R_moy^2,

with ``R_moy`` the **pair mean radius** (r_p + r_q) / 2 by default ([Hassan2019]: "rayon
moyen des particules en contact"); ``radius="global"`` uses the packing's mean radius
instead.  C_t must be calibrated for the choice made (aromm.dem.calibration): with the same
packing the two choices give different C_t, not different physics.

``lambda_pq`` is the phase conductivity for a same-phase bond and the harmonic mean
``2 l_a l_b / (l_a + l_b)`` across two phases [Hassan2019, eq. 14], so

    K = sum_a  k_a * L(g, bonds in phase a)  +  sum_{a<b} hm(k_a, k_b) * L(g, bonds a|b),

with ``g = C_t pi R_moy^2 / d`` (m) and ``L`` the weighted graph Laplacian: every term is
affine in the parameters ``"<phase>.k"`` (W/(m K)).

Capacity [Hassan2019, eq. 1, 5]: the particle's density is ``rho_d = rho_c / phi`` with
``phi = sum V_p / V_domain``, so particle p holds ``rho_c c V_p / phi`` (J/K) and the
capacities add up to ``rho_c c V_domain``.  The parameter ``"<phase>.c"`` is the
continuum's *volumetric* heat capacity ``rho_c c`` in J/(m^3 K) (docs/design.md), and the
capacity operator is ``diag(V_p / phi)`` (m^3) over that phase's particles.

Faces: the particles of face ``x0`` are those whose sphere cuts the plane x = x_min
(``x_p - r_p <= x_min``), likewise for the other faces.  Face conditions are stated in the scene
vocabulary (:class:`aromm.core.vocabulary.FaceSpec`): a fixed temperature is a
:class:`~aromm.core.system.Dirichlet` on those particles with parameter ``"<face>.T"``; an
imposed entering flux ``"<face>.flux"`` (W/m^2) or an exchange ``"<face>.h"`` is shared between them
in proportion to their cross-sections ``pi r_p^2``.  Observations are V-weighted means of T over a face's
particles, or over slabs of a profile (names ``"<axis>_slab<k>"``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import Affine, Coefficient, FloatArray, Geometry, Term, ThermalSystem, TimeGrid
from aromm.core.vocabulary import FACES, FaceSpec, face_terms, parameter_values
from aromm.dem.neighbours import Bonds, IntArray
from aromm.dem.packing import Packing

AXES = "xyz"
Radius = Literal["pair", "global"]


def face_particles(packing: Packing, face: str) -> IntArray:
    """Particles whose sphere cuts the plane of ``face`` (e.g. ``"y0"`` is y = y_min)."""
    if face not in FACES:
        raise InputError(f"unknown face {face!r}; allowed: {', '.join(FACES)}")
    axis = AXES.index(face[0])
    c, r = packing.centers[:, axis], packing.radii
    lo = float(packing.lower[axis])
    if face[1] == "0":
        return np.flatnonzero(c - r <= lo).astype(np.int64)
    return np.flatnonzero(c + r >= lo + float(packing.box[axis])).astype(np.int64)


def transmission_factor(packing: Packing, bonds: Bonds, c_t: float, radius: Radius = "pair") -> FloatArray:
    """``g_pq = S^t_pq / d_pq = C_t pi R_moy^2 / d_pq`` (m), so that ``H_pq = lambda g_pq`` (eq. 3, 6)."""
    if c_t <= 0:
        raise InputError(f"C_t must be positive, got {c_t}")
    p, q = bonds.pairs[:, 0], bonds.pairs[:, 1]
    if radius == "pair":
        r_moy = 0.5 * (packing.radii[p] + packing.radii[q])
    elif radius == "global":
        r_moy = np.full(bonds.m, packing.mean_radius)
    else:
        raise InputError(f"unknown R_moy convention {radius!r}; allowed: pair, global")
    return c_t * np.pi * r_moy**2 / bonds.lengths


def laplacian(n: int, pairs: IntArray, weights: FloatArray) -> sp.csr_array:
    """Weighted graph Laplacian ``(L T)_p = sum_q w_pq (T_p - T_q)`` (symmetric, rows sum to 0)."""
    p, q = pairs[:, 0], pairs[:, 1]
    rows = np.concatenate([p, q, p, q])
    cols = np.concatenate([p, q, q, p])
    data = np.concatenate([weights, weights, -weights, -weights])
    return sp.csr_array(sp.coo_array((data, (rows, cols)), shape=(n, n)))


def representative_volumes(packing: Packing) -> FloatArray:
    """``V_p / phi`` (m^3): the particle's share of the domain [Hassan2019, eq. 1, §2.2], summing to V."""
    return packing.volumes / packing.volume_fraction


def sphere_inclusion(packing: Packing, radius_fraction: float = 1.0 / 3.0,
                     center: npt.ArrayLike | None = None) -> IntArray:
    """Phase index per particle: 1 if its centre is inside the sphere of radius ``fraction * L``, else 0.

    The default is [Hassan2019, § 3.2]: radius L/3 centred in the cube (inclusion fraction 15.51 %).
    """
    if radius_fraction <= 0:
        raise InputError(f"inclusion radius fraction must be positive, got {radius_fraction}")
    c = (packing.lower + 0.5 * packing.box) if center is None else np.asarray(center, dtype=float)
    a = radius_fraction * float(packing.box[0])
    return (np.sum((packing.centers - c) ** 2, axis=1) <= a * a).astype(np.int64)


@dataclass(frozen=True)
class Network:
    """A bond network ready to become a ThermalSystem: packing, bonds, phase per particle, C_t."""

    packing: Packing
    bonds: Bonds
    c_t: float
    phases: IntArray
    phase_names: tuple[str, ...] = ("matrix",)
    radius: Radius = "pair"

    def __post_init__(self) -> None:
        if self.phases.shape != (self.packing.n,):
            raise InputError(f"phases must give one index per particle ({self.packing.n})")
        if self.phases.size and (self.phases.min() < 0 or self.phases.max() >= len(self.phase_names)):
            raise InputError(f"phase indices must be in 0..{len(self.phase_names) - 1} "
                             f"for phases {self.phase_names}")

    @property
    def n(self) -> int:
        return self.packing.n

    @property
    def factor(self) -> FloatArray:
        """``g_pq = S^t / d`` (m) per bond."""
        return transmission_factor(self.packing, self.bonds, self.c_t, self.radius)

    def conductances(self, values: Mapping[str, float]) -> FloatArray:
        """``H_pq`` (W/K) per bond for conductivities ``values["<phase>.k"]`` (harmonic mean across phases)."""
        k = np.array([float(values[f"{name}.k"]) for name in self.phase_names])
        ka, kb = k[self.phases[self.bonds.pairs[:, 0]]], k[self.phases[self.bonds.pairs[:, 1]]]
        return self.factor * 2.0 * ka * kb / (ka + kb)

    def conductance(self) -> Affine:
        """``K`` as an affine sum: one Laplacian per phase and per phase pair [Hassan2019, eq. 14]."""
        g = self.factor
        a = self.phases[self.bonds.pairs[:, 0]]
        b = self.phases[self.bonds.pairs[:, 1]]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        terms = []
        for i, name in enumerate(self.phase_names):
            for j in range(i, len(self.phase_names)):
                sel = (lo == i) & (hi == j)
                if not sel.any():
                    continue
                op = laplacian(self.n, self.bonds.pairs[sel], g[sel])
                if i == j:
                    terms.append(Term(f"K_{name}", Coefficient((f"{name}.k",)), op, "conduction"))
                else:
                    other = self.phase_names[j]
                    coef = Coefficient((f"{name}.k", f"{other}.k"), kind="harmonic")
                    terms.append(Term(f"K_{name}|{other}", coef, op, "conduction"))
        return Affine(tuple(terms))

    def capacity(self) -> Affine:
        """``C = sum_a (rho c)_a diag(V_p / phi)`` over each phase's particles [Hassan2019, eq. 1, 5]."""
        vol = representative_volumes(self.packing)
        terms = []
        for i, name in enumerate(self.phase_names):
            sel = self.phases == i
            if sel.any():
                terms.append(Term(f"C_{name}", Coefficient((f"{name}.c",)), sp.csr_array(sp.diags_array(vol * sel)),
                                  "capacity"))
        return Affine(tuple(terms))

    def face_weights(self, face: str) -> FloatArray:
        """Observation row: V-weighted mean over the particles of ``face`` (sums to one)."""
        idx = face_particles(self.packing, face)
        if idx.size == 0:
            raise InputError(f"face {face!r} has no particle")
        w = np.zeros(self.n)
        w[idx] = self.packing.volumes[idx]
        return w / w.sum()

    def face_areas(self, face: str) -> FloatArray:
        """Share of the face area (m^2) per particle: the face's particles in proportion to pi r_p^2."""
        idx = face_particles(self.packing, face)
        if idx.size == 0:
            raise InputError(f"face {face!r} has no particle")
        axis = AXES.index(face[0])
        area = float(np.prod(np.delete(self.packing.box, axis)))
        share = np.zeros(self.n)
        share[idx] = self.packing.radii[idx] ** 2
        return area * share / share.sum()

    def slab_weights(self, axis: str, bins: int) -> dict[str, FloatArray]:
        """Observation rows: V-weighted means over ``bins`` equal slabs along ``axis`` (by centre)."""
        if axis not in AXES or bins < 1:
            raise InputError(f"profile: axis must be one of x, y, z and bins >= 1, got {axis!r}, {bins}")
        ax = AXES.index(axis)
        s = (self.packing.centers[:, ax] - self.packing.lower[ax]) / self.packing.box[ax]
        slab = np.clip((s * bins).astype(int), 0, bins - 1)
        rows = {}
        for k in range(bins):
            w = np.where(slab == k, self.packing.volumes, 0.0)
            if w.sum() == 0:
                raise InputError(f"profile: slab {k} of {bins} along {axis} has no particle; use fewer bins")
            rows[f"{axis}_slab{k}"] = w / w.sum()
        return rows

    # ------------------------------------------------------------ aromm.core.vocabulary.Discretisation (faces)
    def face_mass(self, face: str) -> sp.csr_array:
        """Lumped face "mass": the face's area shared between its particles, ``diag(area_p)`` (m²)."""
        return sp.csr_array(sp.diags_array(self.face_areas(face)))

    def face_dofs(self, face: str) -> IntArray:
        return face_particles(self.packing, face)

    def system(
        self,
        parameters: Mapping[str, float],
        *,
        boundary: Sequence[FaceSpec] = (),
        outputs: Sequence[str] = (),
        profile: tuple[str, int] | None = None,
        time: TimeGrid | None = None,
    ) -> ThermalSystem:
        """The ThermalSystem of this network under the face conditions ``boundary`` (aromm.core.vocabulary).

        A fixed ``T`` is a Dirichlet condition on the face's particles; an entering flux (W/m²) and a
        convective exchange h (W/(m² K)) with T_ext are shared between them in proportion to ``pi r_p^2``
        (terms ``U_<face>``, ``H_<face>``, ``UH_<face>`` as for every discretisation); unlisted faces are
        adiabatic.  A capacity is included only for a transient (``time`` given).  ``parameters`` holds
        the phase values (``"<phase>.k"``, ``"<phase>.c"``); face values come from ``boundary``.
        Observations are V-weighted means over a face's particles, and over the slabs of ``profile``.
        """
        faces, dirichlet = face_terms(self, boundary)
        observation = {face: self.face_weights(face) for face in outputs}
        if profile is not None:
            observation.update(self.slab_weights(*profile))
        geometry = Geometry(
            points=self.packing.centers, cells=np.arange(self.n, dtype=np.int64)[:, None], cell_type="vertex",
            cell_data={"radius": self.packing.radii, "phase": self.phases},
        )
        shell = sum((self.face_areas(face) for face in FACES), start=np.zeros(self.n))
        return ThermalSystem(
            n=self.n,
            conductance=Affine(self.conductance().terms + tuple(t for t in faces if t.role == "exchange")),
            capacity=self.capacity() if time is not None else Affine(),
            load=Affine(tuple(t for t in faces if t.role == "load")),
            dirichlet=tuple(dirichlet),
            observation=observation,
            parameters={**parameter_values((), boundary, float(parameters.get("initial.T", 0.0)), False),
                        **parameters},
            time=time,
            geometry=geometry,
            boundary=sp.csr_array(sp.diags_array(shell)),
        )
