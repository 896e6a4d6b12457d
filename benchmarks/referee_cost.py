"""What a certified amalgam's Krylov referee costs on the warm path (aromm.api's cache kind 'referee').

The "two phases" body of benchmarks/certified_bound.py (``--size``³ random voxels, 40 % fibre, its box fibre.k ∈
[0.1, 1] W/(m K) × fibre.c ∈ [1e6, 1e7] J/(m³ K)) as a voxel Scene, so that aromm's cache keys it.  Prints CPU
seconds (process_time; wall seconds beside them) of:

* the build: ``aromm.reduce(scene, order, method="aromm", bounds=box, cache=False)``, the amalgam and its Krylov
  referee over the box;
* the cold worst bound: :func:`aromm.reduction.referee.refereed` of that amalgam without its referee and the referee,
  the certified bound evaluated at every point of the referee's training grid and the scene's values, what a warm
  call did before the worst bound was cached;
* the same reduce through a temporary cache folder, twice: the first builds and stores the amalgam, the referee and
  the worst bound, the second (the warm path) loads all three;
* one simulation of the amalgam at fibre.k 0.5 (the mean of ``--simulations``).

    OMP_NUM_THREADS=1 python benchmarks/referee_cost.py                      # 16³, order 200
    OMP_NUM_THREADS=1 python benchmarks/referee_cost.py --size 8 --order 40

Measured at 3343793, 16³ and order 200 (record benchmarks/records/referee_cost_16_200_3343793.txt, load 0.9–1.7):
build 12.8 CPU s, cold worst bound 2.8 CPU s over 26 points, warm reduce 0.028 CPU s, one simulation 6.4 ms.

Record: benchmarks/records/referee_cost_<size>_<order>_<commit>.txt.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from certified_bound import FLUX, case

import aromm
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import PhaseSpec
from aromm.reduction.referee import refereed
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene


def scene(size: int) -> Scene:
    """certified_bound.case("two phases", size) as a Scene (the same labels, phases, faces, time grid and outputs)."""
    labels = (np.random.default_rng(2).random((size,) * 3) < 0.4).astype(np.int32)
    phases = (PhaseSpec("gas", 0, 0.026, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6))
    return Scene(VoxelGeometry(labels, (5e-6,) * 3), phases, tuple(FLUX), 0.0, TimeGrid(2.0, 0.05), ("z0", "z1"))


def timed(call: Callable[[], Any]) -> tuple[Any, float, float]:
    """``call()``, its CPU and wall seconds."""
    cpu, wall = time.process_time(), time.perf_counter()
    out = call()
    return out, time.process_time() - cpu, time.perf_counter() - wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=16, help="voxels per side")
    parser.add_argument("--order", type=int, default=200, help="the amalgam's order")
    parser.add_argument("--simulations", type=int, default=20, help="simulations averaged")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    box = case("two phases", args.size)[1]
    body = scene(args.size)
    print(f"{args.size}³ voxels, amalgam of order {args.order} over {box}, load average {os.getloadavg()[0]:.2f}, "
          f"OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}")

    def reduce(cache: bool | str) -> aromm.ReducedModel:
        return aromm.reduce(body, args.order, method="aromm", bounds=box, cache=cache)

    def row(what: str, cpu: float, wall: float, note: str = "") -> None:
        print(f"{what:44s} {cpu:9.4f} {wall:9.4f}  {note}", flush=True)

    print(f"{'':44s} {'CPU s':>9s} {'wall s':>9s}")
    rom, cpu, wall = timed(lambda: reduce(False))
    assert rom.finer is not None
    row("build (amalgam and referee, no cache)", cpu, wall,
        f"order {rom.order}, referee order {rom.finer.order}, bound {rom.info['error_bound']:.3g} °C")
    cold, cpu, wall = timed(lambda: refereed(replace(rom, finer=None), rom.finer))
    row("cold worst bound (refereed)", cpu, wall, str(cold.info["certificate"]))
    with tempfile.TemporaryDirectory() as folder:
        first, cpu, wall = timed(lambda: reduce(folder))
        row("reduce, empty cache (builds and stores)", cpu, wall, f"bound {first.info['error_bound']:.3g} °C")
        warm, cpu, wall = timed(lambda: reduce(folder))
        row("reduce, warm cache", cpu, wall, f"bound {warm.info['error_bound']:.3g} °C, cached "
            f"{warm.info.get('cached', 0)}")
    _, cpu, wall = timed(lambda: [rom.simulate({"fibre.k": 0.5}) for _ in range(args.simulations)])
    row(f"one simulation (mean of {args.simulations})", cpu / args.simulations, wall / args.simulations)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
