"""The scene vocabulary: phases, face conditions, the named parameters they define, and the terms they add.

A scene (docs/design.md "Scene file") speaks of *phases* (an image label with a conductivity k, a
volumetric capacity c and an optional source q) and of *face conditions* on the six faces of the box
(``x0`` is the plane x = 0, ``x1`` the plane x = L_x, ...): an entering flux φ, a convective exchange
h with T_ext, or a fixed temperature T.  Unlisted faces are adiabatic.

This module turns that vocabulary into the affine :class:`~aromm.core.system.Term` s of a
:class:`~aromm.core.system.ThermalSystem` [Chavez2020, eq. 2–3], the same way for every discretisation
(voxel Q1 elements, conforming simplex meshes, DEM bond networks):

==================  ===================================  ===================  ==========
condition           term                                 coefficient          role
==================  ===================================  ===================  ==========
phase p, k          ``K_p`` = ∫_p ∇φ_a·∇φ_b              ``p.k``              conduction
phase p, (kx,...)   ``K_p_x`` = ∫_p ∂_xφ_a ∂_xφ_b        ``p.k_x``            conduction
phase p, tensor     ``K_p_1`` = ∫_p ∇φ_a·v_1v_1ᵀ∇φ_b     ``p.k_1`` (2, 3)     conduction
phase p, fibre      ``K_p_k_axial`` = ∫_p ∇φ_a·aaᵀ∇φ_b   ``p.k_axial``        conduction
                    ``K_p_k_transverse`` (I − aaᵀ)       ``p.k_transverse``   conduction
phase p, c          ``C_p`` = ∫_p φ_a φ_b                ``p.c``              capacity
phase p, q          ``Q_p`` = ∫_p φ_a                    ``p.q``              load
face f, flux φ      ``U_f`` = ∫_f φ_a                    ``f.flux``           load
face f, h           ``H_f`` = ∫_f φ_a φ_b                ``f.h``              exchange
face f, h, T_ext    ``UH_f`` = ∫_f φ_a                   ``f.h · f.T_ext``    load
face f, T           Dirichlet on the face's unknowns     ``f.T``              —
==================  ===================================  ===================  ==========

A face's ``flux``, ``T_ext`` or ``T`` may be a :class:`~aromm.core.profiles.Profile` g(t) (a CSV history,
piecewise linear) instead of a number.  Its term then carries g as its function of time and the named
parameter (``z0.flux``, ``z1.T_ext``, ``x0.T``) becomes a dimensionless *scale* of the history, 1 in the
scene: the load is ``z0.flux · g(t) · U_z0`` (W), the fixed temperature ``x0.T · g(t)``.  The system stays
affine in its parameters, and a scale can be identified like any other parameter.

A discretisation supplies only the operators (a :class:`Discretisation`); adding a boundary-condition
type means adding it here and to the scene parser.  Capacities are built only for a transient scene,
exchange terms only on faces with h.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.anisotropy import PhaseTensor
from aromm.core.errors import InputError
from aromm.core.profiles import Profile
from aromm.core.system import Affine, Coefficient, Dirichlet, FloatArray, Geometry, Term, ThermalSystem, TimeGrid

FACES = ("x0", "x1", "y0", "y1", "z0", "z1")
AXES = "xyz"
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class PhaseSpec:
    """A phase: image label, conductivity (W/(m K), scalar or (kx, ky, kz)), capacity (J/(m³ K)), source (W/m³).

    An anisotropic phase (aromm.core.anisotropy) has a ``tensor``; its conductivity is then that tensor's, and ``k``
    holds only its largest value (a scale for messages)."""

    name: str
    label: int
    k: float | tuple[float, float, float]
    c: float | None = None
    q: float | None = None
    tensor: PhaseTensor | None = None

    @property
    def orthotropic(self) -> bool:
        return isinstance(self.k, tuple)


#: A face value: a number, or a history g(t) whose scale parameter is 1 in the scene.
Load = float | Profile


def scale_of(value: Load) -> float:
    """The named parameter's value for a face value: the number itself, or 1 (the scale) for a profile."""
    return 1.0 if isinstance(value, Profile) else float(value)


def history(value: Load | None) -> Profile | None:
    """The function of time of a face value (None for a number)."""
    return value if isinstance(value, Profile) else None


@dataclass(frozen=True)
class FaceSpec:
    """Condition on one face: entering flux (W/m²) and/or convection h (W/(m² K)) to T_ext (°C), or fixed T.

    ``flux``, ``T_ext`` and ``T`` are numbers or :class:`~aromm.core.profiles.Profile` histories (module doc).
    """

    face: str
    flux: Load | None = None
    h: float | None = None
    T_ext: Load = 0.0
    T: Load | None = None

    def __post_init__(self) -> None:
        if self.face not in FACES:
            raise InputError(f"unknown face {self.face!r}; allowed: {', '.join(FACES)}")
        if self.T is not None and (self.flux is not None or self.h is not None):
            raise InputError(f"face {self.face}: a fixed T excludes flux and h")

    @property
    def axis(self) -> int:
        """0, 1 or 2 for a face normal to x, y or z."""
        return AXES.index(self.face[0])

    @property
    def varies(self) -> bool:
        """True when a value of this face is a history g(t)."""
        return any(isinstance(v, Profile) for v in (self.flux, self.T_ext, self.T))


def held(f: FaceSpec) -> FaceSpec:
    """The face with every history replaced by its final (held) value: the conditions of the steady limit."""
    def final(v: Load | None) -> float | None:
        return v.final if isinstance(v, Profile) else v

    return FaceSpec(f.face, flux=final(f.flux), h=f.h, T_ext=final(f.T_ext) or 0.0, T=final(f.T))


def opposite(face: str) -> str:
    """The face across the box: ``opposite("z0") == "z1"``."""
    return f"{face[0]}{'1' if face[1] == '0' else '0'}"


def parameter_values(phases: Sequence[PhaseSpec], boundary: Sequence[FaceSpec], initial_T: float,
                     transient: bool) -> dict[str, float]:
    """Named parameter values (docs/design.md) of a scene: ``fibre.k`` (or ``fibre.k_x``...), ``fibre.c``
    (transient only), ``fibre.q``, ``z0.flux``, ``z1.h``, ``z1.T_ext``, ``x0.T``, ``initial.T``.

    >>> parameter_values([PhaseSpec("gas", 0, 0.025, 1.2e3)], [FaceSpec("z1", h=20.0)], 0.0, True)
    {'initial.T': 0.0, 'gas.k': 0.025, 'gas.c': 1200.0, 'z1.h': 20.0, 'z1.T_ext': 0.0}
    """
    out: dict[str, float] = {"initial.T": float(initial_T)}
    for ph in phases:
        if ph.tensor is not None:
            out.update({f"{ph.name}.{n}": float(k) for n, k in zip(ph.tensor.names, ph.tensor.values, strict=True)})
        elif isinstance(ph.k, tuple):
            out.update({f"{ph.name}.k_{ax}": float(k) for ax, k in zip(AXES, ph.k, strict=True)})
        else:
            out[f"{ph.name}.k"] = float(ph.k)
        if transient and ph.c is not None:
            out[f"{ph.name}.c"] = float(ph.c)
        if ph.q is not None:
            out[f"{ph.name}.q"] = float(ph.q)
    for f in boundary:
        if f.T is not None:
            out[f"{f.face}.T"] = scale_of(f.T)
            continue
        if f.h is not None:
            out[f"{f.face}.h"] = float(f.h)
            out[f"{f.face}.T_ext"] = scale_of(f.T_ext)
        if f.flux is not None:
            out[f"{f.face}.flux"] = scale_of(f.flux)
    return out


#: Properties positive by nature: conductivity (or one of its axes), capacity, exchange coefficient.
POSITIVE_PROPERTIES = ("k", "k_x", "k_y", "k_z", "k_1", "k_2", "k_3", "k_axial", "k_transverse", "c", "h",
                       "xi", "D_phi", "delta_p", "beta")  # the last four: moisture (aromm.physics.hygrothermal)


def is_positive(name: str) -> bool:
    """Whether the parameter ``name`` must be > 0 (``fibre.k``, ``fibre.k_x``, ``fibre.c``, ``z1.h``); temperatures,
    fluxes, sources and scales of histories may take any sign.

    >>> [is_positive(n) for n in ("fibre.k", "gas.c", "z1.h", "z1.T_ext", "z0.flux", "initial.T")]
    [True, True, True, False, False, False]
    """
    return name.rpartition(".")[2] in POSITIVE_PROPERTIES


class FaceDiscretisation(Protocol):
    """The face operators :func:`face_terms` needs: ``face_mass(f)`` is ``∫_f φ_a φ_b`` (m²; lumped for a
    bond network), ``face_dofs(f)`` the unknowns fixed by a temperature on face f."""

    @property
    def n(self) -> int: ...

    def face_mass(self, face: str) -> sp.csr_array: ...

    def face_dofs(self, face: str) -> IntArray: ...


class Discretisation(FaceDiscretisation, Protocol):
    """The operators a finite-element discretisation provides to :func:`phase_terms` and :func:`face_terms`.

    ``conduction(i, axis)`` is ``∫_{phase i} ∂_axis φ_a ∂_axis φ_b`` (axis ``"x"``, ``"y"``, ``"z"``) or
    ``∫ ∇φ_a·∇φ_b`` (axis None); ``mass(i)`` is ``∫_{phase i} φ_a φ_b``; ``tensor_conduction(i, spec)`` the
    matrices ``∫_{phase i} ∇φ_a·A_j∇φ_b`` of the unit tensors of an anisotropic phase (aromm.core.anisotropy).
    """

    def conduction(self, phase: int, axis: str | None) -> sp.csr_array: ...

    def tensor_conduction(self, phase: int, spec: PhaseTensor) -> list[sp.csr_array]: ...

    def mass(self, phase: int) -> sp.csr_array: ...


def phase_terms(disc: Discretisation, phases: Sequence[PhaseSpec], present: Sequence[int], *,
                transient: bool) -> list[Term]:
    """Conduction, capacity (transient only) and source terms of the phases whose indices are ``present``."""
    terms: list[Term] = []
    for i in present:
        ph = phases[i]
        if ph.tensor is not None:
            terms.extend(Term(f"K_{ph.name}_{n}", Coefficient((f"{ph.name}.{n}",)), op, "conduction")
                         for n, op in zip(ph.tensor.names, disc.tensor_conduction(i, ph.tensor), strict=True))
        elif isinstance(ph.k, tuple):
            terms.extend(Term(f"K_{ph.name}_{ax}", Coefficient((f"{ph.name}.k_{ax}",)), disc.conduction(i, ax),
                              "conduction") for ax in AXES)
        else:
            terms.append(Term(f"K_{ph.name}", Coefficient((f"{ph.name}.k",)), disc.conduction(i, None),
                              "conduction"))
        if not (transient or ph.q is not None):
            continue
        mass = disc.mass(i)
        if transient:
            if ph.c is None:
                raise InputError(f"phase {ph.name!r} needs a capacity c for a transient scene")
            terms.append(Term(f"C_{ph.name}", Coefficient((f"{ph.name}.c",)), mass, "capacity"))
        if ph.q is not None:
            terms.append(Term(f"Q_{ph.name}", Coefficient((f"{ph.name}.q",)), mass @ np.ones(disc.n), "load"))
    return terms


def face_terms(disc: FaceDiscretisation, boundary: Sequence[FaceSpec]) -> tuple[list[Term], list[Dirichlet]]:
    """Exchange and load terms of the face conditions, and the fixed temperatures (table in the module doc)."""
    terms: list[Term] = []
    dirichlet: list[Dirichlet] = []
    ones = np.ones(disc.n)
    for f in boundary:
        if f.T is not None:
            dirichlet.append(Dirichlet(f"T_{f.face}", disc.face_dofs(f.face), f"{f.face}.T", history(f.T)))
            continue
        if f.flux is not None:
            terms.append(Term(f"U_{f.face}", Coefficient((f"{f.face}.flux",)), disc.face_mass(f.face) @ ones, "load",
                              history(f.flux)))
        if f.h is not None:
            mass = disc.face_mass(f.face)
            terms.append(Term(f"H_{f.face}", Coefficient((f"{f.face}.h",)), mass, "exchange"))
            terms.append(Term(f"UH_{f.face}", Coefficient((f"{f.face}.h", f"{f.face}.T_ext")), mass @ ones, "load",
                              history(f.T_ext)))
    return terms, dirichlet


def face_means(disc: FaceDiscretisation, outputs: Sequence[str]) -> dict[str, FloatArray]:
    """Observation rows of face-mean temperatures: ``e_f = B_f 1 / |f|`` (so ``e_f @ T`` is the mean on f)."""
    rows: dict[str, FloatArray] = {}
    for face in outputs:
        w = np.asarray(disc.face_mass(face) @ np.ones(disc.n), dtype=float)
        rows[face] = w / w.sum()
    return rows


def boundary_mass(disc: FaceDiscretisation, faces: Sequence[str] = FACES) -> sp.csr_array:
    """``B = ∫_Γ φ_a φ_b`` (m²) over the given faces (default: the whole outer boundary of the box)."""
    total = sp.csr_array((disc.n, disc.n))
    for face in faces:
        total = total + disc.face_mass(face)
    return sp.csr_array(total)


def system_of(disc: FaceDiscretisation, terms: Sequence[Term], dirichlet: Sequence[Dirichlet], *,
              outputs: Sequence[str], parameters: Mapping[str, float], time: TimeGrid | None,
              geometry: Geometry | None = None) -> ThermalSystem:
    """The :class:`ThermalSystem` of a discretisation's terms: conduction and exchange into K, capacities into C,
    loads into F, face means of ``outputs`` as its observation rows."""
    return ThermalSystem(
        n=disc.n,
        conductance=Affine(tuple(t for t in terms if t.role in ("conduction", "exchange"))),
        capacity=Affine(tuple(t for t in terms if t.role == "capacity")),
        load=Affine(tuple(t for t in terms if t.role == "load")),
        dirichlet=tuple(dirichlet),
        observation=face_means(disc, outputs),
        parameters=parameters,
        time=time,
        geometry=geometry,
        boundary=boundary_mass(disc),
    )


def phase_index(labels: npt.NDArray[np.integer], phases: Sequence[PhaseSpec]) -> npt.NDArray[np.int64]:
    """The position in ``phases`` of every voxel's phase (an array shaped like ``labels``); −1 where no phase has its
    label.

    >>> phase_index(np.array([[[3, 1, 3]]]), [PhaseSpec("a", 3, 1.0), PhaseSpec("b", 1, 2.0)]).tolist()
    [[[0, 1, 0]]]
    """
    phase = np.full(np.shape(labels), -1, dtype=np.int64)
    for i, ph in enumerate(phases):
        phase[labels == ph.label] = i
    return phase


def check_phases(phases: Sequence[PhaseSpec], labels_present: Mapping[int, object] | set[int]) -> None:
    """Refuse image labels that belong to no phase (InputError naming them)."""
    known = {p.label for p in phases}
    missing = set(labels_present) - known
    if missing:
        raise InputError(f"image labels {sorted(missing)} belong to no phase; phases cover {sorted(known)}")


def insulating(phase: PhaseSpec) -> bool:
    """A phase that conducts no heat: a scalar ``k = 0`` (steady scenes; fv, and q1 where it stays non-singular)."""
    return phase.tensor is None and not isinstance(phase.k, tuple) and phase.k == 0.0


def check_image(labels: np.ndarray, voxel_size: Sequence[float], phases: Sequence[PhaseSpec]) -> None:
    """Refuse an image that is not 3-D, voxel sizes that are not three positive lengths, labels of no phase."""
    if labels.ndim != 3:
        raise InputError(f"the image must be 3-D, got shape {labels.shape}")
    if len(voxel_size) != 3 or not all(np.isfinite(v) and v > 0 for v in voxel_size):
        raise InputError(f"voxel_size must be three positive lengths in m, got {tuple(voxel_size)}")
    check_phases(phases, set(np.unique(labels).tolist()))


def singular_boundary(boundary: Sequence[FaceSpec], time: object | None) -> str | None:
    """Why a steady problem with these faces has no unique solution (``None`` when it has one).

    ``time`` is the scene's time grid (None: steady).  Steady, ``K T = F`` with every face adiabatic or
    under a prescribed flux: ``K`` has the constant field in its kernel (the temperature level is
    undetermined, and a solution exists only if the loads balance), so a face with a fixed temperature
    ``T`` or an exchange ``h`` is needed.
    """
    if time is not None or any(f.T is not None or f.h is not None for f in boundary):
        return None
    given = ", ".join(f"{f.face} (flux)" for f in boundary)
    faces = f"faces given: {given}, every other face is adiabatic" if given else "no face given, all are adiabatic"
    return ("[boundary]: a steady scene needs at least one face with a fixed temperature T or an exchange "
            f"coefficient h; {faces}, so the temperature level is undetermined (singular conductance). "
            "Add e.g. [boundary.z1] with h = 20.0 (and T_ext) or T = 0.0, or a [time] section for a transient")


def loaded_axis(boundary: Sequence[FaceSpec], size: tuple[float, float, float]) -> int:
    """The axis (0, 1, 2) along which the faces with a condition load the sample: the longest such axis, or the
    longest axis when no face has one.

    >>> loaded_axis([FaceSpec("z0", flux=1.0), FaceSpec("z1", h=5.0)], (1.0, 1.0, 0.5))
    2
    """
    axes = sorted({face.axis for face in boundary}) or [0, 1, 2]
    return max(axes, key=lambda a: size[a])
