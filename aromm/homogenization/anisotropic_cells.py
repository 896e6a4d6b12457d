"""Cell problems of images with anisotropic phases (aromm.core.anisotropy), on the assembled Q1 operator.

The matrix-free multigrid of :mod:`aromm.homogenization.cell_problems` holds one diagonal conductivity per phase.  A
phase with a
full tensor, or a fibre phase with one axis per voxel, contributes ``Σ_i k_i ∫ ∇φ_a · A_i ∇φ_b`` with off-diagonal
terms (:func:`aromm.fem.voxel_grid.tensor_conduction`), so its cell problems are solved here on the assembled matrix K
of the box, by a direct method or pyamg (aromm.linalg.direct), with the same three boundary conditions:

* ``periodic`` — the nodes of opposite faces are identified by the 0/1 matrix P (box → periodic nodes); for the
  macroscopic gradient e_j, T = g_j + P T̃_j with g_j = x_j at the nodes, and Pᵀ K P T̃_j = b_j = −Pᵀ K g_j.  The
  full tensor is ``k_ij |Ω| = g_iᵀ K g_j − b_iᵀ T̃_j`` (energy identity, as in aromm.homogenization.cell_problems,
  which reduces to ``δ_ij ⟨k_j⟩`` for the first term when every tensor is diagonal);
* ``flux`` — [Chavez2020, eq. 13]: flux q into face i0, T = 0 on i1: k_ii = q L_i / (T̄_i0 − T̄_i1);
* ``temperature`` — T = 1 on i0, 0 on i1: k_ii = (Tᵀ K T) L_i / A_i (the heat flow for ΔT = 1 K).

Every solve reaches ``‖b − A x‖ ≤ rtol ‖b‖`` or raises NumericalError (aromm.linalg.direct.check_residual).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.fem.voxel import assemble_voxels
from aromm.fem.voxel_grid import face_mass, face_nodes_and_quads, node_points
from aromm.linalg.direct import check_residual, factorize
from aromm.linalg.multigrid.pcg import pinned
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

PROBE_FLUX = 1.0  # W/m²; the problem is linear
#: A periodic load below this fraction of the box's own (‖K g_j‖) is round-off: the medium is uniform along j.
ROUNDOFF = 1e-12


def anisotropic(scene: Scene) -> bool:
    """Whether a phase of the scene has a conductivity tensor or a fibre axis (aromm.core.anisotropy)."""
    return any(ph.tensor is not None for ph in scene.phases)


def box_conductance(image: VoxelGeometry, scene: Scene) -> sp.csr_array:
    """K (W/K) of the image's box, all faces free, at the scene's parameter values."""
    system = assemble_voxels(image.labels, image.voxel_size, scene.phases)
    return sp.csr_array(system.conductance.evaluate(system.values()))


def periodic_map(shape: tuple[int, int, int]) -> sp.csr_array:
    """P (n_box, n_periodic): box node (i, j, k) → periodic node (i mod nx, j mod ny, k mod nz), x fastest."""
    nx, ny, nz = shape
    k, j, i = np.meshgrid(np.arange(nz + 1), np.arange(ny + 1), np.arange(nx + 1), indexing="ij")
    target = (i % nx + nx * (j % ny + ny * (k % nz))).ravel()
    return sp.csr_array((np.ones(target.size), (np.arange(target.size), target)), shape=(target.size, nx * ny * nz))


def assembled_cell(scene: Scene, boundary: str, method: str, rtol: float,
                   axes: Sequence[int] = (0, 1, 2)) -> FloatArray:
    """Apparent conductivity tensor (W/(m K)) under ``boundary`` (module docstring); ``method`` a direct solver or
    ``"amg"`` of aromm.linalg.direct; the flux and temperature probes solve the ``axes`` asked only."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    k_box = box_conductance(image, scene)
    points = node_points(image.shape, image.voxel_size)
    volume = float(np.prod(scene.size))
    out = np.zeros((3, 3))
    if boundary == "periodic":
        p = periodic_map(image.shape)
        k_per = sp.csr_array(p.T @ k_box @ p)
        first = np.unique(p.indices, return_index=True)[1]  # each periodic node's box twin of lowest index
        factor = factorize(pinned(k_per), method, rtol=rtol, points=points[first])
        grads = [points[:, j] for j in range(3)]
        loads = [-(p.T @ (k_box @ g)) for g in grads]
        for j in range(3):
            rhs = loads[j].copy()
            rhs[0] = 0.0  # the loads sum to zero: node 0's equation follows from the others
            field = factor.solve(rhs, check=False)
            if np.linalg.norm(loads[j]) > ROUNDOFF * np.linalg.norm(k_box @ grads[j]):  # else a homogeneous medium
                check_residual(k_per, field, loads[j], rtol, method)
            for i in range(3):
                out[i, j] = (float(grads[i] @ (k_box @ grads[j])) - float(loads[i] @ field)) / volume
        return out
    for axis in axes:
        out[axis, axis] = _faces(scene, image, k_box, points, axis, boundary=boundary, method=method, rtol=rtol)
    return out


def _faces(scene: Scene, image: VoxelGeometry, k_box: sp.csr_array, points: FloatArray, axis: int, *,
           boundary: str, method: str, rtol: float) -> float:
    name = "xyz"[axis]
    hot, cold = face_nodes_and_quads(image.shape, f"{name}0")[0], face_nodes_and_quads(image.shape, f"{name}1")[0]
    length = scene.size[axis]
    area = float(np.prod(scene.size)) / length
    fixed: npt.NDArray[np.int64] = np.concatenate([hot, cold]) if boundary == "temperature" else cold
    free = np.setdiff1d(np.arange(k_box.shape[0]), fixed)
    k_ff = sp.csr_array(k_box[free][:, free])
    factor = factorize(k_ff, method, rtol=rtol, points=points[free])
    field = np.zeros(k_box.shape[0])
    if boundary == "temperature":
        field[hot] = 1.0
        field[free] = factor.solve(-(k_box[free][:, hot] @ np.ones(hot.size)))
        return float(field @ (k_box @ field)) * length / area
    weights = np.asarray(face_mass(image.shape, image.voxel_size, f"{name}0") @ np.ones(k_box.shape[0]))
    field[free] = factor.solve(PROBE_FLUX * weights[free])
    drop = float(weights @ field) / area  # T̄_i0 − T̄_i1 with T̄_i1 = 0
    return PROBE_FLUX * length / drop
