"""What resolution costs in homogenisation: boundary conditions against n, and sub-voxel refinement.

Tables:

1. Sphere in a cube (κ = 10, r = L/3, exact simple-cubic 1.39573) for each boundary condition
   (periodic, flux = [Chavez2020, eq. 13], temperature) against n: k_xx, its error, the error after the
   volume-fraction correction k + dk/dφ (φ − φ_n) (Maxwell's slope; the voxel sphere's fraction scatters
   around 4π/81), CPU seconds (multigrid, rtol 1e-8, three directions).  Then Richardson extrapolation
   2 k(2n) − k(n) (first order) of the corrected values for each pair (n, 2n).
2. Laminate (layers normal to z, 1 / 10, half and half) along its layers: periodic and temperature are
   exact at every n, flux converges to a wrong limit (the uniform-flux face is not isothermal).
3. ``--refine``: the shipped wood VER (data/scenes/wood_homogenize.toml, 46³) with every voxel split into
   R³ elements, R = 1, 2, 3 (``aromm homogenize --refine R``): periodic k̄ diagonal, CPU seconds, peak GB
   (a fresh process per R), the observed order p from k(h) = k* + C h^p with h = 1/R, and k*.

Usage: python benchmarks/homogenize_resolution.py [--quick] [--max-refine 3]
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

ROOT = Path(__file__).resolve().parent.parent
SC_EXACT = 1.39573
PHI = 4 * np.pi / 81


def maxwell(phi: float, kappa: float = 10.0) -> float:
    return (kappa + 2 + 2 * phi * (kappa - 1)) / (kappa + 2 - phi * (kappa - 1))


SLOPE = (maxwell(PHI + 1e-6) - maxwell(PHI - 1e-6)) / 2e-6


def _scene(labels: np.ndarray, k1: float = 10.0):  # type: ignore[no-untyped-def]
    from aromm.core.vocabulary import PhaseSpec
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import Scene

    n = labels.shape[0]
    return Scene(VoxelGeometry(labels, (1e-3 / n,) * 3), (PhaseSpec("m", 0, 1.0), PhaseSpec("i", 1, k1)))


def sphere(n: int) -> np.ndarray:
    c = (np.arange(n) + 0.5) / n - 0.5
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    return (x**2 + y**2 + z**2 <= 1 / 9).astype(np.uint8)


def sphere_table(sizes: tuple[int, ...]) -> None:
    from aromm.core.choices import BOUNDARIES
    from aromm.homogenization.cell_problems import effective_conductivity

    print("\n1. sphere in a cube, κ = 10, exact 1.39573: error against n for each boundary condition")
    print(f"{'boundary':<12}{'n':>5}{'φ_n':>9}{'k_xx':>11}{'error %':>10}{'φ-corrected %':>15}{'n × corr. %':>13}"
          f"{'CPU s':>8}{'iterations':>14}")
    corrected: dict[str, dict[int, float]] = {b: {} for b in BOUNDARIES}
    for boundary in BOUNDARIES:
        for n in sizes:
            labels = sphere(n)
            phi = float(labels.mean())
            cpu = time.process_time()
            result = effective_conductivity(_scene(labels), boundary, "mg")
            seconds = time.process_time() - cpu
            k = float(result.k[0, 0])
            kc = k + SLOPE * (PHI - phi)
            corrected[boundary][n] = kc
            print(f"{boundary:<12}{n:>5}{phi:>9.5f}{k:>11.6f}{(k / SC_EXACT - 1) * 100:>+10.3f}"
                  f"{(kc / SC_EXACT - 1) * 100:>+15.3f}{n * (kc / SC_EXACT - 1) * 100:>+13.1f}{seconds:>8.2f}"
                  f"{max(result.iterations):>14}", flush=True)
    print("Richardson 2 k(2n) − k(n) of the φ-corrected values (first order), error against 1.39573:")
    for boundary in BOUNDARIES:
        pairs = [(n, 2 * n) for n in sizes if 2 * n in sizes]
        cells = [f"({a}, {b}): {((2 * corrected[boundary][b] - corrected[boundary][a]) / SC_EXACT - 1) * 100:+.3f} %"
                 for a, b in pairs]
        print(f"  {boundary:<12}" + "   ".join(cells))


def laminate_table(sizes: tuple[int, ...]) -> None:
    from aromm.core.choices import BOUNDARIES
    from aromm.homogenization.cell_problems import effective_conductivity

    print("\n2. laminate (layers normal to z, k 1 / 10, half and half): k_xx along the layers, exact 5.5")
    print(f"{'n':>5}" + "".join(f"{b + ' error %':>22}" for b in BOUNDARIES))
    for n in sizes:
        labels = np.zeros((n, n, n), dtype=np.uint8)
        labels[:, :, : n // 2] = 1
        errors = [effective_conductivity(_scene(labels), b, "mg").k[0, 0] / 5.5 - 1 for b in BOUNDARIES]
        print(f"{n:>5}" + "".join(f"{e * 100:>+22.4f}" for e in errors), flush=True)


def refine_worker(factor: int) -> dict[str, object]:
    from aromm.homogenization.cell_problems import effective_conductivity
    from aromm.scene.scene_file import load_scene

    scene = load_scene(ROOT / "data" / "scenes" / "wood_homogenize.toml").refined(factor)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    cpu, wall = time.process_time(), time.perf_counter()
    result = effective_conductivity(scene, "periodic", "mg")
    return {"k": np.diag(result.k).tolist(), "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
            "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, "base": base,
            "shape": list(scene.geometry.labels.shape), "iterations": result.iterations}


def observed_order(values: list[float]) -> tuple[float, float]:
    """p and k* of k(h) = k* + C h^p through h = 1, 1/2, 1/3 (bisection on the ratio of differences)."""
    ratio = (values[0] - values[1]) / (values[1] - values[2])

    def f(p: float) -> float:
        return (1 - 2.0**-p) / (2.0**-p - 3.0**-p) - ratio

    lo, hi = 0.05, 8.0
    if f(lo) * f(hi) > 0:
        return float("nan"), float("nan")
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
    p = (lo + hi) / 2
    c = (values[0] - values[1]) / (1 - 2.0**-p)
    return p, values[2] - c * 3.0**-p


def refine_table(max_refine: int) -> None:
    print("\n3. wood VER (46³ voxels, 5 µm) with --refine R: periodic k̄ (W/(m K)), multigrid, rtol 1e-8")
    print(f"{'R':>3}{'elements':>16}{'k_xx':>10}{'k_yy':>10}{'k_zz':>10}{'CPU s':>9}{'wall s':>9}{'peak GB':>9}"
          f"{'B/voxel':>9}{'load':>6}")
    ks = []
    for factor in range(1, max_refine + 1):
        proc = subprocess.run([sys.executable, __file__, "--worker", str(factor)], capture_output=True, text=True,
                              check=True)
        res = json.loads(proc.stdout.strip().splitlines()[-1])
        ks.append(res["k"])
        voxels = float(np.prod(res["shape"]))
        print(f"{factor:>3}{'×'.join(map(str, res['shape'])):>16}" + "".join(f"{v:>10.5f}" for v in res["k"])
              + f"{res['cpu']:>9.1f}{res['wall']:>9.1f}{res['peak'] / 1e9:>9.2f}{res['peak'] / voxels:>9.0f}"
              f"{os.getloadavg()[0]:>6.1f}", flush=True)
    if len(ks) >= 3:
        fits = [observed_order([k[axis] for k in ks[:3]]) for axis in range(3)]
        print("observed order p:  " + "  ".join(f"{ax} {p:.2f}" for ax, (p, _) in zip("xyz", fits, strict=True)))
        gaps = ", ".join(f"{(ks[0][a] / fits[a][1] - 1) * 100:+.2f} %" for a in range(3))
        print("extrapolated k*:   " + "  ".join(f"{ax} {v:.5f}" for ax, (_, v) in zip("xyz", fits, strict=True))
              + f"   (1× differs from k* by {gaps})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--max-refine", type=int, default=3)
    parser.add_argument("--only", choices=("sphere", "laminate", "refine"), default=None)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(refine_worker(args.worker)))
        return
    print(f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f} (shared machine: CPU seconds are the robust figure)")
    sizes = (10, 20, 30, 40) if args.quick else (10, 20, 30, 40, 60, 80)
    if args.only in (None, "sphere"):
        sphere_table(sizes)
    if args.only in (None, "laminate"):
        laminate_table((8, 16, 32) if args.quick else (8, 16, 32, 64))
    if args.only in (None, "refine"):
        refine_table(2 if args.quick else args.max_refine)


if __name__ == "__main__":
    main()
