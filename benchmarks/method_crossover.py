"""Where ``method="auto"`` switches from the amalgam to the Krylov reduction: offline cost of both, by size.

For the wood VERs of ``aromm.studies.chavez2020.small_wood(n)`` (scenario 1, the scene's ``[reduction]`` reference
values), each method builds its model with no cache in a fresh process on one BLAS thread: the amalgam
[Chavez2020, § 3] at its defaults (ñ = 200 from Ñ = 320 modes, ARPACK or LOBPCG by size, correction vectors) and the
Krylov reduction (:mod:`aromm.reduction.krylov`, its defaults over the scene's box, order ≤ 200).  It prints, per
size and method, the order, CPU and wall seconds of the build, the peak memory of the process, the load average,
and the largest difference between the two models' face means at the reference values over the scene's output
times (the Krylov model is within 1e-6 °C of the exact outputs at 24³ and 46³, benchmarks/mor_peers.py, so the
difference is the amalgam's error).  The crossover is the first size where the Krylov build costs less CPU.

    python benchmarks/method_crossover.py --sizes 12 16 20 24 32
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
import tempfile
import time

import numpy as np

METHODS = ("aromm", "krylov")


def build(n: int, method: str, out: str) -> None:
    """One build in this process: its record on stdout, its face means at the reference values in ``out``."""
    from aromm.reduction.offline import reduce
    from aromm.scene.scene_file import assemble
    from aromm.studies.chavez2020 import loading, small_wood

    scene = loading(small_wood(n), "z")
    system = assemble(scene)
    wall, cpu = time.perf_counter(), time.process_time()
    rom = reduce(system, settings=scene.reduction.updated(method=method), cache=False)
    record = {"n": n, "unknowns": system.n, "method": method, "order": rom.order,
              "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
              "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, "load": os.getloadavg()[0]}
    np.save(out, rom.simulate(dict(scene.reduction.reference)).as_array())
    print(json.dumps(record))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[12, 16, 20, 24, 32])
    parser.add_argument("--one", nargs=3, metavar=("N", "METHOD", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        build(int(args.one[0]), args.one[1], args.one[2])
        return
    print(f"{'n³':>4} {'unknowns':>9} {'method':>7} {'order':>5} {'CPU s':>7} {'wall s':>7} {'peak GB':>7} "
          f"{'load':>5} {'|amalgam - krylov| °C':>22}")
    crossover = None
    with tempfile.TemporaryDirectory() as work:
        for n in args.sizes:
            rows, outputs = {}, {}
            for method in METHODS:
                out = os.path.join(work, f"{n}-{method}.npy")
                text = subprocess.run([sys.executable, __file__, "--one", str(n), method, out], check=True,
                                      capture_output=True, text=True).stdout
                rows[method], outputs[method] = json.loads(text.strip().splitlines()[-1]), np.load(out)
            gap = float(np.abs(outputs["aromm"] - outputs["krylov"]).max())
            for method in METHODS:
                r = rows[method]
                print(f"{n:4d} {r['unknowns']:9d} {method:>7} {r['order']:5d} {r['cpu']:7.1f} {r['wall']:7.1f} "
                      f"{r['peak_gb']:7.2f} {r['load']:5.1f} {gap:22.2e}", flush=True)
            if crossover is None and rows["krylov"]["cpu"] < rows["aromm"]["cpu"]:
                crossover = rows["krylov"]["unknowns"]
    print(f"first size where the Krylov build costs less CPU: {crossover} unknowns" if crossover else
          "the amalgam was cheaper at every size")


if __name__ == "__main__":
    main()
