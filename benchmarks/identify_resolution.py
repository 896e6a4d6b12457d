"""What resolution costs for identification (issue 12, item 3): the same material at 1×, 2× and 3×.

Material: ``aromm.studies.chavez2020.small_wood(n)`` (default n = 24 over the paper's 230 µm box), refined R× by
splitting every voxel into R³ elements (``Scene.refined``, as ``--refine R``): the same geometry, finer Q1
elements.  benchmarks/homogenize_resolution.py does the same for the periodic k̄ tensor of the shipped VER.
Each stage runs in its own process (seconds and peak memory per stage):

1. at every R: k̄_xx, k̄_yy, k̄_zz by eq. 13 under the three Table 1 scenarios
   (aromm.homogenization.properties.fluxmetric, the k̄ an identification uses) and c̄ (eq. 14);
2. Richardson extrapolation of each k̄ to zero voxel size with the observed order p from the three
   resolutions (f(h) = f∞ + C h^p, h = 1, 1/2, 1/3 of the coarse voxel);
3. fixed "experimental" data for scenario 1 (flux into z0): the homogeneous twin [Chavez2020, eq. 1] with the
   extrapolated k̄_zz and c̄, solved on a fine 1-D column (``--twin-cells`` elements, dt / 10, sampled
   every 0.1 s): the same data for every R, as an experiment would give;
4. at every R: the reduced model of scenario 1 (ñ = 200, eigensolver by size) and the identification of
   (k_F, c_F) from those data (swarm + least squares, aromm.studies.chavez2020.run): estimates and seconds;
5. Richardson extrapolation of the identified k_F and c_F.  As R → ∞ they should tend to the values the
   material was built with (0.3 W/(m K), 4e6 J/(m³ K)); their distance at 1× is the part of the
   identification error due to discretisation.

    python benchmarks/identify_resolution.py --size 24 --factors 1 2 3 --cache /tmp/aromm-resolution

The machine is shared: CPU seconds (time.process_time of each worker) are the figure; wall seconds and
load averages are printed beside them.
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

import numpy as np
from homogenize_resolution import observed_order  # the same folder (run as a script)

from aromm.scene.scene_file import Scene

TRUTH = {"fibre.k": 0.3, "fibre.c": 4e6}
MEMORY_LIMIT_GB = 14.0
AXES = ("x", "y", "z")


def material(n: int, r: int, axis: str) -> Scene:
    """``small_wood(n)`` with every voxel split into r³ elements (Scene.refined), under scenario ``axis``."""
    from aromm.studies.chavez2020 import loading, small_wood

    return loading(small_wood(n).refined(r), axis)


def solver_for(nodes: int) -> str:
    return "mg" if nodes > 150_000 else "auto"


def homogenise_worker(n: int, r: int) -> dict[str, object]:
    from aromm.homogenization.properties import fluxmetric, mean_capacity

    wall, cpu = time.perf_counter(), time.process_time()
    nodes = (n * r + 1) ** 3
    k = {axis: fluxmetric(material(n, r, axis), method=solver_for(nodes)).k for axis in AXES}
    c = mean_capacity(material(n, r, "z"))
    return {"stage": "homogenise", "r": r, "k": k, "c": c, "cpu": time.process_time() - cpu,
            "wall": time.perf_counter() - wall}


def identify_worker(n: int, r: int, data: Path, cache: Path, order: int = 200) -> dict[str, object]:
    from aromm.reduction.offline import reduce
    from aromm.scene.scene_file import assemble
    from aromm.studies.chavez2020 import run
    from inverse.measurements import load_measurements

    scene = material(n, r, "z")
    system = assemble(scene)
    wall, cpu = time.perf_counter(), time.process_time()
    rom = reduce(system, order=order, basis_values=scene.reduction.basis, reference_values=scene.reduction.reference,
                 cache=cache)
    out: dict[str, object] = {"stage": "identify", "r": r, "nodes": system.n, "rom_cpu": time.process_time() - cpu,
                              "rom_wall": time.perf_counter() - wall, "rom_cached": rom.info.get("cached", 0),
                              "eigensolver": rom.info.get("eigensolver", "arpack")}
    measurements = load_measurements(data, rom.outputs)
    wall, cpu = time.perf_counter(), time.process_time()
    result = run(f"{r}x", rom, measurements, TRUTH)
    out.update({"identify_cpu": time.process_time() - cpu, "identify_wall": time.perf_counter() - wall,
                "estimates": dict(result.result.estimates), "errors": dict(result.errors),
                "criterion": result.result.criterion})
    return out


def twin_data(n: int, k_zz: float, c: float, cells: int, path: Path) -> None:
    """Fixed data: the homogeneous twin of scenario 1 on a 1-D column of ``cells`` elements, dt / 10."""
    from aromm.core.system import TimeGrid
    from aromm.homogenization.synthetic import homogeneous_measurements
    from aromm.scene.geometry import VoxelGeometry
    from inverse.measurements import Measurements, save_measurements

    scene = material(n, 1, "z")
    grid = scene.time
    assert grid is not None
    sx, sy, sz = scene.size
    column = replace(scene, geometry=VoxelGeometry(np.zeros((1, 1, cells), dtype=np.int64), (sx, sy, sz / cells)),
                     time=TimeGrid(grid.end, grid.dt / 10))
    fine = homogeneous_measurements(column, k_zz, c)
    keep = np.isin(np.round(fine.t / grid.dt, 6), np.round(grid.times / grid.dt, 6))
    save_measurements(Measurements(fine.t[keep], {f: v[keep] for f, v in fine.values.items()},
                                   "homogeneous twin, extrapolated k̄_zz"), path)


def richardson(values: list[float], factors: list[int]) -> tuple[float, float]:
    """(f∞, observed order p) from f at voxel sizes 1/R: through R = 1, 2, 3 by the observed order of
    benchmarks/homogenize_resolution.py; from two values with p = 1 (first order) assumed."""
    if len(values) >= 3 and factors[:3] == [1, 2, 3]:
        p, f_inf = observed_order(values[:3])
        return f_inf, p
    h = [1.0 / r for r in factors]
    coef = (values[-2] - values[-1]) / (h[-2] - h[-1])
    return values[-1] - coef * h[-1], 1.0


def spawn(args: list[str]) -> dict[str, object] | None:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        print(f"worker {args} failed with exit code {done.returncode}:\n{done.stderr}", flush=True)
        return None
    return json.loads(done.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=24, help="voxels per axis at 1x")
    parser.add_argument("--factors", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--order", type=int, default=200, help="reduced-model order ñ")
    parser.add_argument("--twin-cells", type=int, default=480, help="elements of the 1-D twin column")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "aromm-resolution")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        limit = int(MEMORY_LIMIT_GB * 1e9)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        stage, r = args.worker[0], int(args.worker[1])
        if stage == "homogenise":
            out = homogenise_worker(args.size, r)
        else:
            out = identify_worker(args.size, r, Path(args.worker[2]), args.cache, args.order)
        out["peak_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
        out["load"] = os.getloadavg()[0]
        print(json.dumps(out))
        return
    factors = sorted(args.factors)
    base = ["--size", str(args.size), "--cache", str(args.cache), "--order", str(args.order)]
    print(f"material: small_wood({args.size}) refined {factors}; truth {TRUTH}", flush=True)
    hom = {}
    for r in factors:
        row = spawn([*base, "--worker", "homogenise", str(r)])
        if row is None:
            continue
        hom[r] = row
        k = row["k"]
        print(f"{r}x ({args.size * r}³): k̄ = {k['x']:.5f} / {k['y']:.5f} / {k['z']:.5f} W/(m K) (xx/yy/zz, eq. 13), "  # type: ignore[index]
              f"c̄ = {row['c']:.5g}; {row['cpu']:.1f} s CPU, {row['wall']:.1f} s wall, {row['peak_gb']:.2f} GB, "
              f"load {row['load']:.1f}", flush=True)
    done = [r for r in factors if r in hom]
    extrapolated = {}
    for axis in AXES:
        values = [float(hom[r]["k"][axis]) for r in done]  # type: ignore[index]
        extrapolated[axis] = richardson(values, done)
        print(f"k̄_{axis}{axis}: Richardson {extrapolated[axis][0]:.5f} (observed order {extrapolated[axis][1]:.2f}); "
              f"1x differs by {100 * (values[0] / extrapolated[axis][0] - 1):+.2f} %", flush=True)
    data = args.cache / f"twin-{args.size}.csv"
    args.cache.mkdir(parents=True, exist_ok=True)
    twin_data(args.size, extrapolated["z"][0], float(hom[done[0]]["c"]), args.twin_cells, data)  # type: ignore[arg-type]
    ident = {}
    for r in done:
        row = spawn([*base, "--worker", "identify", str(r), str(data)])
        if row is None:
            continue
        ident[r] = row
        est = row["estimates"]
        print(f"{r}x ({row['nodes']} nodes): k_F = {est['fibre.k']:.5f}, c_F = {est['fibre.c']:.5g} "  # type: ignore[index]
              f"(errors {100 * row['errors']['fibre.k']:.3f} / {100 * row['errors']['fibre.c']:.3f} %); "  # type: ignore[index]
              f"ROM {row['rom_cpu']:.1f} s CPU ({row['eigensolver']}{', cached' if row['rom_cached'] else ''}), "
              f"identification {row['identify_cpu']:.1f} s CPU, {row['peak_gb']:.2f} GB, load {row['load']:.1f}",
              flush=True)
    got = [r for r in done if r in ident]
    for name, truth in TRUTH.items():
        values = [float(ident[r]["estimates"][name]) for r in got]  # type: ignore[index]
        if len(values) >= 2:
            f_inf, p = richardson(values, got)
            print(f"{name}: Richardson {f_inf:.6g} (observed order {p:.2f}; truth {truth:.6g}, "
                  f"{100 * (f_inf / truth - 1):+.3f} %); 1x identifies {100 * (values[0] / truth - 1):+.3f} %",
                  flush=True)


if __name__ == "__main__":
    main()
