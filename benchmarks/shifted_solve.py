"""One shifted solve of the Krylov reduction on the matrix-free multigrid, with the kernel's share of its cost.

For the wood VER of ``aromm.studies.chavez2020.small_wood(n)`` (scenario 1, matrix-free terms as in
benchmarks/reduce_scaling.py), the scipy engine solves ``(K(μ) + s C(μ)) X = B`` at the centre of the box
(k_F = 0.316 W/(m K), c_F = 3.16e6 J/(m³ K)), s = 0.1 1/s, for the first two input columns to the relative residual
1e-10 from a zero guess, then once more for C X (the next Krylov step, the hierarchy reused).  It prints the set-up
and both solves in CPU seconds, the CG iterations, the process's user and system CPU seconds and minor page faults
(``getrusage``: system time is where fresh mappings of large arrays are paid), its peak memory and the load.

    python benchmarks/shifted_solve.py --sizes 128 256
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
from pathlib import Path

CENTRE = {"fibre.k": 0.316, "fibre.c": 3.16e6}
SHIFT = 0.1  # 1/s


def worker(n: int) -> dict[str, object]:
    """The two solves in this process (a fresh one per size: getrusage and the peak are the process's)."""
    sys.path.insert(0, str(Path(__file__).parent))
    from reduce_scaling import matrix_free_system

    from aromm.reduction.lifting import lift
    from aromm.reduction.rom import one_blas_thread
    from aromm.reduction.scipy_engine import ScipyEngine
    from aromm.studies.chavez2020 import loading, small_wood

    scene = loading(small_wood(n), "z")
    engine = ScipyEngine(lift(matrix_free_system(scene), scene.reduction.basis, "auto"), "auto")
    before = resource.getrusage(resource.RUSAGE_SELF)
    with one_blas_thread():
        b = engine.inputs(CENTRE)[:, :2]
        start = time.process_time()
        x = engine.shifted_solve(CENTRE, SHIFT, b, 1e-10)
        first = time.process_time() - start
        start = time.process_time()
        engine.shifted_solve(CENTRE, SHIFT, engine.capacity(CENTRE, x), 1e-10)
        second = time.process_time() - start
    after = resource.getrusage(resource.RUSAGE_SELF)
    stats = engine.stats
    return {"n": n, "nodes": int(engine.size), "setup_cpu_s": stats.setup_seconds, "first_cpu_s": first,
            "second_cpu_s": second, "iterations": list(stats.iterations),
            "user_s": after.ru_utime - before.ru_utime, "system_s": after.ru_stime - before.ru_stime,
            "minor_faults": after.ru_minflt - before.ru_minflt, "peak_gb": after.ru_maxrss / 1e6,
            "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker)))
        return
    print(f"{'n³':>4} {'nodes':>10} {'set-up s':>8} {'solve s':>8} {'again s':>8} {'CG its':>14} {'user s':>7} "
          f"{'system s':>8} {'faults':>9} {'peak GB':>7}  load   (CPU s of the process, one BLAS thread)")
    for n in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--worker", str(n)], check=True, capture_output=True,
                             text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        its = ",".join(str(i) for i in r["iterations"])
        print(f"{n:4d} {r['nodes']:10d} {r['setup_cpu_s']:8.1f} {r['first_cpu_s']:8.1f} {r['second_cpu_s']:8.1f} "
              f"{its:>14} {r['user_s']:7.1f} {r['system_s']:8.1f} {r['minor_faults']:9d} {r['peak_gb']:7.2f}  "
              f"{r['load']:.1f}", flush=True)


if __name__ == "__main__":
    main()
