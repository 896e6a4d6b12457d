"""Galerkin coarse grids of the voxel Q1 operator, element by element, and their 27-point coefficient arrays.

Coarsening halves the element count along every axis: coarse element J covers fine elements 2J and 2J + 1
(only 2J at the end of an odd axis), and the prolongation P is trilinear interpolation in index space.  The
Galerkin operator Pᵀ A P is a sum over coarse elements of Σ_children P_cᵀ A_child P_c, with P_c the 8×8
interpolation from the coarse element's corners to the child's, a Kronecker product of 1-D 2×2 matrices
([[1, 0], [½, ½]] for a first child, [[½, ½], [0, 1]] for a second, the identity for a lone child).  Each
element matrix is held as 27 "class values": a symmetric 8×8 matrix that is a sum of Kronecker products of
symmetric 2×2 factors is fixed by its values on the node-pair classes {00, 01, 11} of each axis, and
P_cᵀ B P_c maps that class basis to itself by one 3×3 matrix per axis and child.  So the coarse operator is
built from the image's conductivities in slabs, without ever assembling the fine matrix; [Trottenberg2001,
§ 3.4] (Galerkin coarse-grid operator, trilinear transfer).

Homogeneous Dirichlet faces are kept on every level (their local node classes are zeroed, the rows
become the identity); periodic grids coarsen with the wrap-around.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.linalg.multigrid.coarse_stencil import DIAGONAL, StencilMatrix
from aromm.linalg.multigrid.operator import VoxelOperator, fold_ghosts

# class basis of symmetric 2×2 matrices: B00 = [[1,0],[0,0]], B01 = [[0,1],[1,0]], B11 = [[0,0],[0,1]]
_BASIS = np.array([[[1.0, 0.0], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]]])
_CHILD_P = {"first": np.array([[1.0, 0.0], [0.5, 0.5]]), "second": np.array([[0.5, 0.5], [0.0, 1.0]]),
            "alone": np.eye(2)}


def _class_map(p: FloatArray) -> FloatArray:
    """m[a, a'] with Pᵀ B_a P = Σ_a' m[a, a'] B_a'."""
    out = np.empty((3, 3))
    for a in range(3):
        m = p.T @ _BASIS[a] @ p
        out[a] = (m[0, 0], m[0, 1], m[1, 1])
    return out


_MAPS = {kind: _class_map(p) for kind, p in _CHILD_P.items()}


def prolongation_1d(n: int, periodic: bool) -> sp.csr_array:
    """Linear interpolation from the coarse nodes (every other fine node, plus the end of an odd box axis)."""
    nc = (n + 1) // 2
    fine = n if periodic else n + 1
    coarse = nc if periodic else nc + 1
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    for f in range(fine):
        if f % 2 == 0 or (not periodic and f == n):
            rows.append(f)
            cols.append(f // 2 if f % 2 == 0 else nc)
            vals.append(1.0)
        else:
            rows += [f, f]
            cols += [f // 2, (f // 2 + 1) % coarse]
            vals += [0.5, 0.5]
    return sp.csr_array((vals, (rows, cols)), shape=(fine, coarse))


@dataclass(frozen=True, eq=False)
class ElementLevel:
    """One grid level: class values (3, 3, 3, nz, ny, nx) (classes along z, y, x) and its boundary."""

    values: FloatArray
    periodic: bool
    fixed: tuple[str, ...]

    @classmethod
    def fine(cls, op: VoxelOperator) -> ElementLevel:
        """The fine level of ``op`` (27 values per voxel: for small grids, direct solvers and tests)."""
        values = fine_values(op, (0, op.elements[0]), (0, op.elements[1]), (0, op.elements[2]))
        mask_fixed(values, op.fixed, (0, 0, 0), op.elements)
        return cls(np.ascontiguousarray(values), op.periodic, op.fixed)

    @classmethod
    def coarse_of(cls, op: VoxelOperator) -> ElementLevel:
        """Pᵀ A P of the matrix-free operator (peak memory: the coarse level).

        With few phases (``len(phases)⁸ ≤ LOOKUP_CODES``) a coarse element with eight children and no fixed
        face is one of ``len(phases)⁸`` cases: its 27 values are looked up by the code of its children's
        phases, and only the elements at fixed faces or at the lone end of an odd axis are coarsened.
        """
        def source(k0: int, k1: int) -> FloatArray:
            return fine_values(op, (k0, k1), (0, op.elements[1]), (0, op.elements[2]))

        if len(op.class_values) ** 8 > LOOKUP_CODES:
            return cls(coarsen(op.elements, source, op.fixed), op.periodic, op.fixed)
        return cls(_coarse_by_codes(op), op.periodic, op.fixed)

    @property
    def elements(self) -> tuple[int, int, int]:
        nz, ny, nx = self.values.shape[3:]
        return (nz, ny, nx)

    @property
    def node_shape(self) -> tuple[int, int, int]:
        nz, ny, nx = self.elements
        return (nz, ny, nx) if self.periodic else (nz + 1, ny + 1, nx + 1)

    def coarse(self) -> ElementLevel:
        def source(k0: int, k1: int) -> FloatArray:
            return self.values[:, :, :, k0:k1]

        return ElementLevel(coarsen(self.elements, source, self.fixed), self.periodic, self.fixed)

    def stencil(self, dtype: type = np.float64) -> FloatArray:
        """The assembled operator as 27 coefficient arrays on the node grid, in the layout of
        :mod:`aromm.linalg.multigrid.coarse_stencil`, summed in ``dtype``: zeros where a neighbour is missing, identity
        on fixed rows."""
        nz, ny, nx = self.elements
        stencil: FloatArray = np.zeros((27, nz + 1, ny + 1, nx + 1), dtype=dtype)
        for pz, py, px, qz, qy, qx in np.ndindex(2, 2, 2, 2, 2, 2):
            offset = (qz - pz + 1) * 9 + (qy - py + 1) * 3 + (qx - px + 1)
            value = self.values[pz + qz, py + qy, px + qx]  # class index: 00 → 0, 01/10 → 1, 11 → 2
            stencil[offset, pz:pz + nz, py:py + ny, px:px + nx] += value
        if self.periodic:
            fold_ghosts(stencil, (1, 2, 3))
            stencil = np.ascontiguousarray(stencil[:, :-1, :-1, :-1])
        diagonal = stencil[DIAGONAL]
        for face in self.fixed:
            axis = 2 - "xyz".index(face[0])
            diagonal[(slice(None),) * axis + (0 if face[1] == "0" else diagonal.shape[axis] - 1,)] = 1.0
        return stencil

    def to_stencil(self, dtype: type = np.float32) -> StencilMatrix:
        """The assembled operator without column indices (a V-cycle's level: 27 values a node)."""
        return StencilMatrix(self.stencil(dtype), self.periodic)

    def to_csr(self, dtype: type = np.float64) -> sp.csr_array:
        """Assembled operator in CSR with int32 indices while they fit: 27 entries per row (zeros where a neighbour
        is missing), identity on fixed rows."""
        stencil = self.stencil(dtype)
        shape = self.node_shape
        n = int(np.prod(shape))
        index_type = np.int32 if 27 * n < 2**31 else np.int64
        cols = np.empty((*shape, 27), dtype=index_type)
        strides = (shape[1] * shape[2], shape[2], 1)
        for offset, shifts in enumerate(np.ndindex(3, 3, 3)):
            # per axis: the neighbour's index times the axis stride; a missing neighbour (box) is the node itself
            terms = []
            for axis, shift in enumerate(shifts):
                own = np.arange(shape[axis])
                other = own + shift - 1
                other = other % shape[axis] if self.periodic else np.where((other < 0) | (other >= shape[axis]),
                                                                           -1, other)
                terms.append(other)
            missing = (terms[0] < 0)[:, None, None] | (terms[1] < 0)[None, :, None] | (terms[2] < 0)[None, None, :]
            index = ((terms[0] * strides[0])[:, None, None] + (terms[1] * strides[1])[None, :, None]
                     + terms[2][None, None, :]).astype(index_type)
            if missing.any():
                index[missing] = np.arange(n, dtype=index_type).reshape(shape)[missing]
            cols[..., offset] = index
        data = np.array(stencil.reshape(27, n).T, order="C")
        del stencil
        out = sp.csr_array((data.ravel(), cols.ravel(), np.arange(0, 27 * n + 1, 27, dtype=index_type)), shape=(n, n))
        out.sum_duplicates()
        return out


def fine_values(op: VoxelOperator, *ranges: tuple[int, int]) -> FloatArray:
    """Class values (3, 3, 3, block) of the elements in ``ranges`` (z, y, x), convection faces included."""
    block = tuple(slice(a, b) for a, b in ranges)
    values = np.moveaxis(op.class_values[op.phase[block]], (3, 4, 5), (0, 1, 2))
    for face, h in op.exchange:
        axis = "zyx".index(face[0])
        layer = 0 if face[1] == "0" else op.elements[axis] - 1
        if ranges[axis][0] <= layer < ranges[axis][1]:
            target: list[slice | int] = [slice(None)] * 6
            target[3 + axis] = layer - ranges[axis][0]
            values[tuple(target)] += op.exchange_classes(face, h)[:, :, :, None, None]
    return values


def assembled_matrix(op: VoxelOperator) -> sp.csr_array:
    """The constrained operator ``op`` assembled (27-point rows): for direct solvers and tests."""
    return ElementLevel.fine(op).to_csr()


@dataclass(frozen=True, eq=False)
class CoarseLevel:
    """An assembled coarse level: 27-point matrix (coefficient arrays; CSR on the coarsest level, which is factorised),
    node shape and element counts (z, y, x)."""

    matrix: sp.csr_array | StencilMatrix
    node_shape: tuple[int, int, int]
    elements: tuple[int, int, int]
    fixed: tuple[str, ...]

    def with_fixed(self, fixed: tuple[str, ...]) -> CoarseLevel:
        """The same level with the node planes of ``fixed`` held at zero (identity rows and columns).

        Equal to coarsening the constrained operator: the trilinear P maps coarse functions that vanish on a
        face to fine ones that vanish on it (face nodes interpolate from face nodes only), so
        P₀ᵀ A₀ P₀ is Pᵀ A P restricted to the free nodes.  Lets the fixed-temperature problems of the three
        axes share one Galerkin hierarchy.
        """
        mask = fixed_mask(self.node_shape, fixed)
        m = self.matrix
        if isinstance(m, StencilMatrix):
            return CoarseLevel(m.with_fixed(mask), self.node_shape, self.elements, fixed)
        keep = ~mask
        lengths = np.diff(m.indptr)
        data = m.data * (np.repeat(keep, lengths) & keep[m.indices])  # in the matrix's precision
        rows = np.flatnonzero(mask)  # identity on the fixed rows: their stored diagonal entry set to 1
        starts, counts = m.indptr[rows], lengths[rows]
        positions = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))
        positions = positions[m.indices[positions] == np.repeat(rows, counts)]
        data[positions] = 1.0
        matrix = sp.csr_array((data, m.indices, m.indptr), shape=m.shape)  # the index arrays are shared
        return CoarseLevel(matrix, self.node_shape, self.elements, fixed)


def galerkin_levels(op: VoxelOperator, coarsest: int, dtype: type = np.float64) -> list[CoarseLevel]:
    """The assembled coarse levels of ``op``, halving down to at most ``coarsest`` nodes (or 4 elements on an axis);
    all but the coarsest (float64, for its factorisation) stored in ``dtype`` as soon as they are built."""
    out: list[CoarseLevel] = []
    level = ElementLevel.coarse_of(op) if min(op.elements) >= 4 else None
    while level is not None:
        if int(np.prod(level.node_shape)) <= coarsest or min(level.elements) < 4:
            out.append(CoarseLevel(level.to_csr(), level.node_shape, level.elements, level.fixed))
            return out
        out.append(CoarseLevel(level.to_stencil(dtype), level.node_shape, level.elements, level.fixed))
        level = level.coarse()
    return out


def fixed_mask(node_shape: tuple[int, int, int], fixed: tuple[str, ...]) -> npt.NDArray[np.bool_]:
    """Flat mask of the nodes on the ``fixed`` faces ("x0" … "z1") of a box grid of ``node_shape`` (z, y, x)."""
    mask = np.zeros(node_shape, dtype=bool)
    for face in fixed:
        axis = 2 - "xyz".index(face[0])
        mask[(slice(None),) * axis + (0 if face[1] == "0" else node_shape[axis] - 1,)] = True
    return mask.ravel()


def mask_fixed(values: FloatArray, fixed: tuple[str, ...], start: tuple[int, int, int],
               elements: tuple[int, int, int]) -> None:
    """Zero the classes touching fixed node planes in a block of ``elements`` (z, y, x) starting at ``start``."""
    for face in fixed:
        axis = "zyx".index(face[0])  # class axis and element axis (offset by 3)
        first = face[1] == "0"
        classes = (0, 1) if first else (1, 2)
        index = 0 if first else elements[axis] - 1
        if not start[axis] <= index < start[axis] + values.shape[3 + axis]:
            continue
        element = index - start[axis]
        for c in classes:
            sl: list[slice | int] = [slice(None)] * 6
            sl[axis] = c
            sl[3 + axis] = element
            values[tuple(sl)] = 0.0


def coarsen(elements: tuple[int, int, int], source: Callable[[int, int], FloatArray],
            fixed: tuple[str, ...]) -> FloatArray:
    """Galerkin class values of the coarse elements from the fine ones, a slab of coarse z-planes at a time.

    Along each axis the children of one parity share one 3×3 class map, so a stage is two matrix products
    (BLAS) over all elements of that parity plus the lone last child of an odd axis (identity map).
    """
    nz, ny, nx = elements
    ncz, ncy, ncx = ((n + 1) // 2 for n in elements)
    out = np.empty((3, 3, 3, ncz, ncy, ncx))
    step = max(1, COARSEN_SLAB // (27 * 16 * ny * nx))  # coarse planes per slab: the fine slab ≲ COARSEN_SLAB bytes
    for j0 in range(0, ncz, step):
        j1 = min(ncz, j0 + step)
        k0, k1 = 2 * j0, min(nz, 2 * j1)
        out[:, :, :, j0:j1] = _restrict_block(np.array(source(k0, k1), dtype=float), fixed, (k0, 0, 0), elements)
    mask_fixed(out, fixed, (0, 0, 0), (ncz, ncy, ncx))
    return out


def _restrict_block(v: FloatArray, fixed: tuple[str, ...], start: tuple[int, int, int],
                    elements: tuple[int, int, int]) -> FloatArray:
    """Coarse class values of a block of fine ones (``start`` even along every axis), fixed faces masked."""
    mask_fixed(v, fixed, start, elements)
    for class_axis in (2, 1, 0):  # x, y, z
        v = _restrict_axis(v, class_axis)
    return v


LOOKUP_CODES = 3**8  # phase codes of the eight children tabulated (at most three phases: 6561 × 27 values)


def _coarse_by_codes(op: VoxelOperator) -> FloatArray:
    """First coarse level by look-up of the children's phase code (see ElementLevel.coarse_of)."""
    elements = op.elements
    coarse = tuple((n + 1) // 2 for n in elements)
    pz, py, px = (n // 2 for n in elements)
    table = op.class_values
    phases = len(table)
    code = np.zeros((pz, py, px), dtype=np.int32)
    for bit, (cz, cy, cx) in enumerate(np.ndindex(2, 2, 2)):
        code += phases**bit * op.phase[cz:2 * pz:2, cy:2 * py:2, cx:2 * px:2].astype(np.int32)  # uint8 phases
    digits = (np.arange(phases**8)[:, None] // phases ** np.arange(8)) % phases  # (codes, child)
    children = table[digits].reshape(-1, 2, 2, 2, 3, 3, 3)  # (code, cz, cy, cx, classes z, y, x)
    block = np.ascontiguousarray(children.transpose(4, 5, 6, 1, 2, 0, 3)).reshape(3, 3, 3, 2, 2, -1)
    lookup = _restrict_block(block, (), (0, 0, 0), block.shape[3:]).reshape(27, -1)  # type: ignore[arg-type]
    out = np.empty((3, 3, 3, *coarse))
    out[:, :, :, :pz, :py, :px] = lookup[:, code].reshape(3, 3, 3, pz, py, px)
    special = [(axis, coarse[axis] - 1) for axis in range(3) if elements[axis] % 2]  # lone children
    special += [("zyx".index(face[0]), 0 if face[1] == "0" else coarse["zyx".index(face[0])] - 1)
                for face in (*op.fixed, *(f for f, _ in op.exchange))]
    for axis, index in special:  # coarsened from the fine values, fixed faces masked
        fine = [slice(0, n) for n in elements]
        fine[axis] = slice(2 * index, min(elements[axis], 2 * index + 2))
        start = [0, 0, 0]
        start[axis] = 2 * index
        v = fine_values(op, *((s.start, s.stop) for s in fine))
        target = [slice(None)] * 6
        target[3 + axis] = slice(index, index + 1)
        out[tuple(target)] = _restrict_block(v, op.fixed, (start[0], start[1], start[2]), elements)
    mask_fixed(out, op.fixed, (0, 0, 0), coarse)  # type: ignore[arg-type]
    return out


COARSEN_SLAB = 1 << 23  # bytes of fine class values per slab of the coarsening (8 MB)


def _restrict_axis(v: FloatArray, class_axis: int) -> FloatArray:
    """Σ over the two children along one axis of P_cᵀ B P_c in class form (class axis a ↔ element axis a + 3)."""
    axis = class_axis + 3
    n = v.shape[axis]
    pairs = n // 2

    def part(start: int, stop: int, step: int) -> FloatArray:
        return v[(slice(None),) * axis + (slice(start, stop, step),)]

    out = _class_product(part(0, 2 * pairs, 2), _MAPS["first"], class_axis)
    out += _class_product(part(1, 2 * pairs, 2), _MAPS["second"], class_axis)
    if n % 2:
        out = np.concatenate([out, part(n - 1, n, 1)], axis=axis)  # a lone child keeps its values
    return out


def _class_product(v: FloatArray, m: FloatArray, class_axis: int) -> FloatArray:
    """w[…a'…] = Σ_a m[a, a'] v[…a…] along ``class_axis``."""
    return np.moveaxis(np.tensordot(m, v, axes=([0], [class_axis])), 0, class_axis)
