"""Matrix-free terms of the voxel model: one phase's conduction or capacity, or one face's convection mass.

[Chavez2020, eq. 2–3] writes the voxel model as ``(Σ c_i C_i) dT/dt = −(Σ k_i K_i + Σ h_f H_f) T + U``.  Each
``K_i``, ``C_i`` (a phase's Q1 conduction or capacity on a box grid) and ``H_f`` (a face's Q1 mass) is held here
as a :class:`VoxelTerm`: the grid's per-voxel phase index and the term's name, applied by the Haar form of
:class:`~aromm.linalg.multigrid.operator.VoxelOperator` (a phase's weights one, the others zero) — about 1 byte
per voxel instead of ≈ 330 bytes per node of an assembled 27-point matrix.  :func:`shifted_operator` sums a
family of them with weights into one ``VoxelOperator`` (``K(μ) + s C(μ) + H(μ)``), whose multigrid hierarchy is
built from per-phase class values (:mod:`aromm.linalg.multigrid.hierarchy`) without any fine-level matrix.

A term restricted to the free unknowns of a lifted system (fixed temperatures on whole faces,
:mod:`aromm.reduction.lifting`) is ``P_fᵀ A P_f``: a vector is embedded with zeros on the fixed faces, multiplied
and read back on the free nodes.  :meth:`VoxelTerm.tocsr` assembles the same matrix (the fem assembler's
scatter, tested equal), for small systems and for code that needs a matrix.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.anisotropy import PhaseTensor
from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.fem.voxel_grid import VoxelGrid
from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.pcg import MultigridSolver

KINDS = ("conduction", "capacity", "exchange")
FACES = ("x0", "x1", "y0", "y1", "z0", "z1")
#: Columns of a block applied in one pass of a matrix-free product (they share the gathered weights of each
#: slab; the pass holds two grid arrays of this many columns: 0.5 GB each at 256³).
GROUP = 4


@dataclass(frozen=True, eq=False)
class VoxelTerm:
    """One term of a voxel model, matrix-free: ``kind`` conduction (of ``phase``, along ``axis`` or isotropic),
    capacity (of ``phase``) or exchange (the mass of ``face``), on the grid nodes not on the ``fixed`` faces."""

    grid: VoxelGrid
    kind: str
    phase: int = -1
    axis: str | None = None
    face: str = ""
    fixed: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"voxel term kind {self.kind!r}; allowed: {', '.join(KINDS)}")

    @functools.cached_property
    def free(self) -> npt.NDArray[np.intp]:
        """Grid nodes of the unknowns (all but the fixed faces' nodes), ascending."""
        return free_nodes(self.grid, self.fixed)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.free.size, self.free.size)

    @property
    def ndim(self) -> int:
        return 2

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(float)

    @functools.cached_property
    def operator(self) -> VoxelOperator:
        """The grid operator of this term alone (applied unconstrained; its per-voxel weights are not kept: a system
        holds many terms)."""
        return shifted_operator([self], [1.0], keep_weights=False)

    def __matmul__(self, x: FloatArray) -> FloatArray:
        """``A x`` for a vector (n,) or a block (n, m) on the unknowns."""
        x = np.asarray(x, dtype=float)
        if self.kind == "exchange":
            return np.asarray(self.grid.face_mass(self.face) @ self._embed(x))[self.free]
        return grouped_product(self.operator, self.free, self.grid.n, x)

    def _embed(self, x: FloatArray) -> FloatArray:
        if not self.fixed:
            return x
        full = np.zeros((self.grid.n, *x.shape[1:]))
        full[self.free] = x
        return full

    def diagonal(self) -> FloatArray:
        return self.operator.diagonal()[self.free]

    def abs_max(self) -> float:
        """Largest entry in magnitude (the largest diagonal entry: the term is symmetric positive semi-definite)."""
        return float(self.diagonal().max(initial=0.0))

    def tocsr(self) -> sp.csr_array:
        """The assembled matrix (small systems, fallbacks): the fem assembler's, restricted to the unknowns."""
        if self.kind == "conduction":
            full = self.grid.conduction(self.phase, self.axis)
        elif self.kind == "capacity":
            full = self.grid.mass(self.phase)
        else:
            full = self.grid.face_mass(self.face)
        return full if not self.fixed else sp.csr_array(full[self.free][:, self.free])

    def restricted(self, free: npt.NDArray[np.integer]) -> VoxelTerm | None:
        """The term on the unknowns ``free`` (indices into this term's unknowns), or None when the nodes left out
        are not exactly whole faces."""
        nodes = self.free[np.asarray(free)]
        keep = np.zeros(self.grid.n, dtype=bool)
        keep[nodes] = True
        faces = tuple(f for f in FACES if not keep[self.grid.face_dofs(f)].any())
        candidate = free_nodes(self.grid, faces)
        if candidate.size != nodes.size or not np.array_equal(candidate, np.sort(nodes)):
            return None
        if not np.array_equal(nodes, candidate):  # a permutation of the unknowns: not this layout
            return None
        return VoxelTerm(self.grid, self.kind, self.phase, self.axis, self.face, faces)

    @property
    def plane_nodes(self) -> int:
        """Nodes of one z-plane of the grid (row blocks of whole planes cost least: :meth:`row_block`)."""
        nx, ny, _ = self.grid.shape
        return (nx + 1) * (ny + 1)

    def row_block(self, start: int, stop: int, block: FloatArray, work: FloatArray | None = None) -> FloatArray:
        """Rows ``start:stop`` of ``A @ block`` (block (n, m) on the unknowns), from the z-slab of elements that
        touch those rows' nodes: memory of the slab, not of the grid.  ``work`` (float64, at least
        :meth:`slab_size` × m entries) holds the slab's product, reused from call to call (a fresh 150 MB array per
        slab at 256³ is a fresh mapping faulted in page by page); the rows returned are then a view of it."""
        nx, ny, nz = self.grid.shape
        plane = (nx + 1) * (ny + 1)
        nodes = self.free[start:stop]
        p0, p1 = int(nodes[0]) // plane, int(nodes[-1]) // plane + 1  # node planes of the rows
        e0, e1 = max(p0 - 1, 0), min(p1, nz)  # element layers touching them
        lo, hi = e0 * plane, (e1 + 1) * plane  # node range of those elements
        whole = self.free.size == self.grid.n  # every node unknown: the slab's rows are a slice of the block
        if whole:
            sub = block[lo:hi]
        else:
            first, last = np.searchsorted(self.free, [lo, hi])
            sub = np.zeros((hi - lo, block.shape[1]))
            sub[self.free[first:last] - lo] = block[first:last]
        if self.kind == "exchange":
            rows = sp.csr_array(self.grid.face_mass(self.face)[nodes])
            return np.asarray(rows[:, lo:hi] @ sub)
        op = self.operator
        local = VoxelOperator(op.phase[e0:e1], op.conductivity, op.voxel_size, capacity=op.capacity,
                              keep_weights=False)
        m = block.shape[1]
        out = None if work is None or work.size < (hi - lo) * m else work[:(hi - lo) * m].reshape(m, hi - lo).T
        product = np.asarray(local.matvec(sub, constrained=False, out=out))
        return product[start - lo:stop - lo] if whole else product[nodes - lo]

    def slab_size(self, rows: int) -> int:
        """Nodes of the slab :meth:`row_block` multiplies for ``rows`` consecutive unknowns at most: the node planes
        they span (each plane holds at least the unknowns of a plane not on a fixed z-face), and two more."""
        nx, ny, _ = self.grid.shape
        per_plane = (nx + 1 - sum(f in self.fixed for f in ("x0", "x1"))) * (
            ny + 1 - sum(f in self.fixed for f in ("y0", "y1")))
        return (-(-rows // per_plane) + 3) * self.plane_nodes

    def content_parts(self) -> tuple[object, ...]:
        """What identifies the term, for content hashes (aromm.core.cache)."""
        return ("voxel-term", self.kind, self.phase, self.axis, self.face, self.fixed, self.grid.shape,
                self.grid.voxel_size, self.grid.phase)


def free_nodes(grid: VoxelGrid, fixed: Sequence[str]) -> npt.NDArray[np.intp]:
    if not fixed:
        return grid.all_nodes
    keep = np.ones(grid.n, dtype=bool)
    for face in fixed:
        keep[grid.face_dofs(face)] = False
    return np.flatnonzero(keep)


def is_voxel_family(operators: Sequence[object]) -> bool:
    """True when every operator is a :class:`VoxelTerm` of one grid with the same fixed faces."""
    terms = [op for op in operators if isinstance(op, VoxelTerm)]
    return bool(terms) and len(terms) == len(operators) and all(
        t.grid is terms[0].grid and t.fixed == terms[0].fixed for t in terms)


def as_voxel_terms(operators: Sequence[object]) -> list[VoxelTerm]:
    """The operators as voxel terms of one family (:func:`is_voxel_family`), else InputError."""
    if not is_voxel_family(operators):
        raise InputError("matrix-free voxel terms of one grid with the same fixed faces expected")
    return [op for op in operators if isinstance(op, VoxelTerm)]


def shifted_operator(terms: Sequence[VoxelTerm], weights: Sequence[float], keep_weights: bool = True) -> VoxelOperator:
    """``Σ_i w_i A_i`` of voxel terms on one grid as one matrix-free operator with the terms' fixed faces held at
    zero (identity rows): per-phase conductivities, capacities and convection coefficients summed;
    ``keep_weights`` as :class:`~aromm.linalg.multigrid.operator.VoxelOperator`'s."""
    if not is_voxel_family(terms):
        raise InputError("a shifted voxel operator needs voxel terms of one grid with the same fixed faces")
    grid, fixed = terms[0].grid, terms[0].fixed
    n_phases = int(grid.phase.max()) + 1
    table = np.zeros((n_phases, 3))
    capacity = np.zeros(n_phases)
    exchange: dict[str, float] = {}
    for t, w in zip(terms, weights, strict=True):
        if t.kind == "conduction":
            table[t.phase, slice(None) if t.axis is None else "xyz".index(t.axis)] += w
        elif t.kind == "capacity":
            capacity[t.phase] += w
        else:
            exchange[t.face] = exchange.get(t.face, 0.0) + float(w)
    has_capacity = any(t.kind == "capacity" for t in terms)
    return VoxelOperator(grid.voxel_phase, table, grid.voxel_size, fixed=fixed,
                         capacity=capacity if has_capacity else None,
                         exchange=tuple((f, h) for f, h in exchange.items() if h != 0.0), keep_weights=keep_weights)


class MatrixFreeGrid:
    """The discretisation of :func:`aromm.fem.voxel.assemble_voxels` with matrix-free terms (aromm.core.vocabulary's
    ``Discretisation``): conduction, capacity and face masses as :class:`VoxelTerm`; an anisotropic tensor phase's
    matrices stay assembled.  The terms are typed as the protocol's sparse matrices (they act like them)."""

    def __init__(self, grid: VoxelGrid) -> None:
        self.grid = grid
        self.n = grid.n

    def conduction(self, phase: int, axis: str | None) -> sp.csr_array:
        return cast(sp.csr_array, VoxelTerm(self.grid, "conduction", phase, axis))

    def mass(self, phase: int) -> sp.csr_array:
        return cast(sp.csr_array, VoxelTerm(self.grid, "capacity", phase))

    def tensor_conduction(self, phase: int, spec: PhaseTensor) -> list[sp.csr_array]:
        return self.grid.tensor_conduction(phase, spec)

    def face_mass(self, face: str) -> sp.csr_array:
        return cast(sp.csr_array, VoxelTerm(self.grid, "exchange", face=face))

    def face_dofs(self, face: str) -> npt.NDArray[np.int64]:
        return self.grid.face_dofs(face)


def harmonic_extension(terms: Sequence[VoxelTerm], weights: Sequence[float], boundary: FloatArray,
                       free: npt.NDArray[np.intp], rtol: float = 1e-10) -> FloatArray:
    """``ℓ`` with ``ℓ = boundary`` off ``free`` and ``(Σ w_i A_i ℓ)_free = 0``: the steady lifting of fixed
    temperatures on whole faces, by matrix-free multigrid-preconditioned CG (relative residual ``rtol``) on the
    grid with the fixed faces held."""
    grid = terms[0].grid
    fixed = tuple(f for f in FACES if not np.isin(grid.face_dofs(f), free).any())
    if not np.array_equal(free_nodes(grid, fixed), np.sort(free)):
        raise InputError("matrix-free lifting: the fixed temperatures must hold whole faces of the box")
    op = shifted_operator([VoxelTerm(t.grid, t.kind, t.phase, t.axis, t.face, fixed) for t in terms], weights)
    held = np.ones(grid.n, dtype=bool)
    held[free] = False
    rhs = -op.matvec(np.where(held, boundary, 0.0), constrained=False)
    rhs[held] = 0.0
    out = MultigridSolver(op, rtol=rtol).solve(rhs)
    out[held] = boundary[held]
    return out


def weighted_product(terms: Sequence[VoxelTerm], weights: Sequence[float], block: FloatArray) -> FloatArray:
    """``Σ_i w_i A_i X`` for voxel terms of one family in one matrix-free pass per :data:`GROUP` columns (no summed
    matrix)."""
    return grouped_product(shifted_operator(terms, weights), terms[0].free, terms[0].grid.n,
                           np.asarray(block, dtype=float))


def grouped_product(op: VoxelOperator, free: npt.NDArray[np.integer], n: int, x: FloatArray) -> FloatArray:
    """``A x`` on the unknowns ``free`` of a grid of ``n`` nodes, for a vector or a block: :data:`GROUP` columns
    a pass (they share each slab's gathered weights; a pass holds two (n, GROUP) node arrays).  Without fixed faces
    the unknowns are all the nodes in order and no embedding copy is made."""
    whole = free.size == n

    def apply(columns: FloatArray) -> FloatArray:  # (k, m) rows of unknowns → (m, k)
        full = columns if whole else np.zeros((columns.shape[0], n))
        if not whole:
            full[:, free] = columns
        product = np.asarray(op.matvec(full.T, constrained=False))  # a transposed view: matvec's columns as they are
        return product if whole else product[free]

    if x.ndim == 1:
        return apply(x[None, :])[:, 0]
    out = np.empty((free.size, x.shape[1]))
    for j in range(0, x.shape[1], GROUP):
        cols = slice(j, min(j + GROUP, x.shape[1]))
        out[:, cols] = apply(x[:, cols].T)
    return out
