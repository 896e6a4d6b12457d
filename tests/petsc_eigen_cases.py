"""Cases of the tests of the petsc engine's preconditioned eigensolver and of its MUMPS set-up
(tests/test_petsc_eigensolvers.py), computed the same way at 1 rank (in the pytest process) and at 2 ranks
(``mpiexec -n 2 python tests/petsc_worker.py OUT petsc_eigen_cases``): the images and scenario of
:mod:`petsc_cases`."""

from __future__ import annotations

from typing import Any

import numpy as np
from petsc_cases import N_DIRICHLET, N_STEKLOV, PROBE, basis_scene, reduce_scene
from petsc_mumps_cases import mumps_probe

from aromm import api


def results(comm: Any) -> dict[str, np.ndarray]:
    """The preconditioned eigensolver's eigenvalues (and iterations), reduced models built on its bases, and the
    MUMPS probe, by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc.basis import compute_basis
    from aromm.engines.petsc.reduction import distributed

    system = distributed(basis_scene(), comm)
    basis = compute_basis(system, N_DIRICHLET, N_STEKLOV, solver="gamg", eigensolver="lobpcg")
    out = {"dirichlet": basis.eigenvalues[basis.kinds == "dirichlet"],
           "steklov": basis.eigenvalues[basis.kinds == "steklov"],
           "iterations": np.array([basis.info["steklov_iterations"], basis.info["dirichlet_iterations"]])}
    for corrections in (True, False):
        rom = api.reduce(reduce_scene(), 10, modes=24, corrections=corrections, cache=False, engine="petsc",
                         solver="mumps", eigensolver="lobpcg")
        out[f"rom_corrections_{corrections}"] = rom.simulate(PROBE).as_array()
        out[f"rom_eigensolver_{corrections}"] = np.array(str(rom.info["eigensolver"]))
    return out | mumps_probe(comm)
