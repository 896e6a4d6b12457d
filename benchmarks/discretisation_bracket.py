"""Q1 elements and two-point finite volumes bracket the voxel geometry's conductivity (docs/method/finite_volumes.md).

The same image is split r³ ways (``Scene.refined``: the geometry does not change, only the discretisation), r = 1 … R:
the q1 values fall and the fv values rise towards the voxel geometry's k̄, which lies between them at every r.
Cases: a sphere in a cube (n = 6 voxels, κ = 10) and a white-noise image (5³, 40 % of k = 10 in k = 1), periodic
(the full tensor: its diagonal) and fixed-temperature faces; direct solves (CHOLMOD when installed), so the numbers
are exact to rounding.  Printed: k_xx of each, the gap (q1 − fv)/fv, and CPU seconds per case and discretisation.

Usage: python benchmarks/discretisation_bracket.py [--refine R]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace

import numpy as np

from aromm.core.vocabulary import PhaseSpec
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.linalg.direct import resolve_method
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene


def images() -> dict[str, np.ndarray]:
    c = (np.arange(6) + 0.5) / 6 - 0.5
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    return {"sphere 6³": (x**2 + y**2 + z**2 <= 1 / 9).astype(int),
            "noise 5³": (np.random.default_rng(0).random((5, 5, 5)) < 0.4).astype(int)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refine", type=int, default=4, help="largest split factor R (default 4)")
    args = parser.parse_args()
    method = resolve_method("auto")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} CPUs, load "
          f"{os.getloadavg()[0]:.1f}, solver {method}")
    print(f"{'case':<10}{'boundary':<13}{'r':>3}{'k_xx fv':>12}{'k_xx q1':>12}{'gap q1/fv−1':>13}{'CPU s fv':>10}"
          f"{'CPU s q1':>10}")
    phases = (PhaseSpec("matrix", 0, 1.0), PhaseSpec("inclusion", 1, 10.0))
    for name, labels in images().items():
        scene = Scene(VoxelGeometry(labels, (1e-3,) * 3), phases)
        for boundary in ("periodic", "temperature"):
            for r in range(1, args.refine + 1):
                k, cpu = {}, {}
                for disc in ("fv", "q1"):
                    start = time.process_time()
                    k[disc] = effective_conductivity(replace(scene.refined(r), discretisation=disc), boundary,
                                                     method).k[0, 0]
                    cpu[disc] = time.process_time() - start
                print(f"{name:<10}{boundary:<13}{r:>3}{k['fv']:>12.5f}{k['q1']:>12.5f}"
                      f"{(k['q1'] / k['fv'] - 1) * 100:>12.2f}%{cpu['fv']:>10.2f}{cpu['q1']:>10.2f}", flush=True)


if __name__ == "__main__":
    main()
