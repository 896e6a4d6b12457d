"""Finite-element assembly on a voxel image: one trilinear (Q1) hexahedron per voxel.

[Chavez2020, eq. 2–3]: ``(c_F C_F + c_G C_G) dT/dt = -(k_F K_F + k_G K_G + H) T + U``.
Every voxel is the same box (dx, dy, dz), so each phase's capacity and conductance
matrix is one reference element matrix scattered over that phase's voxels (the grid, its element matrices and
numbering: :mod:`aromm.fem.voxel_grid`); this equals
scikit-fem's generic Hex1 assembly (tests/test_fem.py checks 1e-12) and is ~10x faster.

Nodes are numbered ``i + (nx+1) * (j + (ny+1) * k)`` (x fastest) for the node at
``(i dx, j dy, k dz)``; the image is indexed ``labels[i, j, k]`` for voxel (i, j, k).
Faces are named ``x0`` (plane x = 0), ``x1`` (x = L_x), and likewise for y and z.

Only the terms a scene calls for are built (aromm.core.vocabulary): capacity only for a transient, a
convection matrix only on faces with ``h``, one conductance block per phase present,
directional blocks only for orthotropic phases.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import (
    FaceSpec,
    PhaseSpec,
    check_image,
    face_terms,
    insulating,
    parameter_values,
    phase_index,
    phase_terms,
    system_of,
)
from aromm.fem.insulation import conducting_voxels, singular_insulation
from aromm.fem.voxel_grid import VoxelGrid


def anchors(boundary: Sequence[FaceSpec]) -> list[str]:
    """The faces that fix the temperature level: a fixed temperature or an exchange."""
    return [f.face for f in boundary if f.T is not None or f.h is not None]


def refuse_singular_insulation(labels: np.ndarray, phases: Sequence[PhaseSpec], boundary: Sequence[FaceSpec], *,
                               transient: bool) -> None:
    """Refuse an insulating phase (k = 0) where the Q1 system would be singular (:mod:`aromm.fem.insulation`), and in
    a transient (as the finite volumes do: every phase must conduct there).  :func:`assemble_voxels` checks a steady
    system only when a face fixes its temperature level: without one it is a cell problem's box, all faces free
    (:mod:`aromm.homogenization.anisotropic_cells`), which its probe checks (``refuse_singular_cells``)."""
    cold = [ph for ph in phases if insulating(ph)]
    if transient:
        raise InputError(f"phase {cold[0].name!r}: k = 0 (insulating) is for steady scenes (homogenize, rev, simulate "
                         "without [time]); a transient needs every phase to conduct")
    why = singular_insulation(conducting_voxels(labels, phases), anchors(boundary))
    if why is not None:
        raise InputError(f"phase {cold[0].name!r}: k = 0 (insulating) in q1: {why}; the finite volumes remove such "
                         "voxels (discretisation fv)")


def assemble_voxels(
    labels: np.ndarray,
    voxel_size: Sequence[float],
    phases: Sequence[PhaseSpec],
    boundary: Sequence[FaceSpec] = (),
    *,
    time: TimeGrid | None = None,
    initial_T: float = 0.0,
    outputs: Sequence[str] = (),
    matrix_free: bool = False,
) -> ThermalSystem:
    """Assemble the voxel model into a :class:`ThermalSystem` with only the terms asked for.

    ``matrix_free``: conduction, capacity and convection terms as matrix-free operators
    (:mod:`aromm.fem.voxel_terms`, ≈ 1 byte per voxel instead of ≈ 330 bytes per node each), which the Krylov
    reduction and the multigrid transient use as they are; other consumers assemble them (``tocsr``).

    >>> import numpy as np
    >>> labels = np.zeros((2, 2, 2), dtype=int)
    >>> sys_ = assemble_voxels(labels, (1e-3,) * 3, [PhaseSpec("gas", 0, 0.025)],
    ...                        [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)], outputs=["z0"])
    >>> sys_.term_names
    ('K_gas', 'H_z1', 'U_z0', 'UH_z1')
    """
    labels = np.asarray(labels)
    voxel_size = tuple(float(v) for v in voxel_size)
    check_image(labels, voxel_size, phases)
    if any(insulating(ph) for ph in phases) and (time is not None or any(anchors(boundary))):
        refuse_singular_insulation(labels, phases, boundary, transient=time is not None)
    shape = (int(labels.shape[0]), int(labels.shape[1]), int(labels.shape[2]))
    phase = phase_index(labels, phases).ravel(order="C")
    grid = VoxelGrid(shape, (voxel_size[0], voxel_size[1], voxel_size[2]), phase)
    present = [i for i in range(len(phases)) if np.any(phase == i)]
    transient = time is not None
    disc = grid
    if matrix_free:
        from aromm.fem.voxel_terms import MatrixFreeGrid  # the matrix-free terms sit on this module's grid

        disc = MatrixFreeGrid(grid)  # type: ignore[assignment]
    faces, dirichlet = face_terms(disc, boundary)
    return system_of(grid, phase_terms(disc, phases, present, transient=transient) + faces, dirichlet,
                     outputs=outputs, time=time, geometry=grid.geometry(labels),
                     parameters=parameter_values([phases[i] for i in present], boundary, initial_T, transient))
