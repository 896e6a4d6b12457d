"""P1 finite elements on conforming simplex meshes (any mesh meshio reads) into a ThermalSystem.

Phases come from cell sets (``mesh.cell_sets[phase_name]``) or from an integer cell-data
array (``gmsh:physical`` by default) matched against :attr:`aromm.fem.PhaseSpec.label`.
A contact resistance ``R`` (m^2 K/W) between two phases (scene: ``[interfaces."fibre|gas"] R``)
is modelled on **split interface nodes**: every node on the interface gets one copy per side,
each phase's elements use their own copy, and the two copies are coupled by

    K_int = (1/R) J^T M_Gamma J,        (J T)_i = T_i^{fibre} - T_i^{gas},

with ``M_Gamma`` the P1 facet mass matrix of the interface (scikit-fem ``FacetBasis`` on the
interface facets), i.e. the weak form of the flux ``q_n = (T_fibre - T_gas)/R`` across it.
The coefficient is the parameter ``"fibre|gas.h_c" = 1/R`` (W/(m^2 K)) so the system stays
affine; ``R = 0`` means perfect contact (nodes not split).  Terms follow aromm.fem: ``K_<phase>``,
``C_<phase>`` (transient only), ``H_<face>``/``U_<face>`` for faces, and ``G_<p>|<q>`` for an
interface.  Faces ``x0 ... z1`` are the planes of the mesh's bounding box.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import meshio
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementTetP1, ElementTriP1, FacetBasis, LinearForm, MeshTet, MeshTri
from skfem.helpers import dot, grad

from aromm.errors import InputError
from aromm.fem import FACES, FaceSpec, PhaseSpec, parameter_values
from aromm.system import Affine, Coefficient, Dirichlet, FloatArray, Geometry, Term, ThermalSystem, TimeGrid

IntArray = npt.NDArray[np.int64]
_SIMPLEX = {"tetra": (MeshTet, ElementTetP1, 3), "triangle": (MeshTri, ElementTriP1, 2)}


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
class SplitMesh:
    """A simplex mesh whose resistive-interface nodes are duplicated, one copy per side.

    ``points[k]`` is the position of unknown ``k``; ``elements`` (n_el, n_vertices) index
    unknowns; ``phase`` is the phase index of each element; ``source`` maps an unknown to the
    original mesh node.  ``interfaces`` maps a pair name ``"p|q"`` to ``(M, dof_p, dof_q)``:
    the facet mass matrix on the original interface nodes ``nodes`` and each side's unknowns.
    """

    points: FloatArray
    elements: IntArray
    phase: IntArray
    source: IntArray
    interfaces: Mapping[str, tuple[sp.csr_array, IntArray, IntArray]]


def _volume_block(mesh: meshio.Mesh) -> tuple[str, int]:
    for i, block in enumerate(mesh.cells):
        if block.type in ("tetra", "triangle") and (block.type == "tetra" or not any(
                b.type == "tetra" for b in mesh.cells)):
            return block.type, i
    kinds = sorted({b.type for b in mesh.cells})
    raise InputError(f"the mesh needs tetra (3-D) or triangle (2-D) cells; it has {kinds}")


def _element_phases(mesh: meshio.Mesh, block: int, phases: Sequence[PhaseSpec], label_key: str) -> IntArray:
    n_el = len(mesh.cells[block].data)
    out = np.full(n_el, -1, dtype=np.int64)
    for i, ph in enumerate(phases):
        if ph.name in mesh.cell_sets:
            ids = np.asarray(mesh.cell_sets[ph.name][block], dtype=np.int64)
            out[ids] = i
        elif label_key in mesh.cell_data:
            out[np.asarray(mesh.cell_data[label_key][block]) == ph.label] = i
        else:
            raise InputError(f"phase {ph.name!r}: the mesh has no cell set of that name and no cell data "
                             f"{label_key!r}; cell sets: {sorted(mesh.cell_sets)}, cell data: {sorted(mesh.cell_data)}")
    if np.any(out < 0):
        raise InputError(f"{np.count_nonzero(out < 0)} mesh cells belong to no phase; phases: "
                         f"{[p.name for p in phases]} (labels {[p.label for p in phases]})")
    return out


def _pair_name(a: str, b: str, resistances: Mapping[str, float]) -> str | None:
    for key in (f"{a}|{b}", f"{b}|{a}"):
        if key in resistances:
            return key
    return None


def split_interfaces(points: FloatArray, elements: IntArray, phase: IntArray, names: Sequence[str],
                     resistances: Mapping[str, float]) -> SplitMesh:
    """Duplicate the nodes of every resistive interface and assemble its facet mass (scikit-fem).

    ``resistances`` names the resistive pairs (``"p|q"``); every node of the mesh must belong
    to an element.  A node shared by several phases gets one unknown per group of phases
    joined by perfect contact (triple lines are handled); the group with the lowest phase
    index keeps the node's number, the other copies are appended.  The interface facet mass
    is computed on the original (unsplit) mesh.
    """
    mesh_cls, elem_cls, _ = _SIMPLEX["tetra" if elements.shape[1] == 4 else "triangle"]
    n_nodes, n_ph = points.shape[0], len(names)
    resistive = {(i, j) for i in range(n_ph) for j in range(n_ph)
                 if i != j and _pair_name(names[i], names[j], resistances) is not None}
    incident = np.zeros((n_nodes, n_ph), dtype=bool)
    for p in range(n_ph):
        incident[np.unique(elements[phase == p]), p] = True
    # rep[node, p]: lowest phase of the perfect-contact group of p at that node (fixed point)
    rep = np.tile(np.arange(n_ph), (n_nodes, 1))
    for _ in range(n_ph):
        for p in range(n_ph):
            for q in range(n_ph):
                if p != q and (p, q) not in resistive:
                    both = incident[:, p] & incident[:, q]
                    low = np.minimum(rep[both, p], rep[both, q])
                    rep[both, p] = low
                    rep[both, q] = low
    present = np.zeros((n_nodes, n_ph), dtype=bool)
    for p in range(n_ph):
        present[np.flatnonzero(incident[:, p]), rep[incident[:, p], p]] = True
    first = np.argmax(present, axis=1)
    ids = np.full((n_nodes, n_ph), -1, dtype=np.int64)
    keep = present & (np.arange(n_ph) == first[:, None])
    ids[keep] = np.nonzero(keep)[0]
    extra_nodes, extra_groups = np.nonzero(present & ~keep)
    ids[extra_nodes, extra_groups] = n_nodes + np.arange(extra_nodes.size)
    dof = np.take_along_axis(ids, rep, axis=1)  # unknown of (node, phase)
    split_elements = dof[elements, phase[:, None]]

    mesh = mesh_cls(np.ascontiguousarray(points.T), np.ascontiguousarray(elements.T), sort_t=False)
    f2t = mesh.f2t
    inner = np.flatnonzero(f2t[1] >= 0)
    ph0, ph1 = phase[f2t[0, inner]], phase[f2t[1, inner]]
    interfaces: dict[str, tuple[sp.csr_array, IntArray, IntArray]] = {}
    for p, q in sorted(resistive):
        key = _pair_name(names[p], names[q], resistances)
        if p > q or key is None:
            continue
        facets = inner[((ph0 == p) & (ph1 == q)) | ((ph0 == q) & (ph1 == p))]
        if facets.size == 0:
            continue
        m_full = sp.csr_array(_mass.assemble(FacetBasis(mesh, elem_cls(), facets=facets)))
        nodes = np.unique(mesh.facets[:, facets])
        side_a, side_b = (p, q) if key == f"{names[p]}|{names[q]}" else (q, p)
        interfaces[key] = (sp.csr_array(m_full[nodes][:, nodes]), dof[nodes, side_a], dof[nodes, side_b])
    source = np.concatenate([np.arange(n_nodes), extra_nodes])
    return SplitMesh(points=points[source], elements=split_elements, phase=phase, source=source,
                     interfaces=interfaces)


def _face_facets(mesh: MeshTet | MeshTri, face: str, lo: FloatArray, hi: FloatArray) -> IntArray:
    axis = "xyz".index(face[0])
    plane = lo[axis] if face[1] == "0" else hi[axis]
    tol = 1e-9 * float(np.max(hi - lo))
    bf = mesh.boundary_facets()
    on = np.all(np.abs(mesh.p[axis, mesh.facets[:, bf]] - plane) <= tol, axis=0)
    return bf[on]


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
) -> ThermalSystem:
    """A :class:`ThermalSystem` from a conforming simplex mesh (tetra or triangle, coordinates in m).

    ``interfaces`` maps ``"p|q"`` to the contact resistance R (m^2 K/W, >= 0; 0 = perfect
    contact).  Boundary faces are the bounding-box planes ``x0 ... z1`` (FaceSpec as in
    aromm.fem: fixed T, entering flux, or convection h to T_ext); unlisted faces are adiabatic.
    """
    resist = {k: float(v) for k, v in (interfaces or {}).items()}
    names = [p.name for p in phases]
    for key, value in resist.items():
        parts = key.split("|")
        if len(parts) != 2 or any(p not in names for p in parts) or parts[0] == parts[1]:
            raise InputError(f"interface {key!r}: expected 'phase|phase' with two different phases among {names}")
        if not (np.isfinite(value) and value >= 0):
            raise InputError(f"interface {key!r}: contact resistance R must be finite and >= 0 m^2 K/W; got {value}")
    resist = {k: v for k, v in resist.items() if v > 0}
    cell_type, block = _volume_block(mesh)
    mesh_cls, elem_cls, dim = _SIMPLEX[cell_type]
    used, elements = np.unique(np.asarray(mesh.cells[block].data, dtype=np.int64), return_inverse=True)
    elements = elements.reshape(-1, dim + 1)
    points = np.asarray(mesh.points, dtype=float)[used, :dim]  # nodes of lower-dimensional cells dropped
    phase = _element_phases(mesh, block, phases, label_key)
    split = split_interfaces(points, elements, phase, names, resist)
    fem_mesh = mesh_cls(np.ascontiguousarray(split.points.T), np.ascontiguousarray(split.elements.T), sort_t=False)
    n = split.points.shape[0]
    element = elem_cls()

    conductance: list[Term] = []
    capacity: list[Term] = []
    load: list[Term] = []
    for i, ph in enumerate(phases):
        idx = np.flatnonzero(phase == i)
        if idx.size == 0:
            continue
        basis = Basis(fem_mesh, element, elements=idx)
        if isinstance(ph.k, tuple):
            for ax in range(dim):
                conductance.append(Term(f"K_{ph.name}_{'xyz'[ax]}", Coefficient((f"{ph.name}.k_{'xyz'[ax]}",)),
                                        sp.csr_array(_directional(ax).assemble(basis))))
        else:
            conductance.append(Term(f"K_{ph.name}", Coefficient((f"{ph.name}.k",)),
                                    sp.csr_array(_laplace.assemble(basis))))
        if time is not None or ph.q is not None:
            mass = sp.csr_array(_mass.assemble(basis))
            if time is not None:
                if ph.c is None:
                    raise InputError(f"phase {ph.name!r} needs a capacity c for a transient scene")
                capacity.append(Term(f"C_{ph.name}", Coefficient((f"{ph.name}.c",)), mass))
            if ph.q is not None:
                load.append(Term(f"Q_{ph.name}", Coefficient((f"{ph.name}.q",)), mass @ np.ones(n)))
    params = parameter_values([p for i, p in enumerate(phases) if np.any(phase == i)], boundary, initial_T,
                              time is not None)
    for key, (m_gamma, side_a, side_b) in split.interfaces.items():
        k = side_a.size
        jump = sp.csr_array((np.r_[np.ones(k), -np.ones(k)], (np.r_[np.arange(k), np.arange(k)],
                                                              np.r_[side_a, side_b])), shape=(k, n))
        conductance.append(Term(f"G_{key}", Coefficient((f"{key}.h_c",)), sp.csr_array(jump.T @ m_gamma @ jump)))
        params[f"{key}.h_c"] = 1.0 / resist[key]

    lo, hi = split.points.min(axis=0), split.points.max(axis=0)
    dirichlet: list[Dirichlet] = []
    face_loads: list[Term] = []

    def face_basis(face: str) -> FacetBasis:
        if face not in FACES or "xyz".index(face[0]) >= dim:
            raise InputError(f"unknown face {face!r}; allowed: {', '.join(FACES[: 2 * dim])}")
        facets = _face_facets(fem_mesh, face, lo, hi)
        if facets.size == 0:
            raise InputError(f"face {face!r}: no boundary facet of the mesh lies on that bounding-box plane")
        return FacetBasis(fem_mesh, element, facets=facets)

    for f in boundary:
        fb = face_basis(f.face)
        if f.T is not None:
            dofs = np.unique(fem_mesh.facets[:, fb.find]).astype(np.int64)
            dirichlet.append(Dirichlet(f"T_{f.face}", dofs, f"{f.face}.T"))
            continue
        weights = np.asarray(_unit.assemble(fb))
        if f.h is not None:
            conductance.append(Term(f"H_{f.face}", Coefficient((f"{f.face}.h",)), sp.csr_array(_mass.assemble(fb))))
            face_loads.append(Term(f"U_{f.face}", Coefficient((f"{f.face}.h", f"{f.face}.T_ext")), weights))
        if f.flux is not None:
            load.append(Term(f"U_{f.face}", Coefficient((f"{f.face}.flux",)), weights))
    load.extend(face_loads)
    observation = {}
    for face in outputs:
        w = np.asarray(_unit.assemble(face_basis(face)))
        observation[face] = w / w.sum()
    geometry = Geometry(split.points if dim == 3 else np.column_stack([split.points, np.zeros(n)]),
                        split.elements, cell_type, {"phase": phase})
    return ThermalSystem(n=n, conductance=Affine(tuple(conductance)), capacity=Affine(tuple(capacity)),
                         load=Affine(tuple(load)), dirichlet=tuple(dirichlet), observation=observation,
                         parameters=params, time=time, geometry=geometry)
