"""Cell-centred finite volumes on a voxel image: the unknowns, the two-point links and their operators.

The discretisation of taufactor [Cooper2016], PuMA [Ferguson2018] and OpenImpala: one temperature per voxel at its
centre; between two face neighbours i, j at distance d across a face of area A the heat flow is
``g (T_i − T_j)`` with the series (harmonic-mean) conductance of the two half cells::

    g = A / (d / (2 k_i) + d / (2 k_j)) = (A / d) · 2 k_i k_j / (k_i + k_j).

A face of the box that carries a condition (fixed temperature, flux, exchange) or an output gets one extra,
massless unknown per voxel face on it: the temperature *at the face*, half a cell from the centre, linked to its
voxel by ``2 k A / d``.  A fixed temperature is then imposed at the face (the convention of those codes), a flux
enters through it, an exchange ``h`` acts on it in series with the half cell, and a face-mean output averages it.

Why this form, and not one interface unknown per mixed-phase face: the affine system of
:mod:`aromm.core.system` already has harmonic coefficients (``Coefficient(kind="harmonic")``, the DEM bonds), so
``K(p) = Σ_p k_p K_p + Σ_{p<q} H(k_p, k_q) K_pq`` is exact with the voxels as the only volume unknowns; interface
unknowns would add one massless unknown per mixed face (a third of the voxels in a fibre image) and a singular
capacity to every transient.  Orthotropic phases (k_x, k_y, k_z) enter axis by axis (links along x carry k_x);
a rotated tensor has off-diagonal fluxes that a two-point flux cannot carry, and is refused.

Voxels of an insulating phase (``k = 0``) carry no unknown.  Unknowns: the conducting voxels in C order of the
image (``labels[i, j, k]``, k fastest), then the face unknowns face by face.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.anisotropy import PhaseTensor
from aromm.core.errors import InputError

AXES = "xyz"
IntArray = npt.NDArray[np.int64]


def laplacian(i: IntArray, j: IntArray, g: npt.NDArray[np.float64], n: int) -> sp.csr_array:
    """The conductance matrix of links ``i — j`` of conductances ``g``: ``Σ g (e_i − e_j)(e_i − e_j)ᵀ``.

    >>> laplacian(np.array([0]), np.array([1]), np.array([2.0]), 2).toarray().tolist()
    [[2.0, -2.0], [-2.0, 2.0]]
    """
    rows = np.concatenate([i, j, i, j])
    cols = np.concatenate([i, j, j, i])
    vals = np.concatenate([g, g, -g, -g])
    return sp.csr_array(sp.coo_array((vals, (rows, cols)), shape=(n, n)))


@dataclass(frozen=True)
class Links:
    """Two-point links of one axis: unknowns ``i``, ``j``, their phases and the geometric factor ``A / d`` (m)."""

    i: IntArray
    j: IntArray
    phase_i: IntArray
    phase_j: IntArray
    factor: float


@dataclass(eq=False)
class VolumeGrid:
    """The finite-volume unknowns of an image whose voxels have phase indices ``phase`` (−1: no unknown, an
    insulating or removed voxel) and the box faces in ``faces`` (those that carry a condition or an output).

    Implements the ``Discretisation`` protocol of :mod:`aromm.core.vocabulary` (``conduction``, ``mass``,
    ``face_mass``, ``face_dofs``) and adds :meth:`interface`, the harmonic-mean links between two phases.

    >>> grid = VolumeGrid(np.zeros((2, 1, 1), dtype=np.int64), (1.0, 1.0, 1.0), ("x0",))
    >>> grid.n, grid.face_dofs("x0").tolist()
    (3, [2])
    >>> grid.conduction(0, None).toarray().tolist()
    [[3.0, -1.0, -2.0], [-1.0, 1.0, 0.0], [-2.0, 0.0, 2.0]]
    """

    phase: npt.NDArray[np.int64]  # (nx, ny, nz)
    voxel_size: tuple[float, float, float]
    faces: tuple[str, ...] = ()
    cells: int = field(init=False)
    _index: npt.NDArray[np.int64] = field(init=False, repr=False)
    _face_cells: dict[str, IntArray] = field(init=False, repr=False)
    _face_dofs: dict[str, IntArray] = field(init=False, repr=False)
    _links: dict[int, Links] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        conducting = self.phase >= 0
        self.cells = int(conducting.sum())
        index = np.full(self.phase.shape, -1, dtype=np.int64)
        index[conducting] = np.arange(self.cells)
        self._index = index
        self._face_cells, self._face_dofs, self._links = {}, {}, {}
        start = self.cells
        for face in self.faces:
            axis, side = AXES.index(face[0]), (0 if face[1] == "0" else -1)
            layer = np.take(index, side, axis=axis).ravel()
            cells = layer[layer >= 0]
            self._face_cells[face] = cells
            self._face_dofs[face] = np.arange(start, start + cells.size, dtype=np.int64)
            start += cells.size
        self._n = start

    @property
    def n(self) -> int:
        return self._n

    @property
    def index(self) -> IntArray:
        """The unknown of each voxel (−1: none), shaped like the image."""
        return self._index

    @property
    def cell_phase(self) -> IntArray:
        """Phase index of each cell unknown."""
        return self.phase[self.phase >= 0]

    def area(self, axis: int) -> float:
        """Area (m²) of a voxel face normal to ``axis``."""
        return float(np.prod([v for a, v in enumerate(self.voxel_size) if a != axis]))

    def links(self, axis: int) -> Links:
        """The links between face neighbours along ``axis`` (both conducting), found once: every phase's and every
        phase pair's operator selects from them."""
        if axis not in self._links:
            self._links[axis] = self._find_links(axis)
        return self._links[axis]

    def _find_links(self, axis: int) -> Links:
        lo = np.take(self._index, np.arange(self.phase.shape[axis] - 1), axis=axis).ravel()
        hi = np.take(self._index, np.arange(1, self.phase.shape[axis]), axis=axis).ravel()
        both = (lo >= 0) & (hi >= 0)
        i, j = lo[both], hi[both]
        phase = self.cell_phase
        return Links(i, j, phase[i], phase[j], self.area(axis) / self.voxel_size[axis])

    def _axes(self, axis: str | None) -> list[int]:
        return list(range(3)) if axis is None else [AXES.index(axis)]

    def conduction(self, phase: int, axis: str | None) -> sp.csr_array:
        """``K_p``: the links inside phase ``phase`` (factor A/d) and its half-links to face unknowns (2A/d), along
        ``axis`` (all axes for None); its coefficient is the phase's k (or k_axis)."""
        i, j, g = [], [], []
        for a in self._axes(axis):
            links = self.links(a)
            inside = (links.phase_i == phase) & (links.phase_j == phase)
            i.append(links.i[inside])
            j.append(links.j[inside])
            g.append(np.full(int(inside.sum()), links.factor))
            for face in self.faces:
                if AXES.index(face[0]) != a:
                    continue
                cells = self._face_cells[face]
                mine = self.cell_phase[cells] == phase
                i.append(cells[mine])
                j.append(self._face_dofs[face][mine])
                g.append(np.full(int(mine.sum()), 2.0 * links.factor))
        return laplacian(np.concatenate(i), np.concatenate(j), np.concatenate(g), self.n)

    def interface(self, p: int, q: int, axis: str | None) -> sp.csr_array | None:
        """``K_pq``: the links between a voxel of phase p and one of phase q (factor A/d; the coefficient is the
        harmonic mean ``2 k_p k_q / (k_p + k_q)``); None when the phases never touch along ``axis``."""
        i, j, g = [], [], []
        for a in self._axes(axis):
            links = self.links(a)
            mixed = ((links.phase_i == p) & (links.phase_j == q)) | ((links.phase_i == q) & (links.phase_j == p))
            i.append(links.i[mixed])
            j.append(links.j[mixed])
            g.append(np.full(int(mixed.sum()), links.factor))
        if not sum(x.size for x in i):
            return None
        return laplacian(np.concatenate(i), np.concatenate(j), np.concatenate(g), self.n)

    def tensor_conduction(self, phase: int, spec: PhaseTensor) -> list[sp.csr_array]:
        raise InputError("a phase with a rotated conductivity tensor (a fibre axis, or k given as a tensor) has "
                         "off-diagonal fluxes that the two-point finite volumes cannot carry: use "
                         "discretisation q1, or give the phase k = [kx, ky, kz] along the image axes")

    def mass(self, phase: int) -> sp.csr_array:
        """``C_p``: the voxel volume (m³) on the diagonal of phase ``phase``'s cells (face unknowns are massless)."""
        diag = np.zeros(self.n)
        diag[: self.cells][self.cell_phase == phase] = float(np.prod(self.voxel_size))
        return sp.csr_array(sp.diags_array(diag))

    def face_mass(self, face: str) -> sp.csr_array:
        """The voxel-face area (m²) on the diagonal of the face's unknowns (zero for a face without unknowns)."""
        diag = np.zeros(self.n)
        if face in self._face_dofs:
            diag[self._face_dofs[face]] = self.area(AXES.index(face[0]))
        return sp.csr_array(sp.diags_array(diag))

    def face_cells(self, face: str) -> IntArray:
        """The cell unknown under each of ``face``'s unknowns (in the order of :meth:`face_dofs`)."""
        self.face_dofs(face)  # refuses a face without unknowns
        return self._face_cells[face]

    def points(self) -> npt.NDArray[np.float64]:
        """Where the unknowns sit (n, 3), m: the voxel centres, then each face unknown on its box face over its
        voxel (the geometric nested-dissection ordering of a direct solve orders them by it).

        >>> VolumeGrid(np.zeros((2, 1, 1), dtype=np.int64), (1.0, 1.0, 1.0), ("x0",)).points().tolist()
        [[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [0.0, 0.5, 0.5]]
        """
        h = np.asarray(self.voxel_size, dtype=float)
        centres = (np.argwhere(self.phase >= 0) + 0.5) * h
        out = [centres]
        for face in self.faces:
            axis = AXES.index(face[0])
            at = centres[self._face_cells[face]].copy()
            at[:, axis] = 0.0 if face[1] == "0" else self.phase.shape[axis] * h[axis]
            out.append(at)
        return np.concatenate(out)

    def face_dofs(self, face: str) -> IntArray:
        if face not in self._face_dofs:
            raise ValueError(f"face {face!r} has no unknowns in this grid (faces: {self.faces})")
        return self._face_dofs[face]

