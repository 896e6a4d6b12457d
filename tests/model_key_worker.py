"""``mpiexec -n P python model_key_worker.py DROP aromm-args...``: the ``aromm`` command line on every rank with
the Krylov reductor's drop threshold set to DROP (tests/petsc_krylov_cases.py explains why the cross-engine
comparisons raise it); exits with the command's code."""

from __future__ import annotations

import sys

import aromm.reduction.krylov
from aromm.cli import main

if __name__ == "__main__":
    aromm.reduction.krylov.DROP = float(sys.argv[1])
    sys.exit(main(sys.argv[2:]))
