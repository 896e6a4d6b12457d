"""Homogenisation side by side: aromm (multigrid, CHOLMOD, pyamg) against taufactor, and aromm at 256³.

Every case runs in a fresh process (one at a time) that reports CPU seconds (all threads), wall seconds and
its peak resident memory; the baseline (interpreter, libraries and the image, before any solver work) is
measured in the same process, so "state" bytes/voxel = (peak − baseline)/voxels and "all-in" = peak/voxels.
The machine is shared (2 cores): the load average is printed with every row.

Tables:

1. peers — sphere in a cube (κ = 10, r = L/3, 40³ and 80³; exact simple-cubic 1.39573), laminate (64³,
   layers normal to z, k 1 / 10; exact arithmetic and harmonic means), Gaussian-filtered random medium
   (σ = 2 voxels, periodic filter, 40 % of phase k = 0.3 W/(m K) in k = 0.025, 100³ and 200³).  aromm
   ``mg`` with periodic (full tensor) and fixed-temperature faces (taufactor's own condition), both at
   rtol 1e-8; taufactor's MultiPhaseSolver on the CPU along x (its default convergence, 1e-2 on the
   flux spread).  Seconds per direction: aromm's three directions share one multigrid setup (periodic).
2. crossover (``--crossover``) — periodic tensor of the random medium, n = 16 … 80: CHOLMOD (nested
   dissection), pyamg smoothed aggregation + CG, and multigrid, CPU seconds per direction and peak GB
   (64³ at most: CHOLMOD needs ~5.5 GB at 80³).
3. big (``--big 256``) — the random medium at 256³ with the multigrid: tensor, seconds per direction,
   peak GB and bytes/voxel.

Usage: python benchmarks/homogenize_peers.py [--quick] [--crossover] [--big 256] [--no-peers]
taufactor is optional (pip install ".[peers]", with torch==2.13.0 for a CPU build); absent, its rows say so.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

SC_EXACT = 1.39573
K_GAS, K_FIBRE = 0.025, 0.3


def image(case: str, n: int) -> tuple[np.ndarray, tuple[float, float], dict[str, float]]:
    """Labels (x, y, z) with phase 1 the conductive one, the two conductivities, and the exact values."""
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
    return (field > np.quantile(field, 0.6)).astype(np.uint8), (K_GAS, K_FIBRE), {}


def worker(spec: dict[str, object]) -> dict[str, object]:
    tool, case, n = str(spec["tool"]), str(spec["case"]), int(spec["n"])  # type: ignore[call-overload]
    labels, (k0, k1), exact = image(case, n)
    if tool == "taufactor":
        try:
            import taufactor
            import torch
        except ImportError:
            return {"skipped": "taufactor/torch not installed (pip install '.[peers]', torch==2.13.0 for CPU)"}
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        cpu, wall = time.process_time(), time.perf_counter()
        solver = taufactor.MultiPhaseSolver(labels + 1, cond={1: k0, 2: k1}, device="cpu")
        solver.solve(verbose=False)
        k = np.full((3, 3), np.nan)
        k[0, 0] = float(np.ravel(solver.D_eff)[0])
        out = {"k": k.tolist(), "cpu_per_direction": time.process_time() - cpu,
               "wall_per_direction": time.perf_counter() - wall, "iterations": [solver.iter],
               "threads": torch.get_num_threads()}
    else:
        from aromm.core.vocabulary import PhaseSpec
        from aromm.homogenization.cell_problems import effective_conductivity
        from aromm.scene.geometry import VoxelGeometry
        from aromm.scene.scene_file import Scene

        scene = Scene(VoxelGeometry(labels, (1e-3 / n,) * 3), (PhaseSpec("m", 0, k0), PhaseSpec("i", 1, k1)))
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        method, boundary = tool.split("-")
        cpu, wall = time.process_time(), time.perf_counter()
        result = effective_conductivity(scene, boundary, method)
        out = {"k": result.k.tolist(), "cpu_per_direction": (time.process_time() - cpu) / 3,
               "wall_per_direction": (time.perf_counter() - wall) / 3, "iterations": result.iterations,
               "setup_cpu": result.setup_cpu_seconds}
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {**out, "exact": exact, "peak": peak, "base": base, "voxels": n**3}


def run(spec: dict[str, object]) -> dict[str, object]:
    proc = subprocess.run([sys.executable, __file__, "--worker", json.dumps(spec)], capture_output=True, text=True,
                          check=False)
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit {proc.returncode}"
        return {"skipped": f"failed: {last}"}
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "load": os.getloadavg()[0]}


def row(label: str, spec: dict[str, object], res: dict[str, object]) -> str:
    head = f"{label:<16}{spec['tool']!s:<22}{spec['n']!s:>5}"
    if "skipped" in res:
        return f"{head}  {res['skipped']}"
    k = np.array(res["k"])
    exact: dict[str, float] = res["exact"]  # type: ignore[assignment]
    value = f"{k[0, 0]:.6f}" + (f" / zz {k[2, 2]:.6f}" if np.isfinite(k[2, 2]) else "")
    errors = [f"{ax} {(k['xyz'.index(ax[0]), 'xyz'.index(ax[1])] / v - 1) * 100:+.3f} %" for ax, v in exact.items()]
    peak, base, voxels = float(res["peak"]), float(res["base"]), float(res["voxels"])  # type: ignore[arg-type]
    its = res.get("iterations", [])
    return (f"{head}  {value:<28}{', '.join(errors) or '—':<26}{res['cpu_per_direction']:>8.2f}"
            f"{res['wall_per_direction']:>8.2f}{peak / 1e9:>7.2f}{peak / voxels:>8.0f}{(peak - base) / voxels:>8.0f}"
            f"  {its!s:<14}{res['load']:>5.1f}")


HEADER = (f"{'case':<16}{'tool':<22}{'n':>5}  {'k_xx (W/(m K))':<28}{'error vs exact':<26}{'CPU s/dir':>8}"
          f"{'wall s':>8}{'GB':>7}{'B/vox':>8}{'state':>8}  {'iterations':<14}{'load':>5}")


def peers(quick: bool) -> None:
    cases = [("sphere", 40), ("sphere", 80), ("laminate", 64), ("random", 100), ("random", 200)]
    if quick:
        cases = [("sphere", 40), ("laminate", 32), ("random", 64)]
    print("\n1. aromm vs taufactor (CPU); aromm rtol 1e-8, taufactor default convergence (1e-2 flux spread)")
    print(HEADER)
    for case, n in cases:
        for tool in ("mg-periodic", "mg-temperature", "taufactor"):
            spec = {"tool": tool, "case": case, "n": n}
            print(row(f"{case}", spec, run(spec)), flush=True)


def crossover(quick: bool) -> None:
    sizes = (16, 24, 32) if quick else (16, 24, 32, 40, 48, 64)  # CHOLMOD at 80³ needs ~5.5 GB
    print("\n2. crossover, periodic tensor of the random medium: CPU seconds per direction (setup included)")
    print(HEADER)
    for n in sizes:
        for tool in ("cholmod-periodic", "amg-periodic", "mg-periodic"):
            spec = {"tool": tool, "case": "random", "n": n}
            print(row("random", spec, run(spec)), flush=True)


def big(n: int) -> None:
    print(f"\n3. random medium at {n}³, multigrid, periodic (full tensor)")
    spec = {"tool": "mg-periodic", "case": "random", "n": n}
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
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} CPUs, "
          f"load {os.getloadavg()[0]:.1f} (shared machine: CPU seconds are the robust figure)")
    if not args.no_peers:
        peers(args.quick)
    if args.crossover:
        crossover(args.quick)
    if args.big:
        big(args.big)


if __name__ == "__main__":
    main()
