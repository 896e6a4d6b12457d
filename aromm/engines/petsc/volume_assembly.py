"""The finite-volume ThermalSystem of a voxel problem assembled by boxes (``[model] discretisation = "fv"``).

The cell-centred scheme of :mod:`aromm.fv.grid` (two-point links, harmonic-mean conductances between phases,
a massless unknown at each voxel face of a box face that carries a condition or an output) couples a voxel to its
six face neighbours only.  So each rank reads its box of the image with a halo of one voxel
(:func:`halo_box`), assembles that padded box with the serial assembler :func:`aromm.fv.volumes.assemble_volumes`
(the same links, coefficients and term names), and keeps the rows of the unknowns it owns: the voxels of its box
and the face unknowns on them.  Those rows are complete (every link of an owned voxel is inside the padded box), so
nothing is summed across ranks; the halo only supplies the column numbers of the neighbours' voxels.

Rows (:class:`VolumeRows`) are numbered rank by rank as PETSc numbers a DMDA of the voxel grid, x fastest over the
rank's box, followed by the rank's face unknowns face by face (``x0, x1, y0, …``), each in the face's own x-fastest
order: the cells' part of every row block is exactly a DMDA's 7-point-stencil layout of the image, the face
unknowns trail it.  The numbering is arithmetic (no communication) because every voxel carries an unknown: an
insulating phase (``k = 0``) needs the connectivity of the whole image to remove isolated clusters
(:func:`aromm.fv.volumes.pruned`) and is refused here.

The term list of the whole image (:func:`template`): each phase's terms from a stand-in image, the interface
terms ``K_a|b`` of the phase pairs that touch anywhere in the image (the union over the ranks' padded boxes).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import Affine, Term, ThermalSystem
from aromm.engines.petsc import convert, runtime
from aromm.engines.petsc.layout import BoxLayout, RowLayout
from aromm.engines.petsc.problem import VoxelProblem
from aromm.fv.grid import AXES, VolumeGrid
from aromm.fv.volumes import unknown_faces, volume_grid

Box = tuple[tuple[int, int], tuple[int, int], tuple[int, int]]
IntArray = npt.NDArray[np.int64]


def halo_box(layout: BoxLayout) -> Box:
    """This rank's box grown by one voxel on every side that is inside the image."""
    return tuple((max(lo - 1, 0), min(hi + 1, n)) for (lo, hi), n in zip(layout.box, layout.shape, strict=True))  # type: ignore[return-value]


class VolumeRows:
    """Global rows of the finite-volume unknowns on a :class:`BoxLayout` (module docstring): ``faces`` are the
    image faces that carry unknowns."""

    def __init__(self, layout: BoxLayout, faces: tuple[str, ...]) -> None:
        self.layout, self.faces = layout, faces
        blocks = layout.blocks()
        sizes = [np.diff(c) for c in layout.cuts]
        counts = []
        for b in blocks:
            shape = [int(sizes[a][b[a]]) for a in range(3)]
            counts.append(int(np.prod(shape)) + sum(self._area(shape, f) for f in self._touched(b, faces)))
        self.starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.rows = RowLayout(tuple(int(s) for s in self.starts), layout.rank)

    def _touched(self, block: tuple[int, int, int], faces: tuple[str, ...]) -> list[str]:
        grid = self.layout.grid
        return [f for f in faces if block[AXES.index(f[0])] == (0 if f[1] == "0" else grid[AXES.index(f[0])] - 1)]

    @staticmethod
    def _area(shape: list[int], face: str) -> int:
        a = AXES.index(face[0])
        return int(np.prod([shape[b] for b in range(3) if b != a]))

    def _blocks_of(self, coords: IntArray) -> tuple[IntArray, IntArray, IntArray]:
        """Owning block index per axis, the box's lower corner and its sizes, for voxel coordinates (k, 3)."""
        q = np.empty_like(coords)
        lo = np.empty_like(coords)
        size = np.empty_like(coords)
        for a in range(3):
            cuts = np.asarray(self.layout.cuts[a], dtype=np.int64)
            q[:, a] = np.minimum(np.searchsorted(cuts, coords[:, a], side="right") - 1, len(cuts) - 2)
            lo[:, a] = cuts[q[:, a]]
            size[:, a] = cuts[q[:, a] + 1] - lo[:, a]
        return q, lo, size

    def _rank(self, q: IntArray) -> IntArray:
        m, n, _ = self.layout.grid
        return q[:, 0] + m * (q[:, 1] + n * q[:, 2])

    def owners(self, coords: IntArray) -> IntArray:
        """The rank that owns the voxels at ``coords`` (k, 3) and the face unknowns on them."""
        return self._rank(self._blocks_of(coords)[0])

    def cells(self, coords: IntArray) -> IntArray:
        """Global rows of the voxels at ``coords`` (k, 3)."""
        q, lo, size = self._blocks_of(coords)
        local = coords - lo
        return self.starts[self._rank(q)] + local[:, 0] + size[:, 0] * (local[:, 1] + size[:, 1] * local[:, 2])

    def face_unknowns(self, face: str, coords: IntArray) -> IntArray:
        """Global rows of the face unknowns of ``face`` on the voxels at ``coords`` (k, 3)."""
        q, lo, size = self._blocks_of(coords)
        rank = self._rank(q)
        volume = size.prod(axis=1)
        before = np.zeros(len(coords), dtype=np.int64)
        for f in self.faces[: self.faces.index(face)]:
            a = AXES.index(f[0])
            side = 0 if f[1] == "0" else self.layout.grid[a] - 1
            area = np.prod(np.delete(size, a, axis=1), axis=1)
            before += np.where(q[:, a] == side, area, 0)
        a = AXES.index(face[0])
        b, c = (x for x in range(3) if x != a)
        local = coords - lo
        return self.starts[rank] + volume + before + local[:, b] + size[:, b] * local[:, c]


def padded_system(problem: VoxelProblem, layout: BoxLayout) -> tuple[ThermalSystem, VolumeGrid, Box, np.ndarray]:
    """The serial finite-volume system of this rank's padded box (:meth:`VoxelProblem.part`: coupled with moisture,
    its fields one block after the other), the grid that numbers the unknowns of each field, the box and its
    labels."""
    box = halo_box(layout)
    labels = problem.image.read(box)
    touched = layout.faces(box)
    system = problem.part(labels, touched)
    boundary = tuple(f for f in problem.boundary if f.face in touched)
    outputs = tuple(o for o in problem.observed if o in touched)
    grid = volume_grid(labels, problem.voxel_size, problem.phases, boundary, outputs, steady=problem.time is None)
    if grid.n * problem.fields != system.n:
        raise RuntimeError(f"padded box: {grid.n} unknowns per field numbered, the assembler made {system.n}")
    return system, grid, box, labels


def global_rows(grid: VolumeGrid, box: Box, numbering: VolumeRows) -> tuple[IntArray, npt.NDArray[np.bool_]]:
    """The global row of every unknown of the padded box's ``grid`` and whether this rank owns it."""
    offset = np.array([lo for lo, _ in box], dtype=np.int64)
    coords = np.argwhere(grid.phase >= 0).astype(np.int64) + offset  # C order: the grid's cell numbering
    rows = np.empty(grid.n, dtype=np.int64)
    owner = np.empty(grid.n, dtype=np.int64)
    rows[: grid.cells] = numbering.cells(coords)
    owner[: grid.cells] = numbering.owners(coords)
    for face in grid.faces:
        dofs = grid.face_dofs(face)
        cells = coords[grid.face_cells(face)]
        rows[dofs] = numbering.face_unknowns(face, cells)
        owner[dofs] = numbering.owners(cells)
    return rows, owner == numbering.layout.rank


def template(problem: VoxelProblem, padded: ThermalSystem, comm: Any) -> ThermalSystem:
    """The whole image's term list (module docstring): the stand-in's terms, with the interface terms of every phase
    pair that touches in some rank's padded box (collective)."""
    base = problem.template()
    found = {t.name: t.coefficient for t in padded.conductance.terms if "|" in t.name}
    union: dict[str, Any] = {}
    for part in runtime.mpi(comm).allgather(found):
        union.update(part)
    zero = sp.csr_array((base.n, base.n))
    own = [t for t in base.conductance.terms if "|" not in t.name]
    phases = [t for t in own if t.role == "conduction"]
    interfaces = [Term(name, union[name], zero, "conduction") for name in sorted(union)]
    conductance = Affine((*phases, *interfaces, *(t for t in own if t.role != "conduction")))
    return replace(base, conductance=conductance)


def assemble_volume_boxes(problem: VoxelProblem, comm: Any) -> Any:
    """Assemble ``problem`` in finite volumes by boxes (collective: every rank calls it); a
    :class:`~aromm.engines.petsc.assembly.DistributedSystem` without a node grid (the multigrid of the Krylov
    engine then falls back to GAMG)."""
    from aromm.engines.petsc.assembly import (
        DistributedSystem,
        DistributedTerm,
        field_outputs,
        interlacing,
        permuted,
        problem_key,
    )

    problem.refuse_insulating()
    layout = problem.layout(comm)
    count = problem.fields
    numbering = VolumeRows(layout, unknown_faces(problem.boundary, problem.observed))
    rows = numbering.rows.interlaced(count)
    padded, grid, box, padded_labels = padded_system(problem, layout)
    cells, mine = global_rows(grid, box, numbering)
    local = np.flatnonzero(mine)[np.argsort(cells[mine], kind="stable")]  # this rank's unknowns of one field
    where = (cells[:, None] * count + np.arange(count)).ravel()  # interlaced rows of the padded box's unknowns
    order = (local[:, None] * count + np.arange(count)).ravel()
    if not np.array_equal(where[order], np.arange(rows.lo, rows.hi)):
        raise RuntimeError("finite-volume rows: this rank's unknowns are not its row block")
    whole = template(problem, padded, comm)
    fields = interlacing(count, grid.n)

    def owned(op: Any, vector: bool) -> Any:
        op = permuted(op, fields)
        if vector:
            return convert.vector(np.asarray(op, dtype=float)[order], rows, comm)
        block = sp.csr_array(op)[order]
        block = sp.csr_array((block.data, where[block.indices], block.indptr), shape=(rows.local, rows.n))
        return convert.matrix(block, rows, comm, count)

    ops = {t.name: t.operator for g in (padded.capacity, padded.conductance, padded.load, padded.initial)
           for t in g.terms}

    def terms(group: Affine, vector: bool) -> tuple[DistributedTerm, ...]:
        empty = np.zeros(padded.n) if vector else sp.csr_array((padded.n, padded.n))
        return tuple(DistributedTerm(t.name, t.coefficient, owned(ops.get(t.name, empty), vector), t.role)
                     for t in group.terms)

    means = {}
    for face in problem.observed:  # e_f = B_f 1 / |f|, |f| summed over the ranks
        weights = np.zeros(grid.n)
        if face in grid.faces:
            weights = np.asarray(grid.face_mass(face) @ np.ones(grid.n))
        means[face] = weights[local] / runtime.allsum([weights[local].sum()], comm)[0]
    observation = field_outputs(whole, means, rows, comm)
    position = np.argsort(fields) if fields is not None else np.arange(padded.n)  # interlaced place of each unknown
    fixed = {d.name: position[d.dofs] for d in padded.dirichlet}
    dirichlet = {d.name: np.sort(where[np.intersect1d(fixed.get(d.name, np.zeros(0, np.int64)), order)])
                 for d in whole.dirichlet}
    m_, n_, p_ = layout.grid
    own = tuple(slice(lo - plo, hi - plo) for (lo, hi), (plo, _) in zip(layout.box, box, strict=True))
    labels = padded_labels[own]  # this rank's box, for the key
    return DistributedSystem(
        whole, rows, comm,
        capacity=terms(whole.capacity, False), conductance=terms(whole.conductance, False),
        load=terms(whole.load, True), dirichlet=dirichlet, observation=observation,
        boundary=owned(padded.boundary, False), fingerprint=problem_key(problem, labels, layout, comm),
        description=f"{problem.where}{problem.shape[0]}×{problem.shape[1]}×{problem.shape[2]} voxels in finite "
                    f"volumes, {m_}×{n_}×{p_} boxes" + (f", {count} unknowns per cell" if count > 1 else ""),
        initial=terms(whole.initial, True))
