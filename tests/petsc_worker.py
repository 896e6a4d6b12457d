"""Run the ``results`` of a cases module (:mod:`petsc_cases` by default) under MPI and save them from rank 0:
``mpiexec -n P python petsc_worker.py OUT [MODULE]``."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from aromm.engines.petsc import runtime


def main(out: str, module: str = "petsc_cases") -> None:
    comm = runtime.world()
    found = importlib.import_module(module).results(comm)
    if runtime.is_root(comm):
        np.savez(out, ranks=np.array(runtime.size(comm)), **found)


if __name__ == "__main__":
    main(*sys.argv[1:3])
