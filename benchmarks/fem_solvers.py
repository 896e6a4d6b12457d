"""Cost of the full-order voxel model, and what resolution buys in accuracy.

Prints two tables:

1. For cubes of N^3 voxels (two random-free phases: a wood-like VER from the shipped
   generator): assembly, factorisation, steady solve, transient step, and the peak
   resident memory of a fresh process doing all of it (N = 20, 46, 80 by default).
   The factorisation is timed with the nested-dissection ordering the solvers use and,
   with --amd, with CHOLMOD's own AMD ordering for comparison.
2. Sphere of radius L/3 in a cube, contrast 10: k_eff by the flux method ([Chavez2020]
   eq. 13) against resolution, its error against the exact simple-cubic value
   1.39573 (docs/notes/solver_facts.md; Maxwell 1.39503 for comparison), and the seconds.

Usage: python benchmarks/fem_solvers.py [--sizes 20 46 80] [--solver auto|cholmod|splu|amg] [--steps 50]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np

EXACT_SC = 1.39573  # kappa = 10, phi = 4 pi / 81, simple-cubic array (docs/notes/solver_facts.md)


def one_size(n: int, solver: str, steps: int, amd: bool) -> dict[str, float]:
    from aromm.core.system import Affine, TimeGrid
    from aromm.core.vocabulary import FaceSpec, PhaseSpec
    from aromm.fem import assemble_voxels
    from aromm.full.solve import steady_field, transient
    from aromm.linalg.direct import factorize
    from aromm.microstructure import wood

    labels = wood((n, n, n), 5e-6, np.random.default_rng(0))
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    faces = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)]
    t0 = time.perf_counter()
    system = assemble_voxels(labels, (5e-6,) * 3, phases, faces, time=TimeGrid(steps * 0.1, 0.1),
                             outputs=["z0", "z1"])
    t_assemble = time.perf_counter() - t0
    v = system.values()
    t0, c0 = time.perf_counter(), time.process_time()
    fac = factorize(system.conductance.evaluate(v), solver, points=system.geometry.points)
    t_factor, c_factor = time.perf_counter() - t0, time.process_time() - c0
    c_amd = float("nan")
    if amd and solver != "amg":
        c0 = time.process_time()
        factorize(system.conductance.evaluate(v), solver)
        c_amd = time.process_time() - c0
    t0 = time.perf_counter()
    fac.solve(system.load.evaluate(v))
    t_solve = time.perf_counter() - t0
    del fac
    t0 = time.perf_counter()
    steady_field(replace(system, capacity=Affine(), time=None), method=solver)
    t_steady = time.perf_counter() - t0
    t0 = time.perf_counter()
    transient(system, method=solver, scheme="bdf2")
    t_transient = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {"n": n, "dofs": system.n, "assemble_s": t_assemble, "factor_s": t_factor, "factor_cpu_s": c_factor,
            "factor_amd_cpu_s": c_amd, "solve_s": t_solve, "steady_s": t_steady, "transient_s": t_transient,
            "steps": steps, "peak_MB": peak}


def sphere_convergence(sizes: list[int], solver: str) -> list[tuple[int, float, float, float]]:
    from aromm.homogenization.properties import homogenize
    from aromm.scene.scene_file import scene_from_dict

    rows = []
    for n in sizes:
        scene = scene_from_dict({"geometry": {"generator": "sphere_in_cube", "n": n, "voxel_size": 1e-3 / n},
                                 "phases": {"m": {"label": 0, "k": 1.0}, "p": {"label": 1, "k": 10.0}}})
        t0 = time.perf_counter()
        k = homogenize(scene, boundary="flux", method=solver)[0, 0]
        rows.append((n, k, 100 * (k / EXACT_SC - 1), time.perf_counter() - t0))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[20, 46, 80])
    parser.add_argument("--sphere", type=int, nargs="+", default=[12, 24, 36, 48])
    parser.add_argument("--solver", default="auto")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--amd", action="store_true", help="also time the AMD ordering (slow in 3-D)")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one_size(args.one, args.solver, args.steps, args.amd)))
        return
    print(f"Full-order voxel model (wood-like VER, scenario 1, solver {args.solver}, {args.steps} BDF2 steps)")
    print(f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: wall times include contention;"
          " the CPU time of the single-threaded factorisation does not)")
    print(f"{'N^3':>6} {'DOF':>9} {'assemble s':>11} {'factor s':>9} {'(cpu s)':>8} {'AMD cpu s':>10} "
          f"{'solve s':>8} {'steady s':>9} {'transient s':>12} {'s/step':>7} {'peak MB':>8}")
    for n in args.sizes:
        command = [sys.executable, __file__, "--one", str(n), "--solver", args.solver, "--steps", str(args.steps)]
        out = subprocess.run(command + (["--amd"] if args.amd else []), capture_output=True, text=True, check=False)
        if out.returncode != 0:
            print(f"{n:>6} failed: {out.stderr.strip().splitlines()[-1] if out.stderr else out.returncode}")
            continue
        r = json.loads(out.stdout)
        print(f"{n:>6} {r['dofs']:>9} {r['assemble_s']:>11.2f} {r['factor_s']:>9.2f} {r['factor_cpu_s']:>8.2f} "
              f"{r['factor_amd_cpu_s']:>10.2f} {r['solve_s']:>8.3f} "
              f"{r['steady_s']:>9.2f} {r['transient_s']:>12.2f} {r['transient_s'] / r['steps']:>7.3f} "
              f"{r['peak_MB']:>8.0f}")
    print()
    print(f"Sphere (radius L/3) in a cube, contrast 10, flux method; exact SC value {EXACT_SC}")
    print(f"{'N':>4} {'k_eff':>9} {'error %':>8} {'seconds':>8}")
    for n, k, err, sec in sphere_convergence(args.sphere, args.solver):
        print(f"{n:>4} {k:>9.5f} {err:>+8.3f} {sec:>8.2f}")


if __name__ == "__main__":
    main()
