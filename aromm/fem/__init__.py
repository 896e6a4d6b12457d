"""Finite-element assemblers: a scene's geometry and vocabulary (aromm.core.vocabulary) → ThermalSystem.

* :mod:`aromm.fem.voxel`: one trilinear (Q1) hexahedron per voxel of a label image (the grid:
  :mod:`aromm.fem.voxel_grid`; matrix-free terms: :mod:`aromm.fem.voxel_terms`);
* :mod:`aromm.fem.mesh`: Lagrange simplices (P1/P2) on a conforming mesh, with contact resistance.
"""

from typing import Any

from aromm.fem.voxel import assemble_voxels
from aromm.fem.voxel_grid import VoxelGrid, connectivity, element_matrices, face_mass, node_points, scatter

__all__ = [
    "VoxelGrid",
    "assemble_mesh",
    "assemble_voxels",
    "connectivity",
    "element_matrices",
    "face_mass",
    "node_points",
    "scatter",
]


def __getattr__(name: str) -> Any:
    """``assemble_mesh`` is imported on first use: scikit-fem (≈ 0.2 CPU s) is for mesh scenes only."""
    if name == "assemble_mesh":
        from aromm.fem.mesh import assemble_mesh

        return assemble_mesh
    raise AttributeError(f"module 'aromm.fem' has no attribute {name!r}")
