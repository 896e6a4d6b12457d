"""Full-model references for benchmarks/reduce_scaling.py: multigrid-CG BDF2 at dt and dt/2, stored once per size.

Scenario 1 of [Chavez2020, Table 1] on ``aromm.studies.chavez2020.small_wood(n)`` (500 W/m² into z0, h = 20 W/(m² K)
on z1), at the reference point (k_F, c_F) = (0.3 W/(m K), 4e6 J/(m³ K)) and at the slow corner of the identification
box (0.1, 1e7), over the first ``--horizon`` seconds (outputs every 2 dt, the times both runs share).  The full
model is stepped by BDF2 (``aromm.full.solve.transient``, linear solver ``mg``: multigrid-preconditioned CG, relative
residual 1e-8 per step, on matrix-free voxel terms: :mod:`aromm.full.voxel_transient`) at dt = 0.1 s and at dt/2;
the file keeps both, so the reader forms the Richardson value
(4 T(dt/2) − T(dt)) / 3 (time error O(dt³)) and the full model's own BDF2 error 4/3 |T(dt) − T(dt/2)|.

    nice python benchmarks/scaling_truth.py --sizes 46 64 96 128 --out truth/

Each size runs in its own process; CPU and wall seconds, load and peak memory of each run are stored beside
the outputs (``<out>/truth-<n>.npz``).
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
from pathlib import Path

import numpy as np

#: (name, (k_F W/(m K), c_F J/(m³ K))) of the two checked points: the scene's reference and the slow corner.
POINTS = {"reference": {"fibre.k": 0.3, "fibre.c": 4e6}, "corner": {"fibre.k": 0.1, "fibre.c": 1e7}}
DT = 0.1


def path_for(out: Path, n: int) -> Path:
    return out / f"truth-{n}.npz"


def compute(n: int, horizon: float, out: Path, half: bool) -> dict[str, float]:
    from reduce_scaling import matrix_free_system

    from aromm.core.system import TimeGrid
    from aromm.full.solve import transient
    from aromm.studies.chavez2020 import loading, small_wood

    wall, cpu, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
    system = matrix_free_system(loading(small_wood(n), "z"))  # no matrix assembled (aromm.full.voxel_transient)
    times = np.arange(0.0, horizon + 1e-9, 2 * DT)
    arrays: dict[str, np.ndarray] = {"times": times, "names": np.array(system.observation_matrix()[0])}
    for name, point in POINTS.items():
        for label, dt in (("dt", DT), ("half", DT / 2))[:2 if half else 1]:
            stepped = replace(system, time=TimeGrid(horizon, dt))
            start = time.process_time()
            arrays[f"{name}_{label}"] = transient(stepped, point, times, method="mg").as_array()
            print(f"{n}³ {name} dt={dt:g}: {time.process_time() - start:.0f} CPU s", file=sys.stderr, flush=True)
    meta = {"n": n, "nodes": system.n, "horizon": horizon, "cpu": time.process_time() - cpu,
            "wall": time.perf_counter() - wall, "load_start": load, "load_end": os.getloadavg()[0],
            "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6}
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".truth-{n}.npz"
    np.savez(tmp, meta=json.dumps(meta), **arrays)  # type: ignore[arg-type]
    tmp.replace(path_for(out, n))
    return meta


def load(out: Path, n: int) -> dict[str, object] | None:
    """The stored references of size n, or None: arrays by name, ``meta`` a dict."""
    path = path_for(out, n)
    if not path.exists():
        return None
    with np.load(path) as data:
        stored: dict[str, object] = {k: data[k] for k in data.files}
    stored["meta"] = json.loads(str(stored["meta"]))
    return stored


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[46, 64, 96, 128])
    parser.add_argument("--horizon", type=float, default=10.0, help="seconds of the experiment compared")
    parser.add_argument("--out", type=Path, required=True, help="directory of the truth-<n>.npz files")
    parser.add_argument("--half-up-to", type=int, default=10_000,
                        help="run the dt/2 reference only for sizes up to this n (its cost doubles the run)")
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        sys.path.insert(0, str(Path(__file__).parent))
        print(json.dumps(compute(args.worker, args.horizon, args.out, args.worker <= args.half_up_to)))
        return
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    for n in args.sizes:
        if path_for(args.out, n).exists():
            print(f"{n}³: stored ({path_for(args.out, n)})")
            continue
        done = subprocess.run([sys.executable, __file__, "--worker", str(n), "--horizon", str(args.horizon),
                               "--out", str(args.out), "--half-up-to", str(args.half_up_to)],
                              stdout=subprocess.PIPE, text=True, env=env, check=False)
        print(f"{n}³: " + (done.stdout.strip().splitlines()[-1] if done.returncode == 0 else
                           f"worker failed with exit code {done.returncode}"), flush=True)


if __name__ == "__main__":
    main()
