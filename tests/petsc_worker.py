"""Run :func:`petsc_cases.results` under MPI and save them from rank 0: ``mpiexec -n P python petsc_worker.py OUT``."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

import petsc_cases

from aromm.engines.petsc import runtime


def main(out: str) -> None:
    comm = runtime.world()
    found = petsc_cases.results(comm)
    if runtime.is_root(comm):
        np.savez(out, ranks=np.array(runtime.size(comm)), **found)


if __name__ == "__main__":
    main(sys.argv[1])
