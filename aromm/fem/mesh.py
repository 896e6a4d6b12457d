"""Lagrange finite elements (P1 or P2) on conforming simplex meshes (any mesh meshio reads) into a ThermalSystem.

Phases come from cell sets (``mesh.cell_sets[phase_name]``) or from an integer cell-data
array (``gmsh:physical`` by default) matched against :attr:`aromm.core.vocabulary.PhaseSpec.label`.
A contact resistance ``R`` (m^2 K/W) between two phases (scene: ``[interfaces."fibre|gas"] R``)
is modelled on **split interface unknowns**: every degree of freedom on the interface gets one
copy per side, each phase's elements use their own copy, and the two copies are coupled by

    K_int = (1/R) J^T M_Gamma J,        (J T)_i = T_i^{fibre} - T_i^{gas},

with ``M_Gamma`` the facet mass matrix of the interface (scikit-fem ``FacetBasis`` on the
interface facets), i.e. the weak form of the flux ``q_n = (T_fibre - T_gas)/R`` across it.
Every matrix is assembled by scikit-fem on the original mesh, phase by phase, and its
indices are then relabelled to the split unknowns.  The coefficient is the parameter
``"fibre|gas.h_c" = 1/R`` (W/(m^2 K)) so the system stays affine; ``R = 0`` means perfect
contact (nothing split).  Phase and face terms come from aromm.core.vocabulary (``K_<phase>``,
``C_<phase>`` for a transient, ``H_<face>``, ``U_<face>``...), plus ``G_<p>|<q>`` (role conduction) for an
interface.  Faces ``x0 ... z1`` are the planes of the mesh's bounding box.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import meshio
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from skfem import (
    Basis,
    BilinearForm,
    ElementTetP1,
    ElementTetP2,
    ElementTriP1,
    ElementTriP2,
    FacetBasis,
    LinearForm,
    MeshTet,
    MeshTri,
)
from skfem.helpers import dot, grad

from aromm.core.anisotropy import PhaseTensor
from aromm.core.errors import InputError
from aromm.core.system import Affine, Coefficient, FloatArray, Geometry, Term, ThermalSystem, TimeGrid
from aromm.core.vocabulary import (
    FACES,
    FaceSpec,
    PhaseSpec,
    face_means,
    face_terms,
    parameter_values,
    phase_terms,
)

IntArray = npt.NDArray[np.int64]
_MESHES = {"tetra": (MeshTet, 3), "triangle": (MeshTri, 2)}
_ELEMENTS = {("tetra", 1): ElementTetP1, ("tetra", 2): ElementTetP2, ("triangle", 1): ElementTriP1,
             ("triangle", 2): ElementTriP2}
_EXPORT_TYPE = {("tetra", 1): "tetra", ("tetra", 2): "tetra10", ("triangle", 1): "triangle",
                ("triangle", 2): "triangle6"}


@BilinearForm
def _laplace(u, v, w):  # type: ignore[no-untyped-def]
    return dot(grad(u), grad(v))


@BilinearForm
def _mass(u, v, w):  # type: ignore[no-untyped-def]
    return u * v


@LinearForm
def _unit(v, w):  # type: ignore[no-untyped-def]
    return v


def _directional(axis: int) -> BilinearForm:
    @BilinearForm
    def form(u, v, w):  # type: ignore[no-untyped-def]
        return u.grad[axis] * v.grad[axis]

    return form


@dataclass(frozen=True)
class DofSplit:
    """Unknowns after splitting: ``dof[i, p]`` is the unknown of original dof ``i`` seen from phase ``p``
    (-1 where phase p does not touch it); ``source[k]`` the original dof of unknown ``k``."""

    dof: IntArray
    source: IntArray

    @property
    def n(self) -> int:
        return int(self.source.size)


def _pair_name(a: str, b: str, resistances: Mapping[str, float]) -> str | None:
    for key in (f"{a}|{b}", f"{b}|{a}"):
        if key in resistances:
            return key
    return None


def split_dofs(element_dofs: IntArray, phase: IntArray, n_dofs: int, names: Sequence[str],
               resistances: Mapping[str, float]) -> DofSplit:
    """Duplicate the degrees of freedom shared by phases in resistive contact.

    ``element_dofs`` is (n_elements, n_local); ``resistances`` names the resistive pairs ``"p|q"``.
    A dof shared by several phases gets one unknown per group of phases joined by perfect
    contact (so triple lines are handled); the group with the lowest phase index keeps the
    dof's number, the other copies are appended.
    """
    n_ph = len(names)
    resistive = {(i, j) for i in range(n_ph) for j in range(n_ph)
                 if i != j and _pair_name(names[i], names[j], resistances) is not None}
    incident = np.zeros((n_dofs, n_ph), dtype=bool)
    for p in range(n_ph):
        incident[np.unique(element_dofs[phase == p]), p] = True
    # rep[i, p]: lowest phase of the perfect-contact group of p at dof i (fixed point)
    rep = np.tile(np.arange(n_ph), (n_dofs, 1))
    for _ in range(n_ph):
        for p in range(n_ph):
            for q in range(n_ph):
                if p != q and (p, q) not in resistive:
                    both = incident[:, p] & incident[:, q]
                    low = np.minimum(rep[both, p], rep[both, q])
                    rep[both, p] = low
                    rep[both, q] = low
    present = np.zeros((n_dofs, n_ph), dtype=bool)
    for p in range(n_ph):
        present[np.flatnonzero(incident[:, p]), rep[incident[:, p], p]] = True
    first = np.argmax(present, axis=1)
    ids = np.full((n_dofs, n_ph), -1, dtype=np.int64)
    keep = present & (np.arange(n_ph) == first[:, None])
    ids[keep] = np.nonzero(keep)[0]
    extra_dofs, extra_groups = np.nonzero(present & ~keep)
    ids[extra_dofs, extra_groups] = n_dofs + np.arange(extra_dofs.size)
    dof = np.where(incident, np.take_along_axis(ids, rep, axis=1), -1)
    return DofSplit(dof=dof, source=np.concatenate([np.arange(n_dofs), extra_dofs]))


def _relabel(matrix: sp.sparray | sp.spmatrix, dof_p: IntArray, n: int) -> sp.csr_array:
    """A matrix assembled on the original dofs, restricted to one phase, in split numbering."""
    coo = sp.coo_array(matrix)
    keep = coo.data != 0.0
    rows, cols = dof_p[coo.row[keep]], dof_p[coo.col[keep]]
    if np.any(rows < 0) or np.any(cols < 0):
        raise AssertionError("a phase matrix touches a dof outside that phase")
    return sp.csr_array((coo.data[keep], (rows, cols)), shape=(n, n))


def _volume_block(mesh: meshio.Mesh) -> tuple[str, int]:
    types = [b.type for b in mesh.cells]
    for wanted in ("tetra", "triangle"):
        if wanted in types:
            return wanted, types.index(wanted)
    raise InputError(f"the mesh needs tetra (3-D) or triangle (2-D) cells; it has {sorted(set(types))}")


def _element_phases(mesh: meshio.Mesh, block: int, phases: Sequence[PhaseSpec], label_key: str) -> IntArray:
    n_el = len(mesh.cells[block].data)
    out = np.full(n_el, -1, dtype=np.int64)
    for i, ph in enumerate(phases):
        if ph.name in mesh.cell_sets:
            out[np.asarray(mesh.cell_sets[ph.name][block], dtype=np.int64)] = i
        elif label_key in mesh.cell_data:
            out[np.asarray(mesh.cell_data[label_key][block]) == ph.label] = i
        else:
            raise InputError(f"phase {ph.name!r}: the mesh has no cell set of that name and no cell data "
                             f"{label_key!r}; cell sets: {sorted(mesh.cell_sets)}, cell data: {sorted(mesh.cell_data)}")
    if np.any(out < 0):
        raise InputError(f"{np.count_nonzero(out < 0)} mesh cells belong to no phase; phases: "
                         f"{[p.name for p in phases]} (labels {[p.label for p in phases]})")
    return out


def _check_interfaces(interfaces: Mapping[str, float] | None, names: Sequence[str]) -> dict[str, float]:
    out = {}
    for key, value in (interfaces or {}).items():
        parts = key.split("|")
        if len(parts) != 2 or any(p not in names for p in parts) or parts[0] == parts[1]:
            raise InputError(f"interface {key!r}: expected 'phase|phase' with two different phases among {names}")
        r = float(value)
        if not (np.isfinite(r) and r >= 0):
            raise InputError(f"interface {key!r}: contact resistance R must be finite and >= 0 m^2 K/W; got {value}")
        if r > 0:
            out[key] = r
    return out


@dataclass(frozen=True, eq=False)
class SimplexMesh:
    """Lagrange elements on a simplex mesh in split numbering (aromm.core.vocabulary.Discretisation)."""

    mesh: MeshTet | MeshTri
    element: object
    phase: IntArray
    split: DofSplit
    names: tuple[str, ...]
    _faces: dict[str, sp.csr_array] = field(default_factory=dict, init=False, repr=False)

    @property
    def n(self) -> int:
        return self.split.n

    @property
    def dim(self) -> int:
        return int(self.mesh.p.shape[0])

    @functools.cached_property
    def whole(self) -> Basis:
        return Basis(self.mesh, self.element)

    def _basis(self, phase: int) -> Basis:
        return Basis(self.mesh, self.element, elements=np.flatnonzero(self.phase == phase))

    def conduction(self, phase: int, axis: str | None) -> sp.csr_array:
        form = _laplace if axis is None else _directional("xyz".index(axis))
        if axis is not None and "xyz".index(axis) >= self.dim:
            raise InputError(f"phase {self.names[phase]!r}: a {self.dim}-D mesh has no axis {axis!r}")
        return _relabel(form.assemble(self._basis(phase)), self.split.dof[:, phase], self.n)

    def mass(self, phase: int) -> sp.csr_array:
        return _relabel(_mass.assemble(self._basis(phase)), self.split.dof[:, phase], self.n)

    def tensor_conduction(self, phase: int, spec: PhaseTensor) -> list[sp.csr_array]:
        raise InputError(f"phase {self.names[phase]!r}: a conductivity tensor or fibre phase needs a voxel image "
                         "(geometry.image); mesh phases take k or [kx, ky, kz]")

    @functools.cached_property
    def _bounds(self) -> tuple[FloatArray, FloatArray]:
        return self.mesh.p.min(axis=1), self.mesh.p.max(axis=1)

    def _face_parts(self, face: str) -> list[tuple[FacetBasis, IntArray, IntArray]]:
        """Facet bases of the face, one per phase touching it, with its facets and that phase's dof map."""
        if face not in FACES or "xyz".index(face[0]) >= self.dim:
            raise InputError(f"unknown face {face!r}; allowed: {', '.join(FACES[: 2 * self.dim])}")
        axis = "xyz".index(face[0])
        lo, hi = self._bounds
        plane = lo[axis] if face[1] == "0" else hi[axis]
        boundary = self.mesh.boundary_facets()
        tol = 1e-9 * float(np.max(hi - lo))
        on = np.all(np.abs(self.mesh.p[axis, self.mesh.facets[:, boundary]] - plane) <= tol, axis=0)
        facets = boundary[on]
        if facets.size == 0:
            raise InputError(f"face {face!r}: no boundary facet of the mesh lies on that bounding-box plane")
        owner = self.phase[self.mesh.f2t[0, facets]]
        return [(FacetBasis(self.mesh, self.element, facets=facets[owner == i]), facets[owner == i],
                 self.split.dof[:, i]) for i in np.unique(owner)]

    def _facet_mass(self, facets: IntArray) -> sp.csr_array:
        """``∫ φ_a φ_b`` over boundary ``facets``, each seen from the phase that owns it (split numbering)."""
        owner = self.phase[self.mesh.f2t[0, facets]]
        parts = (_relabel(_mass.assemble(FacetBasis(self.mesh, self.element, facets=facets[owner == i])),
                          self.split.dof[:, i], self.n) for i in np.unique(owner))
        return sp.csr_array(sum(parts, start=sp.csr_array((self.n, self.n))))

    def face_mass(self, face: str) -> sp.csr_array:
        if face not in self._faces:
            self._faces[face] = self._facet_mass(np.concatenate([f for _, f, _ in self._face_parts(face)]))
        return self._faces[face]

    def boundary_mass(self) -> sp.csr_array:
        """``B = ∫_Γ φ_a φ_b`` over every boundary facet of the mesh (m², or m in 2-D)."""
        return self._facet_mass(self.mesh.boundary_facets())

    def face_dofs(self, face: str) -> IntArray:
        dofs = [dof_p[self.whole.get_dofs(facets=facets).all()] for _, facets, dof_p in self._face_parts(face)]
        return np.unique(np.concatenate(dofs)).astype(np.int64)

    def interface(self, p: int, q: int) -> sp.csr_array | None:
        """``J^T M_Gamma J`` on the facets between phases p and q (None when they do not touch)."""
        f2t = self.mesh.f2t
        inner = np.flatnonzero(f2t[1] >= 0)
        ph0, ph1 = self.phase[f2t[0, inner]], self.phase[f2t[1, inner]]
        facets = inner[((ph0 == p) & (ph1 == q)) | ((ph0 == q) & (ph1 == p))]
        if facets.size == 0:
            return None
        m_gamma = sp.csr_array(_mass.assemble(FacetBasis(self.mesh, self.element, facets=facets)))
        dofs = np.unique(self.whole.get_dofs(facets=facets).all())  # the dofs living on the interface
        k = dofs.size
        jump = sp.csr_array((np.r_[np.ones(k), -np.ones(k)],
                             (np.r_[np.arange(k), np.arange(k)],
                              np.r_[self.split.dof[dofs, p], self.split.dof[dofs, q]])), shape=(k, self.n))
        return sp.csr_array(jump.T @ m_gamma[dofs][:, dofs] @ jump)


def assemble_mesh(
    mesh: meshio.Mesh,
    phases: Sequence[PhaseSpec],
    boundary: Sequence[FaceSpec] = (),
    *,
    interfaces: Mapping[str, float] | None = None,
    time: TimeGrid | None = None,
    initial_T: float = 0.0,
    outputs: Sequence[str] = (),
    label_key: str = "gmsh:physical",
    order: int = 1,
) -> ThermalSystem:
    """A :class:`ThermalSystem` from a conforming simplex mesh (tetra or triangle, coordinates in m).

    ``interfaces`` maps ``"p|q"`` to the contact resistance R (m^2 K/W, >= 0; 0 = perfect
    contact).  Boundary faces are the bounding-box planes ``x0 ... z1`` (aromm.core.vocabulary.FaceSpec:
    fixed T, entering flux, or convection h to T_ext); unlisted faces are adiabatic.
    ``order`` is the Lagrange degree, 1 or 2 (straight-sided elements either way).
    """
    names = tuple(p.name for p in phases)
    resist = _check_interfaces(interfaces, names)
    if order not in (1, 2):
        raise InputError(f"element order must be 1 or 2; got {order}")
    cell_type, block = _volume_block(mesh)
    mesh_cls, dim = _MESHES[cell_type]
    used, conn = np.unique(np.asarray(mesh.cells[block].data, dtype=np.int64), return_inverse=True)
    conn = conn.reshape(-1, dim + 1)
    points = np.asarray(mesh.points, dtype=float)[used, :dim]  # nodes of lower-dimensional cells dropped
    phase = _element_phases(mesh, block, phases, label_key)
    fem_mesh = mesh_cls(np.ascontiguousarray(points.T), np.ascontiguousarray(conn.T), sort_t=False)
    element = _ELEMENTS[(cell_type, order)]()
    whole = Basis(fem_mesh, element)
    split = split_dofs(whole.element_dofs.T, phase, whole.N, names, resist)
    disc = SimplexMesh(fem_mesh, element, phase, split, names)
    present = [i for i in range(len(phases)) if np.any(phase == i)]
    transient = time is not None
    terms = phase_terms(disc, phases, present, transient=transient)
    params = parameter_values([phases[i] for i in present], boundary, initial_T, transient)
    for key in resist:
        p, q = (names.index(part) for part in key.split("|"))
        operator = disc.interface(p, q)
        if operator is not None:
            terms.append(Term(f"G_{key}", Coefficient((f"{key}.h_c",)), operator, "conduction"))
            params[f"{key}.h_c"] = 1.0 / resist[key]
    faces, dirichlet = face_terms(disc, boundary)
    terms += faces
    cells = split.dof[whole.element_dofs, phase[None, :]].T  # (n_el, n_local) in split numbering
    locs = whole.doflocs.T[split.source]
    geometry = Geometry(locs if dim == 3 else np.column_stack([locs, np.zeros(split.n)]), cells,
                        _EXPORT_TYPE[(cell_type, order)], {"phase": phase})
    return ThermalSystem(n=split.n,
                         conductance=Affine(tuple(t for t in terms if t.role in ("conduction", "exchange"))),
                         capacity=Affine(tuple(t for t in terms if t.role == "capacity")),
                         load=Affine(tuple(t for t in terms if t.role == "load")), dirichlet=tuple(dirichlet),
                         observation=face_means(disc, outputs), parameters=params, time=time, geometry=geometry,
                         boundary=disc.boundary_mass())
