"""The two kinds of scene geometry: a voxel label image, or a conforming simplex mesh with tagged cells.

Each knows its box, the labels it holds, its phases' volume fractions and how it is discretised into a
:class:`~aromm.core.system.ThermalSystem` (aromm.fem.voxel, aromm.fem.mesh).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem.voxel import assemble_voxels
from aromm.fv.volumes import assemble_volumes

if TYPE_CHECKING:  # meshio (≈ 0.06 CPU s) is read for mesh scenes only
    import meshio

#: Cell data of a mesh that tells the phases apart (gmsh physical groups).
MESH_LABEL_KEY = "gmsh:physical"


@dataclass(frozen=True, eq=False)
class VoxelGeometry:
    """A label image indexed ``[x, y, z]`` with voxel edges ``voxel_size`` (m); one Q1 element per voxel."""

    labels: np.ndarray
    voxel_size: tuple[float, float, float]

    @property
    def size(self) -> tuple[float, float, float]:
        """Edge lengths of the box (m)."""
        nx, ny, nz = self.labels.shape
        return (nx * self.voxel_size[0], ny * self.voxel_size[1], nz * self.voxel_size[2])

    @property
    def shape(self) -> tuple[int, int, int]:
        nx, ny, nz = self.labels.shape
        return (int(nx), int(ny), int(nz))

    def present(self) -> set[int]:
        """The labels that occur in the image."""
        return set(np.unique(self.labels).tolist())

    def volume_fractions(self, phases: Sequence[PhaseSpec]) -> dict[str, float]:
        """Fraction of voxels of each phase (every voxel has the same volume).

        >>> VoxelGeometry(np.array([[[0, 1, 1, 1]]]), (1.0, 1.0, 1.0)).volume_fractions([PhaseSpec("a", 1, 1.0)])
        {'a': 0.75}
        """
        flat = np.asarray(self.labels).ravel()
        counts = np.bincount(flat - flat.min()) if flat.size else np.zeros(0)
        return {ph.name: float(counts[ph.label - flat.min()] / flat.size)
                if 0 <= ph.label - flat.min() < counts.size else 0.0 for ph in phases}

    def assemble(self, phases: Sequence[PhaseSpec], boundary: Sequence[FaceSpec], *,
                 interfaces: Mapping[tuple[str, str], float], time: TimeGrid | None, initial_T: float,
                 outputs: Sequence[str], where: str = "", matrix_free: bool = False,
                 discretisation: str = "q1") -> ThermalSystem:
        """Q1 elements (``matrix_free``: their terms as operators) or, ``discretisation="fv"``, finite volumes."""
        if interfaces:
            raise InputError(f"{where}[interfaces]: contact resistance needs a conforming mesh (geometry.mesh); "
                             "voxel images have no interface surface to put it on")
        if discretisation == "fv":
            return assemble_volumes(self.labels, self.voxel_size, phases, boundary, time=time, initial_T=initial_T,
                                    outputs=outputs)
        return assemble_voxels(self.labels, self.voxel_size, phases, boundary, time=time, initial_T=initial_T,
                               outputs=outputs, matrix_free=matrix_free)


@dataclass(frozen=True, eq=False)
class MeshGeometry:
    """A conforming tetrahedral (or triangular) mesh, coordinates in m, phases by the cell tags
    ``gmsh:physical``; Lagrange elements of degree ``order`` (1 or 2)."""

    mesh: meshio.Mesh
    order: int = 1

    @property
    def size(self) -> tuple[float, float, float]:
        """Edge lengths of the mesh's bounding box (m)."""
        extent = np.ptp(np.asarray(self.mesh.points, dtype=float), axis=0)
        return (float(extent[0]), float(extent[1]), float(extent[2]) if extent.size > 2 else 0.0)

    def _cells(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(connectivity, tags) of the volume cells (tetrahedra, or triangles for a 2-D mesh)."""
        kind = "tetra" if any(b.type == "tetra" for b in self.mesh.cells) else "triangle"
        return [(np.asarray(block.data), np.asarray(tags).astype(np.int64))
                for block, tags in zip(self.mesh.cells, self.mesh.cell_data[MESH_LABEL_KEY], strict=True)
                if block.type == kind]

    def present(self) -> set[int]:
        return set(np.unique(np.concatenate([tags for _, tags in self._cells()])).tolist())

    def volume_fractions(self, phases: Sequence[PhaseSpec]) -> dict[str, float]:
        """Sum of the volumes (areas in 2-D) of each phase's simplices over the total."""
        points = np.asarray(self.mesh.points, dtype=float)
        volume: dict[int, float] = {}
        for conn, tags in self._cells():
            corners = points[conn]
            edges = corners[:, 1:, : conn.shape[1] - 1] - corners[:, :1, : conn.shape[1] - 1]
            size = np.abs(np.linalg.det(edges))
            for label in np.unique(tags):
                volume[int(label)] = volume.get(int(label), 0.0) + float(size[tags == label].sum())
        total = sum(volume.values())
        return {ph.name: volume.get(ph.label, 0.0) / total for ph in phases}

    def assemble(self, phases: Sequence[PhaseSpec], boundary: Sequence[FaceSpec], *,
                 interfaces: Mapping[tuple[str, str], float], time: TimeGrid | None, initial_T: float,
                 outputs: Sequence[str], where: str = "") -> ThermalSystem:
        resistances = {f"{a}|{b}": r for (a, b), r in interfaces.items()}
        from aromm.fem.mesh import assemble_mesh  # scikit-fem: only for a mesh scene

        return assemble_mesh(self.mesh, phases, boundary, interfaces=resistances, time=time, initial_T=initial_T,
                             outputs=outputs, order=self.order)


SceneGeometry = VoxelGeometry | MeshGeometry
