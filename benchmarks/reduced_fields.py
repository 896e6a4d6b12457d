"""Temperature fields from the reduced model: what the basis Ψ costs (bytes, seconds) and the error it buys.

For [Chavez2020]'s scenario 1 on a spruce-like VER (aromm.studies.chavez2020.small_wood, n³ voxels, 60 s at
dt = 0.1 s) it prints, per size:

* the cache: bytes of the light model entry (``rom``), of Ψ's coefficients on the detailed basis
  (``reconstruction``, the only addition for fields), and of the detailed basis it rebuilds Ψ from
  (``basis`` + ``corrections``, cached anyway by every build); Ψ itself in memory (bytes and bytes per voxel);
* seconds (CPU and wall) to load the light model and to load it with Ψ (``reduce(..., fields=True)``);
* the error of the reduced fields against the full model's (BDF2 at dt and dt/2, extrapolated: the BDF2
  error is printed too), max and capacity-weighted RMS, beside the error of the face means;
* the peak Python-tracked memory of :meth:`ReducedModel.iter_fields` over 10 and over 100 times (it
  should not grow with the number of times: one field at a time);
* the observation rows of a 16 × 16 IR camera on z1, sparse against dense.

    python benchmarks/reduced_fields.py                      # sizes 12 and 24
    python benchmarks/reduced_fields.py --sizes 16 --order 60 --json out.json
    python benchmarks/reduced_fields.py --sizes 46 --order 200 --no-full   # VER size: bytes and seconds only
                                                                           # (the full fields would hold every step)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.observables import Observables
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.full.solve import simulate
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble
from aromm.scene.sensors import FaceSensor, voxel_rows
from aromm.studies.chavez2020 import BASIS_VALUES, REFERENCE_VALUES, loading, small_wood

TIMES = np.array([1.0, 10.0, 60.0])
PARAMS = {"fibre.k": 0.3, "fibre.c": 4e6}


def _clock() -> tuple[float, float]:
    return time.process_time(), time.perf_counter()


def _since(start: tuple[float, float]) -> tuple[float, float]:
    return time.process_time() - start[0], time.perf_counter() - start[1]


def _bytes(folder: Path, kind: str) -> int:
    return sum(p.stat().st_size for p in folder.glob(f"{kind}-*.npz"))


def measure(n: int, order: int, full: bool = True) -> dict[str, float]:
    scene = loading(small_wood(n), "z", end=60.0, dt=0.1)
    system = assemble(scene)
    voxels = n**3
    out: dict[str, float] = {"size": n, "nodes": system.n, "order": order}
    with tempfile.TemporaryDirectory() as tmp:
        store = NpzCache(tmp)
        options = {"basis_values": BASIS_VALUES, "reference_values": REFERENCE_VALUES, "cache": store}
        start = _clock()
        reduce(system, order, **options)  # type: ignore[arg-type]
        out["build_cpu_s"], out["build_wall_s"] = _since(start)
        start = _clock()
        light = reduce(system, order, **options)  # type: ignore[arg-type]
        out["load_cpu_s"], out["load_wall_s"] = _since(start)
        start = _clock()
        rom = reduce(system, order, fields=True, **options)  # type: ignore[arg-type]
        out["load_fields_cpu_s"], out["load_fields_wall_s"] = _since(start)
        assert light.basis is None and rom.basis is not None
        folder = Path(tmp)
        out["rom_entry_bytes"] = _bytes(folder, "rom")
        out["reconstruction_bytes"] = _bytes(folder, "reconstruction")
        out["detailed_basis_bytes"] = _bytes(folder, "basis") + _bytes(folder, "corrections")
        out["psi_bytes"] = rom.basis.nbytes
        out["psi_bytes_per_voxel"] = rom.basis.nbytes / voxels

    start = _clock()
    reduced = rom.simulate(PARAMS, TIMES, fields=True)
    out["reduced_fields_cpu_s"], out["reduced_fields_wall_s"] = _since(start)
    if full:
        out.update(_against_full(system, reduced))
    for nt in (10, 100):
        times = np.linspace(0.5, 60.0, nt)
        tracemalloc.start()
        for _ in rom.iter_fields(PARAMS, times):
            pass
        out[f"iter_fields_peak_bytes_{nt}"] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()

    camera = FaceSensor("cam", "z1", ((0.0, scene.size[0]), (0.0, scene.size[1])), (16, 16))
    rows = voxel_rows([camera], scene.geometry.shape, scene.geometry.voxel_size)  # type: ignore[union-attr]
    out["camera_sparse_bytes"] = sum(r.data.nbytes + r.indices.nbytes + r.indptr.nbytes for r in rows.values())
    out["camera_dense_bytes"] = 8 * system.n * len(rows)
    return out


def _against_full(system: ThermalSystem, reduced: Observables) -> dict[str, float]:
    """Errors of the reduced fields and outputs against the full model (BDF2 at dt and dt/2, Richardson)."""
    out: dict[str, float] = {}
    start = _clock()
    coarse = simulate(system, PARAMS, TIMES, fields=True)
    out["full_cpu_s"], out["full_wall_s"] = _since(start)
    fine = simulate(replace(system, time=TimeGrid(60.0, 0.05)), PARAMS, TIMES, fields=True)
    assert reduced.fields is not None and coarse.fields is not None and fine.fields is not None
    exact = fine.fields + (fine.fields - coarse.fields) / 3.0  # Richardson, BDF2 is second order
    weight = np.asarray(system.capacity.evaluate(system.values(PARAMS)) @ np.ones(system.n))
    diff = reduced.fields - exact
    out["field_max_error"] = float(np.abs(diff).max())
    out["field_rms_error"] = float(np.sqrt(((diff**2) @ weight / weight.sum()).max()))
    out["bdf2_dt_field_error"] = float(np.abs(coarse.fields - exact).max())
    exact_out = fine.as_array() + (fine.as_array() - coarse.as_array()) / 3.0
    out["output_max_error"] = float(np.abs(reduced.as_array() - exact_out).max())
    out["field_scale"] = float(np.abs(exact).max())
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[12, 24])
    parser.add_argument("--order", type=int, default=40)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-full", dest="full", action="store_false", help="skip the full-model comparison")
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        row = measure(n, args.order, args.full)
        rows.append(row)
        print(f"\n{n}³ voxels, {int(row['nodes'])} nodes, order {args.order}, load average {os.getloadavg()[0]:.1f} "
              "(shared 2-core machine)")
        print(f"  cache: rom entry {row['rom_entry_bytes'] / 1e6:.3f} MB, Ψ coefficients (reconstruction) "
              f"{row['reconstruction_bytes'] / 1e6:.3f} MB, detailed basis {row['detailed_basis_bytes'] / 1e6:.1f} MB")
        print(f"  Ψ in memory {row['psi_bytes'] / 1e6:.1f} MB = {row['psi_bytes_per_voxel']:.0f} B/voxel")
        print(f"  load light {row['load_cpu_s']:.3f} s CPU ({row['load_wall_s']:.3f} wall); with Ψ "
              f"{row['load_fields_cpu_s']:.3f} s CPU ({row['load_fields_wall_s']:.3f} wall); "
              f"build {row['build_cpu_s']:.1f} s CPU ({row['build_wall_s']:.1f} wall)")
        print(f"  fields at {TIMES.tolist()} s: reduced {row['reduced_fields_cpu_s']:.3f} s CPU")
        if args.full:
            print(f"  full BDF2 {row['full_cpu_s']:.2f} s CPU; error vs the extrapolated full model: fields max "
                  f"{row['field_max_error']:.2e} °C, RMS {row['field_rms_error']:.2e} °C; outputs "
                  f"{row['output_max_error']:.2e} °C; BDF2 at dt = 0.1 s itself {row['bdf2_dt_field_error']:.2e} °C "
                  f"(fields up to {row['field_scale']:.3g} °C)")
        print(f"  iter_fields peak traced memory: 10 times {row['iter_fields_peak_bytes_10'] / 1e6:.2f} MB, "
              f"100 times {row['iter_fields_peak_bytes_100'] / 1e6:.2f} MB")
        print(f"  16 × 16 camera rows: sparse {row['camera_sparse_bytes'] / 1e3:.1f} kB, dense would be "
              f"{row['camera_dense_bytes'] / 1e6:.1f} MB")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    print(f"\npeak RSS {peak:.0f} MB")
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "peak_rss_mb": peak}, indent=1))


if __name__ == "__main__":
    main()
