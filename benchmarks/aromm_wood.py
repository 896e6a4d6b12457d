"""Must-show figures of the AROMM reduced model on the shipped wood VER [Chavez2020, § 3.3, Fig. 4].

Scenario 1 (data/scenes/wood_s1.toml) at k_F = 0.3 W/(m K), c_F = 4e6 J/(m³ K) — not the reference
values of the bases (0.53, 1.2e6) nor of the amalgam (0.1, 1.2e6) — measured side by side in one run:

* offline build (Dirichlet + Steklov bases, correction modes, reference cases, amalgam): wall and CPU
  seconds and peak memory (fresh cache folder, so nothing is reused);
* the full model (aromm.simulate, BDF2 with the scene's dt, CHOLMOD) and the reduced model on the
  same parameters: max |reduced − full| on the two face means over the whole scenario, seconds;
* with ``--fine-dt``: the full model again with a smaller step, to separate the full model's own
  time-discretisation error (the reduced model is exact in time);
* the reduced model on a swarm of 32 parameter sets in one call (seconds per set);
* ``--seed-variant``: the same order without correction modes (the method of [Chavez2020] exactly).

    python benchmarks/aromm_wood.py                      # ñ = 200 from Ñ = 300 modes
    python benchmarks/aromm_wood.py --fine-dt 0.02 --seed-variant

Measured with the second command on the shared 2-core machine (load average 4–6 from other jobs):
offline ñ = 200 from Ñ = 314 (150 Dirichlet, 150 Steklov, 14 correction) in 252 s CPU / 484 s wall,
peak 2.31 GB; full model 111 s, reduced 9.5 ms per evaluation (11 639×), 8.9 ms per set in a swarm
of 32; max |reduced − full(dt = 0.1 s)| = 0.042 / 0.027 °C (z0 / z1), of which the full model's own
BDF2 error is 0.041 / 0.025 °C (|full(0.1) − full(0.02)|); max |reduced − full(dt = 0.02 s)| =
0.0009 / 0.0019 °C; the variant of [Chavez2020] (no correction modes) 0.080 / 0.017 °C.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from aromm.core.system import ThermalSystem, TimeGrid
from aromm.full.solve import simulate
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble, load_scene
from aromm.studies.chavez2020 import BASIS_VALUES, REFERENCE_VALUES

SCENES = Path(__file__).resolve().parents[1] / "data" / "scenes"
POINT = {"fibre.k": 0.3, "fibre.c": 4e6}
SEED = {"basis_values": BASIS_VALUES, "reference_values": REFERENCE_VALUES}  # the [reduction] of the scenes


def clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def since(start: tuple[float, float]) -> tuple[float, float]:
    wall, cpu = clock()
    return wall - start[0], cpu - start[1]


def peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def with_dt(system: ThermalSystem, dt: float) -> ThermalSystem:
    from dataclasses import replace

    assert system.time is not None
    return replace(system, time=TimeGrid(system.time.end, dt))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--order", type=int, default=200, help="reduced order ñ")
    parser.add_argument("--modes", type=int, default=300, help="detailed basis Ñ (Dirichlet + Steklov)")
    parser.add_argument("--fine-dt", type=float, default=None, help="also run the full model with this dt (s)")
    parser.add_argument("--seed-variant", action="store_true", help="also reduce without correction modes")
    parser.add_argument("--cache", type=Path, default=None,
                        help="cache folder kept between runs (default: a fresh temporary folder)")
    args = parser.parse_args()

    s1, s2, s3 = (assemble(load_scene(SCENES / f"wood_s{i}.toml")) for i in (1, 2, 3))
    print(f"shipped wood VER, scenario 1: {s1.n} DOFs; parameters {POINT}")
    with tempfile.TemporaryDirectory() as tmp:
        cache = str(args.cache) if args.cache is not None else tmp
        start = clock()
        rom = reduce(s1, order=args.order, modes=args.modes, references=[s2, s3], cache=cache, **SEED, progress=True)
        off_wall, off_cpu = since(start)
        off_peak = peak_gb()
        start = clock()
        reduce(s1, order=args.order, modes=args.modes, references=[s2, s3], cache=cache, **SEED)
        again, _ = since(start)
        seed_rom = None
        if args.seed_variant:
            seed_rom = reduce(s1, order=args.order, modes=args.modes, references=[s2, s3], cache=cache, **SEED,
                              corrections=False)
    info = rom.info
    print(f"offline: ñ = {rom.order} from Ñ = {info['modes']} ({info['n_dirichlet']} Dirichlet, {info['n_steklov']} "
          f"Steklov incl. constant, {info['n_corrections']} correction modes); wall {off_wall:.1f} s, "
          f"CPU {off_cpu:.1f} s, bases {float(info['basis_seconds']):.1f} s; peak memory {off_peak:.2f} GB")
    print(f"second reduce of the same scene (cache): {again:.3f} s")

    start = clock()
    full = simulate(s1, POINT).as_array()
    full_wall, full_cpu = since(start)
    rom.simulate(POINT)  # warm-up
    repeats = 20
    start = clock()
    for _ in range(repeats):
        red = rom.simulate(POINT).as_array()
    red_wall, red_cpu = (x / repeats for x in since(start))
    rng = np.random.default_rng(0)
    swarm = {"fibre.k": rng.uniform(0.05, 1.0, 32), "fibre.c": rng.uniform(1e5, 1e7, 32)}
    start = clock()
    rom.simulate_batch(swarm)
    batch_wall, _ = since(start)
    err = np.abs(red - full).max(axis=0)
    print(f"full model ({len(full)} steps of {s1.time.dt if s1.time else 0} s): wall {full_wall:.2f} s, CPU "
          f"{full_cpu:.2f} s")
    print(f"reduced model: wall {red_wall * 1e3:.2f} ms, CPU {red_cpu * 1e3:.2f} ms per evaluation; "
          f"speed-up {full_wall / red_wall:.0f}x (wall), {full_cpu / red_cpu:.0f}x (CPU)")
    print(f"swarm of 32 in one call: {batch_wall:.3f} s ({batch_wall / 32 * 1e3:.2f} ms per set, "
          f"{full_wall / (batch_wall / 32):.0f}x)")
    print(f"max |reduced - full|: z0 {err[0]:.4f} °C, z1 {err[1]:.4f} °C (max face mean {np.abs(full).max():.2f} °C)")
    if seed_rom is not None:
        e = np.abs(seed_rom.simulate(POINT).as_array() - full).max(axis=0)
        print(f"seed variant (no correction modes), ñ = {seed_rom.order}: max |reduced - full| z0 {e[0]:.4f} °C, "
              f"z1 {e[1]:.4f} °C")
    if args.fine_dt is not None:
        start = clock()
        fine = simulate(with_dt(s1, args.fine_dt), POINT, s1.time.times if s1.time else None).as_array()
        fine_wall, _ = since(start)
        e_full = np.abs(full - fine).max(axis=0)
        e_red = np.abs(red - fine).max(axis=0)
        print(f"full model with dt = {args.fine_dt} s ({fine_wall:.1f} s): |full(dt) - full(fine)| z0 {e_full[0]:.4f}, "
              f"z1 {e_full[1]:.4f} °C; |reduced - full(fine)| z0 {e_red[0]:.4f}, z1 {e_red[1]:.4f} °C")
        if seed_rom is not None:
            e = np.abs(seed_rom.simulate(POINT).as_array() - fine).max(axis=0)
            print(f"seed variant: |reduced - full(fine)| z0 {e[0]:.4f}, z1 {e[1]:.4f} °C")


if __name__ == "__main__":
    main()
