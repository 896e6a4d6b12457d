"""method="krylov" on the petsc engine (KSP solves only) against the scipy engine: cost per rank and agreement.

For each size n (the wood VER of benchmarks/petsc_engine.py: n³ voxels of 5 µm, [Chavez2020] scenario 1, outputs
every 0.5 s to 60 s) and each engine / rank count, one fresh process (or ``mpiexec -n P``) builds the Krylov
reduced model of order ``--order`` over the identification box k_F ∈ [0.1, 1] W/(m K), c_F ∈ [1e6, 1e7] J/(m³ K)
(the reductor's defaults otherwise: 6 shifts, 2 moments, tolerance 1e-5 °C, rtol 1e-10, gramian compression).
Printed side by side: wall seconds, CPU seconds per rank (``time.process_time``, largest over the ranks), the
ratio to the scipy engine's CPU, peak resident memory per rank (``ru_maxrss``, largest) and per unknown, the
shifted solves (count, set-ups, mean CG iterations, CPU seconds of set-ups and of solves), the span and its
parameter points, and the largest difference of the face means from the scipy engine's model (°C) at the box's
centre and at its slow corner, at the output times; the load average before and after each run (the machine
is shared).  The scipy engine solves by multigrid-PCG above 30,000 unknowns (aromm.reduction.scipy_engine).

Usage: python benchmarks/petsc_krylov.py [--sizes 32] [--ranks 1 2] [--order 50] [--solvers auto gamg] [--json OUT]
[--baseline EARLIER.json]
(needs petsc4py/slepc4py/mpi4py and mpiexec: README "Running on a cluster").  Worker mode (one measurement,
JSON on stdout): --worker N --engine scipy|petsc.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from petsc_engine import MPI_ENV, scene  # noqa: E402

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1.0e6, 1.0e7)}
POINTS = ({"fibre.k": float(np.sqrt(0.1)), "fibre.c": float(np.sqrt(1e13))}, {"fibre.k": 0.1, "fibre.c": 1.0e7})
INFO = ("solves", "setups", "cg_iterations_mean", "setup_seconds", "solve_seconds", "krylov_span", "krylov_points",
        "compression_loss", "krylov_estimate")
#: PETSc events whose counts the records keep (the cost model of docs/scaling.md reads them).
EVENTS = ("KSPSolve", "PCSetUp", "PCApply", "MatMult", "MatPtAP", "VecMDot", "VecNorm", "VecDot", "VecAXPY",
          "VecScatterBegin", "VecScatterEnd", "VecReduceComm")


def _resident_bytes() -> float:
    """Resident memory of this process now (VmRSS), bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return float(line.split()[1]) * 1024
    return 0.0


def worker(n: int, engine: str, order: int, solver: str) -> dict[str, object]:
    """One measurement in this process (all ranks under mpiexec); the record is complete on rank 0."""
    import aromm
    from aromm.scene.scene_file import assemble

    load_before = os.getloadavg()[0]
    if engine == "petsc":
        from aromm.engines import find_debian_petsc

        find_debian_petsc()  # Debian's petsc4py is on sys.path only once its PETSC_DIR is found
        from petsc4py import PETSc

        PETSc.Log.begin()  # counts of the events (calls, flops, messages, bytes, reductions) per rank
    fixed = _resident_bytes()  # Python, numpy, scipy (and PETSc) loaded, nothing built yet
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sc = scene(n)
    if engine == "petsc":
        rom = aromm.reduce(sc, order, method="krylov", bounds=BOX, cache=False, engine="petsc", solver=solver)
    else:
        rom = aromm.reduce(assemble(sc), order, method="krylov", bounds=BOX, cache=False)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    mine = {"cpu": cpu, "peak": float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024), "fixed": fixed}
    if engine == "petsc":
        from aromm.engines.petsc import runtime

        mine["events"] = {e: PETSc.Log.Event(e).getPerfInfo() for e in EVENTS}
        ranks = runtime.mpi(runtime.world()).gather(mine, root=0)
        if not runtime.is_root(runtime.world()):
            return {}
    else:
        ranks = [mine]
    return {"n": n, "engine": engine, "ranks": len(ranks), "unknowns": (n + 1) ** 3, "order": rom.order,
            "wall": wall, "cpu": [r["cpu"] for r in ranks], "peak": [r["peak"] for r in ranks],
            "fixed": [r["fixed"] for r in ranks], "events": [r.get("events", {}) for r in ranks],
            "info": {k: float(rom.info[k]) for k in INFO}, "solver": str(rom.info["solver"]),
            "stages": {k: float(v) for k, v in rom.info.items() if k.endswith("_bytes")},
            "load": [load_before, os.getloadavg()[0]],
            "outputs": [rom.simulate(p).as_array().tolist() for p in POINTS]}


def run(n: int, engine: str, ranks: int, order: int, solver: str) -> dict[str, object]:
    cmd = [sys.executable, __file__, "--worker", str(n), "--engine", engine, "--order", str(order), "--solver", solver]
    if engine == "petsc":
        cmd = ["mpiexec", "-n", str(ranks), *cmd]
    env = {**os.environ, **MPI_ENV, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[32], help="image sizes n (n³ voxels)")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2], help="rank counts of the petsc runs")
    parser.add_argument("--order", type=int, default=50, help="order of the reduced model")
    parser.add_argument("--solvers", nargs="+", default=["auto", "gamg"],
                        help="petsc solvers of the shifted systems (auto: geometric multigrid where the grid halves; "
                             "mg, gamg, mumps)")
    parser.add_argument("--solver", default="auto", help=argparse.SUPPRESS)
    parser.add_argument("--json", help="also write the records to this file")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="JSON records of an earlier run whose scipy record of each size is the baseline "
                             "(not re-run)")
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--engine", default="scipy", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        record = worker(args.worker, args.engine, args.order, args.solver)
        if record:
            print(json.dumps(record))
        return
    records = []
    print(f"{'n':>4} {'unknowns':>9} {'engine':>14} {'P':>2} {'wall s':>8} {'CPU s/rank':>10} {'ratio':>6} "
          f"{'peak MB/rank':>12} {'B/unknown':>9} {'solves':>6} {'setups':>6} {'CG its':>6} {'setup s':>8} "
          f"{'solve s':>8} {'span':>5} {'pts':>4} {'Δ centre °C':>11} {'Δ corner °C':>11} {'load':>10}")
    for n in args.sizes:
        earlier = json.loads(args.baseline.read_text()) if args.baseline else []
        known = [r for r in earlier if r["engine"] == "scipy" and r["n"] == n]
        base = known[0] if known else run(n, "scipy", 1, args.order, "auto")
        cases = [("scipy", 1, base)] + [("petsc", p, run(n, "petsc", p, args.order, solver))
                                        for solver in args.solvers for p in args.ranks]
        for engine, p, rec in cases:
            records.append(rec)
            cpu, peak, info = max(rec["cpu"]), max(rec["peak"]), rec["info"]
            diff = [float(np.abs(np.asarray(a) - np.asarray(b)).max()) for a, b in zip(rec["outputs"], base["outputs"],
                                                                                     strict=True)]
            name = f"{engine} {rec['solver']}"
            print(f"{n:>4} {rec['unknowns']:>9,} {name:>14} {p:>2} {rec['wall']:>8.1f} {cpu:>10.1f} "
                  f"{cpu / max(base['cpu']):>6.2f} {peak / 2**20:>12.0f} {peak / rec['unknowns']:>9,.0f} "
                  f"{info['solves']:>6.0f} {info['setups']:>6.0f} {info['cg_iterations_mean']:>6.1f} "
                  f"{info['setup_seconds']:>8.1f} {info['solve_seconds']:>8.1f} {info['krylov_span']:>5.0f} "
                  f"{info['krylov_points']:>4.0f} {diff[0]:>11.1e} {diff[1]:>11.1e} "
                  f"{rec['load'][0]:>4.1f}–{rec['load'][1]:<4.1f}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(records, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
