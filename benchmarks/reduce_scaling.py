"""Reduced-model build on wood-like VERs from 24³ to 256³ voxels: seconds, memory, error (issues 12 and 25).

Each size runs in its own process (peak memory per size).  The VER is ``aromm.studies.chavez2020.small_wood(n)``: the
paper's 230 µm box with tracheid walls one voxel thick (so finer images hold more, thinner cells), loaded by
scenario 1 of [Chavez2020, Table 1] (500 W/m² into z0, h = 20 W/(m² K) on z1, 60 s, dt = 0.1 s).  Per size:

* ``reduce`` (ñ = 200 from Ñ = 320 modes, correction modes, the paper's reference properties) from an empty cache
  with the chosen eigensolver: wall and CPU seconds, seconds of the bases, LOBPCG iterations, peak resident
  memory, bytes per voxel, and the memory floor of the float64 basis (Ñ × 8 bytes per node);
* the error of the reduced model at (k_F, c_F) = (0.3, 4e6) against the full model at the same dt (BDF2,
  0.1 s) over the first ``--steps`` steps, and against the full steady solve (the t → ∞ limit), in °C;
  the full model uses CHOLMOD up to ``--amg-above`` nodes and smoothed-aggregation CG above.  The reduced
  model is exact in time, so with ``--half-step`` the full model also runs at dt/2: its own BDF2 error
  (4/3 |full(dt) − full(dt/2)|) and the error of the reduced model against the Richardson value
  (4 full(dt/2) − full(dt))/3;
* with ``--float32``: the same reduced model on the float32-rounded basis (compact storage), max change of
  the face means.

Then the growth exponents of offline CPU time and peak memory (least squares of log against log voxels,
and the two-point exponent between the smallest and largest size), side by side for each eigensolver.

    python benchmarks/reduce_scaling.py --sizes 24 32 46 64 96 --eigensolvers lobpcg --steps 300
    python benchmarks/reduce_scaling.py --sizes 24 32 46 64 --eigensolvers arpack lobpcg   # crossover

The machine is shared: CPU seconds (time.process_time of the worker, one BLAS thread) are the figure to
compare; wall seconds and the load average are printed beside them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

POINT = {"fibre.k": 0.3, "fibre.c": 4e6}
#: The identification box of the Krylov reductor (k_F W/(m K), c_F J/(m³ K)), [Chavez2020, § 4].
BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
#: Seconds of the experiment over which the Krylov model is checked against the stored full model.
CHECK_HORIZON = 5.0


def worker(n: int, eigensolver: str, steps: int, amg_above: int, *, float32: bool, half_step: bool) -> dict[
        str, object]:
    from aromm.core.system import TimeGrid
    from aromm.full.solve import steady_field, transient
    from aromm.reduction.offline import reduce
    from aromm.scene.scene_file import assemble
    from aromm.studies.chavez2020 import loading, small_wood

    out: dict[str, object] = {"n": n, "eigensolver": eigensolver, "load_start": os.getloadavg()[0]}
    wall, cpu = time.perf_counter(), time.process_time()
    scene = loading(small_wood(n), "z")
    system = assemble(scene)
    out["nodes"], out["assembly_cpu"] = system.n, time.process_time() - cpu
    log: list[str] = []

    def listen(report: object) -> None:
        line = f"{time.process_time() - cpu:8.1f} s CPU  {report}"
        if not log or log[-1].split("  ", 1)[1].split("converged=")[1][:4] != line.split("converged=")[1][:4]:
            print(line, file=sys.stderr, flush=True)
        log.append(line)

    with tempfile.TemporaryDirectory() as tmp:
        wall, cpu = time.perf_counter(), time.process_time()
        rom = reduce(system, order=200, modes=320, eigensolver=eigensolver, cache=tmp, eigen_progress=listen,
                     basis_values=scene.reduction.basis, reference_values=scene.reduction.reference)
        out["offline_wall"], out["offline_cpu"] = time.perf_counter() - wall, time.process_time() - cpu
    out["peak_gb_offline"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    info = rom.info
    out.update({key: info[key] for key in ("modes", "basis_seconds", "eigen_iterations", "reference_error",
                                           "eigensolver")})
    out["basis_floor_bytes_per_voxel"] = int(info["modes"]) * 8 * system.n / n**3
    method = "amg" if system.n > amg_above else "cholmod"
    assert system.time is not None
    times = system.time.times[: steps + 1]
    wall, cpu = time.perf_counter(), time.process_time()
    full = transient(system, POINT, times, method=method).as_array()
    out["full_wall"], out["full_cpu"] = time.perf_counter() - wall, time.process_time() - cpu
    out["full_method"] = method
    reduced = rom.simulate(POINT, times).as_array()
    out["max_error"] = float(np.abs(reduced - full).max())
    out["max_face_mean"] = float(np.abs(full).max())
    if half_step:  # the full model at dt/2: its own BDF2 error, and a reference accurate to O(dt³)
        halved = replace(system, time=TimeGrid(system.time.end, system.time.dt / 2))
        finer = transient(halved, POINT, times, method=method).as_array()
        out["full_time_error"] = float(np.abs(full - finer).max() * 4 / 3)
        out["max_error_richardson"] = float(np.abs(reduced - (4 * finer - full) / 3).max())
    _, e = system.observation_matrix()
    steady_full = e @ steady_field(system, POINT, method=method)
    out["steady_error"] = float(np.abs(rom.steady({k: [v] for k, v in POINT.items()})[0] - steady_full).max())
    out["steady_face_mean"] = float(np.abs(steady_full).max())
    if float32:  # a second build with the basis rounded to single precision (the eigen-solve again)
        with tempfile.TemporaryDirectory() as tmp:
            rom32 = reduce(system, order=200, modes=320, eigensolver=eigensolver, basis_storage="float32", cache=tmp,
                           basis_values=scene.reduction.basis, reference_values=scene.reduction.reference)
        out["float32_change"] = float(np.abs(rom32.simulate(POINT, times).as_array() - reduced).max())
    out["peak_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    out["bytes_per_voxel"] = out["peak_gb"] * 1e9 / n**3  # type: ignore[operator]
    out["load_end"] = os.getloadavg()[0]
    return out


def matrix_free_system(scene: Any) -> Any:
    """The scene's voxel system with matrix-free conduction, capacity and convection terms (aromm.fem.voxel_terms)."""
    from aromm.fem.voxel import assemble_voxels

    geo = scene.geometry
    return assemble_voxels(geo.labels, geo.voxel_size, scene.phases, scene.boundary, time=scene.time,
                           initial_T=scene.initial_T, outputs=scene.outputs, matrix_free=True)


def krylov_worker(n: int, *, rtol: float, order: int, truth_dir: Path | None, cache: Path | None,
                  check_only: bool = False, assembled: bool = False) -> dict[str, object]:
    """The Krylov reductor (order ``order`` over :data:`BOX`) on the n³ VER, checked against the stored full model
    (benchmarks/scaling_truth.py) at the reference and at the slow corner.  ``cache``: a folder the model is stored
    in (the key of ``aromm reduce`` on the same scene: benchmarks/end_to_end.py then identifies with it)."""
    import logging

    from scaling_truth import POINTS, load

    from aromm.core.system import TimeGrid
    from aromm.full.solve import transient
    from aromm.reduction.krylov import KrylovReductor
    from aromm.reduction.offline import reduce
    from aromm.scene.scene_file import assemble
    from aromm.studies.chavez2020 import loading, small_wood

    logging.basicConfig(level=logging.INFO, stream=sys.stderr, format="%(asctime)s %(message)s")
    out: dict[str, object] = {"n": n, "eigensolver": "krylov", "load_start": os.getloadavg()[0], "rtol": rtol,
                              "terms": "assembled" if assembled else "matrix-free"}
    wall, cpu = time.perf_counter(), time.process_time()
    scene = loading(small_wood(n), "z")
    system = assemble(scene) if assembled else matrix_free_system(scene)
    out["nodes"], out["assembly_cpu"] = system.n, time.process_time() - cpu
    out["peak_gb_assembly"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    reductor = KrylovReductor.over(BOX, rtol=rtol)
    wall, cpu = time.perf_counter(), time.process_time()
    rom = reduce(system, order, method=reductor, cache=str(cache) if cache else False,
                 basis_values=scene.reduction.basis)
    if int(rom.info.get("cached", 0)) and not check_only:
        raise SystemExit(f"{n}³: the model came from the cache {cache}: no build to time (empty it first)")
    out["offline_wall"], out["offline_cpu"] = time.perf_counter() - wall, time.process_time() - cpu
    out["peak_gb_offline"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    out["load_offline"] = os.getloadavg()[0]
    info = rom.info
    out.update({key: info[key] for key in (
        "order", "krylov_span", "krylov_points", "krylov_estimate", "compression", "compression_loss", "solver",
        "solves", "setups", "setup_seconds", "solve_seconds", "cg_iterations_max", "cg_iterations_mean",
        "basis_seconds") if key in info})
    out["basis_seconds"] = info["basis_seconds"]
    out["eigen_iterations"] = "-"
    out["modes"] = info["krylov_span"]
    out["basis_floor_bytes_per_voxel"] = int(info["krylov_span"]) * 8 * system.n / n**3
    out["bytes_per_voxel"] = float(out["peak_gb_offline"]) * 1e9 / n**3  # type: ignore[arg-type]
    truth = load(truth_dir, n) if truth_dir is not None else None
    if truth is not None:
        times = np.asarray(truth["times"])
        keep = times <= CHECK_HORIZON + 1e-9
        times = times[keep]
        for name, point in POINTS.items():
            coarse = np.asarray(truth[f"{name}_dt"])[keep]
            if f"{name}_half" in truth:
                fine = np.asarray(truth[f"{name}_half"])[keep]
                exact = rom.simulate(point, times).as_array()
                out[f"{name}_error"] = float(np.abs(exact - (4 * fine - coarse) / 3).max())
                out[f"{name}_full_time_error"] = float(np.abs(coarse - fine).max() * 4 / 3)
            assert system.time is not None
            stepped = transient(replace(rom.projected, time=TimeGrid(float(times[-1]), system.time.dt)), point,
                                times).as_array()  # the reduced model stepped like the full one: no time error
            out[f"{name}_error_bdf2"] = float(np.abs(stepped - coarse).max())
            out[f"{name}_max_rise"] = float(np.abs(coarse).max())
        out["truth_horizon"] = float(times[-1])
    out["load_end"] = os.getloadavg()[0]
    return out


def print_krylov_row(r: dict[str, Any]) -> None:
    checks = "".join(
        f" | {name}: |ROM − full| both BDF2 dt 0.1 s {r[f'{name}_error_bdf2']:.1e} °C over a rise of "
        f"{r[f'{name}_max_rise']:.2f} °C" + (f", |ROM − full(dt→0)| {r[f'{name}_error']:.1e} °C (full BDF2 own error "
                                           f"{r[f'{name}_full_time_error']:.1e})" if f"{name}_error" in r else "")
        for name in ("reference", "corner") if f"{name}_error_bdf2" in r)
    print(f"{r['n']:>3}³ krylov: {r['nodes']:>8} nodes | offline CPU {r['offline_cpu']:8.1f} s "
          f"(wall {r['offline_wall']:8.1f} s; set-ups {float(r['setup_seconds']):.0f} s, solves "
          f"{float(r['solve_seconds']):.0f} s; {r['solves']} solves, {r['setups']} set-ups, CG it. mean "
          f"{float(r['cg_iterations_mean']):.1f} max {r['cg_iterations_max']}) | span {r['krylov_span']} at "
          f"{r['krylov_points']} points → order {r['order']} ({r['compression']}, loss "
          f"{float(r['compression_loss']):.1e})"
          f" | peak {r['peak_gb_offline']:.2f} GB = {r['bytes_per_voxel']:.0f} B/voxel (basis floor "
          f"{r['basis_floor_bytes_per_voxel']:.0f})" + checks + f" | load {r['load_start']:.1f}–{r['load_end']:.1f}",
          flush=True)


def fit_exponent(sizes: list[float], values: list[float]) -> tuple[float, float]:
    """(least-squares slope of log value against log size, two-point slope between the extremes)."""
    x, y = np.log(sizes), np.log(values)
    slope = float(np.polyfit(x, y, 1)[0]) if len(sizes) > 1 else float("nan")
    two = float((y[-1] - y[0]) / (x[-1] - x[0])) if len(sizes) > 1 else float("nan")
    return slope, two


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[24, 32, 46, 64, 96])
    parser.add_argument("--eigensolvers", nargs="+", default=["lobpcg"], choices=["arpack", "lobpcg", "auto", "krylov"],
                        help="eigensolvers of the amalgam (order 200), or 'krylov': the eigen-free Krylov reductor")
    parser.add_argument("--krylov-order", type=int, default=50, help="order of the Krylov reduced model")
    parser.add_argument("--rtol", type=float, default=1e-10, help="relative residual of the Krylov shifted solves")
    parser.add_argument("--cache", type=Path, default=None, help="Krylov: keep the model in this cache folder")
    parser.add_argument("--check-only", action="store_true",
                        help="Krylov: check the model stored in --cache against --truth-dir (its build is not timed)")
    parser.add_argument("--assembled", action="store_true",
                        help="Krylov: assemble the terms as sparse matrices (default: matrix-free voxel terms)")
    parser.add_argument("--truth-dir", type=Path, default=None,
                        help="Krylov: folder of the full-model references of benchmarks/scaling_truth.py")
    parser.add_argument("--steps", type=int, default=300, help="time steps of the full model compared (dt 0.1 s)")
    parser.add_argument("--amg-above", type=int, default=150_000, help="full model by AMG-CG above this many nodes")
    parser.add_argument("--float32", action="store_true", help="also measure float32 storage of the basis")
    parser.add_argument("--half-step", action="store_true",
                        help="also run the full model at dt/2 (its own time error; ROM against the Richardson value)")
    parser.add_argument("--json", type=Path, default=None, help="append each worker's result to this file")
    parser.add_argument("--memory-limit-gb", type=float, default=14.0,
                        help="address-space cap of a worker: a MemoryError instead of the machine's OOM killer")
    parser.add_argument("--summarise", type=Path, default=None,
                        help="only print the rows stored in this --json file, the growth exponents and the "
                             "extrapolation of the largest two sizes to --extrapolate")
    parser.add_argument("--extrapolate", type=int, default=256, help="edge n³ the --summarise extrapolates to")
    parser.add_argument("--worker", nargs=2, metavar=("N", "EIGENSOLVER"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.summarise:
        stored = [json.loads(line) for line in args.summarise.read_text().splitlines() if line.strip()]
        for row in sorted(stored, key=lambda r: (str(r["eigensolver"]), int(r["n"]))):
            (print_krylov_row if row["eigensolver"] == "krylov" else print_row)(row)
        summarise(stored, args.extrapolate)
        return
    if args.worker:
        limit = int(args.memory_limit_gb * 1e9)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        if args.worker[1] == "krylov":
            sys.path.insert(0, str(Path(__file__).parent))
            result = krylov_worker(int(args.worker[0]), rtol=args.rtol, order=args.krylov_order,
                                   truth_dir=args.truth_dir, cache=args.cache, check_only=args.check_only,
                                   assembled=args.assembled)
        else:
            result = worker(int(args.worker[0]), args.worker[1], args.steps, args.amg_above, float32=args.float32,
                            half_step=args.half_step)
        print(json.dumps(result))
        return
    rows: list[dict[str, object]] = []
    for solver in args.eigensolvers:
        for n in args.sizes:
            cmd = [sys.executable, __file__, "--worker", str(n), solver, "--steps", str(args.steps),
                   "--amg-above", str(args.amg_above),
                   "--memory-limit-gb", str(args.memory_limit_gb)] + (["--float32"] if args.float32 else []) + (
                       ["--half-step"] if args.half_step else []) + [
                       "--rtol", str(args.rtol), "--krylov-order", str(args.krylov_order)] + (
                       ["--truth-dir", str(args.truth_dir)] if args.truth_dir else []) + (
                       ["--cache", str(args.cache)] if args.cache else []) + (
                       ["--check-only"] if args.check_only else []) + (["--assembled"] if args.assembled else [])
            env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
            done = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=env, check=False)  # stderr: progress
            if done.returncode != 0:
                print(f"{n}³ {solver}: worker failed with exit code {done.returncode} (its messages: stderr)")
                continue
            row = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(row)
            if args.json is not None:
                with args.json.open("a") as fh:
                    fh.write(json.dumps(row) + "\n")
            (print_krylov_row if solver == "krylov" else print_row)(row)
    summarise(rows, args.extrapolate)


def print_row(r: dict[str, object]) -> None:
    print(f"{r['n']:>3}³ {r['eigensolver']:>6}: {r['nodes']:>8} nodes | offline CPU {r['offline_cpu']:8.1f} s "
          f"(wall {r['offline_wall']:8.1f} s, bases {float(r['basis_seconds']):7.1f} s wall, "
          f"{r['eigen_iterations']} LOBPCG it.) | peak {r['peak_gb_offline']:.2f} GB offline, {r['peak_gb']:.2f} GB "
          f"with the full model = {r['bytes_per_voxel']:.0f} B/voxel "
          f"(basis floor {r['basis_floor_bytes_per_voxel']:.0f})"
          f" | max |ROM − full| {r['max_error']:.2e} °C over {r['max_face_mean']:.2f} °C "
          f"(full {r['full_method']}, {r['full_cpu']:.0f} s CPU), steady {r['steady_error']:.2e} °C"
          + (f" | full model's own BDF2 error {r['full_time_error']:.2e} °C, |ROM − full(dt→0)| "
             f"{r['max_error_richardson']:.2e} °C" if "full_time_error" in r else "")
          + (f" | float32 basis changes face means by {r['float32_change']:.1e} °C" if "float32_change" in r else "")
          + f" | load {r['load_start']:.1f}–{r['load_end']:.1f}", flush=True)


def summarise(rows: list[dict[str, object]], target: int) -> None:
    for solver in sorted({str(r["eigensolver"]) for r in rows}):
        mine = sorted((r for r in rows if r["eigensolver"] == solver), key=lambda r: int(r["n"]))  # type: ignore[arg-type]
        if len(mine) < 2:
            continue
        voxels = [float(r["n"]) ** 3 for r in mine]  # type: ignore[arg-type]
        t_ls, t_two = fit_exponent(voxels, [float(r["offline_cpu"]) for r in mine])  # type: ignore[arg-type]
        m_ls, m_two = fit_exponent(voxels, [float(r["peak_gb_offline"]) for r in mine])  # type: ignore[arg-type]
        print(f"{solver}: offline CPU ∝ N^{t_ls:.2f} (least squares), N^{t_two:.2f} ({mine[0]['n']}³→{mine[-1]['n']}³);"
              f" peak memory ∝ N^{m_ls:.2f}, N^{m_two:.2f} (N = voxels)")
        n1, n2 = (float(r["n"]) ** 3 for r in mine[-2:])  # type: ignore[arg-type]
        t1, t2 = (float(r["offline_cpu"]) for r in mine[-2:])  # type: ignore[arg-type]
        m1, m2 = (float(r["peak_gb_offline"]) for r in mine[-2:])  # type: ignore[arg-type]
        grow_t, grow_m = np.log(t2 / t1) / np.log(n2 / n1), np.log(m2 / m1) / np.log(n2 / n1)
        ratio = target**3 / n2  # extrapolation: the growth between the two largest sizes measured
        print(f"{solver}: EXTRAPOLATED to {target}³ from {mine[-2]['n']}³→{mine[-1]['n']}³ (N^{grow_t:.2f} time, "
              f"N^{grow_m:.2f} memory): {t2 * ratio**grow_t:.0f} CPU s, {m2 * ratio**grow_m:.1f} GB (not measured)")  # type: ignore[arg-type]


if __name__ == "__main__":
    main()
