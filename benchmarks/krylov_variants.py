"""The accuracy table of benchmarks/mor_peers.py for two more scenes: h unknown, and a flux history (issue 25, item 4).

On the wood VER of ``aromm.studies.chavez2020.small_wood(n)`` (default 24³), scenario 1 of [Chavez2020, Table 1]
(500 W/m² into z0, h = 20 W/(m² K) on z1, 60 s, outputs every 0.1 s) changed in one way each:

* ``h``: the convection coefficient is an unknown of the identification box, k_F ∈ [0.1, 1] W/(m K) ×
  h ∈ [5, 80] W/(m² K) (c_F = 4e6 J/(m³ K)); grid k_F ∈ {0.1, 0.3, 1} × h ∈ {5, 20, 80};
* ``history``: the flux is a pulse, 500 W/m² from 0 to 10 s, ramped to 0 by 12 s, then 0 (a piecewise-linear
  history); box and grid of mor_peers (k_F ∈ {0.1, 0.3, 1} × c_F ∈ {1e6, 4e6, 1e7}).

For each: the worst error (°C) of the two face means over the grid and the 600 output times against the full model
exact in time (benchmarks/mor_truth.py: rational Krylov Galerkin on 4 shifts × 40 steps per grid point, its own
error printed), for the Krylov reduction over the box at the orders asked and the amalgam of the papers (the scene's
reference properties), with offline CPU seconds.  One BLAS thread; the Krylov greedy's tolerance 1e-6 °C as in
mor_peers (``--tolerance``).

    python benchmarks/krylov_variants.py --variants h history --orders 30 50 --json krylov_variants.json
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mor_truth import krylov_outputs

from aromm.core.profiles import Profile
from aromm.core.system import FloatArray, ThermalSystem
from aromm.core.vocabulary import FaceSpec
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.offline import reduce
from aromm.reduction.rom import one_blas_thread
from aromm.scene.scene_file import Scene, assemble
from aromm.studies.chavez2020 import loading, small_wood

PULSE = Profile((0.0, 10.0, 12.0, 60.0), (500.0, 500.0, 0.0, 0.0))
VARIANTS = {
    "h": ({"fibre.k": (0.1, 1.0), "z1.h": (5.0, 80.0)},
          [{"fibre.k": k, "z1.h": h} for k in (0.1, 0.3, 1.0) for h in (5.0, 20.0, 80.0)]),
    "history": ({"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)},
                [{"fibre.k": k, "fibre.c": c} for k in (0.1, 0.3, 1.0) for c in (1e6, 4e6, 1e7)]),
}
TRUTH_SHIFTS = (0.0, 1.0, 10.0, 100.0)  # 1/s, as benchmarks/mor_peers.py
TRUTH_STEPS = 40


def scene_of(variant: str, n: int) -> Scene:
    scene = loading(small_wood(n), "z")
    if variant == "history":
        assert scene.time is not None
        return scene.with_boundary((FaceSpec("z0", flux=PULSE), FaceSpec("z1", h=20.0, T_ext=0.0)), ("z0", "z1"),
                                   scene.time)
    return scene


def worst(model: object, truth: Mapping[str, FloatArray], grid: list[dict[str, float]], times: FloatArray
          ) -> tuple[float, str]:
    errors = [(float(np.abs(model.simulate(mu, times).as_array() - truth[label(mu)]).max()), label(mu))  # type: ignore[attr-defined]
              for mu in grid]
    return max(errors)


def label(mu: Mapping[str, float]) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in sorted(mu.items()))


def run(variant: str, n: int, orders: list[int], tolerance: float) -> list[dict[str, object]]:
    box, grid = VARIANTS[variant]
    scene = scene_of(variant, n)
    system: ThermalSystem = assemble(scene)
    assert system.time is not None
    times = system.time.times
    start = time.process_time()
    truth, own = {}, 0.0
    for mu in grid:
        truth[label(mu)], err = krylov_outputs(system, mu, times, TRUTH_STEPS, TRUTH_SHIFTS)
        own = max(own, err)
    rise = max(float(np.abs(t).max()) for t in truth.values())
    print(f"{variant}: {n}³, {system.n} unknowns; truth {time.process_time() - start:.0f} CPU s, own error "
          f"{own:.1e} °C, largest face mean {rise:.2f} °C", flush=True)
    rows: list[dict[str, object]] = []
    for method in ("krylov", "aromm"):
        for order in orders if method == "krylov" else (50, 200):
            start = time.process_time()
            chosen = KrylovReductor.over(box, tolerance=tolerance) if method == "krylov" else "aromm"
            extra: dict[str, Any] = {"reference_values": scene.reduction.reference} if method == "aromm" else {}
            rom = reduce(system, order, method=chosen, cache=False, basis_values=scene.reduction.basis, **extra)
            cpu = time.process_time() - start
            error, where = worst(rom, truth, grid, times)
            row = {"variant": variant, "n": n, "method": method, "order": int(rom.info["order"]),
                   "offline_cpu": cpu, "worst": error, "at": where, "truth_own_error": own, "rise": rise,
                   "span": rom.info.get("krylov_span", rom.info.get("modes")),
                   "points": rom.info.get("krylov_points", "-")}
            rows.append(row)
            print(f"{variant:8s} {method:7s} ñ {row['order']:>4} (span {row['span']}, points {row['points']}) "
                  f"offline {cpu:7.1f} CPU s | worst {error:.1e} °C at {where}", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=sorted(VARIANTS))
    parser.add_argument("--size", type=int, default=24, help="voxels per side of the generated VER")
    parser.add_argument("--orders", type=int, nargs="+", default=[30, 50], help="orders of the Krylov model")
    parser.add_argument("--tolerance", type=float, default=1e-6,
                        help="greedy tolerance of the Krylov reduction (°C; 1e-6 as benchmarks/mor_peers.py)")
    parser.add_argument("--json", type=Path, default=None, help="write the rows to this file")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()}")
    rows: list[dict[str, object]] = []
    with one_blas_thread():
        for variant in args.variants:
            rows += run(variant, args.size, args.orders, args.tolerance)
    print(f"peak {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB; load average {os.getloadavg()}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
