"""Finite-volume homogenisation, one direction at a time: the matrix-free multigrid (aromm.fv.multigrid) against the
assembled path (pyamg CG) and, on taufactor's 500³ paper volume, against the published over-converged values.

Every row is one direction in a fresh process, on ``--threads`` threads (numba's, OpenBLAS's: one by default): CPU
seconds (all threads), wall seconds, CG iterations, peak resident memory all-in and above the baseline (interpreter,
libraries and the image, before any solver work), in bytes per voxel, and the 1-minute load average before → after.
Fixed temperatures 1 and 0 on the two faces of the direction (half a cell out), the other faces adiabatic:
k̄ = Q L / (A ΔT).  The tolerance is the CG relative residual ``--rtol`` (1e-6 by default here; the library's 1e-8
is ``--rtol 1e-8``).

Cases:

* ``paper`` — taufactor's test volume (github.com/tldr-group/taufactor, docs/paper/TF-500x500x500-1x2x6-v3.tiff.zip,
  500³, 30 % of voxels at 255 conducting with k = 1, the rest k = 0).  Its paper [Kench2023] gives the
  over-converged τ = 1.1513, 1.3905, 4.2431 (ε/τ = 0.26058, 0.21575, 0.07070) without naming the array axes; they
  are the directions of array axes 1, 2 and 0 of the TIFF as tifffile reads it (pages, rows, columns): the only
  assignment that matches (the others are off by 20–270 %).  Per-direction times of the paper: taufactor 2 on an
  A6000 GPU 26 s, on a 32-core Threadripper 447 s, PoreSpy 540 s, PuMA 1,201 s.  ``--image PATH`` gives the
  unzipped TIFF (not shipped: 125 MB).
* ``random:N`` — a Gaussian-filtered random medium (σ = 2 voxels, seed 0), 40 % of k = 0.3 in k = 0.025 W/(m K).

``--boundary periodic`` solves the periodic cell instead (the full tensor, three solves per row; one axis is enough).

Usage: python benchmarks/fv_solver.py [--image TF-500x500x500-1x2x6-v3.tiff] [--cases paper random:64 …]
[--methods mg amg] [--axes 0 1 2] [--threads 1] [--rtol 1e-6] [--boundary temperature|periodic]
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import resource
import subprocess
import sys
import time

import numpy as np

PUBLISHED_TAU = (4.2431, 1.1513, 1.3905)  # along array axes 0, 1, 2 (module docstring)
PUBLISHED_SECONDS = "taufactor 2: A6000 GPU 26 s, 32-core CPU 447 s; PoreSpy 540 s; PuMA 1,201 s (per direction)"


def _image(case: str, path: str | None) -> tuple[np.ndarray, dict[int, float]]:
    if case == "paper":
        import tifffile

        if path is None:
            raise SystemExit("fv_solver: the paper case needs --image (the unzipped TIFF of taufactor's repository)")
        return tifffile.imread(path), {255: 1.0, 0: 0.0}
    n = int(case.split(":")[1])
    from scipy import ndimage

    field = ndimage.gaussian_filter(np.random.default_rng(0).random((n, n, n)), 2.0, mode="wrap")
    return np.where(field > np.quantile(field, 0.6), 1, 0).astype(np.uint8), {1: 0.3, 0: 0.025}


def worker(case: str, path: str | None, method: str, axis: int, *, rtol: float, boundary: str) -> dict[str, object]:
    """One direction (``periodic``: the whole tensor, its k_axis,axis reported), in this process: k̄ and its costs."""
    from aromm.core.vocabulary import PhaseSpec
    from aromm.homogenization.fv_cells import fv_method, probe_k
    from aromm.homogenization.fv_periodic import periodic_k
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import Scene

    labels, k_of = _image(case, path)
    phases = tuple(PhaseSpec(f"p{label}", label, k) for label, k in k_of.items())
    scene = Scene(VoxelGeometry(labels, (1.0, 1.0, 1.0)), phases, discretisation="fv")  # type: ignore[arg-type]
    if method == "mg":  # compile the kernels before the clock starts (numba caches them on disk after the first run)
        probe_k(Scene(VoxelGeometry(np.full((24, 24, 24), max(k_of, key=k_of.__getitem__)), (1.0,) * 3), phases,  # type: ignore[arg-type]
                      discretisation="fv"), 0, "temperature", "mg", rtol)
    lines: list[str] = []  # the solver's own report (iterations, levels), a debug line of aromm.homogenization

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            lines.append(record.getMessage())

    for logger in ("aromm.homogenization.fv_cells", "aromm.homogenization.fv_periodic"):
        logging.getLogger(logger).addHandler(Keep(logging.DEBUG))
        logging.getLogger(logger).setLevel(logging.DEBUG)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    name = fv_method(method, labels.size, 0)
    cpu, wall = time.process_time(), time.perf_counter()
    if boundary == "periodic":
        tensor, name = periodic_k(scene, name, rtol)
        k = float(tensor[axis, axis])
        lines = [f"{'; '.join(lines)}; tensor diagonal {np.diag(tensor).round(6).tolist()}"]
    else:
        k = probe_k(scene, axis, "temperature", name, rtol)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    conducting = float(np.mean(labels == max(k_of, key=lambda lab: k_of[lab])))
    return {"case": case, "method": name, "axis": axis, "k": k, "cpu_s": cpu, "wall_s": wall, "voxels": labels.size,
            "state_B_per_voxel": (peak - base) / labels.size, "all_in_B_per_voxel": peak / labels.size,
            "fraction": conducting, "solver": lines[-1].split(": ")[-1] if lines else ""}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--image")
    parser.add_argument("--cases", nargs="+", default=["random:64", "random:128"])
    parser.add_argument("--methods", nargs="+", default=["mg", "amg"])
    parser.add_argument("--axes", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--boundary", choices=["temperature", "periodic"], default="temperature",
                        help="periodic: the whole tensor per row (three solves; give one axis)")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        case, method, axis = args.worker
        print(json.dumps(worker(case, args.image, method, int(axis), rtol=args.rtol, boundary=args.boundary)))
        return
    env = dict(os.environ, **{v: str(args.threads) for v in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS",
                                                             "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")})
    print(f"# threads {args.threads}, rtol {args.rtol:g}, {args.boundary}, {os.cpu_count()} cores; published: "
          f"{PUBLISHED_SECONDS}")
    print(f"{'case':>11} {'method':>6} {'axis':>4} {'k':>10} {'vs paper':>9} {'CPU s':>8} {'wall s':>7} "
          f"{'B/vox state':>11} {'all-in':>7}  load")
    for case in args.cases:
        for method in args.methods:
            for axis in args.axes:
                load = os.getloadavg()[0]
                cmd = [sys.executable, __file__, "--worker", case, method, str(axis), "--rtol", str(args.rtol),
                       "--boundary", args.boundary]
                if args.image:
                    cmd += ["--image", args.image]
                done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
                if done.returncode:
                    print(f"{case:>11} {method:>6} {axis:>4}  failed: {done.stderr.strip().splitlines()[-1:]}")
                    continue
                row = json.loads(done.stdout.strip().splitlines()[-1])
                paper = ""
                if case == "paper":
                    paper = f"{row['k'] / (row['fraction'] / PUBLISHED_TAU[axis]) - 1:+.2%}"
                print(f"{case:>11} {row['method']:>6} {axis:>4} {row['k']:10.6f} {paper:>9} {row['cpu_s']:8.1f} "
                      f"{row['wall_s']:7.1f} {row['state_B_per_voxel']:11.1f} {row['all_in_B_per_voxel']:7.1f}  "
                      f"{load:.2f} → {os.getloadavg()[0]:.2f}  {row['solver']}", flush=True)


if __name__ == "__main__":
    main()
