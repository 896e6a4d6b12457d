"""Cost model of the petsc engine (docs/scaling.md): predictions for 256³, 512³, 1024³ from measured records.

Reads the JSON lines written by ``benchmarks/petsc_engine.py --json FILE`` and fits, for the petsc engine:

* CPU seconds of the offline build at 1 rank, ``T1(N) = a N^α`` (N unknowns), at the measured Ñ;
* peak memory per rank at 1 rank, ``M1(N) = m0 + b N`` (m0: the process with PETSc loaded; b: bytes per unknown);
* the 2-rank CPU efficiency ``e2 = T1 / (2 T2_per_rank)`` at the largest size measured at both.

and predicts, for a reduced model of ``--order`` ñ (Ñ = 1.5 ñ + 20 modes), the number of ranks that keeps every
rank under ``--memory`` GB, the memory per rank, and the wall hours ``T1(N) (Ñ / Ñ_meas) / (P e)``.  The modes
enter the memory as ``16 Ñ`` bytes per unknown (the basis and SLEPc's Krylov–Schur workspace of ≈ Ñ vectors,
on top of the measured operators and multigrid), and the time linearly in Ñ (inner solves per mode; the
orthogonalisation ``≈ 4 N ncv²`` flops per restart is printed apart).  Everything beyond the measured sizes
is an extrapolation: the script prints its inputs so that a reader can redo it with numbers from a cluster.

Usage: python benchmarks/scaling_model.py RECORDS.jsonl [...] [--order 200] [--memory 4] [--efficiency E]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

SIZES = (256, 512, 1024)


def modes(order: int) -> int:
    """Ñ of aromm.reduction.offline.default_modes."""
    return int(1.5 * order) + 20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("records", type=Path, nargs="+")
    parser.add_argument("--order", type=int, default=200)
    parser.add_argument("--memory", type=float, default=4.0, help="GB of memory per rank (per core) on the cluster")
    parser.add_argument("--efficiency", type=float, default=None,
                        help="parallel efficiency to assume (default: the measured 2-rank CPU efficiency)")
    parser.add_argument("--flops", type=float, default=2e9, help="orthogonalisation flop rate per core (flop/s)")
    args = parser.parse_args()
    records = [json.loads(line) for path in args.records for line in path.read_text().splitlines() if line.strip()]
    one = sorted((r for r in records if r["engine"] == "petsc" and r["ranks"] == 1), key=lambda r: r["unknowns"])
    two = {r["unknowns"]: r for r in records if r["engine"] == "petsc" and r["ranks"] == 2}
    if len(one) < 2:
        raise SystemExit("need petsc records at 1 rank for at least two sizes")
    n = np.array([r["unknowns"] for r in one], dtype=float)
    cpu = np.array([max(r["cpu"]) for r in one])
    peak = np.array([max(r["peak"]) for r in one])
    alpha, log_a = np.polyfit(np.log(n), np.log(cpu), 1)
    b, m0 = np.polyfit(n, peak, 1)
    measured_modes = int(one[-1]["modes"])
    shared = [u for u in n if u in two]
    at = {r["unknowns"]: r for r in one}
    e2 = float(at[max(shared)]["cpu"][0] / (2 * max(two[max(shared)]["cpu"]))) if shared else 0.5
    e = args.efficiency if args.efficiency is not None else e2
    total = modes(args.order)
    print(f"inputs: {len(one)} sizes at 1 rank, N = {int(n[0]):,} … {int(n[-1]):,} unknowns, Ñ = {measured_modes}")
    print(f"  T1(N) = {math.exp(log_a):.3g} N^{alpha:.2f} CPU s; M1(N) = {m0 / 2**20:.0f} MB + {b:.0f} B × N; "
          f"2-rank CPU efficiency e2 = {e2:.2f} (at N = {int(max(shared)) if shared else 0:,})")
    print(f"model: order ñ = {args.order}, Ñ = {total}; {args.memory:g} GB per rank; efficiency {e:.2f}; modes add "
          f"16 Ñ = {16 * total:,} B per unknown; time × Ñ / {measured_modes}")
    print(f"{'image':>7} {'unknowns':>14} {'basis Φ':>10} {'ranks':>7} {'GB/rank':>8} {'hours':>8} "
          f"{'CPU hours':>10} {'orth. h':>8}")
    for side in SIZES:
        unknowns = float((side + 1) ** 3)
        per_unknown = b + 16 * (total - measured_modes)
        ranks = max(1, math.ceil(unknowns * per_unknown / (args.memory * 2**30 - m0)))
        per_rank = (m0 + unknowns * per_unknown / ranks) / 2**30
        cpu_s = math.exp(log_a) * unknowns**alpha * total / measured_modes
        orth = 4 * unknowns * (2 * total) ** 2 * 3 / args.flops / 3600  # ≈ 3 restarts of a 2Ñ-vector basis
        print(f"{side:>6}³ {unknowns:>14,.0f} {8 * total * unknowns / 2**30:>8.0f} GB {ranks:>7,} {per_rank:>8.2f} "
              f"{cpu_s / (ranks * e) / 3600 + orth / ranks:>8.2f} {cpu_s / 3600:>10,.0f} {orth:>8.1f}")


if __name__ == "__main__":
    main()
