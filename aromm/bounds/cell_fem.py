"""Finite-element values of the cell of [GarnierDanes] with contact resistance, on conforming tetrahedral meshes.

Three octant sub-problems (sphere of radius ``a`` at the origin, ``b = a (1 + B)``), all with
T = 0 on the mid-plane z = 0, T = 1 on the top face and every other face adiabatic (the
symmetry planes x = 0, y = 0 of the full cell and its adiabatic sides, [GarnierDanes]):

* ``"cell"``: the box ``[0, b]^3`` -> ``E_c``, the exact cell value (flux method);
* ``"cylinder"``: the quarter cylinder ``r <= a``, ``0 <= z <= b`` with an adiabatic wall at
  r = a (tangent to the sphere along its equator) -> ``E_II`` of W1a;
* ``"slab"``: the box ``[0, b]^2 x [0, a]`` whose top face is tangent to the sphere (an
  isothermal plane at z = a) -> ``E_1bot`` of W1b.

``E = Q L / (lambda_m A dT)`` with the heat flow ``Q`` taken from the reaction at the fixed
top face (equal to the discrete energy), ``L`` the height and ``A`` the cross-section of the
domain (``pi a^2/4`` for the cylinder).

Meshes come from gmsh (OpenCASCADE booleans, headless), are handed over as meshio meshes with
``gmsh:physical`` tags 1 (filler) and 2 (matrix), and are assembled by
:func:`aromm.fem.mesh.assemble_mesh` with the contact resistance on split interface
unknowns.  ``h`` is the target element size in units of ``a``; the mesh is graded down to
``h/4`` near the sphere so that curvature and the thin gaps are resolved.

Elements are quadratic (P2) by default: with straight-sided tetrahedra the error is then the
geometric one of the inscribed polyhedral sphere, O(h^2) and negative (-0.2 % of E - 1 at
h = 0.3), against +2 % for P1 on the same mesh, whose energy error dominates
(benchmarks/bounds_fem.py).  A voxel (staircase) sphere would overestimate the interface area
by ~50 %; the polyhedral sphere converges to the true area at O(h^2).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Literal

import gmsh
import meshio
import numpy as np

from aromm.bounds.domain import check_B, check_contact, checked
from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem.mesh import assemble_mesh
from aromm.full.solve import reaction_heat_flow, steady_field

Kind = Literal["cell", "cylinder", "slab"]
KINDS: tuple[Kind, ...] = ("cell", "cylinder", "slab")
FILLER, MATRIX = 1, 2
PHASES = (PhaseSpec("filler", FILLER, 1.0), PhaseSpec("matrix", MATRIX, 1.0))
INTERFACE = "filler|matrix"
DEFAULT_H = 0.3
DEFAULT_ORDER = 2


@contextmanager
def _gmsh_session() -> Iterator[None]:
    """A private gmsh session: no terminal output, no signal handler, always finalised."""
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        yield
    finally:
        gmsh.finalize()


def cell_mesh(kind: Kind, B: float, h: float = DEFAULT_H, a: float = 1.0) -> meshio.Mesh:
    """Conforming tetrahedral mesh of one octant sub-problem (see module doc), as a meshio mesh.

    ``h`` is the largest element size in units of ``a`` (graded to ``h/4`` on the sphere);
    cells carry ``gmsh:physical`` = 1 (filler) or 2 (matrix).
    """
    b_cell = float(check_B(B))
    if b_cell <= 0.0:
        raise InputError("B must be > 0 for the finite-element cell (B = 0: touching spheres, no mesh)")
    size = float(checked("h (mesh size / a)", h, 0.0, 1.0, low_open=True))
    if kind not in KINDS:
        raise InputError(f"unknown cell kind {kind!r}; allowed: {', '.join(KINDS)}")
    b = a * (1.0 + b_cell)
    with _gmsh_session():
        gmsh.model.add(kind)
        occ = gmsh.model.occ
        if kind == "cell":
            outer = occ.addBox(0, 0, 0, b, b, b)
        elif kind == "slab":
            outer = occ.addBox(0, 0, 0, b, b, a)
        else:
            outer = occ.addCylinder(0, 0, 0, 0, 0, b, a, angle=np.pi / 2)
        ball = occ.addSphere(0, 0, 0, a)
        clip = occ.addBox(0, 0, 0, 1.01 * a, 1.01 * a, 1.01 * a)
        octant, _ = occ.intersect([(3, ball)], [(3, clip)])
        occ.fragment([(3, outer)], octant)
        occ.synchronize()
        volumes = gmsh.model.getEntities(3)
        if len(volumes) != 2:
            raise InputError(f"gmsh produced {len(volumes)} volumes for the {kind} cell with B = {b_cell:g}")
        filler = min(volumes, key=lambda v: np.linalg.norm(occ.getCenterOfMass(*v)))[1]
        matrix = next(t for _, t in volumes if t != filler)
        gmsh.model.addPhysicalGroup(3, [filler], FILLER, "filler")
        gmsh.model.addPhysicalGroup(3, [matrix], MATRIX, "matrix")
        _size_field(kind, filler, matrix, h=size * a, a=a, gap=b_cell * a)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)
        gmsh.model.mesh.generate(3)
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.zeros(int(node_tags.max()) + 1, dtype=np.int64)
        index[node_tags.astype(np.int64)] = np.arange(node_tags.size)
        blocks, labels = [], []
        for tag in (FILLER, MATRIX):
            entity = filler if tag == FILLER else matrix
            _, _, conn = gmsh.model.mesh.getElements(3, entity)
            tets = index[np.asarray(conn[0], dtype=np.int64)].reshape(-1, 4)
            blocks.append(tets)
            labels.append(np.full(len(tets), tag))
    points = coords.reshape(-1, 3)
    return meshio.Mesh(points, [("tetra", np.vstack(blocks))], cell_data={"gmsh:physical": [np.concatenate(labels)]})


def _size_field(kind: Kind, filler: int, matrix: int, *, h: float, a: float, gap: float) -> None:
    """Element size: ``h`` far away, ``h/4`` within ``2h`` of the spherical interface, and near the
    sphere's poles (its points closest to the cell faces):

    * where the sphere comes within ``gap = B a < a/4`` of a face, ``h gap / a`` at the pole (about
      ``a/h`` elements across the gap), graded up to ``h/4`` over ``sqrt(2 a (a/4 - gap))``, the
      radius where the gap has widened to ``a/4``;
    * where the slab's isothermal top touches the sphere, ``h^2/(16 a)`` at the pole: that node
      is shared by both phases with perfect contact and held at the plane's temperature, feeding
      the filler through elements of the pole's size (an artefact ``~ kappa * size``, 4.7 % on
      E_1bot at kappa = 100, h = 0.3 without this grading).

    The cylinder's equator, tangent to its adiabatic wall, needs no grading (no flux there).
    """
    field = gmsh.model.mesh.field
    faces_f = {t for _, t in gmsh.model.getBoundary([(3, filler)], oriented=False)}
    faces_m = {t for _, t in gmsh.model.getBoundary([(3, matrix)], oriented=False)}
    dist = field.add("Distance")
    field.setNumbers(dist, "SurfacesList", sorted(faces_f & faces_m))
    field.setNumber(dist, "Sampling", int(np.ceil(8.0 * a / h)) + 20)  # sample spacing < h/4 on the sphere
    fields = [_threshold(dist, 0.25 * h, h, 2.0 * h)]
    vertices = [t for _, t in gmsh.model.getEntities(0)]
    for axis in range(3):
        target = np.zeros(3)
        target[axis] = a
        pole = min(vertices, key=lambda t: float(np.linalg.norm(gmsh.model.getValue(0, t, []) - target)))
        if kind == "slab" and axis == 2:
            size, reach = h * h / (16.0 * a), h
        elif kind == "cylinder" and axis < 2:
            continue
        elif gap < 0.25 * a:
            size, reach = h * gap / a, float(np.sqrt(2.0 * a * (0.25 * a - gap)))
        else:
            continue
        near = field.add("Distance")
        field.setNumbers(near, "PointsList", [pole])
        fields.append(_threshold(near, size, 0.25 * h, reach))
    total = field.add("Min")
    field.setNumbers(total, "FieldsList", fields)
    field.setAsBackgroundMesh(total)


def _threshold(distance: int, size_min: float, size_max: float, reach: float) -> int:
    """gmsh Threshold field: ``size_min`` at distance 0 growing linearly to ``size_max`` at ``reach``."""
    field = gmsh.model.mesh.field
    tag = field.add("Threshold")
    field.setNumber(tag, "InField", distance)
    field.setNumber(tag, "SizeMin", size_min)
    field.setNumber(tag, "SizeMax", size_max)
    field.setNumber(tag, "DistMin", 0.0)
    field.setNumber(tag, "DistMax", reach)
    return tag

def cell_system(mesh: meshio.Mesh, contact: bool, order: int = DEFAULT_ORDER) -> ThermalSystem:
    """Steady system of an octant mesh: T = 0 on z0, T = 1 on z1, interface split if ``contact``."""
    return assemble_mesh(mesh, PHASES, [FaceSpec("z0", T=0.0), FaceSpec("z1", T=1.0)],
                         interfaces={INTERFACE: 1.0} if contact else None, order=order)


@dataclass
class CellModel:
    """The FE model of one sub-problem for one (kind, B, h): mesh and systems built once, evaluated for many (C, D).

    ``E(C, D)`` returns the normalised conductance (``lambda_m = 1``, ``lambda_f = 1/D``,
    ``h_c = 1/C`` with lengths in units of ``a``); ``C = 0`` uses the unsplit (perfect
    contact) system.
    """

    kind: Kind
    B: float
    h: float = DEFAULT_H
    order: int = DEFAULT_ORDER
    mesh: meshio.Mesh = field(init=False, repr=False)
    _systems: dict[bool, ThermalSystem] = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.mesh = cell_mesh(self.kind, self.B, self.h)

    @property
    def height(self) -> float:
        return 1.0 if self.kind == "slab" else 1.0 + self.B

    @property
    def area(self) -> float:
        return np.pi / 4.0 if self.kind == "cylinder" else (1.0 + self.B) ** 2

    def system(self, contact: bool) -> ThermalSystem:
        if contact not in self._systems:
            self._systems[contact] = cell_system(self.mesh, contact, self.order)
        return self._systems[contact]

    @property
    def n_unknowns(self) -> int:
        return self.system(True).n

    def E(self, C: float, D: float) -> float:
        """Normalised conductance for contact resistance ``C`` (>= 0) and ``D = lambda_m/lambda_f`` (> 0)."""
        c = float(check_contact(C))
        d = float(checked("D (ratio lambda_m/lambda_f; > 0 for finite elements)", D, 0.0, low_open=True))
        system = self.system(c > 0.0)
        values: dict[str, float] = {"matrix.k": 1.0, "filler.k": 1.0 / d}
        if c > 0.0:
            values[f"{INTERFACE}.h_c"] = 1.0 / c
        return conductance_from_reaction(system, values) * self.height / self.area


def conductance_from_reaction(system: ThermalSystem, values: dict[str, float]) -> float:
    """Heat flow entering through the fixed ``z1`` face at steady state (``z1.T - z0.T = 1`` in the system).

    The reaction ``sum_{i in z1} (K T)_i`` with ``T`` from :func:`aromm.full.solve.steady_field`
    equals the discrete energy ``T^T K T`` (variational).
    """
    top = next(d.dofs for d in system.dirichlet if d.name == "T_z1")
    return reaction_heat_flow(system, steady_field(system, values), top, values)


CELL_VALUES: tuple[tuple[str, Kind], ...] = (("E_c", "cell"), ("E_II", "cylinder"), ("E_1bot", "slab"))


def cell_values(B: float, C: float, D: float, h: float = DEFAULT_H, order: int = DEFAULT_ORDER) -> dict[str, float]:
    """``E_c``, ``E_II`` and ``E_1bot`` of the cell of [GarnierDanes] by finite elements (three meshes)."""
    return {name: CellModel(kind, B, h, order).E(C, D) for name, kind in CELL_VALUES}
