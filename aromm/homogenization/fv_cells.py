"""Homogenisation cell problems in cell-centred finite volumes (:mod:`aromm.fv`), the discretisation of taufactor,
PuMA and OpenImpala.

* ``temperature`` — T = 1 at face i0, T = 0 at face i1 (both half a cell from the voxel centres), the other faces
  adiabatic: ``k_ii = Q L_i / (A_i ΔT)``, Q the heat flow through the fixed face (the reaction of the constraint).
  The field's convention for k̄ and the tortuosity factor τ = φ k_phase / k̄ [Cooper2016].
* ``flux`` — a uniform flux q into face i0, T = 0 at face i1 [Chavez2020, eq. 13]: ``k_ii = (Q / A_i) L_i /
  (T̄_i0 − T̄_i1)`` with Q the heat that enters (q times the conducting part of the face).
* ``periodic`` — ``T = G·x + T̃`` with T̃ periodic, the full tensor (:mod:`aromm.homogenization.fv_periodic`).

An insulating phase (``k = 0``) carries no unknown; a direction without a percolating path gives ``k = 0`` exactly
(with fixed temperatures: no conducting cluster touches both faces; said in the log), not an error.
Solvers: the direct methods of :mod:`aromm.linalg.direct`; ``mg``, CG preconditioned by the aggregation multigrid
of :mod:`aromm.fv.multigrid` on the matrix-free 7-point stencil (the probes: fixed temperatures ≈ 60 B per voxel,
flux ≈ 70 with its right-hand side; links in float32: k̄ within 6e-8 relatively of the float64 operator's); or ``amg``
(pyamg CG on the assembled matrix).  All to the relative residual ``rtol``.  ``auto`` takes ``mg`` from
:data:`aromm.homogenization.cell_problems.MG_CROSSOVER_VOXELS` voxels on (the periodic cell: ``amg`` where the
matrix-free multigrid cannot run: a rotated tensor).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray
from aromm.core.vocabulary import FaceSpec
from aromm.full.solve import reaction_heat_flow, steady_field
from aromm.fv.grid import AXES
from aromm.fv.multigrid import VolumeMultigrid
from aromm.fv.stencil import conductance_stencil
from aromm.fv.volumes import assemble_volumes, conducting_phase, reachable
from aromm.homogenization.fv_periodic import axis_k, periodic_k
from aromm.linalg.direct import resolve_method
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

log = logging.getLogger(__name__)


def fv_method(method: str, voxels: int, crossover: int) -> str:
    """``mg``, or ``auto`` from ``crossover`` voxels on → ``mg`` (the periodic cell takes ``amg`` instead where the
    matrix-free multigrid cannot run: :func:`aromm.homogenization.fv_periodic.periodic_k`); ``auto`` below → the
    direct default; other names as :func:`aromm.linalg.direct.resolve_method` checks them."""
    if method == "mg" or (method == "auto" and voxels >= crossover):
        return "mg"
    return resolve_method(method)


def _stencil_probe(scene: Scene, axis: int, rtol: float, faces: tuple[FaceSpec, FaceSpec],
                   held: list[npt.NDArray[np.int64]]) -> float:
    """k_ii by the matrix-free multigrid (:mod:`aromm.fv.multigrid`) for the probe ``faces`` (hot, cold): fixed
    temperatures 1 and 0 (the heat through the hot face), or a flux q = 1 W/m² into the hot face's conducting cells
    and T = 0 at the cold one, ``k = (Q / A) L / T̄`` with Q the heat that enters and T̄ the mean temperature of those
    cells *at the face*, half a cell out: ``x + q d / (2 k)`` (the assembled path's face unknowns,
    :mod:`aromm.fv.grid`).  ``held``: each voxel's phase, pruned (:func:`_probe_phase`), taken out and freed here
    before the solve."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    phase = held.pop()
    k_of = axis_k(scene)
    isotropic = bool(np.all(k_of == k_of[:, :1]))
    k_axes = [k_of[phase, 0]] * 3 if isotropic else [k_of[phase, a] for a in range(3)]  # phase −1: the zero row
    del phase
    stencil = conductance_stencil((k_axes[0], k_axes[1], k_axes[2]), image.voxel_size, axis)
    k_hot = np.take(k_axes[axis], 0, axis=axis)  # the hot face's cells, W/(m K)
    del k_axes
    size, d = image.size, image.voxel_size[axis]
    box_area = float(np.prod(size)) / size[axis]
    if faces[0].T is not None:
        solver = VolumeMultigrid(stencil, rtol)
        x = solver.solve_hot_face()
        heat = float(np.sum(stencil.low * (1.0 - np.take(x, 0, axis=axis))))  # W, the flow through the hot face
        k = heat * size[axis] / box_area
    else:
        stencil = replace(stencil, low=np.zeros_like(stencil.low))  # no fixed temperature at the hot face
        conducting = k_hot > 0
        cell_area = float(np.prod(image.voxel_size)) / d
        b = np.zeros(stencil.shape)
        np.moveaxis(b, axis, 0)[0] = conducting * cell_area  # q A per conducting face cell, W
        solver = VolumeMultigrid(stencil, rtol)
        x = solver.solve(b)
        face_T = np.take(x, 0, axis=axis)[conducting] + d / (2.0 * k_hot[conducting])
        entering = cell_area * float(np.count_nonzero(conducting))  # W: q times the conducting part of the face
        k = entering / box_area * size[axis] / float(np.mean(face_T))
    log.debug("finite volumes, matrix-free multigrid along %s: %d CG iterations, %d levels, %.0f B/voxel kept",
              AXES[axis], solver.iterations[-1], len(solver.levels), solver.nbytes() / stencil.cells)
    return k


def _probe_phase(scene: Scene, faces: tuple[FaceSpec, FaceSpec]) -> npt.NDArray[np.int64] | None:
    """Each voxel's phase, −1 where no conducting path joins it to a fixed face (:func:`aromm.fv.volumes.reachable`,
    one labelling); None when no heat can flow between the probe's two faces (with fixed temperatures: no cluster
    touches both; with a flux: none touches the cold face)."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    fixed = [f.face for f in faces if f.T is not None]
    phase, joins = reachable(conducting_phase(np.asarray(image.labels), scene.phases), fixed, fixed)
    return phase if joins and bool(np.any(phase >= 0)) else None


def probe_k(scene: Scene, axis: int, boundary: str, method: str, rtol: float) -> float:
    """k_ii under fixed temperatures (``temperature``) or a flux and a fixed temperature (``flux``)."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    name = AXES[axis]
    hot = FaceSpec(f"{name}0", T=1.0) if boundary == "temperature" else FaceSpec(f"{name}0", flux=1.0)
    faces = (hot, FaceSpec(f"{name}1", T=0.0))
    phase = _probe_phase(scene, faces)
    if phase is None:
        log.info("homogenisation: no conducting path along %s between its faces: k̄_%s = 0", name, name * 2)
        return 0.0  # no heat flows from one face to the other (exactly; a solve would give rounding)
    if method == "mg" and all(p.tensor is None for p in scene.phases):
        held = [phase]  # handed over, so that no frame here keeps it through the solve
        del phase
        return _stencil_probe(scene, axis, rtol, faces, held)
    del phase
    method = "amg" if method == "mg" else method  # a rotated tensor: the assembled grid refuses it, saying why
    system = assemble_volumes(image.labels, image.voxel_size, scene.phases, faces, outputs=[f.face for f in faces])
    field = steady_field(system, method=method, rtol=rtol)
    size = image.size
    area = float(np.prod(size)) / size[axis]
    if boundary == "temperature":
        return reaction_heat_flow(system, field, system.dirichlet[0].dofs) * size[axis] / area
    entering = float(np.sum(system.load.evaluate(system.values())))
    drop = float(system.observation[hot.face] @ field)  # the cold face is at 0
    return entering / area * size[axis] / drop if entering else 0.0


def fv_cell(scene: Scene, boundary: str, method: str, rtol: float, crossover: int, *,
            axes: Sequence[int] = (0, 1, 2)) -> tuple[FloatArray, str, list[float], list[float]]:
    """(k tensor W/(m K), solver, CPU s and wall s per solve) of the scene's image in finite volumes; a flux or
    temperature probe solves the ``axes`` asked only (the others' entries stay 0)."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    name = fv_method(method, int(np.asarray(image.labels).size), crossover)
    cpu, wall = time.process_time(), time.perf_counter()
    if boundary == "periodic":
        k, name = periodic_k(scene, name, rtol)
        return k, name, [time.process_time() - cpu], [time.perf_counter() - wall]
    k = np.zeros((3, 3))
    cpus, walls = [], []
    for axis in axes:
        k[axis, axis] = probe_k(scene, axis, boundary, name, rtol)
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
        cpu, wall = time.process_time(), time.perf_counter()
    return k, name, cpus, walls
