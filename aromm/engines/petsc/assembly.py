"""The distributed ThermalSystem: every affine term as a PETSc matrix or vector over the ranks' row blocks.

Two ways in:

* :func:`assemble_boxes` (voxel problems, scalable): rank r reads the voxels of its box
  (:class:`~aromm.engines.petsc.layout.BoxLayout`, a 3-D block of the image) and assembles them with the serial
  assembler :func:`aromm.fem.assemble_voxels` as an image of its own (the same Q1 element matrices, face
  masses and term names; only the faces of the whole box that the rank's box touches are given to it).  Its
  nodes are renumbered to the DMDA's global rows; the rows of its upper node planes belong to the neighbours
  above it (up to 7) and are sent there once per term, so that the owned rows hold the complete sums.
  Every rank's memory is O(its box): nothing of the whole image's matrices is ever on one rank.
* :func:`distribute_system` (any ThermalSystem already assembled on every rank: DEM networks, mesh scenes,
  tests): each rank keeps its block of rows.

A coupled heat–moisture problem (:mod:`aromm.physics.hygrothermal`) has two unknowns per node, T then φ in the serial
systems (field-major); each box's coupled system (:meth:`~aromm.engines.petsc.problem.VoxelProblem.part`) is
interlaced before it is distributed (row ``2 i + f``: field f of node row i, a DMDA of 2 degrees of freedom's
numbering), so every rank's rows stay one block and its matrices have 2 × 2 blocks (block size 2 for GAMG).

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
from aromm.core.observables import PHI_PREFIX, output_kind
from aromm.core.system import Affine, Coefficient, ParamValues, Role, ThermalSystem, TimeGrid, dense
from aromm.engines.petsc import convert, runtime
from aromm.engines.petsc.layout import BoxLayout, RowLayout
from aromm.engines.petsc.problem import VoxelProblem
from aromm.fem.voxel_grid import face_mass
from aromm.microstructure.digest import box_lanes, lanes_hex
from aromm.reduction import model_key


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
    grid: Any = None  # the DMDA of the node grid (voxel problems assembled by boxes), else None
    initial: tuple[DistributedTerm, ...] = ()  # vectors added to the uniform initial.T (a coupled system's φ part)

    @property
    def n(self) -> int:
        return self.rows.n

    @property
    def fields(self) -> int:
        """Unknowns per node (or cell): 1, T; 2, T and φ (a coupled system)."""
        return len(self.template.fields)

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

    def initial_state(self, values: ParamValues) -> Any:
        """The initial field ``initial.T + Σ c_i(p) v_i`` (the template's initial terms; a coupled system's
        ``initial.phi`` on φ) as a new vector."""
        x = (self.combine(self.initial, values) if self.initial
             else convert.vector(np.zeros(self.rows.local), self.rows, self.comm))
        x.shift(float(np.asarray(values["initial.T"])))
        return x


def _to_owners(owner: np.ndarray, arrays: tuple[np.ndarray, ...], layout: BoxLayout, comm: Any,
               ) -> tuple[np.ndarray, ...]:
    """Entries (``arrays`` side by side, one per box node entry) moved to the rank ``owner`` of each: this rank's
    own entries and those its neighbours assembled on the nodes it owns (collective)."""
    me, size = layout.rank, layout.size
    order = np.argsort(owner, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=size))])
    outgoing = [None if r == me or bounds[r] == bounds[r + 1] else tuple(a[order[bounds[r]:bounds[r + 1]]]
                                                                        for a in arrays) for r in range(size)]
    incoming = runtime.mpi(comm).alltoall(outgoing)
    mine = order[bounds[me]:bounds[me + 1]]
    parts = [tuple(a[mine] for a in arrays), *(p for p in incoming if p is not None)]
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(len(arrays)))


@dataclass(frozen=True)
class _BoxRows:
    """Global row (PETSc numbering) and owner rank of each node of this rank's box, in aromm.fem's box order."""

    layout: BoxLayout
    rows: RowLayout
    global_row: np.ndarray
    owner: np.ndarray

    def matrix(self, block: sp.sparray, comm: Any) -> sp.csr_array:
        """This rank's complete rows of a matrix assembled by boxes, in global columns.  The rows of the nodes it
        owns are taken as they are (in the box's order, which is the order of its rows); only the rows of the
        upper node planes go through triplets, to their owners."""
        csr = sp.csr_array(block)
        mine = self.owner == self.layout.rank
        own = csr if mine.all() else csr[np.flatnonzero(mine)]
        own = sp.csr_array((own.data, self.global_row[own.indices], own.indptr), shape=(self.rows.local, self.rows.n))
        ghosts = np.flatnonzero(~mine)
        ghost = sp.coo_array(csr[ghosts]) if ghosts.size else sp.coo_array((0, csr.shape[1]))
        g = self.global_row
        r, c, v = _to_owners(self.owner[ghosts][ghost.row], (g[ghosts][ghost.row], g[ghost.col], ghost.data),
                             self.layout, comm)
        if r.size:
            own = sp.csr_array(own + sp.csr_array((v, (r - self.rows.lo, c)), shape=own.shape))
        return own

    def interlaced(self, fields: int) -> _BoxRows:
        """The rows of ``fields`` unknowns per box node, interlaced (box unknown ``fields j + f``: field f of node
        j, global row ``fields g_j + f``)."""
        if fields == 1:
            return self
        layout = self.rows.interlaced(fields)
        rows = (self.global_row.astype(np.int64)[:, None] * fields + np.arange(fields)).ravel()
        return _BoxRows(self.layout, layout, rows.astype(np.int32 if layout.n < 2**31 else np.int64),
                        np.repeat(self.owner, fields))

    def vector(self, values: np.ndarray, comm: Any) -> np.ndarray:
        """This rank's complete entries of a vector assembled by boxes."""
        r, v = _to_owners(self.owner, (self.global_row, np.asarray(values, dtype=float)), self.layout, comm)
        return np.bincount(r - self.rows.lo, weights=v, minlength=self.rows.local)


def _take(operators: dict[str, Any], name: str, size: int, vector: bool, order: np.ndarray | None = None) -> Any:
    """The box's operator ``name``, dropped from ``operators`` (freed once converted: one term's copy at a time),
    its unknowns taken in ``order`` (:func:`interlacing`; None: as they are)."""
    if name not in operators:
        return np.zeros(size) if vector else sp.csr_array((size, size))  # the box has none of this phase / face
    return permuted(operators.pop(name), order)


def permuted(op: Any, order: np.ndarray | None) -> Any:
    """A matrix or vector ``op`` with its unknowns taken in ``order`` (None: ``op`` itself)."""
    if order is None:
        return op
    return sp.csr_array(op)[order][:, order] if sp.issparse(op) else np.asarray(op, dtype=float)[order]


def interlacing(fields: int, nodes: int) -> np.ndarray | None:
    """The field-major unknown (``f nodes + j``) at each interlaced position ``fields j + f``; None for one field.

    >>> interlacing(2, 3).tolist()
    [0, 3, 1, 4, 2, 5]
    """
    if fields == 1:
        return None
    return (np.arange(fields)[None, :] * nodes + np.arange(nodes)[:, None]).ravel()


def node_grid(layout: BoxLayout, comm: Any, dof: int = 1) -> Any:
    """The PETSc DMDA of the node grid with the ownership of ``layout`` (box stencil of width 1: the 27 nodes a
    Q1 row couples), ``dof`` unknowns per node; checked to own the rows :class:`BoxLayout` numbers."""
    PETSc = runtime.petsc()
    nx, ny, nz = layout.shape
    da = PETSc.DMDA().create(dim=3, dof=dof, sizes=(nx + 1, ny + 1, nz + 1), proc_sizes=layout.grid,
                             stencil_type=PETSc.DMDA.StencilType.BOX, stencil_width=1,
                             ownership_ranges=tuple(layout.ownership(a) for a in range(3)), comm=comm)
    (x0, _), (y0, _), (z0, _) = layout.box
    expected = tuple((lo, lo + layout.ownership(a)[q]) for a, (lo, q) in enumerate(zip((x0, y0, z0), layout.coords(),
                                                                                      strict=True)))
    if tuple(tuple(r) for r in da.getRanges()) != expected or da.getGlobalVec().getOwnershipRange() != (
            dof * layout.rows.lo, dof * layout.rows.hi):
        raise RuntimeError(f"DMDA ownership {da.getRanges()} differs from the box layout's {expected}")
    return da


def assemble_boxes(problem: VoxelProblem, comm: Any) -> DistributedSystem:
    """Assemble ``problem`` by boxes (collective: every rank calls it); in finite volumes by
    :func:`aromm.engines.petsc.volume_assembly.assemble_volume_boxes`."""
    if problem.discretisation == "fv":
        from aromm.engines.petsc.volume_assembly import assemble_volume_boxes

        return assemble_volume_boxes(problem, comm)
    layout = problem.layout(comm)
    template = problem.template()
    count = problem.fields
    faces = layout.faces()
    labels = problem.image.read(layout.box)
    box = problem.part(labels, faces)
    m = box.n
    order = interlacing(count, m // count)
    position = np.arange(m) if order is None else np.argsort(order)  # interlaced place of each box unknown
    fixed = {s.name: position[s.dofs] for s in box.dirichlet}
    operators = {t.name: t.operator for group in (box.capacity, box.conductance, box.load, box.initial)
                 for t in group.terms}
    del box  # its matrices are now held by ``operators`` alone, and freed one by one as they are converted
    nodes = _BoxRows(layout, layout.rows, *layout.box_rows())
    owned = nodes.interlaced(count)
    rows = owned.rows
    mine = owned.owner == layout.rank

    def matrices(group: Affine) -> tuple[DistributedTerm, ...]:
        return tuple(DistributedTerm(t.name, t.coefficient, convert.matrix(
            owned.matrix(_take(operators, t.name, m, False, order), comm), rows, comm, count), t.role)
            for t in group.terms)

    def vectors(group: Affine, summed: bool = True) -> tuple[DistributedTerm, ...]:
        """Loads are summed over the boxes that share a node; an initial field is a value: the owner's."""
        return tuple(DistributedTerm(t.name, t.coefficient, convert.vector(
            owned.vector(v, comm) if summed else v[mine], rows, comm), t.role)
            for t in group.terms for v in (_take(operators, t.name, m, True, order),))

    shape = layout.box_shape
    surface = sp.csr_array((nodes.global_row.size,) * 2)
    for face in faces:
        surface = surface + face_mass(shape, problem.voxel_size, face)
    means = {}
    for face in problem.observed:  # e_f = B_f 1 / |f| (aromm.core.vocabulary.face_means), |f| summed over the boxes
        local = nodes.vector(face_mass(shape, problem.voxel_size, face) @ np.ones(surface.shape[0]) if face in faces
                             else np.zeros(surface.shape[0]), comm)
        means[face] = local / runtime.allsum([local.sum()], comm)[0]
    observation = field_outputs(template, means, rows, comm)
    dirichlet = {}
    for d in template.dirichlet:
        own = fixed.get(d.name, np.zeros(0, dtype=np.int64))
        dirichlet[d.name] = np.unique(owned.global_row[own[owned.owner[own] == layout.rank]])
    m_, n_, p_ = layout.grid
    return DistributedSystem(
        template, rows, comm,
        capacity=matrices(template.capacity),
        conductance=matrices(template.conductance),
        load=vectors(template.load),
        dirichlet=dirichlet, observation=observation,
        boundary=convert.matrix(owned.matrix(sp.kron(surface, sp.eye(count), format="csr"), comm), rows, comm, count),
        fingerprint=problem_key(problem, labels, layout, comm),
        description=f"{problem.where}{problem.shape[0]}×{problem.shape[1]}×{problem.shape[2]} voxels "
                    f"in {m_}×{n_}×{p_} boxes" + (f", {count} unknowns per node" if count > 1 else ""),
        grid=node_grid(layout, comm, count),
        initial=vectors(template.initial, summed=False),
    )


def field_outputs(template: ThermalSystem, means: Mapping[str, np.ndarray], rows: RowLayout, comm: Any,
                  ) -> dict[str, Any]:
    """The output vectors of ``template``'s outputs (``<face>`` on T, ``phi:<face>`` on φ) from this rank's entries
    of each face's mean row ``means[face]`` (one per node or cell), placed on the output's field of the interlaced
    rows ``rows`` (zero on the other fields)."""
    count = len(template.fields)
    out = {}
    for name in template.observation:
        values = np.zeros(rows.local)
        values[template.fields.index(output_kind(name))::count] = means[name.removeprefix(PHI_PREFIX)]
        out[name] = convert.vector(values, rows, comm)
    return out


def image_digest(labels: np.ndarray, layout: BoxLayout, comm: Any) -> str:
    """A digest of the whole image that does not depend on how it is cut (:mod:`aromm.microstructure.digest`):
    each rank sums its box layer by layer, the lanes are summed over the ranks (mod 2⁶⁴)."""
    lanes = box_lanes(labels, layout.box, layout.shape)
    from mpi4py import MPI

    total = np.zeros_like(lanes)
    runtime.mpi(comm).Allreduce(lanes, total, op=MPI.SUM)
    return lanes_hex(total)


def problem_key(problem: VoxelProblem, labels: np.ndarray, layout: BoxLayout, comm: Any) -> str:
    """Content hash of a voxel problem, the same for any number of ranks and any cut: :func:`image_digest` of
    the boxes the ranks read (``labels``, this rank's) with the scene's phases, faces and grids."""
    return content_key("voxel problem", problem.shape, problem.voxel_size, repr(problem.phases),
                       repr(problem.boundary), problem.initial_T, repr(problem.time), problem.outputs,
                       image_digest(labels, layout, comm), problem.discretisation,
                       *(() if problem.moisture is None else ("moisture", repr(problem.moisture))))


def physics_key(problem: VoxelProblem, comm: Any, box: frozenset[str] = frozenset()) -> str:
    """:func:`aromm.reduction.model_key.physics_key` of a box-read problem (collective): each rank reads its box,
    the digest is summed over the ranks, so the key equals that of the scene read whole on one process; the values
    of the parameters in ``box`` left out."""
    layout = problem.layout(comm)
    digest = image_digest(problem.image.read(layout.box), layout, comm)
    return model_key.physics_key(digest, shape=problem.shape, voxel_size=problem.voxel_size, phases=problem.phases,
                                 boundary=problem.boundary, initial_T=problem.initial_T, time=problem.time,
                                 outputs=problem.outputs, box=box, discretisation=problem.discretisation,
                                 moisture=None if problem.moisture is None else model_key.moisture_part(
                                     problem.moisture, box))


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
                             description=f"{system.n} unknowns distributed by rows", complete=True,
                             initial=terms(system.initial))
