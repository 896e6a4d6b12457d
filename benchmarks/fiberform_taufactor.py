"""NASA PuMA's public FiberForm sample (100³) in aromm's finite volumes and in taufactor, direction by direction.

The image is ``python/pumapy/data/100_fiberform.tif`` of github.com/nasa/puma (not shipped; ``--image PATH``),
segmented as PuMA's tests do: grey ≥ 90 is fibre (k = 12 W/(m K)), the rest air (0.0257 W/(m K)); voxel 1.3 µm.
Fixed temperatures on the two faces of each array axis (tifffile's order: pages, rows, columns = PuMA's z, y, x),
the others adiabatic.  aromm: ``--discretisation fv``,
the matrix-free multigrid (:mod:`aromm.fv.multigrid`) at the library's residual 1e-8; taufactor 1.2
``MultiPhaseSolver`` at its default stop (1 % flux spread), along the first array axis of the image turned so that
axis comes first.  One thread each (``NUMBA_NUM_THREADS``, ``torch.set_num_threads``); CPU seconds per direction.

Usage: NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/fiberform_taufactor.py --image 100_fiberform.tif
(taufactor: ``pip install '.[peers]'`` with a CPU build of torch.)
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

K_AIR, K_FIBRE, VOXEL = 0.0257, 12.0, 1.3e-6


def main() -> None:
    import taufactor
    import tifffile
    import torch

    from aromm.core.vocabulary import PhaseSpec
    from aromm.homogenization.cell_problems import effective_conductivity
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import Scene

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--image", required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    labels = (tifffile.imread(args.image) >= 90).astype(np.uint8)
    phases = (PhaseSpec("air", 0, K_AIR), PhaseSpec("fibre", 1, K_FIBRE))
    scene = Scene(VoxelGeometry(labels, (VOXEL,) * 3), phases, discretisation="fv")  # type: ignore[arg-type]
    small = Scene(VoxelGeometry(labels[:24, :24, :24], (VOXEL,) * 3), phases, discretisation="fv")  # type: ignore[arg-type]
    effective_conductivity(small, "temperature", "mg")  # numba loads its kernels: before the clock
    print(f"# {labels.shape} voxels, fibre fraction {labels.mean():.5f}, load {os.getloadavg()[0]:.2f}, "
          f"NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')}, torch threads {torch.get_num_threads()}")
    result = effective_conductivity(scene, "temperature", "mg")
    print(f"{'axis':>4} {'aromm fv':>10} {'taufactor':>10} {'fv/tf − 1':>10} {'CPU s fv':>9} {'CPU s tf':>9}")
    for axis in range(3):
        turned = np.ascontiguousarray(np.moveaxis(labels, axis, 0)) + 1
        cpu = time.process_time()
        solver = taufactor.MultiPhaseSolver(turned, cond={1: K_AIR, 2: K_FIBRE}, device="cpu")
        solver.solve(verbose=False)
        tf_cpu = time.process_time() - cpu
        tf, fv = float(np.ravel(solver.D_eff)[0]), float(result.k[axis, axis])
        print(f"{axis:>4} {fv:10.6f} {tf:10.6f} {fv / tf - 1:+10.3%} {result.cpu_seconds[axis]:9.2f} {tf_cpu:9.2f}",
              flush=True)


if __name__ == "__main__":
    main()
