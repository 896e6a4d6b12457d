"""What the fibre axis read from the image costs and how wrong it is: the structure tensor's scale ``axis_sigma``.

A fibre phase with ``axis = "image"`` (aromm.core.anisotropy) takes each voxel's axis from the structure tensor of the
phase's mask [BigunGranlund1987].  The knob is its Gaussian integration scale σ (voxels).  Truth: voxelised
straight round fibres of radius R voxels, all along t = (0, sin θ, cos θ) (θ = 30°: no lattice direction, so the
staircase is real), on an n³ image.

Table 1, per (R, σ): the angle between each fibre voxel's axis and t (mean, 90th percentile, degrees), CPU seconds
and peak bytes per voxel of the axes (tracemalloc: numpy's arrays).
Table 2, per σ (R = 3): the periodic k̄ tensor of fibres (k_axial 2, k_transverse 0.4 W/(m K)) in a matrix
(0.1 W/(m K)) with the axes from the image, against the same image with the exact axis t given: the relative
Frobenius difference of k̄, and CPU seconds of the homogenisation.

Usage: python benchmarks/fibre_axes.py [--quick]   (prints the load average beside the timings)
"""

from __future__ import annotations

import argparse
import math
import os
import time
import tracemalloc

import numpy as np

THETA = math.radians(30.0)
AXIS = np.array([0.0, math.sin(THETA), math.cos(THETA)])


def rods(n: int, radius: float, spacing: float) -> np.ndarray:
    """Voxels whose centre lies within ``radius`` of a fibre axis; axes along AXIS on a square lattice of
    ``spacing`` voxels in the plane (x, u), u = (0, cos θ, −sin θ)."""
    c = np.arange(n) + 0.5
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    s = y * math.cos(THETA) - z * math.sin(THETA)
    dx = (x % spacing) - spacing / 2
    ds = (s % spacing) - spacing / 2
    return (dx**2 + ds**2 <= radius**2).astype(np.int32)


def axis_table(n: int, radii: tuple[float, ...], sigmas: tuple[float, ...]) -> None:
    from aromm.core.anisotropy import fibre_axes

    print(f"Table 1: per-voxel fibre axis from the structure tensor, {n}³ image, θ = 30° (border reflect)")
    print("   R   sigma  fibre voxels  mean err (deg)  p90 err (deg)   CPU s   bytes/voxel")
    fibre_axes(rods(8, 2.0, 8.0) == 1, 1.0)  # warm-up: scikit-image's imports are not the method's cost
    for radius in radii:
        mask = rods(n, radius, spacing=3 * radius + 2) == 1
        for sigma in sigmas:
            tracemalloc.start()
            cpu = time.process_time()
            axes = fibre_axes(mask, sigma, "reflect")
            seconds = time.process_time() - cpu
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            angle = np.degrees(np.arccos(np.clip(np.abs(axes @ AXIS), 0.0, 1.0)))
            print(f"{radius:4.1f} {sigma:7.2f} {int(mask.sum()):13d} {angle.mean():15.3f} "
                  f"{np.percentile(angle, 90):14.3f} {seconds:7.3f} {peak / mask.size:13.1f}")


def tensor_table(n: int, sigmas: tuple[float, ...]) -> None:
    from aromm.core.anisotropy import PhaseTensor
    from aromm.core.vocabulary import PhaseSpec
    from aromm.homogenization.properties import homogenize
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import Scene

    labels = rods(n, 3.0, spacing=11.0)
    matrix = PhaseSpec("matrix", 0, 0.1)
    exact_axis = PhaseTensor("fibre", (2.0, 0.4), ((0.0, math.sin(THETA), math.cos(THETA)),))
    geometry = VoxelGeometry(labels, (1e-5,) * 3)
    exact = homogenize(Scene(geometry, (matrix, PhaseSpec("fibre", 1, 2.0, tensor=exact_axis))), method="cholmod")
    print(f"\nTable 2: periodic k̄ with axes from the image against the exact axis, {n}³, R = 3, "
          f"fibre fraction {labels.mean():.3f}")
    print(f"exact-axis k̄ (W/(m K)): diag {np.round(np.diag(exact), 5).tolist()}, k̄_yz {exact[1, 2]:.5f}")
    print("  sigma   |Δk̄|/|k̄|   k̄_yz (image)   CPU s")
    for sigma in sigmas:
        spec = PhaseTensor("fibre", (2.0, 0.4), None, sigma, "reflect")
        cpu = time.process_time()
        k = homogenize(Scene(geometry, (matrix, PhaseSpec("fibre", 1, 2.0, tensor=spec))), method="cholmod")
        seconds = time.process_time() - cpu
        print(f"{sigma:7.2f} {np.linalg.norm(k - exact) / np.linalg.norm(exact):11.3e} {k[1, 2]:14.5f} "
              f"{seconds:7.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a 24³ image and fewer cases")
    args = parser.parse_args()
    n = 24 if args.quick else 48
    sigmas = (1.0, 2.0) if args.quick else (0.75, 1.0, 1.5, 2.0, 3.0)
    print(f"load average at start {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    axis_table(n, (2.0,) if args.quick else (2.0, 3.0, 4.0), sigmas)
    tensor_table(24 if args.quick else 33, sigmas)
    print(f"load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
