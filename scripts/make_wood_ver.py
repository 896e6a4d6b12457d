"""Reproducible generator call for data/wood_ver.npz, and the record of how it was tuned.

    python scripts/make_wood_ver.py                 # write data/wood_ver.npz, print phi, c̄ and k̄ (scenarios)
    python scripts/make_wood_ver.py --homogenize    # + k by aromm.homogenize on data/scenes/wood_homogenize.toml
    python scripts/make_wood_ver.py --search 1000   # replay the random search that chose PARAMS

Target [Chavez2020, § 4.2, k_F = 0.3, k_G = 0.025, c_F = 4e6, c_G = 1.2e3]: k̄ = (0.087, 0.099, 0.123) W/(m K)
by the fluxmetric technique (eq. 13) applied to the heterogeneous model under the three scenarios of
Table 1 (flux 500 W/m² on S1, h = 20 W/(m² K) on S2: ``aromm.fluxmetric``), and
c̄ = 1.558e6 J/(m^3 K) (eq. 14, i.e. fibre fraction 0.3893), on a 231 µm cube; here 46^3 voxels of 5 µm.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.vocabulary import PhaseSpec
from aromm.homogenization.properties import fluxmetric
from aromm.microstructure import save_image, wood
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene
from aromm.studies.chavez2020 import loading

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "wood_ver.npz"
SHAPE = (46, 46, 46)
VOXEL = 5.0e-6
K = {1: 0.3, 0: 0.025}  # fibre, gas, W/(m K)
C = {1: 4.0e6, 0: 1.2e3}  # J/(m^3 K)
TARGET_K = np.array([0.087, 0.099, 0.123])
TARGET_C = 1.558e6

# chosen by `--search 1000` with the scenario objective (best draw: image seed 347, max error 1.12 %),
# parameters then rounded to three significant digits (max error 1.06 %); see data/README.md
SEED = 347
PARAMS: dict[str, float | None] = {
    "cell_size_radial": 19.7e-6,
    "cell_size_tangential": 29.2e-6,
    "wall_thickness": 4.76e-6,
    "size_jitter": 0.147,
    "tracheid_length": 134e-6,
    "grain_angle": 0.150,  # rad (8.6 degrees)
}


def make(seed: int, params: dict) -> np.ndarray:
    return wood(SHAPE, VOXEL, np.random.default_rng(seed), **params)


def capacity(labels: np.ndarray) -> float:
    phi = float(labels.mean())
    return phi * C[1] + (1.0 - phi) * C[0]


def scenario_k(labels: np.ndarray) -> np.ndarray:
    """Eq. 13 under each Table 1 scenario [Chavez2020, § 4.2], k̄_xx, k̄_yy, k̄_zz by aromm.fluxmetric."""
    phases = (PhaseSpec("gas", 0, K[0], C[0]), PhaseSpec("fibre", 1, K[1], C[1]))
    material = Scene(VoxelGeometry(labels, (VOXEL,) * 3), phases)
    return np.array([fluxmetric(loading(material, axis), method="amg").k for axis in "xyz"])


def score(k: np.ndarray, c: float) -> float:
    return float(max(np.abs(k / TARGET_K - 1).max(), abs(c / TARGET_C - 1)))


# search ranges (m, rad): radial cell size, tangential/radial ratio, wall, jitter, tracheid length,
# probability of no tips, grain angle.  Earlier searches (data/README.md) had no grain angle.
RANGES: dict[str, Any] = {"radial": (19e-6, 25e-6), "ratio": (1.15, 1.5), "wall": (4.5e-6, 6.5e-6),
                          "jitter": (0.08, 0.22), "tracheid": (50e-6, 200e-6), "no_tips": 0.5, "grain": (0.05, 0.30)}


def search(n: int, seed: int = 2026) -> None:
    """Random search: draw parameters, keep images whose c̄ is within 1.5 %, solve k, print the best."""
    rng = np.random.default_rng(seed)
    ranges = RANGES
    best: tuple[float, tuple[int, dict[str, Any]] | None] = (np.inf, None)
    print("   seed  radial  tangent  wall  jitter  tracheid  grain°   phi     k_xx    k_yy    k_zz   max err")
    for _ in range(n):
        a = rng.uniform(*ranges["radial"])
        params = {
            "cell_size_radial": a,
            "cell_size_tangential": a * rng.uniform(*ranges["ratio"]),
            "wall_thickness": rng.uniform(*ranges["wall"]),
            "size_jitter": rng.uniform(*ranges["jitter"]),
            "tracheid_length": None if rng.random() < ranges["no_tips"] else rng.uniform(*ranges["tracheid"]),
            "grain_angle": rng.uniform(*ranges["grain"]),
        }
        image_seed = int(rng.integers(1000))
        labels = make(image_seed, params)
        c = capacity(labels)
        if abs(c / TARGET_C - 1) > 0.015:
            continue
        k = scenario_k(labels)
        err = score(k, c)
        length = params["tracheid_length"]
        print(
            f"{image_seed:7d} {params['cell_size_radial'] * 1e6:6.1f} {params['cell_size_tangential'] * 1e6:8.1f}"
            f" {params['wall_thickness'] * 1e6:5.2f} {params['size_jitter']:7.3f}"
            f" {'-' if length is None else f'{length * 1e6:8.1f}':>9} {np.degrees(params['grain_angle']):6.2f}"
            f" {labels.mean():6.4f}"
            f" {k[0]:7.4f} {k[1]:7.4f} {k[2]:7.4f} {err:8.4f}",
            flush=True,
        )
        if err < best[0]:
            best = (err, (image_seed, params))
    print("best:", best)


def report(method: str, conductivity: Callable[[np.ndarray], np.ndarray], labels: np.ndarray) -> None:
    """Print k̄ of ``labels`` by ``conductivity``, its max relative error against the targets, and the seconds."""
    start = time.perf_counter()
    k = conductivity(labels)
    print(f"{method}: k = {np.round(k, 5).tolist()} W/(m K) (target {TARGET_K.tolist()}),"
          f" max rel. error {score(k, capacity(labels)):.4f}, {time.perf_counter() - start:.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--search", type=int, metavar="N", help="replay the random search with N draws")
    parser.add_argument("--homogenize", action="store_true", help="confirm with aromm.homogenize")
    args = parser.parse_args()
    if args.search:
        search(args.search)
        return
    labels = make(SEED, PARAMS)
    save_image(OUT, labels, VOXEL)
    print(f"wrote {OUT.relative_to(ROOT)}: shape {labels.shape}, voxel {VOXEL} m, fibre fraction {labels.mean():.4f},"
          f" c̄ = {capacity(labels):.4e} J/(m^3 K) (target {TARGET_C:.4e})")
    report("eq. 13 under the scenarios (aromm.fluxmetric)", scenario_k, labels)
    if args.homogenize:
        from aromm.homogenization.properties import homogenize, mean_capacity
        from aromm.scene.scene_file import load_scene

        start = time.perf_counter()
        scene = load_scene(ROOT / "data" / "scenes" / "wood_homogenize.toml")
        k = np.diag(homogenize(scene, boundary="flux", method="amg"))
        c = mean_capacity(scene)
        print(f"aromm.homogenize (data/scenes/wood_homogenize.toml): k = {np.round(k, 4).tolist()} W/(m K),"
              f" c̄ = {c:.4e} J/(m^3 K), max rel. error {score(k, c):.4f}, {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
