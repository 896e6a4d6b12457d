"""Shifted solves of the Krylov reduction: CHOLMOD against multigrid-PCG, per set-up and per right-hand side.

For the wood VERs of ``aromm.studies.chavez2020.small_wood(n)`` (scenario 1), the scipy engine of the Krylov reduction
(aromm.reduction.scipy_engine) solves ``(K(μ) + s C(μ)) X = B`` at k_F = 0.1 W/(m K) and three shifts s (1/60, 0.6,
30 1/s) for the load and the two outputs (3 right-hand sides) to the relative residual 1e-10, with each solver.
It prints the mean CPU seconds of a set-up (factorisation, or multigrid hierarchy) and of one right-hand side,
the largest CG iteration count, the break-even number of right-hand sides per set-up, CPU and wall seconds,
the load average and the peak memory: the data behind ``DIRECT_BELOW``.

    python benchmarks/krylov_solvers.py --sizes 16 24 32 40
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np

from aromm.reduction.rom import one_blas_thread
from aromm.reduction.scipy_engine import ScipyEngine
from aromm.scene.scene_file import assemble
from aromm.studies.chavez2020 import loading, small_wood

SHIFTS = (1 / 60, 0.6, 30.0)  # 1/s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 24, 32, 40])
    args = parser.parse_args()
    print(f"{'n³':>4} {'unknowns':>9} {'cholmod set-up s':>16} {'per rhs s':>9} {'mg set-up s':>11} {'per rhs s':>9} "
          f"{'CG its':>6} {'break-even rhs':>14} {'CPU s':>7} {'wall s':>7}  load")
    for n in args.sizes:
        wall, cpu = time.perf_counter(), time.process_time()
        system = assemble(loading(small_wood(n), "z"))
        costs = {}
        for solver in ("cholmod", "mg"):
            engine = ScipyEngine(system, solver)
            rhs = np.column_stack([engine.inputs({})[:, :1], engine.output_block()])
            with one_blas_thread():
                for s in SHIFTS:
                    engine.shifted_solve({"fibre.k": 0.1}, s, rhs, 1e-10)
            st = engine.stats
            costs[solver] = (st.setup_seconds / st.setups, st.solve_seconds / st.solves, max(st.iterations or [0]))
        (cs, cr, _), (ms, mr, its) = costs["cholmod"], costs["mg"]
        even = (cs - ms) / (mr - cr) if mr > cr else float("inf")
        print(f"{n:4d} {system.n:9d} {cs:16.3f} {cr:9.4f} {ms:11.3f} {mr:9.4f} {its:6d} {even:14.1f} "
              f"{time.process_time() - cpu:7.1f} {time.perf_counter() - wall:7.1f}  {os.getloadavg()[0]:.1f}",
              flush=True)
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")


if __name__ == "__main__":
    main()
