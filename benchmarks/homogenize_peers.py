"""Homogenisation side by side: aromm (multigrid, CHOLMOD, pyamg) against taufactor, and aromm at 256³.

Every case runs in a fresh process (one at a time) that reports CPU seconds (all threads), wall seconds and
its peak resident memory; the baseline (interpreter, libraries and the image, before any solver work) is
measured in the same process, so "state" bytes/voxel = (peak − baseline)/voxels and "all-in" = peak/voxels.
The machine is shared (2 cores): the 1-minute load average before → after each case is printed with every row.

Like for like: every tool runs on the same number of threads (``--threads N``, one by default), printed in every
row as the count the process actually had: each worker starts with OMP_NUM_THREADS, OPENBLAS_NUM_THREADS,
MKL_NUM_THREADS and NUMBA_NUM_THREADS = N, aromm's workers also under ``threadpoolctl.threadpool_limits(N)``,
taufactor's after ``torch.set_num_threads(N)``.  (Left on torch's default of one thread per core, taufactor spent
several times the CPU seconds of a one-thread run for the same answer.)  The ratio lines compare CPU seconds per
direction.

Equal tolerance: both tools stop on the accuracy of k itself.  taufactor stops when the heat flow through every
x-plane is within 1e-2 of the largest and τ changed by less than 2e-3 over 100 sweeps; its algebraic error at
that point, measured against the same SOR continued to a tighter flux spread, is 1e-4 to 8e-4 on these cases.
aromm stops each CG solve by ``ktol`` (default 1e-4): an a priori bound on the algebraic relative error of k
(aromm.homogenization.accuracy: the energy-error estimate of CG, bounded by Wiener's bounds), so aromm is held
to at least taufactor's accuracy.  Each row prints the error it reached ("alg. err", against its own tightly
converged value: aromm at a residual of 1e-10, taufactor continued to a 1e-3 flux spread — 1e-4 stalls in
float32 on the random medium, so its error is a lower estimate; untimed, ``--no-reference`` skips them).
``--ktol 0`` restores the residual criterion rtol 1e-8 (the library default).  ``--fv-rtol 1e-5`` adds a row of
aromm's fv stopped at that residual beside the one at 1e-8 (its algebraic error printed: the like-for-like row).

Tables:

1. peers — sphere in a cube (κ = 10, r = L/3, 40³ and 80³; exact simple-cubic 1.39573), laminate (64³,
   layers normal to z, k 1 / 10; exact arithmetic and harmonic means), Gaussian-filtered random medium
   (σ = 2 voxels, periodic filter, 40 % of phase k = 0.3 W/(m K) in k = 0.025, 100³ and 200³).  aromm
   ``mg`` with periodic (full tensor) and fixed-temperature faces (taufactor's own condition), both at
   ``ktol``; aromm's finite volumes (``fv``, aromm.fv: taufactor's discretisation) with fixed temperatures, pyamg CG
   to the residual rtol 1e-8; taufactor's MultiPhaseSolver on the CPU along x (its default convergence).  Also
   ``pores`` (the random medium's 40 % phase conducting through an insulating solid, k = 0: fv and taufactor's
   Solver only) and ``wood`` (the shipped 46³ VER).  Under each case: k_xx of fv against taufactor, and of q1 against
   fv (the same voxels and faces: the discretisation's share).  Seconds per
   direction (a third of aromm's total): its three periodic directions share one multigrid set-up, its three
   fixed-temperature directions one Galerkin hierarchy (constrained per axis; CoarseLevel.with_fixed).
2. crossover (``--crossover``) — periodic tensor of the random medium, n = 16 … 80: CHOLMOD (nested
   dissection), pyamg smoothed aggregation + CG, and multigrid, CPU seconds per direction and peak GB
   (64³ at most: CHOLMOD needs ~5.5 GB at 80³).
3. big (``--big 256``) — the random medium at 256³ with the multigrid: tensor, seconds per direction,
   peak GB and bytes/voxel.

Usage: nice python benchmarks/homogenize_peers.py [--threads N] [--ktol K] [--cases sphere:40 random:100 …]
[--quick] [--crossover] [--big 256] [--no-peers] [--no-reference]
taufactor is optional (pip install ".[peers]"; a CPU build of torch avoids the CUDA wheels); absent, its rows
say so.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

SC_EXACT = 1.39573
DEFAULT_KTOL = 1e-4
TAUFACTOR_REFERENCE = 1e-3  # flux spread of taufactor's reference run (its default: 1e-2; 1e-4 stalls in float32)
K_GAS, K_FIBRE = 0.025, 0.3


def image(case: str, n: int) -> tuple[np.ndarray, tuple[float, float], dict[str, float]]:
    """Labels (x, y, z) with phase 1 the conductive one, the two conductivities, and the exact values.

    ``pores``: the random medium's 40 % phase conducts (k = 1) through an insulating solid (k = 0: finite volumes and
    taufactor only); ``wood``: the shipped 46³ VER (data/wood_ver.npz, fibre 0.3 in gas 0.025; ``n`` ignored)."""
    if case == "wood":
        with np.load(os.path.join(os.path.dirname(__file__), "..", "data", "wood_ver.npz")) as data:
            labels = np.asarray(data[data.files[0]]).astype(np.uint8)
        return labels, (K_GAS, K_FIBRE), {}
    if case == "sphere":
        c = (np.arange(n) + 0.5) / n - 0.5
        x, y, z = np.meshgrid(c, c, c, indexing="ij")
        return (x**2 + y**2 + z**2 <= 1 / 9).astype(np.uint8), (1.0, 10.0), {"xx": SC_EXACT}
    if case == "laminate":
        labels = np.zeros((n, n, n), dtype=np.uint8)
        labels[:, :, : n // 2] = 1
        return labels, (1.0, 10.0), {"xx": 5.5, "zz": 2 / 1.1}
    import scipy.ndimage as ndi

    field = ndi.gaussian_filter(np.random.default_rng(0).standard_normal((n, n, n)), 2.0, mode="wrap")
    return (field > np.quantile(field, 0.6)).astype(np.uint8), (0.0, 1.0) if case == "pores" else (K_GAS, K_FIBRE), {}


#: libraries aromm's solvers import on first use (the coarsest grid's CHOLMOD, pyamg): imported before the clock
LAZY_IMPORTS = {"mg": ("cvxopt.cholmod",), "cholmod": ("cvxopt.cholmod",), "amg": ("pyamg",),
                "auto": ("cvxopt.cholmod", "pyamg", "aromm.fv.compiled")}  # fv: its compiled kernels (numba)
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def worker(spec: dict[str, object]) -> dict[str, object]:
    tool, case, n = str(spec["tool"]), str(spec["case"]), int(spec["n"])  # type: ignore[call-overload]
    threads = int(spec["threads"])  # type: ignore[call-overload]
    labels, (k0, k1), exact = image(case, n)
    if tool == "taufactor":
        try:
            import taufactor
            import torch
        except ImportError:
            return {"skipped": "taufactor/torch not installed (pip install '.[peers]', a CPU torch)"}
        torch.set_num_threads(threads)
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        cpu, wall = time.process_time(), time.perf_counter()
        solver = (taufactor.Solver(labels, device="cpu") if k0 == 0.0 else  # D_eff relative to the conducting phase
                  taufactor.MultiPhaseSolver(labels + 1, cond={1: k0, 2: k1}, device="cpu"))
        solver.solve(verbose=False)
        k = np.full((3, 3), np.nan)
        k[0, 0] = float(np.ravel(solver.D_eff)[0]) * (k1 if k0 == 0.0 else 1.0)
        out = {"k": k.tolist(), "cpu_per_direction": time.process_time() - cpu,
               "wall_per_direction": time.perf_counter() - wall, "iterations": [solver.iter],
               "threads": torch.get_num_threads()}
        if spec.get("reference"):  # untimed: the same SOR continued to a 100× tighter flux spread
            solver.converged = False
            solver.solve(verbose=False, conv_crit=TAUFACTOR_REFERENCE, iter_limit=200_000)
            out["reference_xx"] = float(np.ravel(solver.D_eff)[0]) * (k1 if k0 == 0.0 else 1.0)
    else:
        from threadpoolctl import threadpool_info, threadpool_limits

        from aromm.core.vocabulary import PhaseSpec
        from aromm.homogenization.cell_problems import effective_conductivity
        from aromm.scene.geometry import VoxelGeometry
        from aromm.scene.scene_file import Scene

        method, boundary = tool.split("-")
        scene = Scene(VoxelGeometry(labels, (1e-3 / n,) * 3), (PhaseSpec("m", 0, k0), PhaseSpec("i", 1, k1)),
                      discretisation="fv" if method == "fv" else "q1")
        method = "auto" if method == "fv" else method  # fv: the matrix-free multigrid from 20³ voxels (fv_cells)
        for backend in LAZY_IMPORTS.get(method, ()):  # before the clock, as taufactor's torch is
            importlib.import_module(backend)
        if method == "auto":  # numba loads each kernel on its first call: once on a small box, before the clock; of
            # phase 1, which conducts in every case (a box of pores' insulating phase 0 solved nothing: ≈ 0.1 s per
            # direction of kernel loading was timed)
            effective_conductivity(Scene(VoxelGeometry(np.ones((24, 24, 24), dtype=np.uint8), (1e-3,) * 3),
                                         scene.phases, discretisation="fv"), boundary, method)
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        ktol = None if spec.get("ktol") is None else float(spec["ktol"])  # type: ignore[arg-type]
        with threadpool_limits(limits=threads):
            cpu, wall = time.process_time(), time.perf_counter()
            rtol = float(spec["rtol"]) if spec.get("rtol") else 1e-8  # type: ignore[arg-type]
            result = effective_conductivity(scene, boundary, method, rtol=rtol, ktol=ktol)
            cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            pools = [int(pool["num_threads"]) for pool in threadpool_info()]
            out = {"k": result.k.tolist(), "cpu_per_direction": cpu / 3, "wall_per_direction": wall / 3,
                   "iterations": result.iterations, "setup_cpu": result.setup_cpu_seconds,
                   "threads": max(pools, default=1)}
            if spec.get("reference"):  # untimed: the same cell problems solved to a residual of 1e-10
                out["reference_xx"] = float(effective_conductivity(scene, boundary, method, rtol=1e-10).k[0, 0])
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {**out, "exact": exact, "peak": peak, "base": base, "voxels": n**3}


def run(spec: dict[str, object]) -> dict[str, object]:
    """One case in a fresh process whose thread pools all start at ``spec["threads"]``."""
    env = {**os.environ, **dict.fromkeys(THREAD_VARIABLES, str(spec["threads"]))}
    load = os.getloadavg()[0]
    proc = subprocess.run([sys.executable, __file__, "--worker", json.dumps(spec)], capture_output=True, text=True,
                          check=False, env=env)
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit {proc.returncode}"
        return {"skipped": f"failed: {last}"}
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "load": (load, os.getloadavg()[0])}


def row(label: str, spec: dict[str, object], res: dict[str, object]) -> str:
    head = f"{label:<10}{spec.get('name', spec['tool'])!s:<16}{spec['n']!s:>4}"
    if "skipped" in res:
        return f"{head}  {res['skipped']}"
    k = np.array(res["k"])
    exact: dict[str, float] = res["exact"]  # type: ignore[assignment]
    value = f"{k[0, 0]:.6f}" + (f" / zz {k[2, 2]:.6f}" if np.isfinite(k[2, 2]) else "")
    errors = [f"{ax} {(k['xyz'.index(ax[0]), 'xyz'.index(ax[1])] / v - 1) * 100:+.3f} %" for ax, v in exact.items()
              if np.isfinite(k["xyz".index(ax[0]), "xyz".index(ax[1])])]
    peak, base, voxels = float(res["peak"]), float(res["base"]), float(res["voxels"])  # type: ignore[arg-type]
    its = res.get("iterations", [])
    load_before, load_after = (float(v) for v in res["load"])  # type: ignore[attr-defined]
    algebraic = f"{abs(k[0, 0] / float(res['reference_xx']) - 1):.1e}" if "reference_xx" in res else "—"  # type: ignore[arg-type]
    return (f"{head}{res['threads']!s:>4}  {value:<28}{', '.join(errors) or '—':<24}{algebraic:>9}"
            f"{res['cpu_per_direction']:>10.3f}{res['wall_per_direction']:>8.3f}{peak / 1e9:>6.2f}{peak / voxels:>7.0f}"
            f"{(peak - base) / voxels:>7.0f}  {its!s:<14}{load_before:>5.1f} → {load_after:.1f}")


HEADER = (f"{'case':<10}{'tool':<16}{'n':>4}{'thr':>4}  {'k_xx (W/(m K))':<28}{'error vs exact':<24}{'alg. err':>9}"
          f"{'CPU s/dir':>10}{'wall s':>8}{'GB':>6}{'B/vox':>7}{'state':>7}  {'iterations':<14}{'load 1 min':>12}")


def ratios(results: dict[str, dict[str, object]]) -> str:
    """taufactor's CPU seconds per direction over each aromm row's, from rows of one case in one run."""
    peer = results.get("taufactor", {})
    if "cpu_per_direction" not in peer:
        return ""
    parts = [f"{float(peer['cpu_per_direction']) / float(res['cpu_per_direction']):.2f} vs {tool}"  # type: ignore[arg-type]
             for tool, res in results.items() if tool != "taufactor" and "cpu_per_direction" in res]
    line = "  CPU s/dir taufactor / aromm: " + ", ".join(parts)
    fv, q1 = results.get("fv-temperature", {}), results.get("mg-temperature", {})
    if "k" in fv and "k" in peer:
        line += f"\n  k_xx fv / taufactor − 1: {(fv['k'][0][0] / peer['k'][0][0] - 1) * 100:+.3f} %"  # type: ignore[index]
    if "k" in fv and "k" in q1:
        line += f"; q1 / fv − 1: {(q1['k'][0][0] / fv['k'][0][0] - 1) * 100:+.3f} % (same faces, same voxels)"  # type: ignore[index]
    return line


PEER_CASES = ("sphere:40", "sphere:80", "laminate:64", "random:100", "random:200", "pores:100", "wood:46")
CASES = ("sphere", "laminate", "random", "pores", "wood")
QUICK_CASES = ("sphere:40", "laminate:32", "random:64")


def peers(cases: list[str], threads: int, ktol: float | None, reference: bool, fv_rtol: float | None = None) -> None:
    tolerance = "rtol 1e-8 (residual)" if ktol is None else f"ktol {ktol:g} (bound on the algebraic error of k)"
    print(f"\n1. aromm vs taufactor (CPU, {threads} thread(s) each); aromm {tolerance}, taufactor its default "
          f"convergence (1e-2 flux spread, 2e-3 change of τ); alg. err = |k_xx / k_xx,ref − 1|, ref = aromm at "
          f"rtol 1e-10, taufactor continued to a {TAUFACTOR_REFERENCE:g} flux spread (untimed)")
    print(HEADER)
    for case_size in cases:
        case, n = case_size.split(":")
        results = {}
        tools = ("fv-temperature", "taufactor") if case == "pores" else \
            ("mg-periodic", "mg-temperature", "fv-temperature", "taufactor")
        loose = [("fv-temperature", f"fv@{fv_rtol:g}")] if fv_rtol else []
        for tool, name in [(t, t) for t in tools[:-1]] + loose + [(tools[-1], tools[-1])]:
            spec: dict[str, object] = {"tool": tool, "name": name, "case": case, "n": int(n), "threads": threads,
                                       "ktol": ktol, "reference": reference, "rtol": fv_rtol if name != tool else None}
            results[name] = run(spec)
            print(row(case, spec, results[name]), flush=True)
        if line := ratios(results):
            print(line, flush=True)


def crossover(quick: bool, threads: int) -> None:
    sizes = (16, 24, 32) if quick else (16, 24, 32, 40, 48, 64)  # CHOLMOD at 80³ needs ~5.5 GB
    print("\n2. crossover, periodic tensor of the random medium: CPU seconds per direction (setup included)")
    print(HEADER)
    for n in sizes:
        for tool in ("cholmod-periodic", "amg-periodic", "mg-periodic"):
            spec: dict[str, object] = {"tool": tool, "case": "random", "n": n, "threads": threads}
            print(row("random", spec, run(spec)), flush=True)


def big(n: int, threads: int) -> None:
    print(f"\n3. random medium at {n}³, multigrid, periodic (full tensor)")
    spec: dict[str, object] = {"tool": "mg-periodic", "case": "random", "n": n, "threads": threads}
    res = run(spec)
    print(HEADER)
    print(row("random", spec, res))
    if "k" in res:
        print("k tensor (W/(m K)):")
        for line in np.array(res["k"]):
            print("   " + "  ".join(f"{v:+.6f}" for v in line))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--quick", action="store_true", help="small sizes only (a minute)")
    parser.add_argument("--no-peers", action="store_true")
    parser.add_argument("--crossover", action="store_true")
    parser.add_argument("--big", type=int, default=0, help="also the random medium at this size (e.g. 256)")
    parser.add_argument("--ktol", type=float, default=DEFAULT_KTOL,
                        help=f"aromm's bound on the algebraic relative error of k (default {DEFAULT_KTOL:g}, at most "
                             "taufactor's measured error at its default); 0: the residual rtol 1e-8 instead")
    parser.add_argument("--fv-rtol", type=float, default=None,
                        help="also run aromm's fv to this residual (e.g. 1e-5), its algebraic error of k printed "
                             "beside taufactor's: the like-for-like row at equal or better accuracy")
    parser.add_argument("--no-reference", action="store_true",
                        help="skip the untimed reference solves that measure each tool's algebraic error")
    parser.add_argument("--threads", type=int, default=1,
                        help="threads of every tool, set in each fresh process (default 1: like for like)")
    parser.add_argument("--cases", nargs="+", metavar="CASE:N",
                        help=f"peer cases to run (default {' '.join(PEER_CASES)}; cases {', '.join(CASES)})")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return
    if args.threads < 1:
        parser.error(f"--threads must be a positive integer, got {args.threads}")
    cases = args.cases or list(QUICK_CASES if args.quick else PEER_CASES)
    for case_size in cases:
        case, _, n = case_size.partition(":")
        if case not in CASES or not n.isdigit() or int(n) < 2:
            parser.error(f"--cases takes CASE:N with CASE among {', '.join(CASES)} and N ≥ 2, got {case_size!r}")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} CPUs, {args.threads} "
          f"thread(s) per tool, load {os.getloadavg()[0]:.1f} (shared machine: CPU seconds are the robust figure)")
    if not args.no_peers:
        peers(cases, args.threads, args.ktol or None, not args.no_reference, args.fv_rtol)
    if args.crossover:
        crossover(args.quick, args.threads)
    if args.big:
        big(args.big, args.threads)


if __name__ == "__main__":
    main()
