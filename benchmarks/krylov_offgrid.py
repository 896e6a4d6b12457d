"""Accuracy of the Krylov reduced model between training points: a Latin hypercube over the box, not only the grid.

The figures of docs/method/krylov.md were the worst error over a 3 × 3 grid of parameter points; a model is used
anywhere in its box.  This benchmark builds the Krylov model of the generated wood VER (scenario 1, box
fibre.k ∈ [0.1, 1] W/(m K) × fibre.c ∈ [1e6, 1e7] J/(m³ K)) at each tolerance and order asked, then measures its
worst output error over the grid and over ``--points`` points of a Latin hypercube (log-uniform, seeded) against
the exact-in-time reference of benchmarks/mor_truth.py (rational-Krylov Galerkin of the full model, its own error
printed), beside what the model says of itself (``reference_error``: greedy estimate plus compression loss, and
``converged``) and its certified bound (:mod:`aromm.reduction.certificate`, on by default below 20,000 unknowns,
``--certify`` above): the worst bound over the hypercube and the effectivity (bound / actual error) per point, its
range printed.  CPU and wall seconds and the load average are printed: the machine may be shared.

    python benchmarks/krylov_offgrid.py --size 24 --tolerances 1e-5 1e-6 --orders 30 50 --points 24
    python benchmarks/krylov_offgrid.py --size 46 --tolerances 1e-5 --orders 200 --points 8 --no-grid --certify
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from mor_truth import krylov_outputs

from aromm.core.errors import ModelWarning
from aromm.reduction.offline import reduce
from aromm.reduction.rom import one_blas_thread
from aromm.scene.scene_file import assemble
from aromm.studies.chavez2020 import loading, small_wood

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1.0e6, 1.0e7)}
TRUTH_SHIFTS = (0.0, 1.0, 10.0, 100.0)  # 1/s, as benchmarks/mor_peers.py
TRUTH_STEPS = 40


def latin_hypercube(count: int, rng: np.random.Generator) -> list[dict[str, float]]:
    """``count`` points, one per stratum of every axis, log-uniform within it."""
    names = sorted(BOX)
    strata = [rng.permutation(count) for _ in names]
    out = []
    for i in range(count):
        point = {}
        for name, perm in zip(names, strata, strict=True):
            lo, hi = np.log(BOX[name][0]), np.log(BOX[name][1])
            point[name] = float(np.exp(lo + (hi - lo) * (perm[i] + rng.random()) / count))
        out.append(point)
    return out


def grid() -> list[dict[str, float]]:
    return [{"fibre.k": k, "fibre.c": c} for k, c in itertools.product((0.1, 0.3162, 1.0), (1e6, 3.162e6, 1e7))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=24, help="voxels per side of the generated VER")
    parser.add_argument("--tolerances", type=float, nargs="+", default=[1e-5, 1e-6], help="greedy tolerances (°C)")
    parser.add_argument("--orders", type=int, nargs="+", default=[30, 50])
    parser.add_argument("--points", type=int, default=24, help="Latin-hypercube points")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-grid", action="store_true", help="the hypercube only (the truth costs per point)")
    parser.add_argument("--certify", action="store_true", help="certify at any size (default: below 20,000 unknowns)")
    args = parser.parse_args()
    system = assemble(loading(small_wood(args.size), "z"))
    assert system.time is not None
    times = system.time.times
    print(f"generated {args.size}³ wood VER, scenario 1: {system.n} unknowns, {times.size} output times; "
          f"load average {os.getloadavg()}")
    points = {"grid": [] if args.no_grid else grid(),
              "hypercube": latin_hypercube(args.points, np.random.default_rng(args.seed))}
    start = time.process_time()
    truth, own = {}, 0.0
    for kind, pts in points.items():
        for i, mu in enumerate(pts):
            truth[kind, i], err = krylov_outputs(system, mu, times, TRUTH_STEPS, TRUTH_SHIFTS)
            own = max(own, err)
    print(f"truth: {sum(len(p) for p in points.values())} points, own error ≤ {own:.2g} °C, "
          f"{time.process_time() - start:.1f} CPU s", flush=True)
    print("tolerance  order  kept  converged  says (°C)  grid (°C)  hypercube (°C)  ratio  bound (°C)  effectivity"
          "  build CPU s  wall s")
    for tol, order in itertools.product(args.tolerances, args.orders):
        cpu, wall = time.process_time(), time.perf_counter()
        with warnings.catch_warnings(), one_blas_thread():
            warnings.simplefilter("ignore", ModelWarning)
            rom = reduce(system, order, method="krylov", bounds=BOX, tolerance=tol, cache=False,
                         certify=True if args.certify else None)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        errors = {kind: [np.abs(rom.simulate(mu, times).as_array() - truth[kind, i]).max(axis=0)
                         for i, mu in enumerate(pts)] for kind, pts in points.items()}
        worst = {kind: max((float(e.max()) for e in errs), default=float("nan")) for kind, errs in errors.items()}
        bounds = [rom.error_bound(mu) for mu in points["hypercube"]]
        if all(b is not None for b in bounds):
            ratios = [b / np.maximum(e, 1e-300) for b, e in zip(bounds, errors["hypercube"], strict=True)]
            bound = f"{max(float(np.max(b)) for b in bounds if b is not None):10.2g}"
            effect = f"{min(float(r.min()) for r in ratios):.3g}–{max(float(r.max()) for r in ratios):.3g}"
        else:
            bound, effect = f"{'none':>10}", "-"
        print(f"{tol:9.0e}  {order:5d}  {rom.order:4d}  {int(rom.info['converged']):9d}  "
              f"{float(rom.info['reference_error']):9.2g}  {worst['grid']:9.2g}  {worst['hypercube']:14.2g}  "
              f"{worst['hypercube'] / max(worst['grid'], 1e-300):5.2f}  {bound}  {effect:>11}  {cpu:11.1f}  "
              f"{wall:6.1f}", flush=True)
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
