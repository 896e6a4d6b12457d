"""DEM benchmarks [Hassan2019]: packing cost, explicit vs implicit, C_t and E against N.

    python benchmarks/dem.py                       # all tables at the default sizes
    python benchmarks/dem.py --table pack --sizes 10000 150000
    python benchmarks/dem.py --table steps --particles 30000
    python benchmarks/dem.py --table ct --sizes 3000 10000 30000 100000 150000 --cache /tmp/packings

Tables (printed, not asserted):

* ``pack``: wall and CPU seconds and peak resident memory of ``pack_spheres`` per size, each size in
  a fresh process (peak RSS is per process).  Wall time depends on the machine's load; CPU time less so.
* ``steps``: the slab of [Hassan2019, § 3.1] (c = 0.9 J/(kg K)) integrated to 0.05, 0.1, 0.2 s by forward Euler
  (eq. 5, 0.9 x the exact stability limit) and by the implicit solvers of aromm.full.solve (BDF2 and backward
  Euler, factorised once) with increasing numbers of steps; error = max |T - T_ref| over particles and
  output times, T_ref = BDF2 with 3200 steps (``--reference-steps``).  Each implicit scheme stops at
  the first step count at least as accurate as the explicit run.
* ``ct``: C_t (pair and global R_moy, periodic; pair, slab test of [Hassan2019, Fig. 3]) and Z x C_t for Z = 6, 9,
  and E = k_eff/k_m of the sphere inclusion (periodic cell) at contrasts 0.01 and 100 against the exact
  simple-cubic value (aromm.bounds.models.rayleigh_simple_cubic), per N.

``--cache DIR`` keeps packings as ``DIR/pack_<N>_seed<S>.npz`` so that tables can reuse them.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import resource
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from aromm.bounds.models import rayleigh_simple_cubic
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.dem.calibration import calibrate, inclusion_network, inclusion_ratios
from aromm.dem.explicit import simulate_explicit, stability_limit
from aromm.dem.neighbours import build_bonds
from aromm.dem.network import Network
from aromm.dem.packing import Packing, load_packing, pack_spheres
from aromm.full.analytic import slab_dirichlet_series
from aromm.full.solve import simulate

L = 0.1  # m, [Hassan2019, § 3.1]
TIMES = np.array([0.05, 0.1, 0.2])
FIXED = (FaceSpec("y0", T=25.0), FaceSpec("y1", T=100.0))  # [Hassan2019, § 3.1]


def _pack_job(args: tuple[int, int, str | None]) -> tuple[int, float, float, float]:
    """Runs in a fresh process: (n, wall s, cpu s, peak RSS MB)."""
    n, seed, cache = args
    with threadpool_limits(1):
        wall, cpu = time.perf_counter(), time.process_time()
        packing = pack_spheres(n, np.random.default_rng(seed), box=L)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    if cache is not None:
        packing.save(Path(cache) / f"pack_{n}_seed{seed}.npz")
    return n, wall, cpu, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def get_packing(n: int, seed: int, cache: str | None) -> Packing:
    """The cached packing of (n, seed), else a new one (saved when a cache is given)."""
    path = Path(cache) / f"pack_{n}_seed{seed}.npz" if cache is not None else None
    if path is not None and path.exists():
        return load_packing(path).scaled(L)
    packing = pack_spheres(n, np.random.default_rng(seed), box=L)
    if path is not None:
        packing.save(path)
    return packing


def table_pack(sizes: list[int], seed: int, cache: str | None) -> None:
    print("\n== packing (FIRE, periodic, phi = 0.64, CV 0.3), one fresh process per size ==")
    print(f"{'N':>9} {'wall s':>9} {'cpu s':>9} {'peak MB':>9}")
    ctx = mp.get_context("spawn")
    for n in sizes:
        with ctx.Pool(1, maxtasksperchild=1) as pool:
            (row,) = pool.map(_pack_job, [(n, seed, cache)])
        print(f"{row[0]:9d} {row[1]:9.1f} {row[2]:9.1f} {row[3]:9.0f}", flush=True)


def slab_system(packing: Packing) -> tuple[Network, dict[str, float]]:
    bonds = build_bonds(packing, 7.5)
    cal = calibrate(packing, 7.5, bonds=bonds)
    cut = packing.cut(packing.lower, packing.lower + packing.box)
    net = Network(cut, build_bonds(cut, gap=bonds.gap_threshold), cal.c_t, np.zeros(cut.n, dtype=np.int64))
    values = {"matrix.k": 33.0, "matrix.c": 7800.0 * 0.9, "initial.T": 25.0}
    return net, values


def table_steps(n: int, seed: int, cache: str | None, reference_steps: int = 3200) -> None:
    packing = get_packing(n, seed, cache)
    net, values = slab_system(packing)

    def run_implicit(steps: int, scheme: str) -> tuple[np.ndarray, float]:
        system = net.system(values, boundary=FIXED, time=TimeGrid(0.2, 0.2 / steps))
        t = time.perf_counter()
        obs = simulate(system, times=TIMES, fields=True, scheme=scheme)  # type: ignore[arg-type]
        assert obs.fields is not None
        return obs.fields, time.perf_counter() - t

    ref, t_ref = run_implicit(reference_steps, "bdf2")
    system = net.system(values, boundary=FIXED, time=TimeGrid(0.2, 0.01))
    limit = stability_limit(system)
    t = time.perf_counter()
    explicit = simulate_explicit(system, times=TIMES, fields=True)
    t_explicit = time.perf_counter() - t
    assert explicit.fields is not None
    err_explicit = float(np.abs(explicit.fields - ref).max())
    y = net.packing.centers[:, 1]
    analytic = slab_dirichlet_series(y[None, :], TIMES[:, None], L, 33.0 / (7800 * 0.9), 25.0, 25.0, 100.0)
    err_space = float(np.abs(ref - analytic).max())
    print(f"\n== slab transient, {net.n} particles, to 0.2 s (reference BDF2 x {reference_steps}: {t_ref:.1f} s) ==")
    print(f"spatial error of the DEM itself (max over particles vs eq. 12): {err_space:.2f} K")
    print(f"{'scheme':>16} {'steps':>7} {'dt s':>10} {'wall s':>8} {'max err K':>10}")
    steps_explicit = int(np.sum(np.ceil(np.diff(np.concatenate([[0.0], TIMES])) / (0.9 * limit))))
    print(f"{'explicit eq. 5':>16} {steps_explicit:7d} {0.9 * limit:10.2e} {t_explicit:8.2f} {err_explicit:10.2e}")
    for scheme in ("bdf2", "euler"):
        steps = 8
        while steps < reference_steps:
            fields, seconds = run_implicit(steps, scheme)
            err = float(np.abs(fields - ref).max())
            print(f"{'implicit ' + scheme:>16} {steps:7d} {0.2 / steps:10.2e} {seconds:8.2f} {err:10.2e}", flush=True)
            if err <= err_explicit:
                break
            steps *= 2


def table_ct(sizes: list[int], seed: int, cache: str | None) -> None:
    print("\n== C_t and E against N (Z = 7.5 unless said) ==")
    print(f"{'N':>8} {'C_t pair':>9} {'C_t glob':>9} {'C_t slab':>9} {'Z*C_t 6':>8} {'Z*C_t 7.5':>9} {'Z*C_t 9':>8}"
          f" {'E(0.01) err':>12} {'E(100) err':>11} {'s':>6}")
    phi = 4 * np.pi / 81
    for n in sizes:
        packing = get_packing(n, seed, cache)
        t = time.perf_counter()
        bonds = build_bonds(packing, 7.5)
        pair = calibrate(packing, 7.5, bonds=bonds)
        glob = calibrate(packing, 7.5, radius="global", bonds=bonds)
        slab = calibrate(packing, 7.5, boundary="slab", bonds=bonds)
        zc = [calibrate(packing, z).c_t * z for z in (6.0, 9.0)]
        net = inclusion_network(packing, 7.5)
        errs = [r.E / float(rayleigh_simple_cubic(phi, r.ratio)) - 1 for r in inclusion_ratios(net, [0.01, 100.0])]
        print(f"{n:8d} {pair.c_t:9.4f} {glob.c_t:9.4f} {slab.c_t:9.4f} {zc[0]:8.3f} {pair.z * pair.c_t:9.3f}"
              f" {zc[1]:8.3f} {errs[0]:+12.2%} {errs[1]:+11.2%} {time.perf_counter() - t:6.0f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--table", choices=["pack", "steps", "ct", "all"], default="all")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 150_000])
    parser.add_argument("--particles", type=int, default=10_000, help="size of the explicit/implicit table")
    parser.add_argument("--reference-steps", type=int, default=3200,
                        help="BDF2 steps of the reference solution of the steps table (512 is enough at 1.5e5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", default=None, help="directory for packings (reused between tables)")
    args = parser.parse_args()
    if args.cache is not None:
        Path(args.cache).mkdir(parents=True, exist_ok=True)
    with threadpool_limits(1):
        if args.table in ("pack", "all"):
            table_pack(args.sizes, args.seed, args.cache)
        if args.table in ("steps", "all"):
            table_steps(args.particles, args.seed, args.cache, args.reference_steps)
        if args.table in ("ct", "all"):
            table_ct(args.sizes, args.seed, args.cache)


if __name__ == "__main__":
    main()
