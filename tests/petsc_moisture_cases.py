"""Cases of the petsc engine's coupled heat and moisture (aromm.physics.hygrothermal on boxes,
aromm.engines.petsc.assembly), computed the same way at 1 rank in the pytest process and under ``mpiexec``
(``petsc_worker.py OUT.npz petsc_moisture_cases``): a two-phase 6×5×4 image (contrast 12 in k, 10 in ξ, 20 in D_φ)
under a humidity step on z0 (its T held), a heat flux and a moisture flux on z1, and vapour exchange with the air on
x1: every kind of coupled term, load, Dirichlet set and output; in Q1 elements and in finite volumes (whose links
between the phases are the coupled system's cone terms)."""

from __future__ import annotations

from typing import Any

import numpy as np

from aromm import api
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.physics.hygrothermal import MoistureState
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.moisture_section import MoistureScene, face_area
from aromm.scene.scene_file import Scene, assemble

SHAPE = (6, 5, 4)
VOXEL = (1e-3, 1.2e-3, 0.9e-3)
PHASES = (PhaseSpec("fibre", 1, 0.3, 1.5e6), PhaseSpec("gas", 0, 0.025, 1.2e5))
MOISTURE = {"fibre": {"xi": 200.0, "D_phi": 2e-8, "delta_p": 2e-11},
            "gas": {"xi": 20.0, "D_phi": 1e-9, "delta_p": 1.8e-10}}
#: Parameters the comparison sets away from the scene's values (one thermal, one moisture property).
PROBE = {"fibre.k": 0.5, "gas.D_phi": 2e-9}
DISCRETISATIONS = ("q1", "fv")


def labels() -> np.ndarray:
    return (np.random.default_rng(7).random(SHAPE) < 0.4).astype(np.int32)


def scene(time: TimeGrid | None, discretisation: str = "q1") -> Scene:
    """The coupled scene (module docstring), transient on ``time`` or steady (None)."""
    extent = tuple(n * h for n, h in zip(SHAPE, VOXEL, strict=True))
    faces = (FaceSpec("z0", T=20.0), FaceSpec("z1", flux=50.0), FaceSpec("x1", h=8.0, T_ext=15.0))
    moisture = MoistureScene(MoistureState(20.0, 0.5), MOISTURE, {"z0": 0.8}, 0.5, ("z1", "x1"),
                             vapour={"x1": (2e-8, 0.3)}, flux={"z1": (1e-6, face_area("z1", extent))})
    return Scene(VoxelGeometry(labels(), VOXEL), PHASES, faces, 20.0, time, ("z1", "x1"),
                 discretisation=discretisation, moisture=moisture)


def transient_scene(discretisation: str = "q1") -> Scene:
    return scene(TimeGrid(600.0, 60.0), discretisation)


def steady_scene(discretisation: str = "q1") -> Scene:
    return scene(None, discretisation)


def step_condition(case: Scene) -> float:
    """The largest 2-norm condition number of the matrices the petsc engine solves for ``case`` at :data:`PROBE`
    (Euler's and BDF2's steps, or the steady matrix), with identity rows and columns on the fixed unknowns as PETSc
    eliminates them (aromm.engines.petsc.transient, steady), symmetrically scaled by their diagonal as the engine
    solves a coupled system (aromm.engines.petsc.linear.krylov)."""
    system = assemble(case)
    values = system.values({k: v for k, v in PROBE.items() if k in system.parameters})
    k = system.conductance.evaluate(values).toarray()
    c = system.capacity.evaluate(values).toarray() if case.time is not None else np.zeros_like(k)
    fixed = np.concatenate([d.dofs for d in system.dirichlet])
    out = 0.0
    for lead in (1.0, 1.5) if case.time is not None else (0.0,):
        a = lead * c / (case.time.dt if case.time is not None else 1.0) + k
        a[fixed, :] = 0.0
        a[:, fixed] = 0.0
        a[fixed, fixed] = 1.0
        scale = 1.0 / np.sqrt(np.diag(a))
        out = max(out, float(np.linalg.cond(scale[:, None] * a * scale[None, :])))
    return out


def results(comm: Any) -> dict[str, np.ndarray]:
    """Everything the tests compare, by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc.problem import box_layout

    out = {"grid": np.array(box_layout(SHAPE, comm).grid)}
    for d in DISCRETISATIONS:
        transient = api.simulate(transient_scene(d), PROBE, engine="petsc")
        out.update({f"{d}_names": np.array(list(transient.mean_T)), f"{d}_transient": transient.as_array(),
                    f"{d}_steady": api.simulate(steady_scene(d), PROBE, engine="petsc").as_array()})
    return out


def serial() -> dict[str, np.ndarray]:
    """The same by the serial engine (direct solves)."""
    out = {}
    for d in DISCRETISATIONS:
        transient = api.simulate(assemble(transient_scene(d)), PROBE)
        out.update({f"{d}_names": np.array(list(transient.mean_T)), f"{d}_transient": transient.as_array(),
                    f"{d}_steady": api.simulate(assemble(steady_scene(d)), PROBE).as_array()})
    return out
