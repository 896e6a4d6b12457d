"""Peak resident memory per rank of the petsc engine, stage by stage, on n³ wood VERs at P ranks (oversubscribed
cores measure memory, not speed).

Two kinds of run, each ``mpiexec -n P`` of this file in worker mode, one fresh process per rank:

* ``--kind reduce``: the whole reduced-model build (``api.reduce(..., engine="petsc")``, order ``--order``,
  correction modes on): the per-stage peaks the engine records (aromm.engines.petsc.memory: assembly, basis =
  SLEPc eigensolves, corrections, projection, amalgam);
* ``--kind operators``: what every build holds apart from the eigensolver's workspace, without the hours of the
  eigensolves at large n: the box assembly, one steady CG + GAMG solve (the hierarchy every inner solve keeps),
  one basis of ``--modes`` columns (random numbers: its memory, not its values) and the projection of every term
  onto it.

Printed per stage: the largest peak over the ranks (MB), the peak as bytes per unknown ((peak × P) / N: what a
rank costs per unknown it owns), and the marginal bytes per unknown above the resident memory of a rank once
Python, numpy/scipy and PETSc are loaded (the fixed cost of a rank); with the load average and wall seconds.

Usage: python benchmarks/petsc_memory.py [--sizes 24 32] [--ranks 1 2 4] [--kind reduce|operators]
       [--order 20] [--modes 94] [--solver gamg]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_mpi_yield_when_idle": "1", "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}


def worker(n: int, kind: str, order: int, modes: int, solver: str) -> dict[str, object] | None:
    import numpy as np

    from aromm import api
    from aromm.engines.petsc import runtime
    from aromm.engines.petsc.memory import StageMemory, resident_bytes
    from aromm.engines.petsc.projection import project
    from aromm.engines.petsc.reduction import distributed
    from aromm.engines.petsc.steady import steady
    from aromm.studies.chavez2020 import loading, small_wood

    comm = runtime.world()
    scene = loading(small_wood(n, box=n * 5e-6), "z", end=60.0, dt=0.5)
    fixed = runtime.allmax(float(resident_bytes()), comm)
    start = time.perf_counter()
    if kind == "reduce":
        rom = api.reduce(scene, order, cache=False, engine="petsc", solver=solver)
        record = {k: float(v) for k, v in rom.info.items() if str(k).endswith(("_peak_bytes", "_rise_bytes"))}
        used_modes = int(rom.info["modes"])
    else:
        memory = StageMemory(comm)
        memory.start("assembly")
        system = distributed(scene, comm)
        memory.start("steady")
        steady(system, solver=solver)
        memory.start("basis")
        basis = np.asfortranarray(np.random.default_rng(0).standard_normal((system.rows.local, modes)))
        memory.start("projection")
        project(system, basis)
        record = memory.record()
        used_modes = modes
    if not runtime.is_root(comm):
        return None
    return {"n": n, "ranks": runtime.size(comm), "unknowns": (n + 1) ** 3, "kind": kind, "modes": used_modes,
            "fixed_bytes": fixed, "wall": time.perf_counter() - start, "load": os.getloadavg()[0], **record}


def measure(n: int, ranks: int, args: argparse.Namespace) -> dict[str, object]:
    command = ["mpiexec", "-n", str(ranks), sys.executable, str(Path(__file__).resolve()), "--worker", str(n),
               "--kind", args.kind, "--order", str(args.order), "--modes", str(args.modes), "--solver", args.solver]
    run = subprocess.run(["nice", *command], capture_output=True, text=True, env={**os.environ, **MPI_ENV},
                         cwd=ROOT, check=False)
    if run.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{run.stderr[-4000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def rows(r: dict[str, object]) -> list[str]:
    n, p, unknowns = int(r["n"]), int(r["ranks"]), int(r["unknowns"])  # type: ignore[call-overload]
    fixed = float(r["fixed_bytes"])  # type: ignore[arg-type]
    out = []
    for key, value in r.items():
        if key.endswith("_peak_bytes"):
            stage, peak = key.removesuffix("_peak_bytes"), float(value)  # type: ignore[arg-type]
            out.append(f"{n:>4}³ {unknowns:>9,} {p:>2} {r['kind']:>9} {r['modes']:>5} {stage:>11} "
                       f"{peak / 2**20:>9.0f} {peak * p / unknowns:>10,.0f} {(peak - fixed) * p / unknowns:>10,.0f} "
                       f"{fixed / 2**20:>7.0f} {float(r['wall']):>7.0f} {float(r['load']):>5.1f}")  # type: ignore[arg-type]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[24, 32])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--kind", choices=("reduce", "operators"), default="reduce")
    parser.add_argument("--order", type=int, default=20, help="reduced order of --kind reduce")
    parser.add_argument("--modes", type=int, default=94, help="basis columns of --kind operators")
    parser.add_argument("--solver", choices=("gamg", "mumps"), default="gamg")
    parser.add_argument("--json", type=Path, default=None, help="append the raw records to this file")
    parser.add_argument("--worker", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        record = worker(args.worker, args.kind, args.order, args.modes, args.solver)
        if record is not None:
            print(json.dumps(record))
        return
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores (shared; ranks > cores are oversubscribed), "
          f"load {os.getloadavg()[0]:.1f}, inner solver {args.solver}")
    print("   n   unknowns  P      kind modes       stage  peak MB/r  B/unknown  marginal  fixed MB  wall s  load")
    for n in args.sizes:
        for p in args.ranks:
            record = measure(n, p, args)
            for line in rows(record):
                print(line, flush=True)
            if args.json is not None:
                with args.json.open("a", encoding="utf-8") as fh:
                    fh.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
