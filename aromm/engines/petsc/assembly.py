"""The distributed ThermalSystem: every affine term as a PETSc matrix or vector over the ranks' row blocks.

Two ways in:

* :func:`assemble_slabs` (voxel problems, scalable): rank r reads its voxel layers ``k0 <= k < k1`` and
  assembles them with the serial assembler :func:`aromm.fem.assemble_voxels` as a box of its own (the same
  Q1 element matrices, face masses and term names; only the faces of the whole box that the slab touches
  are given to it).  Its node ``l`` is the global node ``l + k0 (nx+1)(ny+1)``; the rows of its top plane
  belong to rank r + 1 and are sent there (one plane per term), so that the owned rows hold the complete
  sums.  Every rank's memory is O(its slab): nothing of the whole image's matrices is ever on one rank.
* :func:`distribute_system` (any ThermalSystem already assembled on every rank: DEM networks, mesh scenes,
  tests): each rank keeps its block of rows.

The term list (names, coefficients, order), the parameters, the Dirichlet faces and the output names come
from a *template* ThermalSystem: the serial system of a stand-in image holding each present label once
(:meth:`aromm.engines.petsc.problem.VoxelProblem.template`), or the serial system itself.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from aromm.core.cache import content_key
from aromm.core.system import Affine, Coefficient, ParamValues, Role, ThermalSystem, TimeGrid, dense
from aromm.engines.petsc import convert, runtime
from aromm.engines.petsc.layout import RowLayout, SlabLayout
from aromm.engines.petsc.problem import VoxelProblem
from aromm.fem.voxel import assemble_voxels, face_mass


@dataclass(frozen=True)
class DistributedTerm:
    """``coefficient(p) * operator`` with a PETSc matrix (MPIAIJ) or vector; ``role`` as aromm.core.system.Term's."""

    name: str
    coefficient: Coefficient
    operator: Any
    role: Role


@dataclass(frozen=True)
class DistributedSystem:
    """``C(p) dT/dt + K(p) T = F(p)`` held by PETSc; ``template`` names its terms, parameters and outputs.

    ``dirichlet`` maps a Dirichlet name of the template to this rank's fixed rows (global numbers);
    ``observation`` maps an output face to its row vector (face mean: sums to one); ``boundary`` is the
    boundary mass ``B = ∫_Γ φ_a φ_b`` (m²) over the whole outer surface (Steklov modes), None for a system
    with no boundary.
    """

    template: ThermalSystem
    rows: RowLayout
    comm: Any
    capacity: tuple[DistributedTerm, ...]
    conductance: tuple[DistributedTerm, ...]
    load: tuple[DistributedTerm, ...]
    dirichlet: Mapping[str, np.ndarray]
    observation: Mapping[str, Any]
    boundary: Any
    fingerprint: str
    description: str = ""
    complete: bool = False  # the template is the whole system (distributed by rows), not a stand-in

    @property
    def n(self) -> int:
        return self.rows.n

    @property
    def is_steady(self) -> bool:
        return self.template.is_steady

    @property
    def time(self) -> TimeGrid | None:
        return self.template.time

    @property
    def parameters(self) -> Mapping[str, float]:
        return self.template.parameters

    def values(self, overrides: ParamValues | None = None) -> dict[str, Any]:
        """The scene's parameter values updated by ``overrides`` (unknown names refused)."""
        return self.template.values(overrides)

    def combine(self, terms: tuple[DistributedTerm, ...], values: ParamValues) -> Any:
        """``Σ coefficient_j(values) operator_j`` as one new PETSc matrix (or vector)."""
        PETSc = runtime.petsc()
        total = None
        for t in terms:
            c = float(t.coefficient(values))
            if total is None:
                total = t.operator.copy()
                total.scale(c)
            elif isinstance(t.operator, PETSc.Vec):
                total.axpy(c, t.operator)
            else:
                total.axpy(c, t.operator, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        if total is None:
            raise ValueError("empty affine sum")
        return total

    def load_vector(self, values: ParamValues) -> Any:
        if self.load:
            return self.combine(self.load, values)
        return convert.vector(np.zeros(self.rows.local), self.rows, self.comm)


def _shift(block: sp.csr_array, offset: int, n: int) -> sp.csr_array:
    """Rows of a slab matrix with its column numbers moved to the global numbering."""
    csr = sp.csr_array(block)
    return sp.csr_array((csr.data, csr.indices.astype(np.int64) + offset, csr.indptr), shape=(csr.shape[0], n))


def _owned_rows(slab: sp.csr_array, layout: SlabLayout, comm: Any) -> sp.csr_array:
    """This rank's complete rows of a matrix assembled by slabs: its own rows plus the top-plane rows of the
    rank below (received), in global columns."""
    rows, plane = layout.rows, layout.plane
    csr = sp.csr_array(slab)
    ghost = None if layout.last else _shift(csr[rows.local:], layout.offset, rows.n)
    received = _exchange(ghost, layout, comm)
    mine = _shift(csr[: rows.local], layout.offset, rows.n)
    if received is None:
        return mine
    pad = sp.csr_array((rows.local - plane, rows.n))
    return sp.csr_array(mine + sp.vstack([received, pad], format="csr"))


def _owned_entries(slab: np.ndarray, layout: SlabLayout, comm: Any) -> np.ndarray:
    """This rank's complete entries of a vector assembled by slabs."""
    rows = layout.rows
    received = _exchange(None if layout.last else np.asarray(slab[rows.local:]), layout, comm)
    mine = np.array(slab[: rows.local], dtype=float)
    if received is not None:
        mine[: layout.plane] += received
    return mine


def _exchange(ghost: Any, layout: SlabLayout, comm: Any) -> Any:
    """Send ``ghost`` (the top plane's contributions) up one rank; return what the rank below sent."""
    from mpi4py import MPI

    up = MPI.PROC_NULL if layout.last else layout.rank + 1
    down = MPI.PROC_NULL if layout.first else layout.rank - 1
    return runtime.mpi(comm).sendrecv(ghost, dest=up, source=down)


def _term_operator(group: Affine, name: str, size: int, vector: bool) -> Any:
    for t in group.terms:
        if t.name == name:
            return t.operator
    return np.zeros(size) if vector else sp.csr_array((size, size))  # the slab has none of this phase / face


def assemble_slabs(problem: VoxelProblem, comm: Any) -> DistributedSystem:
    """Assemble ``problem`` by z-slabs (collective: every rank calls it)."""
    layout = problem.layout(comm)
    rows = layout.rows
    template = problem.template()
    faces = layout.faces()
    labels = problem.image.read(layout.k0, layout.k1)
    slab = assemble_voxels(labels, problem.voxel_size, problem.phases,
                           tuple(f for f in problem.boundary if f.face in faces), time=problem.time,
                           initial_T=problem.initial_T)
    m = slab.n

    def matrices(group: Affine, own: Affine) -> tuple[DistributedTerm, ...]:
        return tuple(DistributedTerm(t.name, t.coefficient,
                                     convert.matrix(_owned_rows(_term_operator(own, t.name, m, False), layout, comm),
                                                    rows, comm), t.role) for t in group.terms)

    def vectors(group: Affine, own: Affine) -> tuple[DistributedTerm, ...]:
        return tuple(DistributedTerm(t.name, t.coefficient,
                                     convert.vector(_owned_entries(_term_operator(own, t.name, m, True), layout, comm),
                                                    rows, comm), t.role) for t in group.terms)

    shape = layout.slab_shape
    surface = sp.csr_array((m, m))
    for face in faces:
        surface = surface + face_mass(shape, problem.voxel_size, face)
    observation = {}
    for face in problem.outputs:  # e_f = B_f 1 / |f| (aromm.core.vocabulary.face_means), |f| summed over the slabs
        local = _owned_entries(face_mass(shape, problem.voxel_size, face) @ np.ones(m) if face in faces
                               else np.zeros(m), layout, comm)
        observation[face] = convert.vector(local / runtime.allsum([local.sum()], comm)[0], rows, comm)
    dirichlet = {}
    for d in template.dirichlet:
        own = next((s.dofs for s in slab.dirichlet if s.name == d.name), np.zeros(0, dtype=np.int64))
        dofs = own + layout.offset
        dirichlet[d.name] = dofs[(dofs >= rows.lo) & (dofs < rows.hi)]
    return DistributedSystem(
        template, rows, comm,
        capacity=matrices(template.capacity, slab.capacity),
        conductance=matrices(template.conductance, slab.conductance),
        load=vectors(template.load, slab.load),
        dirichlet=dirichlet, observation=observation,
        boundary=convert.matrix(_owned_rows(surface, layout, comm), rows, comm),
        fingerprint=problem_key(problem, labels, comm),
        description=f"{problem.where}{problem.shape[0]}×{problem.shape[1]}×{problem.shape[2]} voxels "
                    f"in {layout.size} z-slabs",
    )


def problem_key(problem: VoxelProblem, labels: np.ndarray, comm: Any) -> str:
    """Content hash of a voxel problem, the same for any number of ranks: every z layer of the image is hashed
    by the rank that read it (``labels``, its slab), then the layer hashes in order with the scene's phases,
    faces and grids."""
    mine = [content_key(labels[:, :, k]) for k in range(labels.shape[2])]
    layers = [h for part in runtime.mpi(comm).allgather(mine) for h in part]
    return content_key("voxel problem", problem.shape, problem.voxel_size, repr(problem.phases),
                       repr(problem.boundary), problem.initial_T, repr(problem.time), problem.outputs, layers)


def distribute_system(system: ThermalSystem, comm: Any) -> DistributedSystem:
    """Each rank keeps its block of rows of a system that every rank holds (collective)."""
    rows = RowLayout.even(system.n, runtime.size(comm), runtime.rank(comm))
    part = slice(rows.lo, rows.hi)

    def terms(group: Affine) -> tuple[DistributedTerm, ...]:
        out = []
        for t in group.terms:
            op = (convert.matrix(sp.csr_array(t.operator)[part], rows, comm) if sp.issparse(t.operator)
                  else convert.vector(np.asarray(t.operator, dtype=float)[part], rows, comm))
            out.append(DistributedTerm(t.name, t.coefficient, op, t.role))
        return tuple(out)

    dirichlet = {d.name: d.dofs[(d.dofs >= rows.lo) & (d.dofs < rows.hi)] for d in system.dirichlet}
    observation = {k: convert.vector(dense(v).ravel()[part], rows, comm)
                   for k, v in system.observation.items()}
    boundary = None if system.boundary is None else convert.matrix(sp.csr_array(system.boundary)[part], rows, comm)
    return DistributedSystem(system, rows, comm, terms(system.capacity), terms(system.conductance),
                             terms(system.load), dirichlet, observation, boundary, system.fingerprint(),
                             description=f"{system.n} unknowns distributed by rows", complete=True)
