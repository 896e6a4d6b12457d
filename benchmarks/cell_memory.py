"""Peak memory and CPU seconds of the q1 cell problems (multigrid) on a white-noise medium, each run in a fresh process.

The medium: n³ voxels, each of phase 1 (k = 10 W/(m K)) with probability 0.4, else phase 0 (k = 1), seed 0; the
periodic tensor or the three fixed-temperature probes, CG to the residual ``--rtol`` (1e-8), one thread
(OMP/OPENBLAS/NUMBA_NUM_THREADS = 1 in every worker).  Peak = ``ru_maxrss`` of the worker (all-in: interpreter,
numpy, scipy, numba and the image), baseline = the same before the solve; bytes per voxel = bytes / n³.

``--keep-vectors`` adds the same runs with :meth:`aromm.linalg.multigrid.pcg.MultigridSolver.release` disabled (the
solver keeps CG's and the V-cycle's vectors between the cell problems' solves, as before 2594910): what releasing
them saves in memory and costs in time.

Usage: python benchmarks/cell_memory.py [--n 200] [--boundaries periodic temperature] [--keep-vectors]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def worker(n: int, boundary: str, rtol: float, keep: bool) -> dict[str, object]:
    import numpy as np

    from aromm.core.vocabulary import PhaseSpec
    from aromm.homogenization.cell_problems import effective_conductivity
    from aromm.linalg.multigrid.pcg import MultigridSolver
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import Scene

    if keep:
        MultigridSolver.release = lambda self: None  # type: ignore[method-assign]
    labels = (np.random.default_rng(0).random((n, n, n)) < 0.4).astype(np.uint8)
    phases = (PhaseSpec("m", 0, 1.0), PhaseSpec("i", 1, 10.0))
    small = Scene(VoxelGeometry(np.zeros((24, 24, 24), dtype=np.uint8), (1e-3,) * 3), phases)
    effective_conductivity(small, boundary, "mg")  # numba compiles or loads its kernels before the clock
    scene = Scene(VoxelGeometry(labels, (1e-3 / n,) * 3), phases)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    cpu = time.process_time()
    result = effective_conductivity(scene, boundary, "mg", rtol=rtol)
    cpu = time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {"k": np.diag(result.k).tolist(), "iterations": result.iterations, "cpu": cpu, "peak": peak, "base": base}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--boundaries", nargs="+", default=["periodic", "temperature"],
                        choices=["periodic", "temperature"])
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--keep-vectors", action="store_true")
    parser.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        n, boundary, rtol, keep = args.worker
        print(json.dumps(worker(int(n), boundary, float(rtol), keep == "keep")))
        return
    env = {**os.environ, **dict.fromkeys(THREADS, "1")}
    voxels = args.n ** 3
    print(f"# {args.n}³ white noise (40 % k = 10 in k = 1), rtol {args.rtol:g}, one thread, load "
          f"{os.getloadavg()[0]:.2f}")
    print(f"{'boundary':>12} {'vectors':>9} {'CPU s':>7} {'B/voxel':>8} {'state':>6} {'iterations':>12}  "
          "k_xx k_yy k_zz")
    for boundary in args.boundaries:
        for keep in (["release", "keep"] if args.keep_vectors else ["release"]):
            proc = subprocess.run([sys.executable, __file__, "--worker", str(args.n), boundary, str(args.rtol), keep],
                                  capture_output=True, text=True, check=True, env=env)
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            k = " ".join(f"{v:.6f}" for v in r["k"])
            print(f"{boundary:>12} {keep:>9} {r['cpu']:7.1f} {r['peak'] / voxels:8.1f} "
                  f"{(r['peak'] - r['base']) / voxels:6.1f} {r['iterations']!s:>12}  {k}", flush=True)


if __name__ == "__main__":
    main()
