"""Finite-element assembly.  ``aromm.fem.voxel``: one Q1 hexahedron per voxel (re-exported here)."""

from aromm.fem.voxel import (
    FACES,
    VTK_HEX,
    FaceSpec,
    PhaseSpec,
    assemble_voxels,
    connectivity,
    element_matrices,
    face_area,
    face_mass,
    face_nodes_and_quads,
    node_index,
    node_points,
    parameter_values,
    scatter,
)

__all__ = [
    "FACES",
    "VTK_HEX",
    "FaceSpec",
    "PhaseSpec",
    "assemble_voxels",
    "connectivity",
    "element_matrices",
    "face_area",
    "face_mass",
    "face_nodes_and_quads",
    "node_index",
    "node_points",
    "parameter_values",
    "scatter",
]
