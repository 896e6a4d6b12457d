"""Effectivities of a compressed Krylov model's certified bound at the slow corner of its box, through the span it
was compressed from and directly (docs/method/krylov.md, "the direct bound's weak side").

The scene, box and points are tests/petsc_krylov_cases.py's (8×9×10 random two-phase voxels, box fibre.k ∈ [0.1, 1]
W/(m K) × fibre.c ∈ [1e6, 1e7] J/(m³ K), the probe fibre.k 0.5, fibre.c 3e6 and the slow corner fibre.k 0.1,
fibre.c 1e7; greedy of 3 points, 4 shifts, direct solves, drop threshold 1e-7), built certified on the serial scipy
engine at each of ``--orders``.  For every order, point and output: the actual worst error over the output times
against the exact full model (:func:`aromm.full.exact.exact_outputs` of the lifted system), the truth's own rounding
there (:func:`aromm.full.exact.rounding`), and the effectivity (bound / actual error) of the bound through the span
(:func:`aromm.reduction.certificate.through_finer`, the model's ``error_bound``) and of the direct bound alone (the
model without its span).  An error below 10× the truth's rounding is not measurable: its effectivities print as "—"
and stay out of the ranges that close each order.  CPU seconds of the build (process_time; wall beside it).

    OMP_NUM_THREADS=1 python benchmarks/slow_corner.py                  # orders 8 14 24
    OMP_NUM_THREADS=1 python benchmarks/slow_corner.py --orders 8 40

Measured at 3343793 (record benchmarks/records/slow_corner_3343793.txt, load 0.1–0.3, 0.6–0.8 CPU s per build):
through the span 1.03–2.94, 1.08–23.8 and 3.57–159 at orders 8, 14 and 24; directly 8.58–95.8, 19.9–1.28e+03 and
93.6–1.84e+03; every error above 10× the truth's rounding.

Record: benchmarks/records/slow_corner_<commit>.txt.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the test helpers' scene, box and points

import petsc_krylov_cases as cases

import aromm
from aromm.full.exact import exact_outputs, rounding
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.lifting import lift
from aromm.scene.scene_file import assemble

#: The truth's rounding times this is the smallest error measured.
MEASURABLE = 10.0


def _ratio(bound: float, actual: float, floor: float) -> str:
    return f"{bound / actual:9.3g}" if actual > MEASURABLE * floor else f"{'—':>9s}"


def _range(values: list[float]) -> str:
    return f"{min(values):.3g}–{max(values):.3g}" if values else "—"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--orders", nargs="+", type=int, default=[8, 14, 24], help="orders asked")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    shape, _, _ = cases.CERTIFIED
    system = assemble(cases.scene(shape))
    assert system.time is not None
    times = system.time.times
    print(f"{'x'.join(map(str, shape))} voxels ({system.n} unknowns), box {cases.BOX}, load average "
          f"{os.getloadavg()[0]:.2f}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    print(f"{'order':>5s} {'span':>4s} {'point':28s} {'output':>6s} {'actual':>9s} {'floor':>9s} {'via span':>9s} "
          f"{'direct':>9s} {'build CPU s':>11s} {'wall s':>6s}")
    for order in args.orders:
        reductor = KrylovReductor.over(cases.BOX, max_points=3, shifts=4, rtol=1e-12, certify=True)
        cpu, wall = time.process_time(), time.perf_counter()
        with cases.dropping(cases.DROP):
            rom = aromm.reduce(system, order, method=reductor, cache=False)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        truth = lift(system, rom.parameters)
        alone = replace(rom, finer=None)
        span = "—" if rom.finer is None else str(rom.finer.order)
        via: list[float] = []
        direct: list[float] = []
        for p in cases.POINTS:
            actual = np.abs(rom.simulate(p, times).as_array() - exact_outputs(truth, p, times)).max(axis=0)
            floor = rounding(truth, p, times)
            bound, alone_bound = rom.error_bound(p), alone.error_bound(p)
            assert bound is not None and alone_bound is not None
            label = ", ".join(f"{k} {v:g}" for k, v in p.items())
            for i, name in enumerate(rom.outputs):
                print(f"{rom.order:5d} {span:>4s} {label:28s} {name:>6s} {actual[i]:9.3g} {floor[i]:9.2g} "
                      f"{_ratio(bound[i], actual[i], floor[i])} {_ratio(alone_bound[i], actual[i], floor[i])} "
                      f"{cpu:11.2f} {wall:6.1f}")
                if actual[i] > MEASURABLE * floor[i]:
                    via.append(float(bound[i] / actual[i]))
                    direct.append(float(alone_bound[i] / actual[i]))
        print(f"order {rom.order}: effectivity through the span {_range(via)}, direct {_range(direct)} "
              f"({len(via)} of {len(cases.POINTS) * len(rom.outputs)} errors measurable), load "
              f"{os.getloadavg()[0]:.2f}", flush=True)


if __name__ == "__main__":
    main()
