"""``mpiexec -n P python -m mpi4py.futures farm_worker.py OUT.npy``: the farm cases on MPI workers."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

import farm_cases

from inverse.farm import Farm

if __name__ == "__main__":
    np.save(sys.argv[1], farm_cases.estimates(Farm("mpi")))
