"""Accuracy vs cost of the AROMM reduced model (and the POD baseline) on the wood scenes of [Chavez2020].

Sweeps the reduced order ñ, the detailed basis size Ñ and the distance of the fibre properties from
the reference values (k_F 0.05 … 1 W/(m K), c_F 1e5 … 1e7 J/(m³ K)); prints, for AROMM and POD,
the max error (°C) of the two face means of scenario 1 against the full finite-element model,
with the offline seconds (bases + reduction) and the online seconds per evaluation.

    python benchmarks/aromm_accuracy.py                   # AROMM_SIZE voxels per side (default 12)
    python benchmarks/aromm_accuracy.py --shipped         # data/wood_ver.npz (46³), scenes wood_s1..s3
    python benchmarks/aromm_accuracy.py --size 24 --orders 10 20 40 --modes 80 160 --json out.json

Without ``--shipped`` the image is the spruce-like generator of aromm.microstructure at the
scenes' voxel size (5 µm), seeded (rng seed 0), so the run is reproducible.  The same functions
feed notebooks/accuracy_vs_cost.ipynb.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.full.solve import simulate
from aromm.microstructure.generators import wood
from aromm.reduction.modal_bases import compute_basis, split_modes
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble, load_scene
from aromm.studies.chavez2020 import BASIS_VALUES, REFERENCE_VALUES, UNKNOWNS

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "data" / "scenes"
SHIPPED_IMAGE = ROOT / "data" / "wood_ver.npz"
DEFAULT_POINTS = ((0.3, 4e6), (0.05, 1e5), (0.05, 1e7), (1.0, 1e5), (1.0, 1e7), (0.1, 1.2e6))


@dataclass(frozen=True)
class Row:
    method: str
    modes: int
    order: int
    k_F: float
    c_F: float
    max_error: float  # °C, max over both face means and all output times, against the (refined) full model
    offline_s: float  # bases (when not shared) + snapshots + reduction, wall clock
    online_s: float  # one evaluation (whole scenario), wall clock
    full_s: float  # the full model on the same parameters, wall clock


def wood_scenarios(size: int | None, workdir: Path) -> tuple[ThermalSystem, ThermalSystem, ThermalSystem]:
    """Scenarios 1–3 of [Chavez2020] (data/scenes/wood_s{1,2,3}.toml); generated image of ``size`` voxels
    per side when ``size`` is given, else the shipped VER."""
    texts = [(SCENES / f"wood_s{i}.toml").read_text() for i in (1, 2, 3)]
    if size is not None:
        labels = np.asarray(wood((size,) * 3, 5e-6, np.random.default_rng(0)))
        image = workdir / f"wood_{size}.npz"
        np.savez(image, labels=labels)
        texts = [t.replace('image = "../wood_ver.npz"', f'image = "{image.name}"') for t in texts]
        folder = workdir
    else:
        if not SHIPPED_IMAGE.is_file():
            raise SystemExit(f"{SHIPPED_IMAGE} is not there yet; run without --shipped (generated image)")
        folder = SCENES
    systems = []
    for i, text in enumerate(texts, start=1):
        path = folder / f"wood_s{i}.toml"
        if size is not None:
            path.write_text(text)
        systems.append(assemble(load_scene(path)))
    return systems[0], systems[1], systems[2]


def timed_full(system: ThermalSystem, values: dict[str, float]) -> tuple[np.ndarray, float]:
    start = time.perf_counter()
    y = simulate(system, values).as_array()
    return y, time.perf_counter() - start


def converged_full(system: ThermalSystem, values: dict[str, float], refine: int) -> np.ndarray:
    """The full model with the scene's step divided by ``refine`` (BDF2 error / refine²), at the scene's times."""
    assert system.time is not None
    fine = replace(system, time=TimeGrid(system.time.end, system.time.dt / refine))
    return simulate(fine, values, system.time.times).as_array()


VARIANTS = {"aromm": ("aromm", True), "pod": ("pod", True), "aromm-seed": ("aromm", False), "pod-seed": ("pod", False),
            "krylov": ("krylov", False)}


def sweep(systems: Sequence[ThermalSystem], orders: Sequence[int], modes: Sequence[int], *,
          points: Sequence[tuple[float, float]] = DEFAULT_POINTS, methods: Sequence[str] = ("aromm", "pod"),
          refine: int = 1, repeats: int = 5) -> list[Row]:
    """Every (method, Ñ, ñ, parameter point) against the full model of scenario 1.

    ``methods``: ``aromm``, ``pod`` (with correction modes), ``aromm-seed``, ``pod-seed`` (without, i.e.
    the method of [Chavez2020]), ``krylov`` (eigen-free rational Krylov over the identification box ``UNKNOWNS``:
    no mode, so its rows are computed once, at the first Ñ, and carry Ñ = 0).  A POD order beyond the rank of
    its snapshots is refused by ``reduce``: that
    row is left out, and said.  ``refine`` > 1 measures the error against the full model with dt / refine
    (the reduced model is exact in time; the full model's BDF2 error is then removed from the figures).
    """
    s1, *refs = systems
    full = {}
    for k, c in points:
        values = {"fibre.k": k, "fibre.c": c}
        y, seconds = timed_full(s1, values)
        full[(k, c)] = (converged_full(s1, values, refine) if refine > 1 else y, seconds)
    rows = []
    with tempfile.TemporaryDirectory() as cache_dir:
        cache = NpzCache(cache_dir)  # bases computed once per Ñ, shared by every order and method
        for n_modes in modes:
            start = time.perf_counter()
            compute_basis(s1, *split_modes(s1, n_modes), BASIS_VALUES, cache=cache)
            basis_s = time.perf_counter() - start
            for order in orders:
                if order > n_modes:
                    continue
                for name in methods:
                    method, corrections = VARIANTS[name]
                    if method == "krylov" and n_modes != modes[0]:
                        continue
                    start = time.perf_counter()
                    try:
                        rom = (reduce(s1, order=order, method="krylov", bounds=UNKNOWNS, cache=cache,
                                      basis_values=BASIS_VALUES) if method == "krylov" else
                               reduce(s1, order=order, modes=n_modes, references=refs, method=method,
                                      corrections=corrections, cache=cache, basis_values=BASIS_VALUES,
                                      reference_values=REFERENCE_VALUES))
                    except InputError as err:  # POD beyond the rank of its snapshots: refused, never capped
                        if method != "pod":
                            raise
                        print(f"{name}, Ñ = {n_modes}, ñ = {order}: not in the table: {err}")
                        continue
                    offline = (0.0 if method == "krylov" else basis_s) + time.perf_counter() - start
                    for k, c in points:
                        values = {"fibre.k": k, "fibre.c": c}
                        rom.simulate(values)  # warm-up
                        start = time.perf_counter()
                        for _ in range(repeats):
                            y = rom.simulate(values).as_array()
                        online = (time.perf_counter() - start) / repeats
                        y_full, full_s = full[(k, c)]
                        rows.append(Row(name, 0 if method == "krylov" else n_modes, rom.order, k, c,
                                        float(np.abs(y - y_full).max()), offline, online, full_s))
    return rows


def table(rows: Sequence[Row]) -> str:
    head = f"{'method':>10} {'Ñ':>5} {'ñ':>5} {'k_F':>6} {'c_F':>8} {'max err °C':>11} {'offline s':>10} " \
           f"{'online s':>10} {'full s':>8} {'speed-up':>9}"
    lines = [head]
    for r in rows:
        lines.append(f"{r.method:>10} {r.modes:5d} {r.order:5d} {r.k_F:6.3g} {r.c_F:8.2g} {r.max_error:11.4g} "
                     f"{r.offline_s:10.2f} {r.online_s:10.4f} {r.full_s:8.2f} {r.full_s / r.online_s:9.0f}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=int(os.environ.get("AROMM_SIZE", "12")),
                        help="voxels per side of the generated image (env AROMM_SIZE)")
    parser.add_argument("--shipped", action="store_true", help="use data/wood_ver.npz and data/scenes/wood_s*.toml")
    parser.add_argument("--orders", type=int, nargs="+", default=[10, 20, 40, 80])
    parser.add_argument("--modes", type=int, nargs="+", default=[80, 160])
    parser.add_argument("--methods", nargs="+", default=["aromm", "pod", "aromm-seed"], choices=sorted(VARIANTS))
    parser.add_argument("--refine", type=int, default=10,
                        help="errors against the full model with dt / REFINE (1: the scene's dt)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows as JSON")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as work:
        systems = wood_scenarios(None if args.shipped else args.size, Path(work))
        print(f"scenario 1: {systems[0].n} DOFs, {'shipped VER' if args.shipped else f'generated {args.size}³'}")
        rows = sweep(systems, args.orders, args.modes, methods=args.methods, refine=args.refine)
    print(table(rows))
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")
    if args.json is not None:
        args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1))


if __name__ == "__main__":
    main()
