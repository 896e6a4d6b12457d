"""``mpiexec -n P python -m mpi4py.futures farm_cli_worker.py aromm-args...``: the ``aromm`` command line on rank
0 of an mpi4py.futures pool (the other ranks are the farm's workers); exits with the command's code."""

from __future__ import annotations

import sys

from aromm.cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
