"""Real-experiment features of the reduced model (issue 14 items 1–3): errors bought against seconds and bytes.

On a wood image (the spruce-like generator, ``--size`` voxels per side, 5 µm voxels; or the shipped 46³ VER
with ``--shipped``), under [Chavez2020]'s scenario 1 turned into a laboratory experiment:

1. ``pulse``: a 2 s flux pulse (ramps of 0.1 s) on z0, convection h = 20 W/(m² K) on z1.  The reduced
   model (exact in time for the piecewise-linear pulse) against the full model, whose BDF2 error is removed
   by Richardson extrapolation of dt and dt/2 (``--dt``); per order ñ: max error (°C), offline and online
   seconds, and the cost of the history in the online evaluation (a swarm of 20 parameter sets, pulse vs
   constant flux).
2. ``h``: the same reduced models at h × 0.7 and h × 1.3 (bases built at h), with the default correction
   vectors and with h samples added to them (``z1.h`` × 0.7, 1.3): is anything gained?
3. ``fixed``: z1 held at a fixed temperature (constant 20 °C from T0 = 20 °C, and a ramp 20 → 25 °C over
   5 s), lifted into the reduced model (aromm.reduction.lifting), against the full model, at the reference values
   and at k_F = 0.1 W/(m K).

Every row prints wall seconds; the header prints CPU seconds, peak memory, bytes per voxel of the
offline stage and the load average (the machine is shared: wall times vary with the load).

    python benchmarks/real_experiments.py                  # 12³ generated image
    python benchmarks/real_experiments.py --size 16 --orders 10 20 40 80
    python benchmarks/real_experiments.py --shipped --orders 100 200
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import resource
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import transient
from aromm.microstructure.generators import wood
from aromm.microstructure.io import load_image
from aromm.reduction.corrections import correction_samples
from aromm.reduction.offline import reduce
from aromm.reduction.rom import ReducedModel

ROOT = Path(__file__).resolve().parents[1]
PHASES = (PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4.0e6))
PULSE = Profile((0.0, 0.1, 2.0, 2.1), (0.0, 500.0, 500.0, 0.0))
RAMP = Profile((0.0, 5.0), (20.0, 25.0))
END, DT = 20.0, 0.1


def image(size: int, shipped: bool) -> np.ndarray:
    if shipped:
        labels, _ = load_image(ROOT / "data" / "wood_ver.npz")
        return np.asarray(labels)
    return np.asarray(wood((size,) * 3, 5e-6, np.random.default_rng(0)))


def system(labels: np.ndarray, z0: FaceSpec, z1: FaceSpec, initial: float = 0.0) -> ThermalSystem:
    return assemble_voxels(labels, (5e-6,) * 3, PHASES, [z0, z1], time=TimeGrid(END, DT), initial_T=initial,
                           outputs=["z0", "z1"])


def converged(sys_: ThermalSystem, values: Mapping[str, float], dt: float) -> tuple[np.ndarray, float]:
    """The full model at the scene's output times, Richardson-extrapolated from dt and dt/2 (BDF2: error
    O(dt³) left), and the wall seconds of the dt run."""
    t = np.round(DT * np.arange(1, round(END / DT) + 1), 12)
    start = time.perf_counter()
    coarse = transient(dataclasses.replace(sys_, time=TimeGrid(END, dt)), values, t).as_array()
    seconds = time.perf_counter() - start
    fine = transient(dataclasses.replace(sys_, time=TimeGrid(END, dt / 2)), values, t).as_array()
    return (4.0 * fine - coarse) / 3.0, seconds


def online(rom: ReducedModel, values: Mapping[str, float], repeats: int = 3) -> float:
    """Wall seconds of one swarm evaluation (20 parameter sets around ``values``)."""
    swarm = {k: np.full(20, v) * np.linspace(0.9, 1.1, 20) for k, v in values.items()}
    rom.simulate_batch(swarm)
    start = time.perf_counter()
    for _ in range(repeats):
        rom.simulate_batch(swarm)
    return (time.perf_counter() - start) / repeats


def error(rom: ReducedModel, truth: np.ndarray, values: Mapping[str, float]) -> float:
    return float(np.abs(rom.simulate(values).as_array() - truth).max())


def pulse_and_h(labels: np.ndarray, orders: Sequence[int], dt: float, cache: NpzCache) -> None:
    sys_ = system(labels, FaceSpec("z0", flux=PULSE), FaceSpec("z1", h=20.0))
    constant = system(labels, FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0))
    points = {"h": {}, "0.7 h": {"z1.h": 14.0}, "1.3 h": {"z1.h": 26.0},
              "k_F/3, 1.3 h": {"fibre.k": 0.1, "z1.h": 26.0}}
    truths = {}
    for name, values in points.items():
        truths[name], full_s = converged(sys_, values, dt)
    print(f"\n[pulse, h] full model dt = {dt:g} s: {full_s:.2f} s per run; max |T| = "
          f"{max(np.abs(t).max() for t in truths.values()):.3g} °C")
    print(f"{'ñ':>4} {'corrections':>12} {'Ñ':>5} " + " ".join(f"{'err ' + n:>15}" for n in points)
          + f" {'offline s':>10} {'swarm pulse s':>14} {'swarm const s':>14}")
    for order in orders:
        const_rom = reduce(constant, order=order, cache=cache)
        for label, extra in (("default", ()), ("+ h samples", (0.7, 1.3))):
            samples = correction_samples(sys_)
            samples += [{**samples[0], "z1.h": 20.0 * f} for f in extra]
            start = time.perf_counter()
            rom = reduce(sys_, order=order, corrections=samples, cache=cache)
            offline = time.perf_counter() - start
            errs = " ".join(f"{error(rom, truths[n], v):15.3e}" for n, v in points.items())
            print(f"{rom.order:4d} {label:>12} {rom.info['modes']:5d} {errs} {offline:10.2f} "
                  f"{online(rom, {'fibre.k': 0.3}):14.4f} {online(const_rom, {'fibre.k': 0.3}):14.4f}")


def fixed(labels: np.ndarray, orders: Sequence[int], dt: float, cache: NpzCache) -> None:
    cases = {"T = 20": FaceSpec("z1", T=20.0), "T ramp": FaceSpec("z1", T=RAMP)}
    points = {"ref": {}, "k_F/3": {"fibre.k": 0.1}}
    print(f"\n[fixed T on z1, pulse on z0, T0 = 20 °C] errors against the full model (Richardson, dt = {dt:g} s)")
    print(f"{'ñ':>4} {'case':>8} {'Ñ':>5} " + " ".join(f"{'err ' + n:>12}" for n in points) + f" {'offline s':>10}")
    for label, face in cases.items():
        sys_ = system(labels, FaceSpec("z0", flux=PULSE), face, initial=20.0)
        truths = {n: converged(sys_, v, dt)[0] for n, v in points.items()}
        for order in orders:
            start = time.perf_counter()
            rom = reduce(sys_, order=order, cache=cache)
            offline = time.perf_counter() - start
            errs = " ".join(f"{error(rom, truths[n], v):12.3e}" for n, v in points.items())
            print(f"{rom.order:4d} {label:>8} {rom.info['modes']:5d} {errs} {offline:10.2f}")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=int(os.environ.get("AROMM_SIZE", "12")))
    parser.add_argument("--shipped", action="store_true", help="data/wood_ver.npz (46³) instead of a generated image")
    parser.add_argument("--orders", type=int, nargs="+", default=[10, 20, 40])
    parser.add_argument("--dt", type=float, default=0.005, help="full-model step of the Richardson pair (s)")
    args = parser.parse_args(argv)
    labels = image(args.size, args.shipped)
    cpu, wall = time.process_time(), time.perf_counter()
    print(f"image {labels.shape}, {int(np.prod(np.asarray(labels.shape) + 1))} DOFs; load average "
          f"{os.getloadavg()[0]:.1f} (shared machine)")
    with tempfile.TemporaryDirectory() as folder:
        cache = NpzCache(folder)  # bases shared by the rows of one run, none reused from earlier runs
        pulse_and_h(labels, args.orders, args.dt, cache)
        fixed(labels, args.orders, args.dt, cache)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(f"\ntotal: {time.process_time() - cpu:.1f} CPU s, {time.perf_counter() - wall:.1f} wall s, peak memory "
          f"{peak / 1e9:.2f} GB ({peak / labels.size:.0f} bytes per voxel), load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
