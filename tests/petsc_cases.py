"""Cases of the petsc-engine tests, computed the same way at 1 rank (in the pytest process) and at 4 ranks cut
2×2×1 (``mpiexec -n 4 python tests/petsc_worker.py OUT.npz`` with :data:`BOXES_2x2x1`): small random two-phase
images, no symmetry (so no degenerate eigenvalues), contrast 12 in k and 3300 in c."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm import api
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.reduction.modal_bases import reference_operators, zero_modes
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble

PHASES = (PhaseSpec("fibre", 1, 0.3, 4.0e6), PhaseSpec("gas", 0, 0.025, 1.2e3))
SCENARIO = (FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=0.0))
#: Parameters at which the reduced and the full models are compared (away from the reference values).
PROBE = {"fibre.k": 0.5, "fibre.c": 3.0e6}
#: Dirichlet and Steklov modes (the latter counting the constant) of the eigenvalue comparison.
N_DIRICHLET, N_STEKLOV = 12, 12


def labels(shape: tuple[int, int, int], seed: int) -> np.ndarray:
    return (np.random.default_rng(seed).random(shape) < 0.4).astype(np.int32)


def basis_scene() -> Scene:
    """9×10×11 voxels (1320 nodes): the eigenvalue comparison with ARPACK (scipy's eigsh, called directly)."""
    return Scene(VoxelGeometry(labels((9, 10, 11), 3), (1e-4, 1e-4, 1e-4)), PHASES, SCENARIO, 0.0, TimeGrid(2.0, 0.1),
                 ("z0", "z1"))


def reduce_scene() -> Scene:
    return Scene(VoxelGeometry(labels((6, 7, 8), 3), (1e-4, 1e-4, 1e-4)), PHASES, SCENARIO, 0.0, TimeGrid(2.0, 0.2),
                 ("z0", "z1"))


def memory_scene() -> Scene:
    """24³ voxels (15,625 nodes), transient: the per-stage memory of the projection."""
    return Scene(VoxelGeometry(labels((24, 24, 24), 5), (1e-4, 1e-4, 1e-4)), PHASES, SCENARIO, 0.0, TimeGrid(2.0, 0.2),
                 ("z0", "z1"))


def steady_scene() -> Scene:
    """Steady, one fixed-temperature face (Dirichlet elimination) and convection: the full-model solves."""
    return Scene(VoxelGeometry(labels((7, 6, 8), 4), (1e-4, 1.2e-4, 0.9e-4)), PHASES,
                 (FaceSpec("z0", flux=500.0), FaceSpec("x1", T=3.0), FaceSpec("z1", h=20.0, T_ext=1.0)), 1.0, None,
                 ("z0", "z1", "x1"))


#: PETSc options of the 4-rank run: the x and y axes cut in two, z whole (boxes, not slabs).
BOXES_2x2x1 = "-aromm_da_processors_x 2 -aromm_da_processors_y 2 -aromm_da_processors_z 1"


def numbering_error(system: Any) -> int:
    """Largest difference, over the ranks and their box nodes, between the rows aromm.engines.petsc.layout gives
    them and the DMDA's own application-to-PETSc ordering of the natural (aromm.fem) node numbers."""
    from aromm.engines.petsc import runtime
    from aromm.engines.petsc.problem import box_layout
    from aromm.fem.voxel_grid import node_index

    layout = box_layout(basis_scene().geometry.labels.shape, system.comm)
    rows, _ = layout.box_rows()
    (x0, x1), (y0, y1), (z0, z1) = layout.box
    i, j, k = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1), np.arange(z0, z1 + 1), indexing="ij")
    natural = node_index(layout.shape, i, j, k).ravel(order="F")
    petsc = system.grid.getAO().app2petsc(natural.astype(runtime.petsc().IntType))
    return int(runtime.allmax(float(np.abs(np.asarray(petsc) - rows).max()), system.comm))


def results(comm: Any) -> dict[str, np.ndarray]:
    """Everything the tests compare, computed by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc.basis import compute_basis
    from aromm.engines.petsc.problem import box_layout
    from aromm.engines.petsc.reduction import distributed

    out: dict[str, np.ndarray] = {}
    system = distributed(basis_scene(), comm)
    out["numbering_error"] = np.array(numbering_error(system))
    out["grid"] = np.array(box_layout(basis_scene().geometry.labels.shape, comm).grid)
    for solver in ("mumps", "gamg"):
        basis = compute_basis(system, N_DIRICHLET, N_STEKLOV, solver=solver)
        out[f"dirichlet_{solver}"] = basis.eigenvalues[basis.kinds == "dirichlet"]
        out[f"steklov_{solver}"] = basis.eigenvalues[basis.kinds == "steklov"]
    for corrections in (True, False):
        rom = api.reduce(reduce_scene(), 10, modes=24, corrections=corrections, cache=False, engine="petsc",
                           solver="mumps")
        out[f"rom_corrections_{corrections}"] = rom.simulate(PROBE).as_array()
    transient = api.simulate(reduce_scene(), PROBE, engine="petsc", method="mumps")
    out["transient"] = transient.as_array()
    out["steady"] = api.simulate(steady_scene(), {"fibre.k": 0.5}, engine="petsc").as_array()
    scene = steady_scene()
    out["k_flux"] = api.homogenize(scene, "flux", engine="petsc")
    out["k_temperature"] = api.homogenize(scene, "temperature", method="mumps", engine="petsc")
    return out


def arpack() -> dict[str, np.ndarray]:
    """Eigenvalues by plain scipy eigsh (ARPACK shift-invert with its own SuperLU) of aromm.reduction.modal_bases'
    problems."""
    ops = reference_operators(assemble(basis_scene()))
    inner = ops.interior
    k_ii = sp.csc_array(ops.stiffness[inner][:, inner])
    c_ii = sp.csc_array(ops.capacity[inner][:, inner])
    dirichlet = np.sort(spla.eigsh(k_ii, k=N_DIRICHLET, M=c_ii, sigma=0.0, which="LM")[0])
    b = sp.csc_array(ops.zeta * ops.boundary)
    n_zero = zero_modes(ops).shape[1]
    on_gamma = b.diagonal() > 0
    top = float(np.max(ops.stiffness.diagonal()[on_gamma] / b.diagonal()[on_gamma]))
    lam = np.sort(spla.eigsh(sp.csc_array(ops.stiffness), k=N_STEKLOV, M=b, sigma=-1e-6 * top, which="LM")[0])
    return {"dirichlet": dirichlet, "steklov": lam[n_zero:]}


def serial() -> dict[str, np.ndarray]:
    """The keys of :func:`results` that the serial (scipy) engine computes, by the serial engine."""
    out = {}
    for corrections in (True, False):
        rom = api.reduce(reduce_scene(), 10, modes=24, corrections=corrections, cache=False)
        out[f"rom_corrections_{corrections}"] = rom.simulate(PROBE).as_array()
    out["transient"] = api.simulate(assemble(reduce_scene()), PROBE).as_array()
    out["steady"] = api.simulate(assemble(steady_scene()), {"fibre.k": 0.5}).as_array()
    out["k_flux"] = api.homogenize(steady_scene(), "flux")
    out["k_temperature"] = api.homogenize(steady_scene(), "temperature")
    return out
