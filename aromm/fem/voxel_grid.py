"""The Q1 voxel grid: one trilinear hexahedron per voxel, its reference element matrices, node numbering,
connectivity and face masses, and :class:`VoxelGrid` (the ``Discretisation`` of :mod:`aromm.core.vocabulary`).

Nodes are numbered ``i + (nx+1) * (j + (ny+1) * k)`` (x fastest) for the node at ``(i dx, j dy, k dz)``; faces are
named ``x0`` (plane x = 0), ``x1`` (x = L_x), and likewise for y and z.  :mod:`aromm.fem.voxel` assembles a
:class:`~aromm.core.system.ThermalSystem` on it, :mod:`aromm.fem.voxel_terms` applies its terms matrix-free.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.anisotropy import PhaseTensor, element_units
from aromm.core.system import FloatArray, Geometry

VTK_HEX = [0, 1, 3, 2, 4, 5, 7, 6]  # local corner order a + 2b + 4c -> VTK/meshio hexahedron order


def _mass_1d(h: float) -> FloatArray:
    return h / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])


def _stiff_1d(h: float) -> FloatArray:
    return 1.0 / h * np.array([[1.0, -1.0], [-1.0, 1.0]])


def element_matrices(voxel_size: Sequence[float]) -> dict[str, FloatArray]:
    """Reference Q1 matrices of one box (local node a + 2b + 4c at corner (a, b, c)).

    ``mass`` = int phi_a phi_b, ``kx`` = int d_x phi_a d_x phi_b (likewise ``ky``, ``kz``):
    tensor products of the 1-D linear-element mass h/6 [[2,1],[1,2]] and stiffness 1/h [[1,-1],[-1,1]].
    """
    dx, dy, dz = voxel_size
    mx, my, mz = _mass_1d(dx), _mass_1d(dy), _mass_1d(dz)
    sx, sy, sz = _stiff_1d(dx), _stiff_1d(dy), _stiff_1d(dz)
    return {
        "mass": np.kron(mz, np.kron(my, mx)),
        "kx": np.kron(mz, np.kron(my, sx)),
        "ky": np.kron(mz, np.kron(sy, mx)),
        "kz": np.kron(sz, np.kron(my, mx)),
    }


def gradient_products(voxel_size: Sequence[float]) -> FloatArray:
    """(3, 3, 8, 8) reference matrices ``∫ ∂_i φ_a ∂_j φ_b`` of one box, so that an element of conductivity tensor
    A has the matrix ``Σ_ij A_ij M[i, j]``.  Tensor products of 1-D factors: the mass, the stiffness (i = j) and
    ``G = ∫ φ_a' φ_b = [[-1/2, -1/2], [1/2, 1/2]]`` (its transpose on the j side); ``M[i, i]`` are the
    ``kx``, ``ky``, ``kz`` of :func:`element_matrices`.
    """
    g = np.array([[-0.5, -0.5], [0.5, 0.5]])
    out = np.empty((3, 3, 8, 8))
    for i in range(3):
        for j in range(3):
            factors = []
            for axis, h in enumerate(voxel_size):
                if axis == i == j:
                    factors.append(_stiff_1d(h))
                elif axis == i:
                    factors.append(g)
                elif axis == j:
                    factors.append(g.T)
                else:
                    factors.append(_mass_1d(h))
            out[i, j] = np.kron(factors[2], np.kron(factors[1], factors[0]))
    return out


def node_index(shape: tuple[int, int, int], i: npt.ArrayLike, j: npt.ArrayLike, k: npt.ArrayLike) -> np.ndarray:
    nx, ny, _ = shape
    return np.asarray(i) + (nx + 1) * (np.asarray(j) + (ny + 1) * np.asarray(k))


def connectivity(shape: tuple[int, int, int], voxels: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Corner nodes (n_voxels, 8) of voxels given by flat C-order indices into ``shape``."""
    i, j, k = np.unravel_index(voxels, shape)
    corners = [node_index(shape, i + a, j + b, k + c) for c in (0, 1) for b in (0, 1) for a in (0, 1)]
    return np.stack(corners, axis=1).astype(np.int64)


def scatter(conn: npt.NDArray[np.int64], local: npt.NDArray[np.floating], n: int) -> sp.csr_array:
    """Global matrix = sum over elements of the local matrix (one for all, or one per element (n_el, m, m))
    placed at ``conn`` rows/cols."""
    m = conn.shape[1]
    rows = np.repeat(conn, m, axis=1).ravel()
    cols = np.tile(conn, (1, m)).ravel()
    data = np.tile(local.ravel(), conn.shape[0]) if local.ndim == 2 else local.ravel()
    out = sp.csr_array(sp.coo_array((data, (rows, cols)), shape=(n, n)))
    out.sum_duplicates()
    return out


def tensor_conduction(conn: npt.NDArray[np.int64], voxel_size: Sequence[float], unit: FloatArray,
                      n: int) -> sp.csr_array:
    """``∫ ∇φ_a · A ∇φ_b`` over the elements ``conn`` for a tensor A (3, 3) or one per element (n_el, 3, 3)."""
    ref = gradient_products(voxel_size)
    if unit.ndim == 2:
        return scatter(conn, np.einsum("ij,ijab->ab", unit, ref), n)
    return scatter(conn, np.einsum("eij,ijab->eab", unit, ref), n)


def face_nodes_and_quads(shape: tuple[int, int, int], face: str) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Quads of a face as (n_quads, 4) node indices, local order (a + 2b) over its two in-plane axes."""
    axis = "xyz".index(face[0])
    side = shape[axis] if face[1] == "1" else 0
    inplane = [ax for ax in range(3) if ax != axis]
    n1, n2 = shape[inplane[0]], shape[inplane[1]]
    uu, vv = np.meshgrid(np.arange(n1), np.arange(n2), indexing="ij")
    u, v = uu.ravel(), vv.ravel()
    quads = []
    for b in (0, 1):
        for a in (0, 1):
            ijk: list[np.ndarray] = [np.empty(0)] * 3
            ijk[axis] = np.full(u.shape, side)
            ijk[inplane[0]] = u + a
            ijk[inplane[1]] = v + b
            quads.append(node_index(shape, *ijk))
    q = np.stack(quads, axis=1).astype(np.int64)
    return np.unique(q), q, (inplane[0], inplane[1])


def face_mass(shape: tuple[int, int, int], voxel_size: Sequence[float], face: str) -> sp.csr_array:
    """Boundary mass ``B_f = int_face phi_a phi_b`` (m^2), zero away from the face."""
    _, quads, (p, q) = face_nodes_and_quads(shape, face)
    local = np.kron(_mass_1d(voxel_size[q]), _mass_1d(voxel_size[p]))
    return scatter(quads, local, int(np.prod(np.asarray(shape) + 1)))


def node_points(shape: tuple[int, int, int], voxel_size: Sequence[float]) -> FloatArray:
    nx, ny, nz = shape
    x, y, z = (np.arange(n + 1) * h for n, h in zip((nx, ny, nz), voxel_size, strict=True))
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    return np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])


@dataclass(frozen=True, eq=False)
class VoxelGrid:
    """The Q1 discretisation of a voxel image (aromm.core.vocabulary.Discretisation): one box element per voxel.

    ``phase[v]`` is the index of voxel v's phase (C order over ``shape``).  Face masses are built once.
    """

    shape: tuple[int, int, int]
    voxel_size: tuple[float, float, float]
    phase: npt.NDArray[np.int64]
    _faces: dict[str, sp.csr_array] = field(default_factory=dict, init=False, repr=False)

    @property
    def n(self) -> int:
        return int(np.prod(np.asarray(self.shape) + 1))

    @functools.cached_property
    def _reference(self) -> dict[str, FloatArray]:
        return element_matrices(self.voxel_size)

    @functools.cached_property
    def all_nodes(self) -> npt.NDArray[np.intp]:
        """``arange(n)``, shared by the matrix-free terms of a grid without fixed faces."""
        return np.arange(self.n)

    @functools.cached_property
    def voxel_phase(self) -> npt.NDArray[np.integer]:
        """Phase index per voxel as a (nz, ny, nx) array (the layout of aromm.linalg.multigrid), smallest dtype."""
        nx, ny, nz = self.shape
        dtype = np.min_scalar_type(max(int(self.phase.max()), 0))
        return np.ascontiguousarray(self.phase.reshape(nx, ny, nz).transpose(2, 1, 0).astype(dtype))

    def _connectivity(self, phase: int) -> npt.NDArray[np.int64]:
        return connectivity(self.shape, np.flatnonzero(self.phase == phase))

    def conduction(self, phase: int, axis: str | None) -> sp.csr_array:
        ref = self._reference
        local = ref["kx"] + ref["ky"] + ref["kz"] if axis is None else ref[f"k{axis}"]
        return scatter(self._connectivity(phase), local, self.n)

    def mass(self, phase: int) -> sp.csr_array:
        return scatter(self._connectivity(phase), self._reference["mass"], self.n)

    def tensor_conduction(self, phase: int, spec: PhaseTensor) -> list[sp.csr_array]:
        mask = (self.phase == phase).reshape(self.shape)
        conn = self._connectivity(phase)
        return [tensor_conduction(conn, self.voxel_size, unit, self.n) for unit in element_units(spec, mask)]

    def face_mass(self, face: str) -> sp.csr_array:
        if face not in self._faces:
            self._faces[face] = face_mass(self.shape, self.voxel_size, face)
        return self._faces[face]

    def face_dofs(self, face: str) -> npt.NDArray[np.int64]:
        return face_nodes_and_quads(self.shape, face)[0]

    def geometry(self, labels: npt.NDArray[np.integer]) -> Geometry:
        return GridGeometry(self.shape, tuple(self.voxel_size), np.asarray(labels).ravel(order="C"))


class GridGeometry(Geometry):
    """The :class:`~aromm.core.system.Geometry` of a voxel grid whose points and hexahedra are formed when read.

    Held, they are 88 bytes per voxel (1.5 GB at 256³) for the whole life of a system that reads them only to
    export a field.

    >>> g = GridGeometry((2, 1, 1), (1e-3, 1e-3, 1e-3), np.array([0, 1]))
    >>> g.points.shape, g.cells.shape, g.cell_type, g.nodes
    ((12, 3), (2, 8), 'hexahedron', 12)
    """

    shape: tuple[int, int, int]
    voxel_size: tuple[float, ...]

    def __init__(self, shape: tuple[int, int, int], voxel_size: tuple[float, ...],
                 labels: npt.NDArray[np.integer]) -> None:  # the frozen parent's fields, set as its __init__ would
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "voxel_size", voxel_size)
        object.__setattr__(self, "cell_type", "hexahedron")
        object.__setattr__(self, "cell_data", {"label": labels})

    @property
    def nodes(self) -> int:
        return int(np.prod(np.asarray(self.shape) + 1))

    @property  # type: ignore[override]
    def points(self) -> FloatArray:
        return node_points(self.shape, self.voxel_size)

    @property  # type: ignore[override]
    def cells(self) -> npt.NDArray[np.int64]:
        return connectivity(self.shape, np.arange(int(np.prod(self.shape))))[:, VTK_HEX]
