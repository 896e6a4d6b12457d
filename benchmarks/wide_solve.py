"""A wide block of shifted solves (the certified bound's Gram matrices) by multigrid and by a sparse Cholesky factor.

The certificate of a reduced model (:mod:`aromm.reduction.certificate`) solves ``(K(μ̂) + σ C(μ̂)) Z = M`` for every
column of M (inputs, outputs, every affine term times the basis: 200–450 columns) at each of three shifts.  Above
:data:`~aromm.reduction.scipy_engine.DIRECT_BELOW` unknowns the engine iterates (multigrid-preconditioned CG), but a
block of :data:`~aromm.reduction.scipy_engine.WIDE_BLOCK` columns or more is factorised (CHOLMOD with the voxel grid's
nested dissection) up to :data:`~aromm.reduction.scipy_engine.WIDE_DIRECT_BELOW` unknowns.  For the wood VER of
``aromm.studies.chavez2020.small_wood(n)`` (scenario 1, lifted; box centre k_F = 0.316 W/(m K), c_F = 3.16e6
J/(m³ K), σ = 1 1/s, ``--columns`` random right-hand sides, rtol 1e-10) this prints, per method, the set-up and the
CPU seconds per column, and the process's peak memory (each method in a fresh process), on one BLAS thread.

    python benchmarks/wide_solve.py --sizes 32 46 --columns 200
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import resource
import subprocess
import sys
import time

CENTRE = {"fibre.k": 0.316, "fibre.c": 3.16e6}
SHIFT = 1.0  # 1/s


def worker(n: int, method: str, columns: int) -> dict[str, object]:
    """One method's solves in this process: ``mg`` by chunks narrower than WIDE_BLOCK, ``direct`` the whole block."""
    import numpy as np

    from aromm.api import assemble
    from aromm.reduction.lifting import lift
    from aromm.reduction.rom import one_blas_thread
    from aromm.reduction.scipy_engine import WIDE_BLOCK, ScipyEngine
    from aromm.studies.chavez2020 import loading, small_wood

    engine = ScipyEngine(lift(assemble(loading(small_wood(n), "z"))), "auto")
    b = np.random.default_rng(0).standard_normal((engine.size, columns))
    chunk = columns if method == "direct" else WIDE_BLOCK - 1
    with one_blas_thread():
        start = time.process_time()
        for lo in range(0, columns, chunk):
            engine.shifted_solve(CENTRE, SHIFT, b[:, lo:lo + chunk], 1e-10)
        total = time.process_time() - start
    stats = engine.stats
    return {"nodes": engine.size, "method": engine.method_for(chunk), "setup": stats.setup_seconds,
            "per_column": (total - stats.setup_seconds) / columns,
            "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[32, 46])
    parser.add_argument("--columns", type=int, default=200)
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(int(args.worker[0]), args.worker[1], args.columns)))
        return
    print(f"{'n³':>4} {'nodes':>8} {'method':>8} {'set-up CPU s':>12} {'CPU s/column':>12} {'peak GB':>7}  load   "
          f"({args.columns} columns, one BLAS thread)")
    for n in args.sizes:
        for method in ("mg", "direct"):
            out = subprocess.run([sys.executable, __file__, "--columns", str(args.columns), "--worker", str(n), method],
                                 check=True, capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            print(f"{n:4d} {r['nodes']:8d} {r['method']:>8} {r['setup']:12.2f} {r['per_column']:12.4f} "
                  f"{r['peak_gb']:7.2f}  {r['load']:.1f}", flush=True)


if __name__ == "__main__":
    main()
