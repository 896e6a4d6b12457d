"""Cases of the petsc engine's finite volumes (aromm.engines.petsc.volume_assembly), computed the same way at 1 rank
in the pytest process and under ``mpiexec`` (``petsc_worker.py OUT.npz petsc_fv_cases``): a three-phase image
with an orthotropic phase (so the ranks' padded boxes hold different interface terms), contrast 12 in k."""

from __future__ import annotations

from typing import Any

import numpy as np

from aromm import api
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble

PHASES = (PhaseSpec("fibre", 1, 0.3, 4.0e6), PhaseSpec("gas", 0, 0.025, 1.2e3),
          PhaseSpec("binder", 2, (0.2, 0.1, 0.05), 2.0e6))
PROBE = {"fibre.k": 0.5, "binder.k_y": 0.15}
SHAPE = (7, 6, 9)
VOXEL = (1e-4, 1.2e-4, 0.9e-4)
#: The Krylov model: its training box, where it is compared, its build (no certificate: with 16 affine terms its
#: Gram matrices have thousands of columns, and the bound of the petsc engine's build has its own test).
BOX = {"fibre.k": (0.2, 1.0)}
INSIDE = {"fibre.k": 0.5}
KRYLOV = {"method": "krylov", "bounds": BOX, "tolerance": 1e-3, "certify": False, "cache": False}
#: The amalgam model without correction modes (with them, the near-dependent corrections make the selection
#: differ between the engines' rounding, as in q1: tests/test_petsc_engine.py).
MODAL = {"modes": 24, "corrections": False, "cache": False}


def labels() -> np.ndarray:
    u = np.random.default_rng(11).random(SHAPE)
    return np.where(u < 0.4, 1, np.where(u < 0.9, 0, 2)).astype(np.int32)


def transient_scene() -> Scene:
    """Flux in, exchange out, a face-mean output on a face without a condition."""
    faces = (FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=0.0))
    return Scene(VoxelGeometry(labels(), VOXEL), PHASES, faces, 1.0, TimeGrid(2.0, 0.2), ("z0", "z1", "y1"),
                 discretisation="fv")


def steady_scene() -> Scene:
    """Fixed temperatures (face unknowns eliminated), flux and exchange."""
    return Scene(VoxelGeometry(labels(), VOXEL), PHASES,
                 (FaceSpec("z0", flux=500.0), FaceSpec("x1", T=3.0), FaceSpec("z1", h=20.0, T_ext=1.0)), 1.0, None,
                 ("z0", "z1", "x1"), discretisation="fv")


def product_error(comm: Any) -> float:
    """max over the rows of |K x − P K_serial Pᵀ x| / (8 ε (|K_serial| |x|)), K the conductance of
    :func:`steady_scene` at :data:`PROBE` assembled by boxes, K_serial the serial assembly, P the rows' numbering
    (VolumeRows): at most 1 when both are the same matrix summed in another order (≤ 8 terms per row: 6 links, a
    face link, the diagonal; [Higham2002, § 3.1])."""
    from aromm.engines.petsc import convert, runtime
    from aromm.engines.petsc.problem import VoxelProblem
    from aromm.engines.petsc.reduction import distributed
    from aromm.engines.petsc.volume_assembly import VolumeRows, global_rows
    from aromm.fv.grid import VolumeGrid
    from aromm.fv.volumes import conducting_phase, unknown_faces

    scene = steady_scene()
    problem = VoxelProblem.from_scene(scene)
    system = distributed(scene, comm)
    whole = assemble(scene)
    k_serial = whole.conductance.evaluate(whole.values(PROBE))
    layout = problem.layout(comm)
    faces = unknown_faces(problem.boundary, problem.outputs)
    grid = VolumeGrid(conducting_phase(scene.geometry.labels, PHASES), VOXEL, faces)
    rows, _ = global_rows(grid, ((0, SHAPE[0]), (0, SHAPE[1]), (0, SHAPE[2])), VolumeRows(layout, faces))
    x = np.random.default_rng(0).standard_normal(whole.n)
    expected, floor = np.empty(whole.n), np.empty(whole.n)
    expected[rows] = k_serial @ x
    floor[rows] = 8 * np.finfo(float).eps * (abs(k_serial) @ np.abs(x))
    mine = np.empty(whole.n)
    mine[rows] = x
    k = system.combine(system.conductance, system.values(PROBE))
    local = system.rows
    xv = convert.vector(mine[local.lo:local.hi], local, comm)
    y = xv.duplicate()
    k.mult(xv, y)
    part = slice(local.lo, local.hi)
    err = float((np.abs(y.getArray() - expected[part]) / floor[part]).max()) if local.local else 0.0
    return runtime.allmax(err, comm)


def results(comm: Any) -> dict[str, np.ndarray]:
    """Everything the tests compare, by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc.problem import box_layout

    out: dict[str, np.ndarray] = {"product_error": np.array(product_error(comm)),
                                  "grid": np.array(box_layout(SHAPE, comm).grid)}
    out["transient"] = api.simulate(transient_scene(), PROBE, engine="petsc", method="mumps").as_array()
    out["steady"] = api.simulate(steady_scene(), PROBE, engine="petsc").as_array()
    out["k_flux"] = api.homogenize(steady_scene(), "flux", engine="petsc")
    out["k_temperature"] = api.homogenize(steady_scene(), "temperature", method="mumps", engine="petsc")
    out["krylov"] = api.reduce(transient_scene(), 30, engine="petsc", **KRYLOV).simulate(INSIDE).as_array()
    modal = api.reduce(transient_scene(), 10, engine="petsc", solver="mumps", **MODAL)
    out["modal"] = modal.simulate(INSIDE).as_array()
    return out


def serial() -> dict[str, np.ndarray]:
    """The keys of :func:`results` that the serial engine computes, by the serial engine."""
    return {"transient": api.simulate(assemble(transient_scene()), PROBE).as_array(),
            "steady": api.simulate(assemble(steady_scene()), PROBE).as_array(),
            "k_flux": api.homogenize(steady_scene(), "flux"),
            "k_temperature": api.homogenize(steady_scene(), "temperature"),
            "krylov": api.reduce(transient_scene(), 30, **KRYLOV).simulate(INSIDE).as_array(),
            "modal": api.reduce(transient_scene(), 10, **MODAL).simulate(INSIDE).as_array()}
