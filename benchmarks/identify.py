"""Identification [Chavez2020, § 4]: accuracy and wall time of the whole inverse procedure.

Prints, for a wood VER (coarse n³ by default; the shipped 46³ VER with AROMM_FULL=1):

1. Table 2: k_F, c_F identified from homogeneous-twin measurements (eq. 13, 14) in the three loading
   directions with the reduced model; errors (eq. 15) and wall time per identification (model built);
2. the +2 % study (every homogeneous property 2 % too high, loading along x);
3. twin tests: measurements from the heterogeneous full model itself (optionally at a finer time step),
   without noise (recovery error) and with Gaussian noise σ (how many of R seeded repetitions have the
   truth inside the 95 % intervals), identified with the full model (coarse VER only) and with the
   reduced model;
4. joint identification from the three scenarios at once, with k_F, c_F and then also k_G unknown;
5. accuracy against cost: swarm budget (with / without refinement), reduced order, full model.

Usage: python benchmarks/identify.py [--size 12] [--order 40] [--method aromm|krylov] [--reps 20] [--noise 0.02]
       [--no-full] [--farm serial|processes|mpi] [--workers W]
       AROMM_FULL=1 python benchmarks/identify.py --no-full --data-refine 5 --twin-data twin_x.csv [--full-refine]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from aromm.core.forward_model import ForwardModel
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.full.solve import FullModel
from aromm.scene.geometry import VoxelGeometry
from aromm.studies.chavez2020 import (
    AXES,
    PAPER_PERTURBED,
    PAPER_TABLE2,
    UNKNOWNS,
    as_table,
    budget_sweep,
    fibre_truth,
    homogeneous_properties,
    loading,
    noisy_repetitions,
    reduced,
    refine_from,
    run,
    shipped_scenarios,
    small_wood,
    twin_cases,
)
from inverse.farm import FARMS, Farm
from inverse.identification import DEFAULT_ITERATIONS, DEFAULT_PARTICLES
from inverse.measurements import Measurements, load_measurements, save_measurements, simulate_measurements
from inverse.uncertainty import UncertaintyWarning

ROOT = Path(__file__).resolve().parents[1]
# swarm of the full-model identifications (each evaluation is a full simulation): the refinement does the work
FULL_P, FULL_I = 6, 3


def section(title: str) -> None:
    print(f"\n== {title}", flush=True)


def coverage(model: ForwardModel, exact: Measurements, truth: dict[str, float], *, reps: int, noise: float,
             particles: int = DEFAULT_PARTICLES, iterations: int = DEFAULT_ITERATIONS,
             farm: Farm | None = None) -> dict[str, object]:
    """How many of ``reps`` noisy copies of ``exact`` give 95 % intervals containing the truth (spread over
    ``farm``: serial, a process pool or mpi4py.futures; the same results whatever the farm)."""
    inside = dict.fromkeys(truth, 0)
    seconds = []
    for r in noisy_repetitions(model, exact, truth, reps=reps, noise=noise, particles=particles,
                               iterations=iterations, farm=farm):
        unc = r.result.uncertainty
        for i, name in enumerate(unc.names):
            inside[name] += int(unc.lower[i] <= truth[name] <= unc.upper[i])
        seconds.append(r.result.seconds)
    return {**{f"inside {k}": f"{v}/{reps}" for k, v in inside.items()}, "mean s": float(np.mean(seconds))}


def full_model_data(system: ThermalSystem, truth: dict[str, float], refine: int, path: Path | None) -> Measurements:
    """Face means of the heterogeneous full model at the truth, at the system's times, time step dt / ``refine``."""
    if path is not None and path.exists():
        print(f"twin-test data read from {path}")
        return load_measurements(path)
    grid = system.time
    assert grid is not None
    start = time.perf_counter()
    fine = replace(system, time=TimeGrid(grid.end, grid.dt / refine))
    data = simulate_measurements(FullModel(fine), truth, grid.times)
    print(f"twin-test data: full model, dt = {grid.dt / refine:g} s, {time.perf_counter() - start:.0f} s", flush=True)
    if path is not None:
        save_measurements(data, path)
    return data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=12, help="voxels per side of the coarse VER")
    parser.add_argument("--dt", type=float, default=0.5, help="time step of the coarse VER's scenes (s)")
    parser.add_argument("--order", type=int, default=None, help="reduced order (40 coarse, 200 shipped)")
    parser.add_argument("--method", choices=("aromm", "krylov"), default="aromm",
                        help="reduction method: aromm (the amalgam, the papers' method) or krylov (eigen-free)")
    parser.add_argument("--reps", type=int, default=20, help="noisy repetitions of the twin test")
    parser.add_argument("--noise", type=float, default=0.02, help="noise standard deviation (°C)")
    parser.add_argument("--no-full", action="store_true", help="skip identifications with the full model")
    parser.add_argument("--twin-axis", choices=AXES, default="x", help="loading direction of the twin tests")
    parser.add_argument("--data-refine", type=int, default=1,
                        help="twin-test data from the full model at the scene's dt divided by this (5 for the "
                             "shipped VER: BDF2's time error then falls below the reduced model's)")
    parser.add_argument("--twin-data", type=Path, default=None,
                        help="CSV file keeping the twin-test data: read if it exists, else written")
    parser.add_argument("--full-refine", action="store_true",
                        help="with --no-full: still fit the full model along x by least squares alone, started "
                             "from the reduced estimate (about 30 full simulations)")
    parser.add_argument("--farm", choices=FARMS, default="serial",
                        help="where the noisy repetitions run: serial, processes (this machine), mpi (mpi4py.futures: "
                             "mpiexec -n P python -m mpi4py.futures benchmarks/identify.py --farm mpi)")
    parser.add_argument("--workers", type=int, default=None, help="worker processes of the farm")
    args = parser.parse_args()
    farm = Farm(args.farm, args.workers)
    warnings.simplefilter("ignore", UncertaintyWarning)  # listed with the results instead

    shipped = os.environ.get("AROMM_FULL") == "1"
    if shipped:
        scenes = shipped_scenarios(ROOT)
        order = args.order or 200
    else:
        material = small_wood(args.size)
        scenes = {axis: loading(material, axis, end=60.0, dt=args.dt) for axis in AXES}
        order = args.order or 40
    material = scenes["z"]
    truth = fibre_truth(material)
    geo = material.geometry
    assert isinstance(geo, VoxelGeometry) and material.time is not None
    print(f"VER {'shipped' if shipped else 'coarse'} {geo.shape}, voxel {geo.voxel_size[0]:.3g} m, "
          f"fibre fraction {material.volume_fractions()['fibre']:.4f}, {len(material.time.times)} times, "
          f"{args.method} order {order}, python {sys.version.split()[0]}")

    hom = homogeneous_properties(scenes, method="amg" if shipped else "auto")
    cases = twin_cases(scenes, hom)
    k_bar = ", ".join(f"k̄_{a}{a} = {hom.k[a]:.5g}" for a in AXES)
    print(f"eq. 13 under each scenario: {k_bar} W/(m K), c̄ = {hom.c:.5g} J/(m³ K) ({hom.seconds:.1f} s)")
    roms = {}
    for axis in AXES:
        roms[axis] = reduced(cases[axis], order, method=args.method, progress=sys.stderr.isatty())
        print(f"reduced model {axis}: order {roms[axis].order}, offline {roms[axis].info['offline_seconds']:.1f} s "
              f"(cached {roms[axis].info['cached']})", flush=True)

    section("1. Table 2: homogeneous-twin measurements, reduced model, PSO 20x30 + refinement, seed 0")
    rows = []
    for axis in AXES:
        r = run(f"{axis}{axis}", roms[axis], cases[axis].measurements, truth)
        _, psk, _, psc, ph = PAPER_TABLE2[axis]
        rows.append({**r.row(), "paper σ_k %": psk, "paper σ_c %": psc, "paper t (h)": ph})
    print(as_table(rows))

    section("2. +2 % on every homogeneous property, loading along x (paper: 2.9 % on k, 3.3 % on c)")
    plus = twin_cases({"x": scenes["x"]}, hom, perturbation=0.02)["x"]
    r = run("x +2 %", roms["x"], plus.measurements, truth)
    print(as_table([{**r.row(), "paper σ_k %": PAPER_PERTURBED["fibre.k"], "paper σ_c %": PAPER_PERTURBED["fibre.c"]}]))

    axis = args.twin_axis
    section(f"3. Twin tests (loading along {axis}): data from the heterogeneous full model at dt / "
            f"{args.data_refine}; noise σ = {args.noise} °C, {args.reps} seeded repetitions")
    twin, rom = cases[axis], roms[axis]
    exact = full_model_data(twin.system, truth, args.data_refine, args.twin_data)
    own = simulate_measurements(rom, truth)
    print(f"max |full data - reduced {order}| at the truth: {np.abs(exact.as_array() - own.as_array()).max():.2g} °C")
    full_twin = FullModel(twin.system)
    rows = []
    if not args.no_full:
        rows.append({"data": "full model", "identified with": "full model",
                     **run("", full_twin, exact, truth, particles=FULL_P, iterations=FULL_I).row()})
    rows.append({"data": "full model", "identified with": f"reduced {order}", **run("", rom, exact, truth).row()})
    rows.append({"data": f"reduced {order}", "identified with": f"reduced {order}", **run("", rom, own, truth).row()})
    print(as_table(rows))
    rows = []
    if not args.no_full:
        rows.append({"data": "full + noise", "identified with": "full model",
                     **coverage(full_twin, exact, truth, reps=args.reps, noise=args.noise, particles=FULL_P, farm=farm,
                                iterations=FULL_I)})
    rows.append({"data": "full + noise", "identified with": f"reduced {order}",
                 **coverage(rom, exact, truth, reps=args.reps, noise=args.noise, farm=farm)})
    rows.append({"data": f"reduced {order} + noise", "identified with": f"reduced {order}",
                 **coverage(rom, own, truth, reps=args.reps, noise=args.noise, farm=farm)})
    print(as_table(rows))

    section("4. Joint identification from the three scenarios (homogeneous-twin data, reduced models)")
    pairs = [(roms[a], cases[a].measurements) for a in AXES]
    joint = run("k_F, c_F", pairs, None, truth)
    three = run("k_F, c_F, k_G", pairs, None, {**truth, "gas.k": 0.025},
                unknowns={**UNKNOWNS, "gas.k": (0.005, 0.1)})
    print(as_table([joint.row(), three.row()]))
    own_pairs = [(roms[a], simulate_measurements(roms[a], {**truth, "gas.k": 0.025})) for a in AXES]
    three_twin = run("k_F, c_F, k_G (reduced-model data)", own_pairs, None, {**truth, "gas.k": 0.025},
                     unknowns={**UNKNOWNS, "gas.k": (0.005, 0.1)})
    print(as_table([three_twin.row()]))

    section("5. Accuracy against cost (loading along x, homogeneous-twin data)")
    x = cases["x"]
    full = FullModel(x.system)
    rom = roms["x"]
    runs = budget_sweep(rom, x.measurements, truth, [(5, 2), (10, 5), (20, 10), (20, 30), (40, 50)])
    rows = [{**r.row(), "offline s": 0.0} for r in runs]
    for o in sorted({max(order // 4, 5), max(order // 2, 5)}):
        start = time.perf_counter()
        other = reduced(x, o, method=args.method)
        offline = float(other.info["offline_seconds"]) if not other.info["cached"] else time.perf_counter() - start
        rows.append({**run(f"order {o}", other, x.measurements, truth).row(), "offline s": offline})
    reduced_run = run(f"order {order}", rom, x.measurements, truth)
    rows.append({**reduced_run.row(), "offline s": float(rom.info["offline_seconds"])})
    if not args.no_full:
        label = f"full model, PSO {FULL_P}x{FULL_I} + refine"
        full_run = run(label, full, x.measurements, truth, particles=FULL_P, iterations=FULL_I)
        rows.append({**full_run.row(), "offline s": 0.0})
    print(as_table(rows))
    if args.full_refine:
        print(as_table([refine_from(f"full model, least squares from the order-{order} estimate", full,
                                    x.measurements, reduced_run.result.estimates, truth)]))


if __name__ == "__main__":
    main()
