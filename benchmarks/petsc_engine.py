"""The petsc engine against the scipy engine: reduced-model build and one steady solve on growing wood VERs.

For each size n (n³ voxels of 5 µm, the spruce-like image of aromm.studies.chavez2020.small_wood, [Chavez2020]
scenario 1)
and each engine / rank count, one fresh process (or ``mpiexec -n P``) builds the AROMM reduced model of order
``--order`` (Ñ = 1.5 ñ + 20 modes, correction modes on) and solves one steady state; it prints, side by side:
wall seconds, CPU seconds per rank (``time.process_time``), peak resident memory per rank (``ru_maxrss``),
bytes per voxel (peak of all ranks / voxels), the seconds of each offline stage, the load average of the
machine before and after (the machine is shared: ~6 agents on 2 cores), and the largest difference of the
reduced model's face means from the scipy engine's (°C).  Then the growth exponents d log(cost) / d log(N)
(N unknowns) fitted over the sizes, the inputs of docs/scaling.md.

``--eigensolvers arpack lobpcg`` measures the petsc engine's two eigenbasis methods side by side (SLEPc
Krylov–Schur shift-invert with tight inner solves, against Generalized Davidson + GAMG, aromm.engines.petsc.eigen):
the basis stage's seconds and the preconditioned eigensolver's iterations (Steklov + Dirichlet) are printed.

Usage: python benchmarks/petsc_engine.py [--sizes 16 24 32 48] [--ranks 1 2] [--order 40] [--solver gamg]
       [--eigensolvers auto] [--no-scipy] [--json results.json]
(needs petsc4py/slepc4py/mpi4py and mpiexec: README "Running on a cluster"; OMPI_ALLOW_RUN_AS_ROOT is set for
Open MPI under root.)  Worker mode (one measurement, JSON on stdout): --worker N --engine scipy|petsc.
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
PROBE = {"fibre.k": 0.4, "fibre.c": 3.5e6}
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_mpi_yield_when_idle": "1"}


def scene(n: int):  # type: ignore[no-untyped-def]
    from aromm.studies.chavez2020 import loading, small_wood

    return loading(small_wood(n, box=n * 5e-6), "z", end=60.0, dt=0.5)


def worker(n: int, engine: str, order: int, solver: str, eigensolver: str = "auto") -> dict[str, object]:
    """One measurement in this process (all ranks under mpiexec); the record is complete on rank 0."""
    import aromm
    from aromm.scene.scene_file import assemble

    load_before = os.getloadavg()[0]
    cpu0, wall0 = time.process_time(), time.perf_counter()
    sc = scene(n)
    if engine == "petsc":
        rom = aromm.reduce(sc, order, cache=False, engine="petsc", solver=solver, eigensolver=eigensolver)
    else:
        rom = aromm.reduce(assemble(sc), order, cache=False)
    build_wall, build_cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    steady_scene = sc.with_boundary(sc.boundary, sc.outputs, time=None)
    wall1, cpu1 = time.perf_counter(), time.process_time()
    if engine == "petsc":
        means = aromm.simulate(steady_scene, engine="petsc", method=solver).as_array()
    else:
        means = aromm.simulate(assemble(steady_scene)).as_array()
    steady_wall, steady_cpu = time.perf_counter() - wall1, time.process_time() - cpu1
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # bytes (Linux reports KiB)
    mine = {"cpu": build_cpu, "steady_cpu": steady_cpu, "peak": float(peak)}
    if engine == "petsc":
        from aromm.engines.petsc import runtime

        ranks = runtime.mpi(runtime.world()).gather(mine, root=0)
        if not runtime.is_root(runtime.world()):
            return {}
    else:
        ranks = [mine]
    stages = {k: float(v) for k, v in rom.info.items() if str(k).endswith("_seconds")}
    return {"n": n, "engine": engine, "ranks": len(ranks), "unknowns": (n + 1) ** 3, "order": rom.order,
            "modes": rom.info["modes"], "wall": build_wall, "steady_wall": steady_wall,
            "cpu": [r["cpu"] for r in ranks], "steady_cpu": [r["steady_cpu"] for r in ranks],
            "peak": [r["peak"] for r in ranks], "stages": stages, "load": [load_before, os.getloadavg()[0]],
            "rom": rom.simulate(PROBE).as_array().tolist(), "steady": means.tolist(),
            "reference_error": float(rom.info["reference_error"]),
            "eigensolver": str(rom.info.get("eigensolver", "arpack" if engine == "petsc" else "scipy")),
            "iterations": int(sum(float(rom.info.get(f"{k}_iterations", 0)) for k in ("steklov", "dirichlet")))}


def measure(n: int, engine: str, ranks: int, order: int, solver: str, *, eigensolver: str = "auto",
            ) -> dict[str, object]:
    args = [sys.executable, str(Path(__file__).resolve()), "--worker", str(n), "--engine", engine, "--order",
            str(order), "--solver", solver, "--eigensolver", eigensolver]
    if engine == "petsc":
        args = ["mpiexec", "-n", str(ranks), *args]
    run = subprocess.run(args, capture_output=True, text=True, env={**os.environ, **MPI_ENV}, cwd=ROOT, check=False)
    if run.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{run.stderr[-4000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def row(r: dict[str, object], scipy: dict[str, object] | None) -> str:
    peak = np.asarray(r["peak"], dtype=float)
    cpu = np.asarray(r["cpu"], dtype=float)
    stages = r["stages"]
    assert isinstance(stages, dict)
    diff = "" if scipy is None else f"{np.abs(np.asarray(r['rom']) - np.asarray(scipy['rom'])).max():9.1e}"
    steady = "" if scipy is None else f"{np.abs(np.asarray(r['steady']) - np.asarray(scipy['steady'])).max():9.1e}"
    stage = " ".join(f"{k.removesuffix('_seconds')[:5]}={v:.0f}" for k, v in stages.items() if k != "offline_seconds")
    load = r["load"]
    assert isinstance(load, list)
    eig = f"{str(r.get('eigensolver', ''))[:6]:>6} {r.get('iterations', 0):>5}"
    return (f"{r['n']:>4}³ {r['unknowns']:>9,} {r['engine']:>6} {r['ranks']:>2} {eig} {r['wall']:>8.1f} "
            f"{cpu.max():>8.1f} "
            f"{peak.max() / 2**20:>8.0f} {peak.sum() / int(r['n']) ** 3:>8.0f} {r['steady_wall']:>7.1f} "
            f"{load[0]:>5.1f}/{load[1]:<5.1f} {diff:>9} {steady:>9}  {stage}")


def exponents(results: list[dict[str, object]]) -> list[str]:
    lines = []
    for engine, ranks, eig in sorted({(str(r["engine"]), int(r["ranks"]), str(r.get("eigensolver")))  # type: ignore[call-overload]
                                      for r in results}):
        runs = [r for r in results if r["engine"] == engine and r["ranks"] == ranks and r.get("eigensolver") == eig]
        if len(runs) < 2:
            continue
        n = np.log([float(r["unknowns"]) for r in runs])  # type: ignore[arg-type]
        fits = {
            "build CPU/rank": [max(r["cpu"]) for r in runs],  # type: ignore[call-overload]
            "build wall": [r["wall"] for r in runs],
            "steady wall": [r["steady_wall"] for r in runs],
            "peak memory/rank": [max(r["peak"]) for r in runs],  # type: ignore[call-overload]
        }
        parts = [f"{k} N^{np.polyfit(n, np.log(np.asarray(v, dtype=float)), 1)[0]:.2f}" for k, v in fits.items()]
        lines.append(f"{engine:>6} ×{ranks} {eig}: " + ", ".join(parts))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 24, 32, 48])
    parser.add_argument("--ranks", type=int, nargs="*", default=[1, 2],
                        help="rank counts of the petsc runs (none: scipy only)")
    parser.add_argument("--order", type=int, default=40)
    parser.add_argument("--solver", choices=("gamg", "mumps"), default="gamg")
    parser.add_argument("--eigensolvers", nargs="+", choices=("auto", "arpack", "lobpcg"), default=["auto"],
                        help="the petsc engine's eigenbasis methods, each measured (arpack: shift-invert)")
    parser.add_argument("--eigensolver", default="auto", help=argparse.SUPPRESS)
    parser.add_argument("--no-scipy", action="store_true", help="skip the scipy engine (e.g. where it cannot fit)")
    parser.add_argument("--json", type=Path, default=None, help="append the raw records to this file")
    parser.add_argument("--worker", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--engine", choices=("scipy", "petsc"), default="petsc", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        record = worker(args.worker, args.engine, args.order, args.solver, args.eigensolver)
        if record:
            print(json.dumps(record))
        return
    print(f"python {sys.version.split()[0]}, order {args.order}, petsc inner solver {args.solver}, "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f} (shared machine)")
    print("   n   unknowns engine  P eigen  iters   wall s  CPU s/r  peak MB/r  B/voxel steady s  load b/a   ΔT̄ rom  "
          "ΔT̄ steady  "
          "stages (s, rank 0)")
    results: list[dict[str, object]] = []

    def keep(record: dict[str, object], scipy: dict[str, object] | None) -> None:
        results.append(record)
        print(row(record, scipy), flush=True)
        if args.json is not None:  # appended as measured: a long series interrupted keeps what it measured
            with args.json.open("a", encoding="utf-8") as fh:
                fh.write(json.dumps(record) + "\n")

    for n in args.sizes:
        scipy = None if args.no_scipy else measure(n, "scipy", 1, args.order, args.solver)
        if scipy is not None:
            keep(scipy, None)
        for p in args.ranks:
            for eigensolver in args.eigensolvers:
                keep(measure(n, "petsc", p, args.order, args.solver, eigensolver=eigensolver), scipy)
    print("growth over the sizes (least-squares slope of log cost against log unknowns):")
    for line in exponents(results):
        print("  " + line)


if __name__ == "__main__":
    main()
